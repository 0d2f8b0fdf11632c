use super::*;
use crate::synth::shader;

fn probe(space: &Space, side: usize) -> Probe<'_> {
    Probe { space, seed: 7, side, metric: metric() }
}

fn metric() -> Metric {
    if std::env::var("TESSERA_REL").is_ok() {
        return Metric::Power(crate::synth::metrics::PowerParams { relative: true, ..Default::default() });
    }
    match std::env::var("TESSERA_POOL") {
        Ok(p) => Metric::Power(crate::synth::metrics::PowerParams {
            pool: p.parse().unwrap(),
            ..crate::synth::metrics::PowerParams::log_power()
        }),
        Err(_) => Metric::default(),
    }
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
    let mut rng = crate::synth::rng::Rng::new(11);
    let (mut hits, mut total) = (0, 0);
    for (space, _) in spaces.iter().zip(&cats) {
        for _ in 0..2 {
            let x: Vec<f64> = (0..space.dim()).map(|_| rng.next_f64()).collect();
            let f = probe(space, side).feature(&x);
            let r = match_target(&f, &cands, &MatchConfig::default()).unwrap();
            total += 1;
            hits += (r.shader == space.shader.name) as usize;
            eprintln!("random {}: {} {:?} S' {:.4}", space.shader.name, r.shader, r.status, r.score);
        }
    }
    eprintln!("random targets matched to their shader: {hits} of {total}");
    for (name, img) in &targets[1..3] {
        let f = feature(img, &metric());
        let own: Vec<Candidate> = cands
            .iter()
            .filter(|c| name.starts_with(c.probe.space.shader.name) && !c.probe.space.shader.name.ends_with('2'))
            .map(|c| Candidate { probe: probe(c.probe.space, side), catalogue: c.catalogue })
            .collect();
        let r = match_target(&f, &own, &MatchConfig::default()).unwrap();
        eprintln!("{name} alone: {:?} {} {:?} S' {:.4}", r.status, r.shader, &r.values[..4], r.score);
    }
    for (name, img) in &targets {
        let t = std::time::Instant::now();
        let f = feature(img, &metric());
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

/// Pools a power feature's bins `f × f` (signed vertical frequencies), optionally as log power
/// and normalised to unit length.
fn variant(f: &Feature, pool: usize, log: bool, norm: bool) -> Vec<f64> {
    let Feature::Power(p) = f else { panic!() };
    let n = p.side;
    let half = n / 2 + 1;
    let pw = half.div_ceil(pool);
    let ph = n.div_ceil(pool) + 1;
    let mut out = vec![0.0f64; pw * ph];
    for kx in 0..half {
        for ky in 0..n {
            let fy = if ky > n / 2 { ky as i64 - n as i64 } else { ky as i64 };
            let by = (fy + (n / 2) as i64) as usize / pool;
            out[(kx / pool) * ph + by] += p.weighted[kx * n + ky] as f64;
        }
    }
    if log {
        for v in &mut out {
            *v = (1.0 + *v / 1e-6).ln();
        }
    }
    if norm {
        let l = out.iter().map(|v| v * v).sum::<f64>().sqrt();
        if l > 0.0 {
            for v in &mut out {
                *v /= l;
            }
        }
    }
    out
}

fn vdist(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt()
}

#[test]
#[ignore = "exploration: which feature variant ranks the generating shader first"]
fn feature_variants() {
    let side = 128;
    let spaces: Vec<Space> = shader::LIBRARY.iter().map(|d| Space::new(d)).collect();
    let cats: Vec<_> =
        spaces.iter().map(|s| build_catalogue(&probe(s, side), &CatalogueConfig::default(), 1)).collect();
    let mut rng = crate::synth::rng::Rng::new(5);
    let variants: [(usize, bool, bool); 8] = [
        (1, false, false),
        (2, false, false),
        (4, false, false),
        (8, false, false),
        (4, false, true),
        (1, true, true),
        (4, true, true),
        (8, true, true),
    ];
    let mut wins = vec![0usize; variants.len()];
    let mut total = 0;
    for (si, space) in spaces.iter().enumerate() {
        for t in 0..4 {
            let x: Vec<f64> = (0..space.dim()).map(|_| rng.next_f64()).collect();
            let target = probe(space, side).feature(&x);
            total += 1;
            let mut line = format!("{:10} t{t}", space.shader.name);
            for (vi, &(pool, log, norm)) in variants.iter().enumerate() {
                let tv = variant(&target, pool, log, norm);
                // Best vertex distance per shader.
                let best: Vec<(f64, usize)> = cats
                    .iter()
                    .map(|c| {
                        c.features
                            .iter()
                            .enumerate()
                            .map(|(i, f)| (vdist(&variant(f, pool, log, norm), &tv), i))
                            .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a })
                    })
                    .collect();
                let rank = best.iter().filter(|b| b.0 < best[si].0).count();
                if rank == 0 {
                    wins[vi] += 1;
                }
                let px = &cats[si].points[best[si].1];
                let pd = vdist(px, &x);
                line +=
                    &format!(" | {pool}{}{} r{rank} p{pd:.2}", if log { "L" } else { "" }, if norm { "N" } else { "" });
            }
            eprintln!("{line}");
        }
    }
    eprintln!("wins of {total}: {:?}", wins);
}
