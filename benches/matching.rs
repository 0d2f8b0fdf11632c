//! Matching [references: bourque §4] on this machine: building the catalogues of the whole
//! shader library (target: under 2 minutes; the thesis: 4 hours per shader), then matching
//! 256² targets against the whole library with the catalogues built (target: under 5 s each;
//! the thesis: 12 minutes). One build is timed (it takes tens of seconds, too long for
//! criterion's repeated samples); each match is timed from the target image to the record.
//!
//! Then transformations [references: bourque §ch5] with the catalogues built: the jump points
//! between pairs of shaders and whole transformations, timed from the keys to the frames.
//!
//! `cargo bench --bench matching`

use std::time::Instant;

use tessera::raster::Image;
use tessera::synth::matching::{
    build_catalogue, canonical, feature, jump_points, match_target, transform, Candidate, CatalogueConfig, JumpConfig,
    Key, Link, MatchConfig, Metric, Probe, Space, TransformConfig,
};
use tessera::synth::shader::{render_square, shader, LIBRARY};

fn main() {
    let side = 128;
    let spaces: Vec<Space> = LIBRARY.iter().map(|d| Space::new(d)).collect();
    let probe = |s| Probe { space: s, seed: 7, side, metric: Metric::default() };
    let t = Instant::now();
    let mut per_shader = Vec::new();
    let cats: Vec<_> = spaces
        .iter()
        .map(|s| {
            let t = Instant::now();
            let c = build_catalogue(&probe(s), &CatalogueConfig::default(), 1);
            per_shader.push((s.shader.name, c.len(), t.elapsed().as_secs_f64()));
            c
        })
        .collect();
    let build = t.elapsed().as_secs_f64();
    for (name, n, secs) in &per_shader {
        println!("catalogue {name:12} {n:4} renders kept {secs:7.2} s");
    }
    println!("catalogues of the whole library: {build:.1} s (target < 120 s)");
    let cands: Vec<Candidate> =
        spaces.iter().zip(&cats).map(|(s, c)| Candidate { probe: probe(s), catalogue: c }).collect();
    let targets: Vec<(&str, Image)> = vec![
        ("bar(width = 0.37)", target("bar", &[(0, 0.37)])),
        ("weave(7.3, 0.55, 0.42, 0.3)", target("weave", &[(0, 7.3), (1, 0.55), (2, 0.42), (3, 0.3)])),
        ("star(points = 4)", target("star", &[(0, 4.0), (1, 0.15), (2, 0.4)])),
        (
            "clouds (seed 99)",
            render_square(shader("clouds").unwrap(), &shader("clouds").unwrap().defaults(), 99, 256).unwrap(),
        ),
    ];
    let mut worst: f64 = 0.0;
    for (name, img) in &targets {
        let t = Instant::now();
        let f = feature(&canonical(img, side).unwrap(), &Metric::default());
        let r = match_target(&f, &cands, &MatchConfig::default()).unwrap();
        let secs = t.elapsed().as_secs_f64();
        worst = worst.max(secs);
        println!("match 256² {name:30} -> {:12} S' {:.4} {:5} renders {secs:6.2} s", r.shader, r.score, r.renders);
    }
    println!("slowest match: {worst:.2} s (target < 5 s)");

    let at = |name: &str| cands.iter().position(|c| c.probe.space.shader.name == name).unwrap();
    let key = |name: &str, set: &[(usize, f64)]| {
        let mut values = shader(name).unwrap().defaults();
        for &(i, x) in set {
            values[i] = x;
        }
        Key { shader: at(name), values }
    };
    let cases: Vec<(&str, Vec<&str>, Vec<Key>, f64)> = vec![
        (
            "weave tight -> loose",
            vec!["weave"],
            vec![
                key("weave", &[(0, 10.0), (1, 0.7), (2, 0.7)]),
                key("weave", &[(0, 4.0), (1, 0.35), (2, 0.5), (3, 0.52)]),
            ],
            0.8,
        ),
        (
            "rectangle -> circle via superellipse",
            vec!["rectangle", "circle", "superellipse"],
            vec![key("rectangle", &[]), key("circle", &[])],
            0.95,
        ),
        ("clouds -> starfield", vec!["clouds", "starfield"], vec![key("clouds", &[]), key("starfield", &[])], 0.8),
    ];
    for (name, set, keys, min_jump) in cases {
        let t = Instant::now();
        let ids: Vec<usize> = set.iter().map(|n| at(n)).collect();
        let mut sets = Vec::new();
        for (i, &a) in ids.iter().enumerate() {
            for &b in &ids[i + 1..] {
                let mut j = jump_points(&cands[a], &cands[b], &JumpConfig::default());
                j.points.retain(|p| p.score >= min_jump);
                sets.push((a, b, j));
            }
        }
        let jumps = t.elapsed().as_secs_f64();
        let links: Vec<Link> = sets.iter().map(|(a, b, j)| Link { a: *a, b: *b, jumps: j }).collect();
        let r = transform(&cands, &links, &keys, &TransformConfig::default()).unwrap();
        let secs = t.elapsed().as_secs_f64();
        println!(
            "transform {name:38} {:4} frames ({:4} inserted, {} below tau) {:5} renders; jumps {jumps:5.2} s, total {secs:6.2} s",
            r.frames.len(),
            r.inserted,
            r.failed.len(),
            r.renders
        );
    }
}

fn target(name: &str, set: &[(usize, f64)]) -> Image {
    let def = shader(name).unwrap();
    let mut v = def.defaults();
    for &(i, x) in set {
        v[i] = x;
    }
    render_square(def, &v, 7, 256).unwrap()
}
