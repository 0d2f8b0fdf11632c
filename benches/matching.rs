//! Matching [references: bourque §4] on this machine: building the catalogues of the whole
//! shader library (target: under 2 minutes; the thesis: 4 hours per shader), then matching
//! 256² targets against the whole library with the catalogues built (target: under 5 s each;
//! the thesis: 12 minutes). One build is timed (it takes tens of seconds, too long for
//! criterion's repeated samples); each match is timed from the target image to the record.
//!
//! `cargo bench --bench matching`

use std::time::Instant;

use tessera::raster::Image;
use tessera::synth::matching::{
    build_catalogue, canonical, feature, match_target, Candidate, CatalogueConfig, MatchConfig, Metric, Probe, Space,
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
}

fn target(name: &str, set: &[(usize, f64)]) -> Image {
    let def = shader(name).unwrap();
    let mut v = def.defaults();
    for &(i, x) in set {
        v[i] = x;
    }
    render_square(def, &v, 7, 256).unwrap()
}
