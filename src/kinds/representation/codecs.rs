//! The artifacts of relightable surfaces and their cache encodings. A fitted representation
//! keeps its f64 maps bit for bit (raw little-endian after a JSON header), so a stage reading
//! it from the cache sees what a fresh fit computed.

use std::sync::Arc;

use super::super::artifact::{pack, unpack};
use super::super::Encoded;
use crate::raster::Image;
use crate::synth::relight::{self, frame, Basis, Light, Method, PhotoStack, RelightError, Representation};

/// A representation fitted to a capture.
#[derive(Clone, Debug, PartialEq)]
pub struct Fitted(pub Representation);

impl Fitted {
    /// The maps as an image (what a layer quilts).
    pub fn maps_image(&self) -> Image {
        self.0.to_image()
    }

    /// The fitted surface as every relightable view reads it.
    pub fn relightable(&self) -> Relightable {
        Relightable {
            maps: Arc::new(self.0.to_image()),
            chroma: self.0.chroma_image(),
            basis: self.0.basis.clone(),
            periodic: false,
            angles: None,
        }
    }
}

fn f64_bytes(out: &mut Vec<u8>, v: &[f64]) {
    out.extend_from_slice(&(v.len() as u64).to_le_bytes());
    for x in v {
        out.extend_from_slice(&x.to_le_bytes());
    }
}

fn read_f64s(bytes: &[u8], at: &mut usize) -> Result<Vec<f64>, String> {
    let take = |at: &mut usize, n: usize| -> Result<&[u8], String> {
        let end = at.checked_add(n).filter(|&e| e <= bytes.len()).ok_or("truncated representation artifact")?;
        let s = &bytes[*at..end];
        *at = end;
        Ok(s)
    };
    let n =
        usize::try_from(u64::from_le_bytes(take(at, 8)?.try_into().expect("8 bytes"))).map_err(|e| e.to_string())?;
    let raw = take(at, n.checked_mul(8).ok_or("representation artifact: count overflows")?)?;
    Ok(raw.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes"))).collect())
}

impl Encoded for Fitted {
    fn encode(&self) -> Vec<u8> {
        let head = Representation { maps: Vec::new(), chroma: None, ..self.0.clone() };
        let head = serde_json::to_vec(&head).expect("representation header serialises");
        let mut out = Vec::new();
        out.extend_from_slice(&(head.len() as u64).to_le_bytes());
        out.extend_from_slice(&head);
        f64_bytes(&mut out, &self.0.maps);
        out.push(u8::from(self.0.chroma.is_some()));
        if let Some(c) = &self.0.chroma {
            f64_bytes(&mut out, c);
        }
        out
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let n = bytes.get(..8).ok_or("truncated representation artifact")?;
        let n = usize::try_from(u64::from_le_bytes(n.try_into().expect("8 bytes"))).map_err(|e| e.to_string())?;
        let head = bytes.get(8..8usize.saturating_add(n)).ok_or("truncated representation artifact")?;
        let mut rep: Representation = serde_json::from_slice(head).map_err(|e| e.to_string())?;
        let mut at = 8 + n;
        rep.maps = read_f64s(bytes, &mut at)?;
        let has_chroma = *bytes.get(at).ok_or("truncated representation artifact")?;
        at += 1;
        if has_chroma == 1 {
            rep.chroma = Some(read_f64s(bytes, &mut at)?);
        }
        let m = rep.width * rep.height;
        if rep.maps.len() != m * rep.channels() || rep.chroma.as_ref().is_some_and(|c| c.len() != 3 * m) {
            return Err("representation artifact: maps of the wrong size".into());
        }
        Ok(Fitted(rep))
    }
}

/// What every relightable view reads: per-pixel maps (f32, as quilting and files hold them),
/// the basis that relights them, the chromaticity of a colour capture, whether the surface
/// wraps around (its height is then integrated periodically), and, for a layer grown under an
/// orientation field, each pixel's rotation (radians): its maps are in that frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Relightable {
    pub maps: Arc<Image>,
    pub chroma: Option<Image>,
    pub basis: Basis,
    pub periodic: bool,
    pub angles: Option<Image>,
}

#[derive(serde::Serialize, serde::Deserialize)]
struct Header {
    basis: Basis,
    periodic: bool,
    chroma: bool,
    rotated: bool,
}

impl Encoded for Relightable {
    fn encode(&self) -> Vec<u8> {
        let mut images = vec![&*self.maps];
        images.extend(&self.chroma);
        images.extend(&self.angles);
        let header = Header {
            basis: self.basis.clone(),
            periodic: self.periodic,
            chroma: self.chroma.is_some(),
            rotated: self.angles.is_some(),
        };
        pack(&header, &images)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let (h, mut images): (Header, Vec<Image>) = unpack(bytes)?;
        if images.len() != 1 + usize::from(h.chroma) + usize::from(h.rotated) {
            return Err("relightable artifact: wrong image count".into());
        }
        let angles = if h.rotated { images.pop() } else { None };
        let chroma = if h.chroma { images.pop() } else { None };
        let maps = Arc::new(images.pop().expect("counted"));
        Ok(Relightable { maps, chroma, basis: h.basis, periodic: h.periodic, angles })
    }
}

impl Relightable {
    /// The surface relit at `light`: luminance, or colour (chromaticity × luminance).
    pub fn relit(&self, light: &Light) -> Result<Image, RelightError> {
        let lum = self.luminance(light)?;
        Ok(match &self.chroma {
            None => lum,
            Some(c) => Image::from_fn(lum.width, lum.height, 3, |x, y, ch| c.get(x, y, ch) * lum.get(x, y, 0)),
        })
    }

    /// The relit luminance; each pixel in its own frame when the surface was grown rotated.
    fn luminance(&self, light: &Light) -> Result<Image, RelightError> {
        match &self.angles {
            Some(a) => frame::relight_rotated(&self.maps, &self.basis, light, a),
            None => relight::relight_image(&self.maps, &self.basis, light),
        }
    }

    /// The maps in the image's frame: as stored, or, for a surface grown rotated, rewritten
    /// per pixel (exact for 3I, Gradient and PTM; Eigen has no such rewrite).
    pub fn framed_maps(&self) -> Result<Arc<Image>, RelightError> {
        match &self.angles {
            Some(a) => Ok(Arc::new(frame::to_output_frame(&self.maps, &self.basis, a)?)),
            None => Ok(self.maps.clone()),
        }
    }

    /// The chromaticity as f64 planes, if any.
    pub fn chroma_planes(&self) -> Option<Vec<f64>> {
        self.chroma.as_ref().map(|c| c.data.iter().map(|&v| f64::from(v)).collect())
    }

    /// `(p, q, albedo)`: the maps themselves for Gradient; for the other methods, photometric
    /// stereo on the surface relit at the lights it was captured under (Eigen: its grid) or,
    /// for methods that do not keep them, at slants 30°, 45°, 60° × tilts every 30°.
    #[allow(clippy::type_complexity)]
    pub fn gradients(&self) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>), RelightError> {
        let (w, h) = (self.maps.width, self.maps.height);
        if self.basis == Basis::Gradient {
            let maps = self.framed_maps()?;
            let plane = |c: usize| maps.plane(c).iter().map(|&v| f64::from(v)).collect::<Vec<f64>>();
            return Ok((plane(0), plane(1), plane(2)));
        }
        let tilts: Vec<f64> = (0..12).map(|i| f64::from(i) * 30.0).collect();
        let lights: Vec<Light> = match &self.basis {
            Basis::Eigen(e) => e.lights.clone(),
            _ => relight::grid(&[30.0, 45.0, 60.0], &tilts),
        };
        let mut images = Vec::with_capacity(lights.len());
        for l in &lights {
            let lit = self.luminance(l)?;
            images.push(lit.data.iter().map(|&v| f64::from(v)).collect());
        }
        let stack = PhotoStack::new(w, h, images, lights)?;
        let rep = relight::extract(&stack, Method::Gradient)?;
        Ok((rep.plane(0).to_vec(), rep.plane(1).to_vec(), rep.plane(2).to_vec()))
    }
}
