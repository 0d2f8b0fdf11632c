//! Hostile values for the `appearance` kind ([references: frasson §4]), the `regions(...)`
//! map source and a structure's `layout`: every numeric property at 0, negative, tiny, huge
//! (up to values that would have quilted for hours or allocated terabytes), odd paths. Each is
//! refused quickly with a diagnostic whose label underlines the value at fault, or builds when
//! the value is fine; none panics, hangs or allocates past the memory budget.

mod common;

use std::time::Duration;

use common::{flat, repo, run_within, Project, Run};

const PHOTO: &str = "samples/standins/wall_random_photo.png";
const STRUCTURE: &str = "samples/standins/wall_random.json";

/// A project holding the painted random wall (512 × 384, 100 regions) and `scene.tess`.
fn project(scene: &str) -> Project {
    let p = Project::new(&[("scene.tess", scene)]);
    for f in [PHOTO, STRUCTURE] {
        p.write_bytes(f.rsplit('/').next().unwrap(), &std::fs::read(repo().join(f)).expect("sample"));
    }
    p
}

/// The head every scene here shares: the sample (`image` line included or not), the plane
/// and the structure `layout` with `structure_props` (one per line, each ending in `\n`).
fn head(image_line: &str, structure_props: &str) -> String {
    format!(
        r#"scene {{
  seed = 3
  size = 192 x 128
}}

sample stones {{
{image_line}  structure = "wall_random.json"
}}

surface wall {{
  plane = 192 x 128
}}

structure layout {{
  from = stones
  on = wall
  scale = 0.6
{structure_props}}}
"#
    )
}

/// The scene of `tests/appearance.rs` with `props` (one per line) added to the appearance,
/// which dresses `on`.
fn scene(on: &str, props: &[&str]) -> String {
    let props: String = props.iter().map(|p| format!("  {p}\n")).collect();
    let head = head("  image = \"wall_random_photo.png\"\n", "");
    format!(
        r#"{head}
appearance dressed {{
  from = stones
  on = {on}
{props}}}

output "wall.png" {{
  from = dressed
}}
"#
    )
}

/// Builds `scene.tess` with `args`, killed past a minute.
fn build(p: &Project, args: &[&str]) -> (Run, Duration) {
    let mut all = vec!["build", "scene.tess"];
    all.extend_from_slice(args);
    run_within(p.dir.path(), &all, Duration::from_secs(60))
}

/// The diagnostic's label underlines `value` on the source line that ends with `line`.
#[track_caller]
fn assert_label_at(err: &str, line: &str, value: &str) {
    let lines: Vec<&str> = err.lines().collect();
    let i = lines
        .iter()
        .position(|l| l.contains('│') && l.trim_end().ends_with(line))
        .unwrap_or_else(|| panic!("no source line `{line}` in:\n{err}"));
    let at =
        lines[i].rfind(line).expect("found") + line.rfind(value).unwrap_or_else(|| panic!("`{value}` in `{line}`"));
    let column = lines[i][..at].chars().count();
    let under: Vec<char> = lines.get(i + 1).map(|l| l.chars().collect()).unwrap_or_default();
    let start = under.iter().position(|&c| matches!(c, '─' | '┬' | '▲'));
    assert_eq!(start, Some(column), "the label does not start under `{value}`:\n{err}");
}

/// A build of `scene` (plus `args`) that must fail fast, with `message` and a label under
/// `value` on the line `line`, writing nothing; returns stderr.
#[track_caller]
fn refused(scene: &str, args: &[&str], line: &str, value: &str, message: &str) -> String {
    let p = project(scene);
    let (run, took) = build(&p, args);
    run.failed();
    let err = run.stderr();
    assert!(flat(&err).contains(message), "expected `{message}` for `{line}` in:\n{err}");
    assert_label_at(&err, line, value);
    assert!(took < Duration::from_secs(20), "`{line}` took {took:?}");
    assert!(!p.path("out").exists(), "a refused build wrote outputs");
    err
}

/// A build of `scene` that must succeed quickly, without a panic.
#[track_caller]
fn builds(scene: &str, args: &[&str]) {
    let p = project(scene);
    let (run, took) = build(&p, args);
    run.ok();
    assert!(!run.stderr().contains("panicked"), "{}", run.stderr());
    assert!(took < Duration::from_secs(45), "took {took:?}");
}

/// `(line, value, message)`: one property line of the appearance, the value the label must
/// underline, and what the diagnostic must say.
const OUT_OF_RANGE: &[(&str, &str, &str)] = &[
    ("clusters = 0", "0", "expected an integer from 1 to 10"),
    ("clusters = -1", "-1", "expected an integer from 1 to 10"),
    ("clusters = 1e-9", "1e-9", "expected an integer from 1 to 10"),
    ("clusters = 1000000000000", "1000000000000", "expected an integer from 1 to 10"),
    ("shrink = -1 px", "-1 px", "must be from 0 to 64"),
    ("shrink = 1e12 px", "1e12 px", "must be from 0 to 64"),
    ("texture_size = 0 px", "0 px", "must be from 16 to 2048"),
    ("texture_size = -16 px", "-16 px", "must be from 16 to 2048"),
    ("texture_size = 1e-9 px", "1e-9 px", "must be from 16 to 2048"),
    // Was admitted: ten 4096² textures quilted for many minutes in gigabytes.
    ("texture_size = 4096 px", "4096 px", "must be from 16 to 2048"),
    ("texture_size = 1000000000000 px", "1000000000000 px", "must be from 16 to 2048"),
    ("block = 0 px", "0 px", "must be from 8 to 256"),
    ("block = -4 px", "-4 px", "must be from 8 to 256"),
    ("block = 1e-9 px", "1e-9 px", "must be from 8 to 256"),
    // Was admitted: 85 × 85 blocks per texture, quilting for minutes.
    ("block = 4 px", "4 px", "must be from 8 to 256"),
    ("block = 1e12 px", "1e12 px", "must be from 8 to 256"),
    ("interstice { half_width = 0 px }", "0 px", "must be from 0.5 to 64"),
    ("interstice { half_width = -1 px }", "-1 px", "must be from 0.5 to 64"),
    ("interstice { half_width = 1e-9 px }", "1e-9 px", "must be from 0.5 to 64"),
    // Was admitted: atlases of about 10 GB cut for minutes.
    ("interstice { half_width = 256 px }", "256 px", "must be from 0.5 to 64"),
    ("interstice { half_width = 1e12 px }", "1e12 px", "must be from 0.5 to 64"),
    ("interstice { extension = -1 px }", "-1 px", "must be from 0 to 64"),
    ("interstice { extension = 1e12 px }", "1e12 px", "must be from 0 to 64"),
    ("junction { branch_length = 0 px }", "0 px", "must be from 0.5 to 256"),
    ("junction { branch_length = -1 px }", "-1 px", "must be from 0.5 to 256"),
    ("junction { branch_length = 1e-9 px }", "1e-9 px", "must be from 0.5 to 256"),
    ("junction { branch_length = 1e12 px }", "1e12 px", "must be from 0.5 to 256"),
    ("junction { candidates = 0 }", "0", "expected an integer from 1 to 64"),
    ("junction { candidates = -1 }", "-1", "expected an integer from 1 to 64"),
    ("junction { candidates = 1000000000000 }", "1000000000000", "expected an integer from 1 to 64"),
    ("resolution = 0", "0", "must be from 0.0625 to 16"),
    ("resolution = -1", "-1", "must be from 0.0625 to 16"),
    ("resolution = 1e-9", "1e-9", "must be from 0.0625 to 16"),
    ("resolution = 1e12", "1e12", "must be from 0.0625 to 16"),
    ("seed = -1", "-1", "expected an integer from 0 to 9007199254740992"),
    ("seed = 1e-9", "1e-9", "expected an integer from 0 to 9007199254740992"),
    ("seed = 1e30", "1e30", "expected an integer from 0 to 9007199254740992"),
];

#[test]
fn every_numeric_appearance_property_out_of_its_range_is_refused_at_its_value() {
    for &(line, value, message) in OUT_OF_RANGE {
        refused(&scene("layout", &[line]), &[], line, value, message);
    }
}

#[test]
fn a_half_width_out_of_range_is_shown_with_its_range() {
    let line = "interstice { half_width = 256 px }";
    let err = refused(&scene("layout", &[line]), &[], line, "256 px", "must be from 0.5 to 64");
    insta::assert_snapshot!("appearance_half_width_range", err);
}

#[test]
fn not_a_number_is_refused_at_the_value() {
    refused(&scene("layout", &["resolution = NaN"]), &[], "resolution = NaN", "NaN", "unknown name `NaN`");
    refused(&scene("layout", &["resolution = inf"]), &[], "resolution = inf", "inf", "unknown name `inf`");
    refused(&scene("layout", &["seed = \"1\""]), &[], "seed = \"1\"", "\"1\"", "expected an integer");
}

#[test]
fn the_smallest_values_build() {
    let props = [
        "shrink = 0 px",
        "clusters = 1",
        "texture_size = 16 px",
        "block = 8 px",
        "interstice { half_width = 0.5 px  extension = 0 px }",
        "junction { branch_length = 0.5 px  candidates = 1 }",
        "resolution = 0.0625",
        "seed = 0",
    ];
    builds(&scene("layout", &props), &[]);
    builds(&scene("layout", &["shrink = 1e-9 px"]), &[]);
}

#[test]
fn the_largest_values_that_cost_little_build() {
    let props = [
        "clusters = 10",
        "block = 256 px",
        "interstice { extension = 64 px }",
        "junction { branch_length = 256 px  candidates = 64 }",
        "seed = 9007199254740992",
    ];
    builds(&scene("layout", &props), &[]);
}

#[test]
fn a_shrink_no_region_is_wider_than_is_refused_at_shrink() {
    let err = refused(
        &scene("layout", &["shrink = 64 px"]),
        &[],
        "shrink = 64 px",
        "64 px",
        "none of the 100 region(s) has a pixel 64 px inside its outline",
    );
    insta::assert_snapshot!("appearance_shrink_too_large", err);
}

#[test]
fn a_texture_of_more_than_64_by_64_blocks_is_refused_at_texture_size_before_quilting() {
    // 2048 px in 24 px blocks (every 20 px) would take 103 × 103 blocks per texture: an hour.
    let err = refused(
        &scene("layout", &["texture_size = 2048 px"]),
        &[],
        "texture_size = 2048 px",
        "2048 px",
        "2048 px on a side in 24 px blocks, takes 103 × 103 blocks; at most 64 × 64 are allowed",
    );
    assert!(flat(&err).contains("use `texture_size` of at most 1284 px, or `block` of at least"), "{err}");
    insta::assert_snapshot!("appearance_too_many_blocks", err);
    // A block the regions cannot hold is halved; the help does not suggest a larger one.
    let err = refused(
        &scene("layout", &["texture_size = 2048 px", "block = 256 px"]),
        &[],
        "texture_size = 2048 px",
        "2048 px",
        "its regions hold no 256 px block, so the block was halved",
    );
    assert!(!flat(&err).contains("`block` of at least"), "{err}");
}

#[test]
fn textures_beyond_the_memory_budget_are_refused_at_texture_size() {
    // Up to ten 2048² textures at about 128 bytes per texel: 5 GiB.
    refused(
        &scene("layout", &["texture_size = 2048 px"]),
        &["--max-memory", "1GiB"],
        "texture_size = 2048 px",
        "2048 px",
        "quilting 10 unified textures of 2048 x 2048 px needs about 5.0 GiB but the memory budget is 1.0 GiB",
    );
}

#[test]
fn atlases_beyond_the_memory_budget_are_refused_at_half_width() {
    let line = "interstice { half_width = 64 px }";
    let err = refused(
        &scene("layout", &[line]),
        &["--max-memory", "256MiB"],
        line,
        "64 px",
        "cutting the interstice and junction atlases needs about",
    );
    insta::assert_snapshot!("appearance_atlas_budget", err);
    // Written as a block property or not, the label finds the nearest thing the user wrote.
    let line = "interstice { extension = 64 px }";
    let err = refused(
        &scene("layout", &[line, "junction { branch_length = 256 px }"]),
        &["--max-memory", "12MiB"],
        line,
        "{ extension = 64 px }",
        "cutting the interstice and junction atlases needs about",
    );
    assert!(flat(&err).contains("but the memory budget is 12.0 MiB"), "{err}");
}

#[test]
fn a_render_beyond_the_memory_budget_is_refused_at_resolution() {
    // On the structure: the size is known when planned (3072 × 2048 at 48 bytes a pixel).
    refused(
        &scene("layout", &["resolution = 16"]),
        &["--max-memory", "256MiB"],
        "resolution = 16",
        "16",
        "appearance `dressed` at 3072 x 2048 pixels needs about 288.0 MiB",
    );
    // On a sample: known once its drawing is analysed (8192 × 6144).
    refused(
        &scene("stones", &["resolution = 16"]),
        &["--max-memory", "1GiB"],
        "resolution = 16",
        "16",
        "the appearance's render needs about",
    );
}

#[test]
fn odd_alpha_paths_are_refused_at_the_path() {
    for (path, message) in [
        (".", "cannot read `.`: is a directory, not a file"),
        ("sub/..", "cannot read `.`: is a directory, not a file"),
        ("nope.png", "cannot read `nope.png`"),
        ("wall_random.json", "cannot decode the alpha map: not a PNG or OpenEXR file"),
        ("", "empty file path"),
    ] {
        let line = format!("alpha = \"{path}\"");
        let p = project(&scene("layout", &[&line]));
        std::fs::create_dir_all(p.path("sub")).expect("mkdir");
        let (run, took) = build(&p, &[]);
        run.failed();
        let err = run.stderr();
        assert!(flat(&err).contains(message), "{path:?}: expected `{message}` in:\n{err}");
        assert_label_at(&err, &line, &format!("\"{path}\""));
        assert!(took < Duration::from_secs(20), "{path:?} took {took:?}");
    }
}

/// A structure-only sample, its structure and a map of its regions with `args`, at `size`.
fn regions_scene(args: &str, size: &str, structure_props: &str) -> String {
    let head = head("", structure_props);
    format!(
        r#"{head}
map m {{
  from = regions(of = layout{args})
{size}}}

output "m.png" {{
  from = m
}}
"#
    )
}

#[test]
fn hostile_regions_arguments_are_refused_at_the_argument() {
    let line = |args: &str| format!("from = regions(of = layout{args})");
    for (args, value, message) in [
        (", seed = -1", "-1", "expected an integer from 0 to 9007199254740992"),
        (", seed = 1e-9", "1e-9", "expected an integer from 0 to 9007199254740992"),
        (", seed = 1e30", "1e30", "expected an integer from 0 to 9007199254740992"),
        (", field = nope", "nope", "`nope` is not one of `id`, `random`, `u`, `v`, `edge`, `edge_px`, `axis`"),
        (", field = 0", "0", "expected one of `id`"),
    ] {
        let err = refused(&regions_scene(args, "", ""), &[], &line(args), value, message);
        if args == ", field = nope" {
            assert!(!err.contains("one of one of"), "{err}");
            insta::assert_snapshot!("regions_unknown_field", err);
        }
    }
    // `of` names a structure: a number, the sample or the map itself are refused at it.
    for of in ["3", "stones", "m"] {
        let text = regions_scene("", "", "").replace("regions(of = layout)", &format!("regions(of = {of})"));
        let p = project(&text);
        let (run, took) = build(&p, &[]);
        run.failed();
        assert_label_at(&run.stderr(), &format!("from = regions(of = {of})"), of);
        assert!(took < Duration::from_secs(20), "{of} took {took:?}");
    }
    // A map size of zero or of a trillion pixels is refused at the size.
    for size in ["0 x 0", "1000000000000 x 1000000000000"] {
        let line = format!("size = {size}");
        refused(
            &regions_scene(", field = edge_px", &format!("  {line}\n"), ""),
            &[],
            &line,
            size,
            "sizes are whole numbers of pixels from 1 to 16384",
        );
    }
}

#[test]
fn every_region_field_builds_at_one_pixel_and_with_extreme_seeds() {
    for field in ["id", "random", "u", "v", "edge", "edge_px", "axis"] {
        builds(&regions_scene(&format!(", field = {field}"), "  size = 1 x 1\n", ""), &[]);
    }
    for seed in ["0", "1e12", "9007199254740992"] {
        builds(&regions_scene(&format!(", seed = {seed}"), "", ""), &[]);
    }
}

#[test]
fn a_layout_the_sample_cannot_take_is_refused_at_layout() {
    let line = |v: &str| format!("layout = {v}");
    refused(
        &regions_scene("", "", "  layout = courses\n"),
        &[],
        &line("courses"),
        "courses",
        "`layout = courses` but the sample has no courses",
    );
    refused(
        &regions_scene("", "", "  layout = 0\n"),
        &[],
        &line("0"),
        "0",
        "expected one of `auto`, `courses`, `statistical`",
    );
    builds(&regions_scene("", "", "  layout = statistical\n"), &[]);
}
