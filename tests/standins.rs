//! The structure samples in `samples/standins/` are the synthetic stand-ins of [references: frasson §3.6],
//! generated from seeded procedures, and the photometric captures in
//! `samples/capture/scenario_a` … `scenario_d` are the synthetic relighting scenarios A–D
//! rendered by `synth::relight::fixtures` (tessera's stand-ins for the PhoTex captures,
//! [references: dong §3.3]). This test regenerates them and checks that the committed files
//! match, so samples, generators and ground truth never drift apart.
//! The relief stand-ins in `samples/relief/` ([references: frasson §5.3.3]: the Biot wall, the
//! door, the chip, the stone block, the metal plate) are photos with their true height and the
//! patches cut for them, from `synth::relief::fixtures`.
//! Set `TESSERA_REGENERATE=1` to rewrite the files instead.

use std::path::PathBuf;

use tessera::raster::{self, Image};
use tessera::synth::relief::fixtures::{self as relief, Relief};
use tessera::synth::relight::fixtures::{self as photometric, Scenario};
use tessera::synth::relight::Light;
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
        if i == 0 {
            // True height for relief patches cut from the photo: mortar recessed, stones up.
            let height = Image::from_fn(st.width, st.height, 1, |x, y, _| {
                if mortar.get(x, y, 0) > 0.5 {
                    64.0 / 255.0
                } else {
                    191.0 / 255.0
                }
            });
            out.push((format!("{}_height.png", st.name), raster::io::encode_png(&height, 8).expect("png")));
        }
    }
    let (w, h) = (384, 256);
    let facade = Image { width: w, height: h, channels: 1, data: s::facade_occupancy(w, h) };
    out.push(("facade_occupancy.png".into(), raster::io::encode_png(&facade, 8).expect("png")));
    out
}

/// Writes `files` into `dir` (with `TESSERA_REGENERATE` set) or checks that the committed
/// files there are byte for byte the generated ones.
fn sync(dir: &std::path::Path, files: Vec<(String, Vec<u8>)>) {
    let regenerate = std::env::var_os("TESSERA_REGENERATE").is_some();
    for (name, bytes) in files {
        let path = dir.join(&name);
        if regenerate {
            std::fs::create_dir_all(path.parent().expect("parent")).expect("mkdir");
            std::fs::write(&path, &bytes).expect("write");
            continue;
        }
        let committed = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(committed == bytes, "{name} differs from its generator; run with TESSERA_REGENERATE=1");
    }
}

#[test]
fn committed_standins_match_their_generators() {
    sync(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("samples/standins"), files());
}

/// A plane of values in [0, 1] as a 16-bit greyscale PNG: each value is rounded to its code
/// `round(v · 65535)` here, in f64, and handed to the encoder as `code / 65535`, which the
/// encoder rounds back to the same code.
fn png16(n: usize, values: impl Iterator<Item = f64>) -> Vec<u8> {
    let data = values.map(|v| ((v.clamp(0.0, 1.0) * 65535.0).round() / 65535.0) as f32).collect();
    raster::io::encode_png(&Image { width: n, height: n, channels: 1, data }, 16).expect("png")
}

/// The light-position file's line for `light`: its direction in the RTI frame (y up the
/// image), with enough decimals that loading gives the grid's tilt and slant back to well
/// within the 1e-9° to which lights are matched (six decimals would move them by ~1e-4°).
fn lp_line(file: &str, light: &Light) -> String {
    let d = light.rti_direction();
    format!("{file} {:.15} {:.15} {:.15}", d.x, d.y, d.z)
}

/// Scenario `s`'s capture as files under `scenario_x/`: the 36 images (16-bit linear PNG,
/// every image divided by the capture's largest value, so that value is full scale), the
/// light-position file, and the truth: the height stretched to [0, 1] and the albedo, as
/// 16-bit PNGs.
fn capture_files(s: Scenario) -> Vec<(String, Vec<u8>)> {
    let c = photometric::scenario(s);
    let name = format!("scenario_{}", format!("{s:?}").to_lowercase());
    let top = c.stack.images.iter().flatten().cloned().fold(0.0, f64::max);
    let mut out = Vec::new();
    let mut lp = format!("{}\n", c.stack.len());
    for (img, light) in c.stack.images.iter().zip(&c.stack.lights) {
        let file = format!("{name}_s{:02}_t{:03}.png", light.slant_deg.round(), light.tilt_deg.round());
        lp.push_str(&lp_line(&file, light));
        lp.push('\n');
        out.push((format!("{name}/{file}"), png16(c.n, img.iter().map(|v| v / top))));
    }
    out.push((format!("{name}/{name}.lp"), lp.into_bytes()));
    let (lo, hi) = c.height.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    out.push((format!("{name}/truth_height.png"), png16(c.n, c.height.iter().map(|v| (v - lo) / (hi - lo)))));
    out.push((format!("{name}/truth_albedo.png"), png16(c.n, c.albedo.iter().copied())));
    out
}

#[test]
fn committed_captures_match_their_generators() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("samples/capture");
    for s in Scenario::ALL {
        let files = capture_files(s);
        // The light-position file names the grid's lights, in the frame the loader reads.
        let (_, lp) = files.iter().find(|(n, _)| n.ends_with(".lp")).expect("a light-position file");
        let lp = String::from_utf8(lp.clone()).expect("utf-8");
        let mut lines = lp.lines();
        assert_eq!(lines.next(), Some("36"));
        for (line, want) in lines.zip(photometric::lights36()) {
            let xyz: Vec<f64> = line.split_whitespace().skip(1).map(|f| f.parse().expect("a number")).collect();
            let len = xyz.iter().map(|v| v * v).sum::<f64>().sqrt();
            let got = Light::from_rti_direction(xyz[0] / len, xyz[1] / len, xyz[2] / len);
            assert!(got.same(&want), "{line}: {got:?} is not {want:?}");
        }
        sync(&dir, files);
    }
}

/// A relief stand-in as files: `NAME.png` (8-bit sRGB colour), `NAME_height.png` (16-bit
/// height: codes over full scale, as the `height` layer reads them).
fn relief_files(name: &str, r: &Relief) -> Vec<(String, Vec<u8>)> {
    let colour = raster::color::image_linear_to_srgb(&r.colour);
    vec![
        (format!("{name}.png"), raster::io::encode_png(&colour, 8).expect("png")),
        (format!("{name}_height.png"), raster::io::encode_png(&r.height, 16).expect("png")),
    ]
}

#[test]
fn committed_relief_standins_match_their_generators() {
    let mut files = Vec::new();
    files.extend(relief_files("brick_foliage/wall", &relief::brick_foliage(11)));
    let [bricks, foliage] = relief::brick_foliage_patches(12);
    files.extend(relief_files("brick_foliage/patch_bricks", &bricks));
    files.extend(relief_files("brick_foliage/patch_foliage", &foliage));
    files.extend(relief_files("door/door", &relief::door(160, 160, 40, 21)));
    files.extend(relief_files("door/patch_wood", &relief::door(100, 100, 0, 22)));
    files.extend(relief_files("door/patch_studs", &relief::door(100, 100, 24, 23)));
    files.extend(relief_files("block/rock", &relief::block(128, 128, 41)));
    files.extend(relief_files("block/patch_rock", &relief::block(100, 100, 42)));
    files.extend(relief_files("plate/plate", &relief::plate(160, 160, 8, 51)));
    files.extend(relief_files("plate/patch_plate", &relief::plate(100, 100, 4, 52)));
    files.extend(relief_files("chip/chip", &relief::chip(160, 160, 6, 31)));
    files.extend(relief_files("chip/patch_chip", &relief::chip(100, 100, 2, 32)));
    sync(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("samples/relief"), files);
}

/// A column of twelve sides and a cap, 2 units high and of radius 0.5, for the relief scenes:
/// side `k` takes the texture's columns `k/12 … (k+1)/12` below v = 0.8, the cap a disc above.
fn column_obj() -> String {
    let (sides, r, h) = (12usize, 0.5f64, 2.0f64);
    let mut s = String::from("# tessera stand-in: a twelve-sided column with a cap (y up)\n");
    for y in [0.0, h] {
        for k in 0..sides {
            let t = std::f64::consts::TAU * k as f64 / sides as f64;
            s += &format!("v {:.6} {:.6} {:.6}\n", r * t.sin(), y, r * t.cos());
        }
    }
    for k in 0..=sides {
        for v in [0.0, 0.8] {
            s += &format!("vt {:.6} {:.6}\n", k as f64 / sides as f64, v);
        }
    }
    for k in 0..sides {
        let t = std::f64::consts::TAU * k as f64 / sides as f64;
        s += &format!("vt {:.6} {:.6}\n", 0.5 + 0.07 * t.sin(), 0.9 - 0.09 * t.cos());
    }
    // Positions: bottom ring 1..=12, top ring 13..=24. UVs: (k, bottom) = 2k + 1, (k, top) = 2k + 2.
    for k in 0..sides {
        let (b0, b1, t0, t1) = (k + 1, (k + 1) % sides + 1, k + 1 + sides, (k + 1) % sides + 1 + sides);
        let (u0b, u1b, u1t, u0t) = (2 * k + 1, 2 * (k + 1) + 1, 2 * (k + 1) + 2, 2 * k + 2);
        s += &format!("f {b0}/{u0b} {b1}/{u1b} {t1}/{u1t} {t0}/{u0t}\n");
    }
    let cap: Vec<String> = (0..sides).map(|k| format!("{}/{}", k + 1 + sides, 2 * (sides + 1) + k + 1)).collect();
    s += &format!("f {}\n", cap.join(" "));
    s
}

#[test]
fn committed_meshes_match_their_generators() {
    let files = vec![("column.obj".to_string(), column_obj().into_bytes())];
    sync(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("samples/meshes"), files);
}
