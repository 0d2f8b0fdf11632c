use super::*;
use crate::synth::shader;

fn probe(space: &Space, side: usize) -> Probe<'_> {
    Probe { space, seed: 7, side, metric: Metric::default() }
}

#[test]
#[ignore = "exploration: prints catalogue statistics of the whole library"]
fn library_statistics() {
    for side in [128usize] {
        for def in shader::LIBRARY {
            let space = Space::new(def);
            let p = probe(&space, side);
            let t = std::time::Instant::now();
            let cat = build_catalogue(&p, &CatalogueConfig::default(), 1);
            eprintln!(
                "{side} {:12} dim {} n {:3} screen {:2} kappa {:.5} rounds {:?} features {} d0 {:.4} {:.2}s",
                def.name,
                space.dim(),
                cat.len(),
                cat.screen.len(),
                cat.kappa,
                cat.rounds.iter().map(|r| (r.kappa, r.added, r.duplicates, r.pruned)).collect::<Vec<_>>(),
                cat.features_computed,
                cat.calibration.d0,
                t.elapsed().as_secs_f64()
            );
        }
    }
}

#[test]
#[ignore = "exploration: matches a few targets against the whole library"]
fn library_matches() {
    let side = 128;
    let spaces: Vec<Space> = shader::LIBRARY.iter().map(|d| Space::new(d)).collect();
    let t = std::time::Instant::now();
    let cats: Vec<_> =
        spaces.iter().map(|s| build_catalogue(&probe(s, side), &CatalogueConfig::default(), 1)).collect();
    eprintln!("catalogues {:.1}s", t.elapsed().as_secs_f64());
    let cands: Vec<Candidate> =
        spaces.iter().zip(&cats).map(|(s, c)| Candidate { probe: probe(s, side), catalogue: c }).collect();
    let mut targets = Vec::new();
    let bar = shader::shader("bar").unwrap();
    let mut v = bar.defaults();
    v[0] = 0.37;
    targets.push(("bar 0.37", shader::render_square(bar, &v, 7, side).unwrap()));
    let brick = shader::shader("brick").unwrap();
    let mut v = brick.defaults();
    (v[0], v[1], v[2]) = (0.31, 0.093, 0.017);
    targets.push(("brick .31 .093 .017", shader::render_square(brick, &v, 7, side).unwrap()));
    let weave = shader::shader("weave").unwrap();
    let mut v = weave.defaults();
    (v[0], v[1], v[2], v[3]) = (7.3, 0.55, 0.42, 0.3);
    targets.push(("weave 7.3 .55 .42 .3", shader::render_square(weave, &v, 7, side).unwrap()));
    let star = shader::shader("star").unwrap();
    let mut v = star.defaults();
    (v[0], v[1], v[2]) = (4.0, 0.15, 0.4);
    targets.push(("star 4 .15 .4", shader::render_square(star, &v, 7, side).unwrap()));
    let clouds = shader::shader("clouds").unwrap();
    targets.push(("clouds default seed 99", shader::render_square(clouds, &clouds.defaults(), 99, side).unwrap()));
    let checker = crate::raster::Image::from_fn(side, side, 3, |x, y, _| (((x / 16) + (y / 16)) % 2) as f32);
    targets.push(("checker", checker));
    for (name, img) in &targets {
        let t = std::time::Instant::now();
        let f = feature(img, &Metric::default());
        let r = match_target(&f, &cands, &MatchConfig::default()).unwrap();
        eprintln!(
            "{name}: {:?} {} {:?} S {:.6} S' {:.4} renders {} scanned {:?} {:.2}s",
            r.status,
            r.shader,
            &r.values[..4.min(r.values.len())],
            r.similarity,
            r.score,
            r.renders,
            r.scanned,
            t.elapsed().as_secs_f64()
        );
        for run in &r.runs {
            eprintln!(
                "    {} v{} start {:.4} -> {:.4} it {} h {:.3}",
                run.shader, run.vertex, run.start, run.reached, run.iterations, run.roughness
            );
        }
    }
}
