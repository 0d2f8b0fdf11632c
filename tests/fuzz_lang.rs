//! Seeded mutation fuzzing of the front end: thousands of corrupted variants of the example
//! scenes go through parse, resolve, plan and format in-process. None may panic.

use std::path::Path;
use std::sync::Arc;

use tessera::lang::{self, Loader};

struct Mem(String);

impl Loader for Mem {
    fn load(&self, path: &Path) -> std::io::Result<Arc<str>> {
        if path.file_name().is_some_and(|n| n == "scene.tess") {
            Ok(Arc::from(self.0.as_str()))
        } else {
            // Imports resolve against the real scenes directory.
            let name = path.file_name().ok_or_else(|| std::io::Error::other("no file name"))?;
            let real = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
            std::fs::read_to_string(real).map(|s| Arc::from(s.as_str()))
        }
    }
}

/// xorshift64*: a tiny deterministic generator for the mutations.
fn next(state: &mut u64) -> u64 {
    *state ^= *state >> 12;
    *state ^= *state << 25;
    *state ^= *state >> 27;
    state.wrapping_mul(0x2545_F491_4F6C_DD1D)
}

const ALPHABET: &[u8] = b"{}[](),=\"#x .-0123456789abpxdegr%\n";

fn mutate(src: &str, state: &mut u64) -> String {
    let mut bytes = src.as_bytes().to_vec();
    for _ in 0..1 + next(state) % 4 {
        let pos = (next(state) as usize) % (bytes.len() + 1);
        match next(state) % 4 {
            0 if pos < bytes.len() => {
                bytes.remove(pos);
            }
            1 => bytes.insert(pos, ALPHABET[(next(state) as usize) % ALPHABET.len()]),
            2 if pos < bytes.len() => bytes[pos] = ALPHABET[(next(state) as usize) % ALPHABET.len()],
            _ => {
                // Duplicate a slice: repeats declarations and properties.
                let end = (pos + (next(state) as usize) % 40).min(bytes.len());
                let piece = bytes[pos..end].to_vec();
                let at = (next(state) as usize) % (bytes.len() + 1);
                bytes.splice(at..at, piece);
            }
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

#[test]
fn mutated_scenes_never_panic() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let registry = tessera::kinds::registry();
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut compiled = 0;
    for name in ["masks", "fields", "wall"] {
        let src = std::fs::read_to_string(root.join(format!("scenes/{name}.tess"))).expect("scene");
        for _ in 0..1500 {
            let text = mutate(&src, &mut state);
            let opts = lang::Options { sets: &[], sets_may_miss: false, seed: None, registry: &registry };
            let result = std::panic::catch_unwind(|| {
                let _ = lang::fmt::format_source(&text);
                if let Ok(scene) = lang::compile(Path::new("scene.tess"), &Mem(text.clone()), &opts) {
                    let _ = tessera::kinds::plan(&scene);
                    return true;
                }
                false
            });
            match result {
                Ok(ok) => compiled += usize::from(ok),
                Err(_) => panic!("panic on input:\n{text}"),
            }
        }
    }
    // Some mutations are harmless (inside comments, digits): make sure the test also
    // exercises the planner, not only the error paths.
    assert!(compiled > 50, "only {compiled} mutants compiled");
}
