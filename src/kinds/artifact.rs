//! Artifact types and their cache encodings, and the stage every kind builds: a plain
//! function of one keyed value.

use std::any::Any;
use std::sync::Arc;

use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::graph::{Artifact, RunCx, Stage, StageError, Typed};
use crate::raster::{self, Image};
use crate::synth::surface::Plane;

/// An artifact type that can live in the on-disk cache.
pub trait Encoded: Any + Send + Sync + Sized {
    fn encode(&self) -> Vec<u8>;
    fn decode(bytes: &[u8]) -> Result<Self, String>;
}

impl Encoded for Image {
    fn encode(&self) -> Vec<u8> {
        raster::codec::to_bytes(self)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        raster::codec::from_bytes(bytes).map_err(|e| e.to_string())
    }
}

/// Opaque file bytes: encoded outputs, and sample files passed through for later stages.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Bytes(pub Vec<u8>);

impl Encoded for Bytes {
    fn encode(&self) -> Vec<u8> {
        self.0.clone()
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        Ok(Bytes(bytes.to_vec()))
    }
}

impl Encoded for Plane {
    fn encode(&self) -> Vec<u8> {
        self.occupancy.encode()
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        Ok(Plane { occupancy: Image::decode(bytes)? })
    }
}

/// `meta` as JSON, then the images, each length-prefixed (u64 little-endian).
pub(super) fn pack(meta: &impl Serialize, images: &[&Image]) -> Vec<u8> {
    let head = serde_json::to_vec(meta).expect("artifact metadata serialises");
    let mut out = Vec::new();
    out.extend_from_slice(&(head.len() as u64).to_le_bytes());
    out.extend_from_slice(&head);
    out.extend_from_slice(&(images.len() as u64).to_le_bytes());
    for img in images {
        let b = raster::codec::to_bytes(img);
        out.extend_from_slice(&(b.len() as u64).to_le_bytes());
        out.extend_from_slice(&b);
    }
    out
}

pub(super) fn unpack<M: DeserializeOwned>(bytes: &[u8]) -> Result<(M, Vec<Image>), String> {
    let mut at = 0usize;
    let mut take = |n: usize| -> Result<&[u8], String> {
        let end = at.checked_add(n).filter(|&e| e <= bytes.len()).ok_or("truncated artifact")?;
        let s = &bytes[at..end];
        at = end;
        Ok(s)
    };
    let len = |b: &[u8]| -> Result<usize, String> {
        usize::try_from(u64::from_le_bytes(b.try_into().expect("8 bytes"))).map_err(|e| e.to_string())
    };
    let n = len(take(8)?)?;
    let meta: M = serde_json::from_slice(take(n)?).map_err(|e| e.to_string())?;
    let count = len(take(8)?)?;
    let mut images = Vec::with_capacity(count.min(64));
    for _ in 0..count {
        let n = len(take(8)?)?;
        images.push(raster::codec::from_bytes(take(n)?).map_err(|e| e.to_string())?);
    }
    Ok((meta, images))
}

type RunFn<T> = dyn Fn(&RunCx) -> Result<T, StageError> + Send + Sync;

/// A stage whose key is the canonical serialisation of exactly the value its work receives.
pub struct FnStage<T: Encoded> {
    kind: &'static str,
    version: u32,
    params: String,
    run: Box<RunFn<T>>,
}

impl<T: Encoded> FnStage<T> {
    /// The stage `kind` (code `version`) computing `run(cx, &input)`. `run` is a plain
    /// function (a closure capturing nothing), so nothing can reach the work that the key
    /// does not hold, and there is no second list of parameters to drift from it. `input`
    /// holds the stage's [`In`](crate::graph::In) handles too, so the key holds its wiring;
    /// what decides only whether a result is computed (the memory budget) comes from
    /// [`RunCx::budget`], never from `input`.
    pub fn keyed<P>(kind: &'static str, version: u32, input: P, run: fn(&RunCx, &P) -> Result<T, StageError>) -> Self
    where
        P: serde::Serialize + Send + Sync + 'static,
    {
        let params = serde_json::to_string(&input).expect("stage parameters serialise");
        FnStage { kind, version, params, run: Box::new(move |cx| run(cx, &input)) }
    }
}

impl<T: Encoded> Typed for FnStage<T> {
    type Output = T;
}

impl<T: Encoded> Stage for FnStage<T> {
    fn kind(&self) -> &'static str {
        self.kind
    }

    fn version(&self) -> u32 {
        self.version
    }

    fn params(&self) -> String {
        self.params.clone()
    }

    fn run(&self, cx: &RunCx) -> Result<Artifact, StageError> {
        (self.run)(cx).map(|v| Arc::new(v) as Artifact)
    }

    fn encode(&self, artifact: &Artifact) -> Vec<u8> {
        artifact.downcast_ref::<T>().expect("artifact of this stage's type").encode()
    }

    fn decode(&self, bytes: &[u8]) -> Result<Artifact, String> {
        T::decode(bytes).map(|v| Arc::new(v) as Artifact)
    }
}
