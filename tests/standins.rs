//! The structure samples in `samples/standins/` are the synthetic stand-ins of [references: frasson §3.6],
//! generated from seeded procedures. This test regenerates them and checks that the
//! committed files match, so samples, generators and ground truth never drift apart.
//! Set `TESSERA_REGENERATE=1` to rewrite the files instead.

use std::path::PathBuf;

use tessera::raster::{self, Image};
use tessera::synth::structure::fixtures::standins::{self as s, StandIn};
use tessera::synth::structure::{format, render};

fn all() -> Vec<StandIn> {
    vec![
        s::wall_random(&s::WallRandomParams::default(), 1),
        s::wall_layered(&s::WallLayeredParams::default(), 4),
        s::wall_regular(&s::WallRegularParams::default(), 3),
        s::cells_iso(&s::CellsIsoParams::default(), 5),
        s::scales_diag(&s::ScalesDiagParams::default(), 6),
    ]
}

/// Every generated file: structure JSON, ground-truth labels, density maps, facade mask.
fn files() -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for st in all() {
        let size = [st.width as f64, st.height as f64];
        out.push((format!("{}.json", st.name), format::to_json_sized(&st.subdivision, size).into_bytes()));
        let labels = render::labels_colour(&st.rasterize());
        out.push((format!("{}_truth.png", st.name), raster::io::encode_png(&labels, 8).expect("png")));
        if let Some(d) = &st.density {
            let img = Image { width: st.width, height: st.height, channels: 1, data: d.clone() };
            out.push((format!("{}_density.png", st.name), raster::io::encode_png(&img, 8).expect("png")));
        }
    }
    // Photos painted for the appearance stand-ins, with their ground-truth mortar masks.
    let walls = all();
    let tints: [(usize, Vec<[f64; 3]>); 3] = [
        (0, s::PaintParams::default().tints),
        // Levens: two stone tints and green "leaf" stones.
        (1, vec![[60.0, 4.0, 18.0], [42.0, 2.0, 6.0], [46.0, -30.0, 32.0]]),
        // Valbonne: brick reds.
        (2, vec![[48.0, 30.0, 28.0], [38.0, 24.0, 20.0], [56.0, 22.0, 30.0]]),
    ];
    for (i, tints) in tints {
        let st = &walls[i];
        let painted = s::paint(st, &s::PaintParams { tints, ..s::PaintParams::default() }, 7);
        out.push((format!("{}_photo.png", st.name), raster::io::encode_png(&painted.image, 8).expect("png")));
        let mortar = Image {
            width: st.width,
            height: st.height,
            channels: 1,
            data: painted.mortar.iter().map(|&m| if m { 1.0 } else { 0.0 }).collect(),
        };
        out.push((format!("{}_mortar.png", st.name), raster::io::encode_png(&mortar, 8).expect("png")));
    }
    let (w, h) = (384, 256);
    let facade = Image { width: w, height: h, channels: 1, data: s::facade_occupancy(w, h) };
    out.push(("facade_occupancy.png".into(), raster::io::encode_png(&facade, 8).expect("png")));
    out
}

#[test]
fn committed_standins_match_their_generators() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("samples/standins");
    let regenerate = std::env::var_os("TESSERA_REGENERATE").is_some();
    for (name, bytes) in files() {
        let path = dir.join(&name);
        if regenerate {
            std::fs::create_dir_all(&dir).expect("mkdir");
            std::fs::write(&path, &bytes).expect("write");
            continue;
        }
        let committed = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(committed == bytes, "{name} differs from its generator; run with TESSERA_REGENERATE=1");
    }
}
