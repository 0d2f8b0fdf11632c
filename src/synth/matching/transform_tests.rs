//! Checks of transformations: subdivision and timing on synthetic shaders, jump points, paths
//! and frame sequences on the library.

use super::tests::{candidates, SIDE};
use super::transform::{midpoint, nearest_vertex, subdivide, times};
use super::*;
use crate::raster::Image;
use crate::synth::shader;

fn values(name: &str, set: &[(&str, f64)]) -> Vec<f64> {
    let def = shader::shader(name).unwrap();
    let mut v = def.defaults();
    for &(p, x) in set {
        let at = shader::params::offsets(def.params)[def.param(p).unwrap()];
        v[at] = x;
    }
    v
}

fn index(cands: &[Candidate], name: &str) -> usize {
    cands.iter().position(|c| c.probe.space.shader.name == name).unwrap()
}

fn run(
    cands: &[Candidate],
    keys: &[(&str, Vec<f64>)],
    cfg: &TransformConfig,
    jumps: &JumpConfig,
    min_jump: f64,
) -> Result<(Transformation, Vec<JumpSet>), TransformError> {
    let mut sets = Vec::new();
    let mut pairs = Vec::new();
    for a in 0..cands.len() {
        for b in a + 1..cands.len() {
            let mut j = jump_points(&cands[a], &cands[b], jumps);
            j.points.retain(|p| p.score >= min_jump);
            sets.push(j);
            pairs.push((a, b));
        }
    }
    let links: Vec<Link> = pairs.iter().zip(&sets).map(|(&(a, b), j)| Link { a, b, jumps: j }).collect();
    let keys: Vec<Key> = keys.iter().map(|(n, v)| Key { shader: index(cands, n), values: v.clone() }).collect();
    transform(cands, &links, &keys, cfg).map(|t| (t, sets))
}

/// Every gap between frames of one shader reaches `τ` or is reported; jumps are never halved;
/// times grow strictly from 0 to 1.
fn assert_sound(t: &Transformation, tau: f64) {
    for (i, f) in t.frames.iter().enumerate().skip(1) {
        if !f.jump {
            assert!(f.score >= tau || t.failed.contains(&i), "frame {i}: {} below {tau}", f.score);
        }
    }
    let times: Vec<f64> = t.frames.iter().map(|f| f.t).collect();
    assert_eq!(times[0], 0.0);
    assert_eq!(*times.last().unwrap(), 1.0);
    assert!(times.windows(2).all(|w| w[1] > w[0]), "{times:?}");
}

#[test]
fn subdivision_halves_until_neighbours_are_alike_and_more_where_the_shader_is_steep() {
    // F38 on the x⁸ "shader": its render changes fastest near 1.
    let close = |a: &(f64, f64), b: &(f64, f64)| (a.1 - b.1).abs() <= 0.02;
    let mid = |a: &(f64, f64), b: &(f64, f64)| {
        let x = 0.5 * (a.0 + b.0);
        Some((x, x.powi(8)))
    };
    let pts = vec![(0.0, 0.0), (0.5, 0.5f64.powi(8)), (1.0, 1.0)];
    let s = subdivide(pts.clone(), |_, _| true, close, mid, 10, 10_000);
    assert!(s.failed.is_empty());
    assert!(s.points.windows(2).all(|w| close(&w[0], &w[1])));
    let left = s.points.iter().filter(|p| p.0 > 0.0 && p.0 < 0.5).count();
    let right = s.points.iter().filter(|p| p.0 > 0.5 && p.0 < 1.0).count();
    assert!(right > 5 * left.max(1), "{left} {right}");
    assert_eq!(s.inserted, left + right);
    // At the depth cap the gaps still apart are reported, and each edge got at most 2^depth − 1.
    let strict = |a: &(f64, f64), b: &(f64, f64)| (a.1 - b.1).abs() <= 1e-4;
    let s = subdivide(pts.clone(), |_, _| true, strict, mid, 3, 10_000);
    assert!(!s.failed.is_empty());
    for &i in &s.failed {
        assert!(!strict(&s.points[i - 1], &s.points[i]));
    }
    assert!(s.inserted <= 2 * 7);
    // The budget caps the whole subdivision.
    let s = subdivide(pts, |_, _| true, strict, mid, 10, 5);
    assert_eq!(s.inserted, 5);
}

#[test]
fn subdivision_never_halves_a_jump() {
    // F41: points of two "shaders"; a midpoint across them would panic.
    let pts = vec![(0, 0.0), (0, 1.0), (1, 0.0), (1, 1.0)];
    let s = subdivide(
        pts,
        |a, b| a.0 == b.0,
        |a: &(u8, f64), b: &(u8, f64)| (a.1 - b.1).abs() <= 0.25,
        |a, b| {
            assert_eq!(a.0, b.0, "a jump was halved");
            Some((a.0, 0.5 * (a.1 + b.1)))
        },
        10,
        100,
    );
    assert_eq!(s.points.len(), 10);
    let jump = s.points.iter().position(|p| p.0 == 1).unwrap();
    assert_eq!((s.points[jump - 1], s.points[jump]), ((0, 1.0), (1, 0.0)));
}

#[test]
fn times_grow_strictly_from_zero_to_one() {
    // F44, with identical neighbours (score 1) among them.
    let t = times(&[1.0, 0.9, 1.0, 0.95, 0.5]);
    assert_eq!(t[0], 0.0);
    assert_eq!(t[4], 1.0);
    assert!(t.windows(2).all(|w| w[1] > w[0]), "{t:?}");
    assert!(((t[3] - t[2]) - 0.05 / 0.65).abs() < 1e-6);
    assert_eq!(transform::resample(&t, 3), vec![0, 3, 4]);
}

#[test]
fn a_catalogue_render_is_its_own_nearest_vertex() {
    // F36.
    let cands = candidates(&["bar"]);
    let cat = cands[0].catalogue;
    for v in [0, 7, cat.len() - 1] {
        assert_eq!(nearest_vertex(&cat.features[v], cat), Some(v));
    }
}

#[test]
fn within_one_shader_keys_are_kept_in_order_and_legs_concatenate() {
    // F35, F38, F39, F44 on the bar: width 0.1 → 0.9 → 0.5.
    let cands = candidates(&["bar"]);
    let (a, b, c) =
        (values("bar", &[("width", 0.1)]), values("bar", &[("width", 0.9)]), values("bar", &[("width", 0.5)]));
    let cfg = TransformConfig::default();
    let jc = JumpConfig::default();
    let (abc, _) = run(&cands, &[("bar", a.clone()), ("bar", b.clone()), ("bar", c.clone())], &cfg, &jc, 0.8).unwrap();
    assert_eq!(abc.frames[0].values, a);
    assert_eq!(abc.frames.last().unwrap().values, c);
    let keys: Vec<(usize, usize)> = abc.frames.iter().enumerate().filter_map(|(i, f)| f.key.map(|k| (k, i))).collect();
    assert_eq!(keys.iter().map(|k| k.0).collect::<Vec<_>>(), vec![0, 1, 2]);
    assert_eq!(abc.frames[keys[1].1].values, b);
    assert_sound(&abc, cfg.tau);
    // Solved apart: the same frames, b once.
    let (ab, _) = run(&cands, &[("bar", a), ("bar", b.clone())], &cfg, &jc, 0.8).unwrap();
    let (bc, _) = run(&cands, &[("bar", b), ("bar", c)], &cfg, &jc, 0.8).unwrap();
    let values = |t: &Transformation| t.frames.iter().map(|f| f.values.clone()).collect::<Vec<_>>();
    let mut joined = values(&ab);
    joined.extend(values(&bc).into_iter().skip(1));
    assert_eq!(values(&abc), joined);
}

#[test]
fn midpoints_of_whole_numbers_are_whole() {
    let star = shader::shader("star").unwrap();
    let (four, five, eight) =
        (values("star", &[("points", 4.0)]), values("star", &[("points", 5.0)]), values("star", &[("points", 8.0)]));
    assert_eq!(midpoint(star, &four, &eight).unwrap()[0], 6.0);
    // Nothing lies between 4 and 5 points: the gap cannot be halved.
    assert_eq!(midpoint(star, &four, &five), None);
}

#[test]
fn a_bar_and_a_full_height_rectangle_are_a_jump_point() {
    // F40. The two shaders' default colours differ (red on white, yellow on blue), and the
    // metric sees their contrast: the rectangle is given the bar's colours, as a scene would.
    let bar = &candidates(&["bar"])[0];
    let def = shader::shader("rectangle").unwrap();
    let mut base = def.defaults();
    base[2..8].copy_from_slice(&[1.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
    let space = Space::with(def, base, &[]).unwrap();
    let probe = super::tests::probe(&space, SIDE);
    let catalogue = build_catalogue(&probe, &CatalogueConfig::default(), 1);
    let rect = Candidate { probe: super::tests::probe(&space, SIDE), catalogue: &catalogue };
    let cfg = JumpConfig::default();
    let j = jump_points(bar, &rect, &cfg);
    let best = &j.points[0];
    assert!(best.score >= 0.98, "{best:?}");
    assert!(j.points.iter().all(|p| p.rounds <= cfg.rounds));
    let (b, r) = (bar.probe.space.values(&best.x), space.values(&best.y));
    assert!(r[1] >= 0.95, "a bar is a rectangle of full height: {r:?}");
    assert!((r[0] - b[0]).abs() < 0.01, "of the bar's width: {b:?} {r:?}");
    // Swapping the shaders swaps the result.
    let k = jump_points(&rect, bar, &cfg);
    assert_eq!(k.calibration, j.calibration);
    for (p, q) in j.points.iter().zip(&k.points) {
        assert_eq!((&p.x, &p.y, p.similarity), (&q.y, &q.x, q.similarity));
    }
}

#[test]
fn a_rectangle_becomes_a_circle_through_the_super_ellipse() {
    // F41, F42: the direct jump (a square to a disc, S' ≈ 0.94) is refused at 0.95.
    let keys = [("rectangle", values("rectangle", &[])), ("circle", values("circle", &[]))];
    let cfg = TransformConfig::default();
    let jc = JumpConfig::default();
    let cands = candidates(&["rectangle", "circle", "superellipse"]);
    let (t, _) = run(&cands, &keys, &cfg, &jc, 0.95).unwrap();
    assert_sound(&t, cfg.tau);
    let se = index(&cands, "superellipse");
    let shaders: Vec<usize> = t.frames.iter().map(|f| f.shader).collect();
    assert!(shaders.contains(&se), "{shaders:?}");
    let exponent = shader::shader("superellipse").unwrap().param("exponent").unwrap();
    let first = shaders.iter().position(|&s| s == se).unwrap();
    let last = shaders.iter().rposition(|&s| s == se).unwrap();
    assert_eq!(cands[shaders[first - 1]].probe.space.shader.name, "rectangle");
    assert_eq!(cands[shaders[last + 1]].probe.space.shader.name, "circle");
    let (n_rect, n_circle) = (t.frames[first].values[exponent], t.frames[last].values[exponent]);
    assert!(n_rect >= 8.0, "{n_rect}");
    assert!((n_circle - 2.0).abs() <= 0.3, "{n_circle}");
    // Without the connective shader there is no acceptable path.
    let cands = candidates(&["rectangle", "circle"]);
    assert_eq!(run(&cands, &keys, &cfg, &jc, 0.95).err(), Some(TransformError::NoPath { from: 0, to: 1 }));
}

fn variance(img: &Image) -> f64 {
    let l: Vec<f64> = (0..img.height)
        .flat_map(|y| (0..img.width).map(move |x| (x, y)))
        .map(|(x, y)| (0.2126 * img.get(x, y, 0) + 0.7152 * img.get(x, y, 1) + 0.0722 * img.get(x, y, 2)) as f64)
        .collect();
    let m = l.iter().sum::<f64>() / l.len() as f64;
    l.iter().map(|v| (v - m).powi(2)).sum::<f64>() / l.len() as f64
}

#[test]
fn clouds_become_stars_through_a_plain_sky() {
    // F43: with plain-background jumps allowed, the jump frames are (nearly) flat.
    let cands = candidates(&["clouds", "starfield"]);
    let keys = [("clouds", values("clouds", &[])), ("starfield", values("starfield", &[]))];
    let jc = JumpConfig { presence: 0.0, ..JumpConfig::default() };
    let (t, _) = run(&cands, &keys, &TransformConfig::default(), &jc, 0.8).unwrap();
    let jump = t.frames.iter().position(|f| f.jump).expect("a jump");
    for f in &t.frames[jump - 1..=jump] {
        let def = cands[f.shader].probe.space.shader;
        let img = shader::render_square(def, &f.values, cands[f.shader].probe.seed, SIDE).unwrap();
        assert!(variance(&img) <= 0.01, "{}: {}", def.name, variance(&img));
    }
}

#[test]
fn the_coherence_term_steadies_a_star_field() {
    // F45: stars move less from frame to frame with the term on, and S' still reaches τ.
    let cands = candidates(&["starfield"]);
    let keys = [
        ("starfield", values("starfield", &[("density", 8.0)])),
        ("starfield", values("starfield", &[("density", 24.0)])),
    ];
    let jc = JumpConfig::default();
    let off = TransformConfig::default();
    let on = TransformConfig { coherence: Some(0.02), ..TransformConfig::default() };
    let (a, _) = run(&cands, &keys, &off, &jc, 0.8).unwrap();
    let (b, _) = run(&cands, &keys, &on, &jc, 0.8).unwrap();
    let ssd = |t: &Transformation| {
        let p = &cands[0].probe;
        let imgs: Vec<Image> =
            t.frames.iter().map(|f| shader::render_square(p.space.shader, &f.values, p.seed, SIDE).unwrap()).collect();
        let d: Vec<f64> = imgs
            .windows(2)
            .map(|w| {
                w[0].data.iter().zip(&w[1].data).map(|(x, y)| ((x - y) as f64).powi(2)).sum::<f64>()
                    / w[0].data.len() as f64
            })
            .collect();
        d.iter().sum::<f64>() / d.len() as f64
    };
    let (sa, sb) = (ssd(&a), ssd(&b));
    assert!(sb < sa, "coherence on {sb}, off {sa}");
    assert_sound(&b, on.tau);
    assert!(b.failed.is_empty() || b.failed.len() <= a.failed.len());
}
