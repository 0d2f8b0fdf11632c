//! The artifacts of the appearance stages and their cache encodings: a JSON header and the
//! images behind it, each in the raster codec, so textures stay binary.

use super::super::artifact::{pack, unpack};
use super::super::Encoded;
use crate::synth::appearance::analysis::{Contours, Interiors};
use crate::synth::appearance::Dressing;

impl Encoded for Interiors {
    fn encode(&self) -> Vec<u8> {
        let (meta, images) = self.split();
        pack(&meta, &images)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let (meta, images) = unpack(bytes)?;
        Interiors::join(meta, images)
    }
}

impl Encoded for Contours {
    fn encode(&self) -> Vec<u8> {
        let (meta, images) = self.split();
        pack(&meta, &images)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let (meta, images) = unpack(bytes)?;
        Contours::join(meta, images)
    }
}

impl Encoded for Dressing {
    fn encode(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("dressing serialises")
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        serde_json::from_slice(bytes).map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::Image;

    #[test]
    fn pack_round_trips_and_refuses_truncation() {
        let a = Image::from_fn(3, 2, 4, |x, y, c| (x + 2 * y + 7 * c) as f32);
        let b = Image::filled(1, 1, 1, 0.5);
        let bytes = pack(&vec![1, 2, 3], &[&a, &b]);
        let (meta, images): (Vec<i32>, Vec<Image>) = unpack(&bytes).unwrap();
        assert_eq!(meta, vec![1, 2, 3]);
        assert_eq!(images, vec![a, b]);
        for cut in [0, 5, 9, bytes.len() - 1] {
            assert!(unpack::<Vec<i32>>(&bytes[..cut]).is_err());
        }
    }

    /// A cached header gives back the very floats it was written from: a stage re-run on
    /// cached inputs (the dressing on cached atlases) decides exactly as on fresh ones. JSON's
    /// default best-effort parser came back one ulp off on numbers like these, and a dressing
    /// re-run from the cache differed from a fresh build's.
    #[test]
    fn cached_floats_come_back_bit_for_bit() {
        let mut rng = crate::synth::rng::Rng::new(5);
        let mut floats = vec![97.45365320034685, 18.916268423199654, 2.0612498074769974, 0.1 + 0.2, 5e-324];
        floats.extend((0..10_000).map(|_| rng.range(-1000.0, 1000.0)));
        let bytes = pack(&floats, &[]);
        let (back, _): (Vec<f64>, Vec<Image>) = unpack(&bytes).unwrap();
        for (a, b) in floats.iter().zip(&back) {
            assert_eq!(a.to_bits(), b.to_bits(), "{a} came back as {b}");
        }
    }

    /// A stage reading its input from the disk cache must see the value the producer made:
    /// atlas positions and texture coordinates are computed `f64`s whose shortest decimal has
    /// 17 digits, which JSON parsing without exact rounding reads back an ulp off (and
    /// matching, downstream, then decided differently for dozens of junctions).
    #[test]
    fn contours_and_dressings_decode_to_the_values_encoded() {
        use crate::synth::appearance::analysis::{contours, ContourParams};
        use crate::synth::appearance::dress::{dress, testkit, DressHints, DressParams};
        use crate::synth::appearance::AppearanceData;
        use crate::synth::structure::analysis::sample::analyse_subdivision;
        use crate::synth::structure::analysis::stats::StatsConfig;
        use crate::synth::structure::fixtures::standins::{paint, wall_random, PaintParams, WallRandomParams};

        let s = wall_random(&WallRandomParams::default(), 4);
        let photo = paint(&s, &PaintParams::default(), 4);
        let sample =
            analyse_subdivision(&s.subdivision, Some([s.width as f64, s.height as f64]), &StatsConfig::default())
                .expect("analyses");
        let c = contours(&photo.image, &sample, &ContourParams::default(), None).expect("contours");
        assert_eq!(Contours::decode(&c.encode()).expect("decodes"), c);
        let data = AppearanceData {
            unified: testkit::unified(2, 256, true),
            originals: testkit::originals(2),
            interstices: c.interstices.clone(),
            junctions: c.junctions.clone(),
        };
        let d = dress(&s.mesh, &data, &DressParams::default(), 3, &DressHints::default());
        assert!(d.pieces.len() > s.mesh.regions.len());
        assert_eq!(Dressing::decode(&d.encode()).expect("decodes"), d);
    }
}
