//! Input files: structure JSON, label images, PNG (8/16-bit, 1–4 channels, odd sizes,
//! truncated, corrupt chunks, lying headers) and EXR (tiny, corrupt, NaN/inf/huge values),
//! each with a small scene that reads it the way tessera would (a sample image, a map's
//! `image(...)`, a library entry, a structure file).

use tessera::raster::io::{encode_exr, encode_png};
use tessera::raster::Image;

use super::Rng;

/// The valid files every workspace holds, referenced by generated scenes (`scene::IMAGES`…).
pub fn pool() -> Vec<(String, Vec<u8>)> {
    let mut rng = Rng::new(7);
    let mut out = vec![
        ("img.png".to_string(), encode_png(&noise(&mut rng, 24, 16, 3), 8).unwrap()),
        ("img16.png".to_string(), encode_png(&noise(&mut rng, 17, 13, 1), 16).unwrap()),
        ("rgba.png".to_string(), encode_png(&noise(&mut rng, 20, 20, 4), 8).unwrap()),
        ("gray.png".to_string(), encode_png(&noise(&mut rng, 32, 32, 1), 8).unwrap()),
        ("img.exr".to_string(), encode_exr(&noise(&mut rng, 16, 12, 3)).unwrap()),
        ("labels.png".to_string(), encode_png(&blocks(&mut rng, 48, 32, 8, 3), 8).unwrap()),
        ("s.json".to_string(), grid_json(&mut rng, 64, 48, 4, 3, 2.0).into_bytes()),
        ("s_small.json".to_string(), grid_json(&mut rng, 24, 24, 2, 2, 1.0).into_bytes()),
    ];
    for i in 0..3 {
        out.push((format!("lib/l{i}.png"), encode_png(&noise(&mut rng, 16, 16, 3), 8).unwrap()));
    }
    out
}

/// Empty directories the pool also needs.
pub const EMPTY_DIRS: &[&str] = &["lib_empty"];

pub struct FileCase {
    /// What was generated, for the findings log.
    pub what: String,
    pub files: Vec<(String, Vec<u8>)>,
    pub scene: String,
}

pub fn generate(rng: &mut Rng) -> FileCase {
    match rng.below(10) {
        0..=4 => {
            let (what, bytes, name) = if rng.below(5) < 3 {
                let (w, b) = png(rng);
                (w, b, "f.png".to_string())
            } else {
                let (w, b) = exr(rng);
                (w, b, if rng.chance(0.9) { "f.exr" } else { "f.png" }.to_string())
            };
            let scene = image_scene(rng, &name);
            // The library scene reads the file from a directory with one valid neighbour.
            let neighbour = encode_png(&noise(rng, 16, 16, 3), 8).expect("encodes");
            let files =
                vec![(name.clone(), bytes.clone()), (format!("flib/{name}"), bytes), ("flib/ok.png".into(), neighbour)];
            FileCase { what, files, scene }
        }
        5..=7 => {
            let (what, bytes) = structure_json(rng);
            let scene = structure_scene(rng, "f.json");
            FileCase { what, files: vec![("f.json".into(), bytes)], scene }
        }
        _ => {
            let (what, bytes) = label_image(rng);
            let scene = structure_scene(rng, "f.png");
            FileCase { what, files: vec![("f.png".into(), bytes)], scene }
        }
    }
}

fn noise(rng: &mut Rng, w: usize, h: usize, c: usize) -> Image {
    let mut img = Image::new(w, h, c);
    for v in img.data.iter_mut() {
        *v = rng.unit() as f32;
    }
    img
}

/// A label image of `nx x ny` coloured blocks.
fn blocks(rng: &mut Rng, w: usize, h: usize, nx: usize, ny: usize) -> Image {
    let colours: Vec<[f32; 3]> = (0..nx * ny)
        .map(|_| [rng.below(256) as f32 / 255.0, rng.below(256) as f32 / 255.0, rng.below(256) as f32 / 255.0])
        .collect();
    Image::from_fn(w, h, 3, |x, y, c| {
        let bx = (x * nx / w.max(1)).min(nx - 1);
        let by = (y * ny / h.max(1)).min(ny - 1);
        colours[by * nx + bx][c]
    })
}

// ---------------------------------------------------------------------------------------
// PNG

fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

/// The PNG's chunks as (offset of the length field, type, data range).
fn chunks(png: &[u8]) -> Vec<(usize, [u8; 4], std::ops::Range<usize>)> {
    let mut out = Vec::new();
    let mut i = 8;
    while i + 12 <= png.len() {
        let len = u32::from_be_bytes(png[i..i + 4].try_into().unwrap()) as usize;
        let ty: [u8; 4] = png[i + 4..i + 8].try_into().unwrap();
        let end = i + 8 + len;
        if end + 4 > png.len() {
            break;
        }
        out.push((i, ty, i + 8..end));
        i = end + 4;
    }
    out
}

fn fix_crc(png: &mut [u8], at: usize, data: std::ops::Range<usize>) {
    let crc = crc32(&png[at + 4..data.end]);
    png[data.end..data.end + 4].copy_from_slice(&crc.to_be_bytes());
}

fn odd_size(rng: &mut Rng) -> (usize, usize) {
    let side = |rng: &mut Rng| if rng.chance(0.8) { 1 + rng.below(64) } else { *rng.pick(&[1, 2, 3, 127, 257, 600]) };
    (side(rng), side(rng))
}

fn content(rng: &mut Rng, w: usize, h: usize, c: usize) -> Image {
    match rng.below(4) {
        0 => Image::filled(w, h, c, *rng.pick(&[0.0, 1.0, 0.5])),
        1 => Image::from_fn(w, h, c, |x, y, c| ((x + 2 * y + 3 * c) % 17) as f32 / 16.0),
        _ => noise(rng, w, h, c),
    }
}

pub fn png(rng: &mut Rng) -> (String, Vec<u8>) {
    let (w, h) = odd_size(rng);
    let c = 1 + rng.below(4);
    let bits = if rng.chance(0.5) { 8 } else { 16 };
    let mut bytes = encode_png(&content(rng, w, h, c), bits).expect("encodes");
    let mut what = format!("png {w}x{h} c{c} {bits}-bit");
    if rng.chance(0.6) {
        what.push_str(&corrupt_png(rng, &mut bytes));
    }
    (what, bytes)
}

fn corrupt_png(rng: &mut Rng, png: &mut Vec<u8>) -> String {
    let list = chunks(png);
    match rng.below(9) {
        0 => {
            let n = rng.below(png.len());
            png.truncate(n);
            format!(", truncated to {n}")
        }
        1 => {
            let n = 1 + rng.below(8);
            for _ in 0..n {
                let i = rng.below(png.len());
                png[i] ^= 1 << rng.below(8);
            }
            format!(", {n} bit flips")
        }
        2 | 3 => {
            // A header that lies about the size, with a valid CRC so decoders believe it.
            let (at, _, data) = list[0].clone();
            let w = *rng.pick(&[0u32, 1, 65_535, 100_000, 1 << 20, 0x7FFF_FFFF, u32::MAX]);
            let h = *rng.pick(&[0u32, 1, 65_535, 100_000, 1 << 20, 0x7FFF_FFFF]);
            png[data.start..data.start + 4].copy_from_slice(&w.to_be_bytes());
            png[data.start + 4..data.start + 8].copy_from_slice(&h.to_be_bytes());
            fix_crc(png, at, data);
            format!(", IHDR says {w}x{h}")
        }
        4 => {
            let (at, _, data) = list[0].clone();
            let depth = *rng.pick(&[1u8, 2, 4, 8, 16, 3, 0, 32]);
            let ty = *rng.pick(&[0u8, 2, 3, 4, 6, 1, 7]);
            png[data.start + 8] = depth;
            png[data.start + 9] = ty;
            if rng.chance(0.3) {
                png[data.start + 12] = 1; // Adam7 interlace
            }
            fix_crc(png, at, data);
            format!(", IHDR depth {depth} colour type {ty}")
        }
        5 => {
            // Corrupt the compressed data but keep the CRC valid.
            if let Some((at, _, data)) = list.iter().find(|c| &c.1 == b"IDAT").cloned() {
                if !data.is_empty() {
                    for _ in 0..1 + rng.below(4) {
                        let i = data.start + rng.below(data.len());
                        png[i] = rng.next() as u8;
                    }
                    fix_crc(png, at, data);
                }
            }
            ", IDAT garbage (valid CRC)".into()
        }
        6 => {
            // Drop IEND, or everything after IHDR.
            if rng.chance(0.5) {
                let n = png.len() - 12;
                png.truncate(n);
                ", no IEND".into()
            } else {
                let end = list[0].2.end + 4;
                png.truncate(end);
                ", IHDR only".into()
            }
        }
        7 => {
            // An unknown critical chunk, or a chunk claiming a huge length.
            let at = list[0].2.end + 4;
            let mut chunk = Vec::new();
            if rng.chance(0.5) {
                chunk.extend_from_slice(&4u32.to_be_bytes());
                chunk.extend_from_slice(b"ZZZZ");
                chunk.extend_from_slice(&[1, 2, 3, 4]);
                let crc = crc32(&chunk[4..]);
                chunk.extend_from_slice(&crc.to_be_bytes());
            } else {
                chunk.extend_from_slice(&0x7FFF_FFF0u32.to_be_bytes());
                chunk.extend_from_slice(b"tEXt");
            }
            png.splice(at..at, chunk);
            ", odd chunk".into()
        }
        _ => {
            // A duplicated IDAT.
            if let Some((at, _, data)) = list.iter().find(|c| &c.1 == b"IDAT").cloned() {
                let piece = png[at..data.end + 4].to_vec();
                png.splice(at..at, piece);
            }
            ", IDAT twice".into()
        }
    }
}

// ---------------------------------------------------------------------------------------
// EXR

pub fn exr(rng: &mut Rng) -> (String, Vec<u8>) {
    use exr::prelude as x;
    use exr::prelude::WritableImage;
    let (w, h) = if rng.chance(0.7) { (1 + rng.below(16), 1 + rng.below(16)) } else { odd_size(rng) };
    let options: [&[&str]; 6] = [&["Y"], &["R", "G", "B"], &["R", "G", "B", "A"], &["R", "G"], &["Z"], &["A"]];
    let names = *rng.pick(&options);
    let special = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 3e38, -3e38, f32::MAX, 1e-45, -0.0, 65504.0, 1e20];
    let mode = rng.below(4);
    let sample = |rng: &mut Rng| -> f32 {
        match mode {
            0 => rng.unit() as f32,
            1 if rng.chance(0.1) => *rng.pick(&special),
            1 => rng.unit() as f32,
            2 => *rng.pick(&special),
            _ => (rng.unit() as f32 - 0.5) * 1e6,
        }
    };
    let kind = rng.below(3);
    let list: x::SmallVec<[x::AnyChannel<x::FlatSamples>; 4]> = names
        .iter()
        .map(|&n| {
            let samples = match kind {
                0 => x::FlatSamples::F32((0..w * h).map(|_| sample(rng)).collect()),
                1 => x::FlatSamples::F16((0..w * h).map(|_| x::f16::from_f32(sample(rng))).collect()),
                _ => x::FlatSamples::U32((0..w * h).map(|_| rng.next() as u32 >> rng.below(32)).collect()),
            };
            x::AnyChannel::new(n, samples)
        })
        .collect();
    let compression =
        *rng.pick(&[x::Compression::Uncompressed, x::Compression::ZIP16, x::Compression::RLE, x::Compression::PIZ]);
    let encoding = x::Encoding { compression, blocks: x::Blocks::ScanLines, line_order: x::LineOrder::Increasing };
    let layer = x::Layer::new((w, h), x::LayerAttributes::default(), encoding, x::AnyChannels::sort(list));
    let mut out = std::io::Cursor::new(Vec::new());
    let mut what = format!("exr {w}x{h} {names:?} kind {kind} values {mode} {compression:?}");
    if x::Image::from_layer(layer).write().non_parallel().to_buffered(&mut out).is_err() {
        what.push_str(" (encoder refused)");
        return (what, b"v/1\x01garbage".to_vec());
    }
    let mut bytes = out.into_inner();
    if rng.chance(0.5) {
        match rng.below(3) {
            0 => {
                let n = rng.below(bytes.len());
                bytes.truncate(n);
                what.push_str(&format!(", truncated to {n}"));
            }
            1 => {
                // Flip bytes in the header (attributes, data window).
                let end = bytes.len().min(400);
                for _ in 0..1 + rng.below(4) {
                    let i = 4 + rng.below(end - 4);
                    bytes[i] = rng.next() as u8;
                }
                what.push_str(", header bytes changed");
            }
            _ => {
                for _ in 0..1 + rng.below(8) {
                    let i = rng.below(bytes.len());
                    bytes[i] ^= 1 << rng.below(8);
                }
                what.push_str(", bit flips");
            }
        }
    }
    (what, bytes)
}

// ---------------------------------------------------------------------------------------
// Structures

/// A grid subdivision of `nx x ny` jittered cells over `w x h`.
fn grid_json(rng: &mut Rng, w: usize, h: usize, nx: usize, ny: usize, jitter: f64) -> String {
    let mut v = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let border_x = i == 0 || i == nx;
            let border_y = j == 0 || j == ny;
            let jx = if border_x { 0.0 } else { (rng.unit() - 0.5) * jitter };
            let jy = if border_y { 0.0 } else { (rng.unit() - 0.5) * jitter };
            v.push([(i * w) as f64 / nx as f64 + jx, (j * h) as f64 / ny as f64 + jy]);
        }
    }
    let id = |i: usize, j: usize| j * (nx + 1) + i;
    let mut e = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            if i < nx {
                e.push([id(i, j), id(i + 1, j)]);
            }
            if j < ny {
                e.push([id(i, j), id(i, j + 1)]);
            }
        }
    }
    let verts: Vec<String> = v.iter().map(|p| format!("[{:.3}, {:.3}]", p[0], p[1])).collect();
    let edges: Vec<String> = e.iter().map(|p| format!("[{}, {}]", p[0], p[1])).collect();
    format!(
        "{{\n  \"units\": \"px\",\n  \"size\": [{w}, {h}],\n  \"vertices\": [{}],\n  \"edges\": [{}]\n}}\n",
        verts.join(", "),
        edges.join(", ")
    )
}

pub fn structure_json(rng: &mut Rng) -> (String, Vec<u8>) {
    let most = if rng.chance(0.9) { 6 } else { 40 };
    let nx = 1 + rng.below(most);
    let most = if rng.chance(0.9) { 6 } else { 40 };
    let ny = 1 + rng.below(most);
    let cell = *rng.pick(&[1usize, 2, 4, 8, 12, 16, 24]);
    let (w, h) = (nx * cell, ny * cell);
    let jitter = *rng.pick(&[0.0, 0.5, 1.0, 3.0]);
    let text = grid_json(rng, w, h, nx, ny, jitter);
    let mut what = format!("structure grid {nx}x{ny} cells of {cell} px, jitter {jitter}");
    let text = match rng.below(16) {
        0..=4 => text,
        5 => {
            let n = rng.below(text.len());
            what.push_str(&format!(", truncated to {n}"));
            text[..n].to_string()
        }
        6 => {
            let v = *rng.pick(&["1e308", "-1e308", "1e400", "NaN", "\"NaN\"", "null", "-0", "1e-320", "9e15", "-5"]);
            what.push_str(&format!(", a coordinate {v}"));
            text.replacen("[0.000, 0.000]", &format!("[{v}, 0.000]"), 1)
        }
        7 => {
            let s = *rng.pick(&[
                "[0, 0]",
                "[-1, 5]",
                "[1e308, 1e308]",
                "[100000, 100000]",
                "[1]",
                "[0.5, 0.5]",
                "\"big\"",
                "[NaN, 1]",
            ]);
            what.push_str(&format!(", size {s}"));
            let head = format!("\"size\": [{w}, {h}]");
            text.replacen(&head, &format!("\"size\": {s}"), 1)
        }
        8 => {
            let e = *rng.pick(&["[0, 0]", "[0, 99999]", "[-1, 2]", "[0]", "[0, 1, 2]", "[1.5, 2]", "[4294967296, 0]"]);
            what.push_str(&format!(", edge {e}"));
            text.replacen("\"edges\": [", &format!("\"edges\": [{e}, "), 1)
        }
        9 => {
            what.push_str(", duplicate vertex");
            text.replacen("\"vertices\": [", "\"vertices\": [[0.000, 0.000], ", 1)
        }
        10 => {
            what.push_str(", unknown key / wrong units");
            let r = *rng.pick(&["\"units\": \"mm\"", "\"edge\": []", "\"units\": 1"]);
            text.replacen("\"units\": \"px\"", r, 1)
        }
        11 => {
            what.push_str(", empty");
            rng.pick(&[
                "{}",
                "",
                "[]",
                "{\"vertices\": [], \"edges\": []}",
                "null",
                "{\"vertices\": [[0,0],[1,0],[0,1]], \"edges\": [[0,1],[1,2],[2,0]]}",
            ])
            .to_string()
        }
        12 => {
            // Byte-level damage.
            let mut b = text.into_bytes();
            for _ in 0..1 + rng.below(6) {
                let i = rng.below(b.len());
                b[i] = *rng.pick(b"[]{},:0123456789.-e\"\xff");
            }
            what.push_str(", byte damage");
            return (what, b);
        }
        13 => {
            // Crossing edges: a diagonal through every cell.
            what.push_str(", crossing diagonal");
            let last = (nx + 1) * (ny + 1) - 1;
            text.replacen("\"edges\": [", &format!("\"edges\": [[0, {last}], [{nx}, {}], ", last - nx), 1)
        }
        14 => {
            let d = 100 + rng.below(2000);
            what.push_str(&format!(", nested {d}"));
            format!("{}{}", "[".repeat(d), "]".repeat(d))
        }
        _ => {
            // Scale the coordinates by a tiny or huge factor.
            let f = *rng.pick(&[1e-12, 1e-6, 1e6, 1e12, -1.0]);
            what.push_str(&format!(", coordinates x {f}"));
            let mut r2 = Rng::new(rng.next());
            let mut t = grid_json(&mut r2, w, h, nx, ny, jitter);
            t = t.replace(&format!("\"size\": [{w}, {h}]"), &format!("\"size\": [{}, {}]", w as f64 * f, h as f64 * f));
            t
        }
    };
    (what, text.into_bytes())
}

pub fn label_image(rng: &mut Rng) -> (String, Vec<u8>) {
    let (w, h) = (1 + rng.below(64), 1 + rng.below(64));
    // Degenerate images (a region per pixel, noise) are kept small and rare: they are the
    // slow path of region analysis, and a few cases find it.
    let degenerate = rng.chance(0.1);
    let (w, h) = if degenerate { (1 + w / 4, 1 + h / 4) } else { (w, h) };
    let (img, what) = match if degenerate { rng.below(3) } else { 3 } {
        0 => {
            // Every pixel its own region.
            let img = Image::from_fn(w, h, 3, |x, y, c| [x as f32 / 255.0, y as f32 / 255.0, 0.5][c]);
            (img, format!("labels {w}x{h}, every pixel its own region"))
        }
        1 => (Image::filled(w, h, 3, 0.25), format!("labels {w}x{h}, one colour")),
        2 => {
            let c = if rng.chance(0.5) { 1 } else { 4 };
            (noise(rng, w, h, c), format!("labels {w}x{h}, noise"))
        }
        _ => {
            let nx = 1 + rng.below(8);
            let ny = 1 + rng.below(8);
            (blocks(rng, w.max(nx), h.max(ny), nx, ny), format!("labels {w}x{h}, {nx}x{ny} blocks"))
        }
    };
    let bits = if rng.chance(0.8) { 8 } else { 16 };
    let mut bytes = if rng.chance(0.9) { encode_png(&img, bits).unwrap() } else { encode_exr(&img).unwrap() };
    let mut what = what;
    if rng.chance(0.2) && bytes.starts_with(b"\x89PNG") {
        what.push_str(&corrupt_png(rng, &mut bytes));
    }
    (what, bytes)
}

// ---------------------------------------------------------------------------------------
// Scenes that read the files

fn image_scene(rng: &mut Rng, file: &str) -> String {
    let mut s = format!("scene {{\n  size = 32 x 32\n  seed = {}\n}}\n", rng.below(100));
    match rng.below(5) {
        0 | 1 => {
            s.push_str(&format!("sample s {{\n  image = \"{file}\"\n"));
            if rng.chance(0.3) {
                s.push_str(&format!(
                    "  crop = [{}, {}, {}, {}]\n",
                    rng.below(4),
                    rng.below(4),
                    1 + rng.below(20),
                    1 + rng.below(20)
                ));
            }
            if rng.chance(0.4) {
                s.push_str(&format!("  resize = {} x {}\n", 1 + rng.below(40), 1 + rng.below(40)));
            }
            s.push_str(&format!("  color = {}\n}}\n", rng.pick(&["srgb", "linear", "lab"])));
            let out = rng.pick(&["o.png", "o.exr"]);
            s.push_str(&format!("output \"{out}\" {{\n  from = s\n}}\n"));
            if rng.chance(0.3) {
                s.push_str("surface qs {\n  plane = 24 x 24\n}\nlayer q {\n  quilt = s\n  on = qs\n  block = 8 px\n}\noutput \"q.png\" {\n  from = q\n}\n");
            }
        }
        2 | 3 => {
            let ch = rng.pick(&["luminance", "r", "g", "b", "a", "vector"]);
            s.push_str(&format!(
                "map m {{\n  from = image(\"{file}\", channel = {ch})\n  size = {} x {}\n}}\n",
                1 + rng.below(40),
                1 + rng.below(40)
            ));
            let out = rng.pick(&["m.png", "m.exr"]);
            s.push_str(&format!("output \"{out}\" {{\n  from = m\n}}\n"));
        }
        _ => {
            // A library entry: the file among the pool's images.
            s.push_str(&format!(
                "sample t {{\n  image = \"img.png\"\n}}\nlibrary l {{\n  dir = \"{}\"\n}}\nsample s {{\n  from = similar(library = l, to = t, k = 2)\n}}\noutput \"s.png\" {{\n  from = s\n}}\n",
                "flib"
            ));
        }
    }
    s
}

fn structure_scene(rng: &mut Rng, file: &str) -> String {
    let (w, h) = (16 + rng.below(49), 16 + rng.below(49));
    let mut s = format!("scene {{\n  size = {w} x {h}\n}}\nsample t {{\n  structure = \"{file}\"\n}}\nsurface d {{\n  plane = {w} x {h}\n}}\n");
    s.push_str("structure c {\n  from = t\n  on = d\n");
    if rng.chance(0.3) {
        s.push_str("  mode = trivial\n");
    }
    if rng.chance(0.4) {
        s.push_str(&format!("  scale = {}\n", rng.pick(&["0.5", "1", "2", "0.25", "1.5"])));
    }
    if rng.chance(0.2) {
        s.push_str("  exclude_border_regions = false\n");
    }
    if rng.chance(0.2) {
        s.push_str("  ellipse_fit = pixels\n");
    }
    s.push_str(&format!("  lloyd {{\n    iterations = {}\n  }}\n", rng.below(12)));
    s.push_str(&format!("  shapes {{\n    iterations = {}\n  }}\n", rng.below(12)));
    s.push_str("}\n");
    let view = rng.pick(&[
        ("labels", "png"),
        ("labels16", "png"),
        ("edges", "png"),
        ("ellipses", "png"),
        ("distance", "png"),
        ("closest", "png"),
        ("mesh", "json"),
        ("svg", "svg"),
        ("stats", "json"),
    ]);
    let format = if view.0 == "labels16" { "\n  format = png16" } else { "" };
    s.push_str(&format!("output \"c.{}\" {{\n  from = c\n  view = {}{format}\n}}\n", view.1, view.0));
    s
}
