//! Stage keys: a blake3 hash of everything a stage's result depends on.

use std::fmt;

use super::world::Hash;

#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Key(pub Hash);

impl Key {
    /// The key under which the cache keeps the warnings of the stage with this key: an
    /// entry of its own, so a build that loads or skips the stage can report them again.
    pub fn warnings(&self) -> Key {
        let mut h = blake3::Hasher::new();
        h.update(b"tessera.warnings\0");
        h.update(&self.0);
        Key(*h.finalize().as_bytes())
    }

    pub fn hex(&self) -> String {
        blake3::Hash::from(self.0).to_hex().to_string()
    }

    pub fn short(&self) -> String {
        self.hex()[..12].to_string()
    }
}

impl fmt::Debug for Key {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Key({})", self.short())
    }
}

/// Builds a key from its parts; every part is length-prefixed so no two different
/// sequences of parts can collide by concatenation.
pub struct KeyBuilder(blake3::Hasher);

impl KeyBuilder {
    pub fn new(kind: &str, version: u32) -> Self {
        let mut h = blake3::Hasher::new();
        h.update(b"tessera-stage-key-v1");
        let mut k = KeyBuilder(h);
        k.part(kind.as_bytes());
        k.part(&version.to_le_bytes());
        k
    }

    pub fn part(&mut self, bytes: &[u8]) -> &mut Self {
        self.0.update(&(bytes.len() as u64).to_le_bytes());
        self.0.update(bytes);
        self
    }

    pub fn finish(&self) -> Key {
        Key(*self.0.finalize().as_bytes())
    }
}
