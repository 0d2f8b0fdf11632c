//! A structure regrown from a sample at the sample's own size, from a cold cache: analysis,
//! sampling, Lloyd (stage 1), polygonisation and shape optimisation (stage 2), plus the label
//! output, as `tessera build` runs them. The samples are the painted stand-ins (512×384,
//! 512×448) and the segmented ambientCG photograph (576²). Target: under 1 s each on 2 cores.

use std::path::PathBuf;

#[path = "../tests/common/mod.rs"]
mod common;

use common::copy_dir;
use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use tessera::project::Project;

/// `(scene name, image, structure, width, height)`; paths relative to `samples/`.
const SAMPLES: [(&str, &str, &str, usize, usize); 4] = [
    ("wall_random", "standins/wall_random_photo.png", "standins/wall_random.json", 512, 384),
    ("wall_layered", "standins/wall_layered_photo.png", "standins/wall_layered.json", 512, 448),
    ("wall_regular", "standins/wall_regular_photo.png", "standins/wall_regular.json", 512, 384),
    ("paving", "photos/paving.png", "photos/paving_structure.png", 576, 576),
];

fn workspace() -> tempfile::TempDir {
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&repo.join("samples"), &dir.path().join("samples"));
    std::fs::copy(repo.join("tessera.toml"), dir.path().join("tessera.toml")).unwrap();
    std::fs::create_dir_all(dir.path().join("scenes")).unwrap();
    for (name, image, structure, w, h) in SAMPLES {
        let text = format!(
            "scene {{\n  seed = 1\n  size = {w} x {h}\n}}\n\n\
             sample s {{\n  image = \"../samples/{image}\"\n  structure = \"../samples/{structure}\"\n}}\n\n\
             surface t {{\n  plane = {w} x {h}\n}}\n\n\
             structure g {{\n  from = s\n  on = t\n}}\n\n\
             output \"labels.png\" {{\n  from = g\n}}\n"
        );
        std::fs::write(dir.path().join(format!("scenes/{name}.tess")), text).unwrap();
    }
    dir
}

fn regrow(c: &mut Criterion) {
    let dir = workspace();
    let root = dir.path().to_path_buf();
    let cache = root.join(".tessera");
    let mut group = c.benchmark_group("regrow_cold");
    group.sample_size(10);
    for (name, ..) in SAMPLES {
        let scene = root.join(format!("scenes/{name}.tess"));
        group.bench_function(name, |b| {
            b.iter_batched(
                || {
                    let _ = std::fs::remove_dir_all(&cache);
                },
                |()| {
                    let p = Project::open(&root).unwrap();
                    let built = p.build(&scene).unwrap();
                    p.emit(&built).unwrap()
                },
                BatchSize::PerIteration,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, regrow);
criterion_main!(benches);
