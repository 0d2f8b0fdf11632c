//! Resolution-independent scenes: arithmetic in values, lengths relative to the surface or
//! the scene, their diagnostics and formatting, and `--set`/`--seed` across many scenes.

mod common;

use common::Project;
use tessera::lang::Val;

/// A scene whose sizes all follow `param res`: a quilted layer's block and overlap, a
/// map's blur and a rectangle, a structure's scale.
const RELATIVE: &str = r#"
param res = 512 x 512

scene {
  size = res
}

sample bricks {
  image = "bricks.png"
}

map mask {
  from = rect(at = [25%, 10%], size = [50%, scene.height / 2])
  blur = 0.5%
}

surface wall {
  occupancy = mask
}

layer grown {
  quilt = bricks
  on = wall
  block = 10%
  overlap = clamp(block_overlap, 2 px, 64 px)
}

param block_overlap = 2%
"#;

fn resolved(p: &Project, res: &str) -> tessera::lang::Scene {
    let mut project = tessera::project::Project::open(p.dir.path()).expect("project");
    project.sets = vec![("res".into(), res.into())];
    let (scene, _) = project.compile(&p.path("s.tess")).unwrap_or_else(|e| panic!("compiles at {res}: {e:?}"));
    scene
}

fn num(scene: &tessera::lang::Scene, decl: &str, prop: &str) -> f64 {
    scene.decl(decl).expect("declared").props.num(prop)
}

#[test]
fn relative_lengths_scale_with_the_scene_as_documented() {
    let p = Project::new(&[("s.tess", RELATIVE)]);
    p.write_bytes("bricks.png", &common::png(&common::texture(64, 64, 3)));
    let (small, large) = (resolved(&p, "512 x 512"), resolved(&p, "4096 x 4096"));
    // Whole-pixel lengths are rounded once computed: 10% of 512 is 51.2 → 51, of 4096 409.6 → 410.
    assert_eq!((num(&small, "grown", "block"), num(&large, "grown", "block")), (51.0, 410.0));
    // 2% of the width, clamped to [2, 64] px: 10.24 → 10 and 81.92 → 64.
    assert_eq!((num(&small, "grown", "overlap"), num(&large, "grown", "overlap")), (10.0, 64.0));
    // Plain lengths keep their fraction and scale exactly: blur radius 0.5% of the shorter side.
    assert_eq!((num(&small, "mask", "blur"), num(&large, "mask", "blur")), (2.56, 20.48));
    let rect = |s: &tessera::lang::Scene| match s.decl("mask").unwrap().props.get("from") {
        Some(Val::Call(c)) => (c.args.numbers("at").to_vec(), c.args.numbers("size").to_vec()),
        v => panic!("{v:?}"),
    };
    // Vector components are parts of the width (x) and the height (y).
    assert_eq!(rect(&small), (vec![128.0, 51.2], vec![256.0, 256.0]));
    assert_eq!(rect(&large), (vec![1024.0, 409.6], vec![2048.0, 2048.0]));
}

#[test]
fn a_structure_in_relative_units_keeps_its_region_count_at_another_size() {
    let scene = |side: u32| {
        format!(
            r#"
scene {{
  size = {side} x {side}
  seed = 5
}}
sample skin {{
  structure = "../samples/standins/scales_diag.json"
}}
surface body {{ }}
structure scales {{
  from = skin
  on = body
  scale = 0.6 * surface.width / 128 px
  lloyd {{
    iterations = 10
  }}
  shapes {{
    enabled = false
  }}
}}
output "mesh.json" {{
  from = scales
}}
"#
        )
    };
    let p = Project::copy_of_repo();
    let count = |side: u32| {
        p.write("scenes/rel.tess", &scene(side));
        p.tessera(&["-q", "build", "scenes/rel.tess"]).ok();
        let mesh: serde_json::Value = serde_json::from_slice(&p.read("out/rel/mesh.json")).expect("mesh json");
        mesh["regions"].as_array().expect("regions").len() as f64
    };
    let (small, large) = (count(128), count(384));
    assert!(small >= 10.0, "{small} regions at 128²");
    // The same number of regions, each 3× as large: the look is kept, not the pixel size.
    assert!((large / small - 1.0).abs() < 0.15, "{small} regions at 128², {large} at 384²");
}

#[test]
fn arithmetic_errors_point_at_what_is_wrong() {
    let cases = [
        ("blur = 3 px * 2 px", "a length times a length has no meaning here"),
        ("blur = 4 / (k - 2)", "division by zero"),
        ("blur = 30 deg + 2 px", "`+` of an angle and a length"),
        ("blur = surface.depth", "`depth` is not a size"),
        ("blur = nowhere.width", "unknown name `nowhere`"),
        ("blur = clamp(1, 5, 2)", "`clamp` has its low bound above its high bound"),
        ("blur = min()", "`min` takes at least one value"),
        ("blur = 2 * (3 - 3) + 1 / 0.0", "division by zero"),
        ("threshold = 10 px / 2", "expected a plain number, found a length"),
        ("blur = 1e38 * 10", "overflows when converted"),
        ("blur = -5%", "value out of range"),
        ("blur = 1e-30 * 1e-30", "rounds to 0 in 32-bit floats"),
    ];
    for (line, message) in cases {
        let p = Project::new(&[(
            "s.tess",
            &format!("param k = 2\nmap m {{\n  from = constant(value = 1)\n  {line}\n}}\n"),
        )]);
        let run = p.tessera(&["build", "s.tess"]);
        run.failed();
        assert!(run.stderr().contains(message), "{line}: {}", run.stderr());
        // The label is on the line that holds the arithmetic.
        assert!(run.stderr().contains(":4:"), "{line}: {}", run.stderr());
    }
    let p = Project::new(&[("s.tess", "sample s {\n  image = \"x.png\"\n  crop = [10%, 0, 4, 4]\n}\n")]);
    let run = p.tessera(&["build", "s.tess"]);
    run.failed();
    assert!(run.stderr().contains("a relative length needs a surface"), "{}", run.stderr());
}

#[test]
fn fmt_keeps_expressions_as_written() {
    let text = "map m {\n  from = rect(at = [-(2 px), 10%], size = [scene.width / 2, max(8, 2 * k - 1)])\n  blur = (1 + 2) * 0.5%\n  # A comment on its own line stays there.\n  invert = true\n}\n\nparam k = 3 * 1\n# After a param.\n";
    let p = Project::new(&[("s.tess", text)]);
    p.tessera(&["fmt", "--check", "s.tess"]).ok();
    // Layout is normalised, the expression is not rewritten.
    p.write("s.tess", &text.replace("(1 + 2) * 0.5%", "( 1+2 )*0.5%"));
    p.tessera(&["fmt", "s.tess"]).ok();
    assert_eq!(String::from_utf8(p.read("s.tess")).unwrap(), text);
    p.tessera(&["-q", "build", "s.tess"]).ok();
}

const TAKES_K: &str = "param k = 1\nmap m {\n  from = constant(value = k / 4)\n}\noutput \"m.png\" {\n  from = m\n}\n";
const NO_PARAMS: &str = "map m {\n  from = constant(value = 0.5)\n}\noutput \"m.png\" {\n  from = m\n}\n";

#[test]
fn a_set_applies_to_every_scene_that_declares_it_and_names_them() {
    let p = Project::new(&[("a.tess", TAKES_K), ("b.tess", NO_PARAMS), ("c.tess", TAKES_K)]);
    let run = p.tessera(&["build", "--set", "k=2"]);
    run.ok();
    let taken = run.stdout().lines().find(|l| l.starts_with("--set k=2: taken by ")).unwrap_or_default().to_string();
    assert!(taken.contains("a.tess") && taken.contains("c.tess") && !taken.contains("b.tess"), "{}", run.stdout());
    assert_eq!(p.read("out/a/m.png"), p.read("out/c/m.png"));
    assert_eq!(p.read("out/a/m.png"), p.read("out/b/m.png"), "k = 2 makes a's map 0.5, as b's");
    let run = p.tessera(&["build", "--set", "kk=2"]);
    run.failed();
    assert!(run.stderr().contains("no scene declares `param kk`"), "{}", run.stderr());
    assert!(run.stderr().contains("did you mean `k`?"), "{}", run.stderr());
    let run = p.tessera(&["build", "b.tess", "--set", "k=2"]);
    run.failed();
    assert!(run.stderr().contains("the scene declares no `param k`"), "{}", run.stderr());
}

#[test]
fn a_global_seed_overrides_every_scene_seed() {
    let noise = |seed: u32| {
        format!("scene {{\n  seed = {seed}\n}}\nmap m {{\n  from = noise(scale = 8)\n}}\noutput \"m.png\" {{\n  from = m\n}}\n")
    };
    let p = Project::new(&[("a.tess", &noise(1)), ("b.tess", &noise(2)), ("c.tess", &noise(9))]);
    p.tessera(&["-q", "build"]).ok();
    let (a, b, c) = (p.read("out/a/m.png"), p.read("out/b/m.png"), p.read("out/c/m.png"));
    assert_ne!(a, b);
    p.tessera(&["-q", "build", "--seed", "9"]).ok();
    assert_eq!(p.read("out/a/m.png"), c);
    assert_eq!(p.read("out/b/m.png"), c);
}

#[test]
fn params_that_grow_exponentially_are_stopped_with_a_diagnostic() {
    let mut text = String::from("map m {\n  from = constant(value = 1)\n  blur = p0\n}\n");
    // 12 levels below the param depth limit, 3¹² = 531 441 operands.
    for i in 0..12 {
        text.push_str(&format!("param p{i} = p{} + p{} + p{}\n", i + 1, i + 1, i + 1));
    }
    text.push_str("param p12 = 1\n");
    let p = Project::new(&[("s.tess", &text)]);
    let run = p.tessera(&["build", "s.tess"]);
    run.failed();
    assert!(run.stderr().contains("takes more than 100000 steps to evaluate"), "{}", run.stderr());
}
