//! Messages that name the real problem at the right span, and inputs that once panicked or
//! overflowed the stack in the front end: each a CLI-level regression test.

mod common;

use common::{failed_build, Project};

/// The `[file:line:column]` header of the first snippet.
fn location(stderr: &str) -> &str {
    let start = stderr.find("─[").map(|i| i + "─[".len()).expect("a snippet header");
    let end = stderr[start..].find(']').expect("header end") + start;
    &stderr[start..end]
}

fn png(w: usize, h: usize) -> Vec<u8> {
    let mut img = tessera::raster::Image::new(w, h, 3);
    for (i, v) in img.data.iter_mut().enumerate() {
        *v = ((i * 7919) % 256) as f32 / 255.0;
    }
    tessera::raster::io::encode_png(&img, 8).expect("png")
}

// Item 7: a diagnostic past column 65 535 panicked inside miette (a format width is 16 bits).

#[test]
fn a_diagnostic_far_along_a_long_line_is_shown_cut_down() {
    let scene = format!("map a {{ from = constant(1) {} bogus = 1 }}\n", " ".repeat(100_000));
    let err = failed_build("long_line", &scene, &[]);
    assert!(err.contains("unknown property `bogus`"), "{err}");
    assert_eq!(location(&err), "scene.tess:1:100029");
    assert!(err.len() < 2_000, "the snippet shows the whole line: {} bytes", err.len());
    assert!(err.contains("…") && err.contains("bogus = 1 }"), "{err}");
}

#[test]
fn a_syntax_error_at_the_end_of_a_long_line_is_shown() {
    let scene = format!("map a {{ from = [{}1, ] ] }}\n", "1, ".repeat(40_000));
    let err = failed_build("long_syntax", &scene, &[]);
    assert!(err.contains("tessera::syntax"), "{err}");
    assert!(err.len() < 2_000, "{} bytes", err.len());
}

// Item 7: 6 000–10 000 levels of nesting overflowed the stack in the parser, `build` and `fmt`.

#[test]
fn deep_nesting_is_refused_at_the_bracket_that_crosses_the_limit() {
    for (open, close, prefix) in
        [("[", "]", "map a { from = "), ("f(", ")", "map a { from = "), ("x { ", "}", "map a { ")]
    {
        let depth = 10_000;
        let scene = format!("{prefix}{}{} }}\n", open.repeat(depth), close.repeat(depth));
        let p = Project::new(&[("scene.tess", &scene)]);
        for args in [&["build", "scene.tess"][..], &["fmt", "scene.tess"][..]] {
            let run = p.tessera(args);
            run.failed();
            let err = run.stderr();
            assert!(err.contains("nesting too deep: more than 64 levels"), "{args:?} {open}: {err}");
            assert!(!err.contains("limit reached"), "{err}");
            // The 65th opening bracket: `prefix` opens one `{`, so the 64th of `open`.
            let col = prefix.len() + 63 * open.len() + open.find(['[', '(', '{']).unwrap() + 1;
            assert_eq!(location(&err), format!("scene.tess:1:{col}"), "{open}");
        }
        assert_eq!(p.read("scene.tess"), scene.as_bytes(), "fmt changed a file it refused");
    }
}

#[test]
fn nesting_within_the_limit_is_fine() {
    let depth = 60;
    let scene = format!("map a {{ from = {}constant(1){} }}\n", "combine(a = ".repeat(depth), ")".repeat(depth));
    let p = Project::new(&[("scene.tess", &scene)]);
    let run = p.tessera(&["fmt", "--check", "scene.tess"]);
    assert!(!run.stderr().contains("nesting"), "{}", run.stderr());
}

// Item 12: messages that mislead.

#[test]
fn an_unclosed_brace_is_reported_at_the_brace() {
    let err = failed_build("unclosed", "map a {\n  from = constant(1)\n\noutput \"a.png\" { from = a }\n", &[]);
    assert!(err.contains("unclosed `{`"), "{err}");
    assert!(err.contains("this `{` is never closed"), "{err}");
    assert_eq!(location(&err), "scene.tess:1:7");
}

#[test]
fn a_mismatched_bracket_names_the_one_left_open() {
    let err = failed_build("mismatched", "map a {\n  from = radial(center = [1, 2)\n}\n", &[]);
    assert!(err.contains("mismatched `)`: the `[` opened before it is not closed"), "{err}");
    assert_eq!(location(&err), "scene.tess:2:31");
}

#[test]
fn a_stray_closing_brace_is_named() {
    let err = failed_build("stray", "map a { from = constant(1) }\n}\n", &[]);
    assert!(err.contains("unexpected `}`: nothing is open here"), "{err}");
    assert_eq!(location(&err), "scene.tess:2:1");
}

#[test]
fn garbage_is_named_not_something_else() {
    for (scene, found) in [("%%%\n", "unexpected `%`"), ("\u{0}garbage\n", "unexpected character \\u{0}")] {
        let err = failed_build("garbage", scene, &[]);
        assert!(err.contains(found), "{err}");
        assert!(!err.contains("something else"), "{err}");
        assert!(!err.contains('\u{0}'), "a control character reached the terminal");
    }
}

#[test]
fn a_byte_order_mark_is_accepted_and_kept_by_fmt() {
    let scene = "\u{feff}scene {\n  seed = 1\n}\n";
    let p = Project::new(&[("scene.tess", scene)]);
    p.tessera(&["build", "scene.tess"]).ok();
    p.tessera(&["fmt", "--check", "scene.tess"]).ok();
    p.write("messy.tess", "\u{feff}scene { seed = 1 }\n");
    p.tessera(&["fmt", "messy.tess"]).ok();
    assert_eq!(p.read("messy.tess"), scene.as_bytes());
}

#[test]
fn a_non_ascii_name_is_reported_at_the_name() {
    let err = failed_build("non_ascii", "map dénsité { from = constant(1) }\n", &[]);
    assert!(err.contains("names are ASCII: `dénsité` contains `é`"), "{err}");
    assert_eq!(location(&err), "scene.tess:1:5");
}

#[test]
fn a_vector_of_the_wrong_shape_says_which_shape() {
    let err = failed_build(
        "deep_vector",
        "map a { from = polygon(points = [[[0, 0]], [10, 0], [5, 8]]) }\noutput \"a.png\" { from = a }\n",
        &[],
    );
    assert!(err.contains("expected a vector `[x, y]`, found a vector of 1 vector of 2 numbers"), "{err}");
    assert_eq!(location(&err), "scene.tess:1:34");
}

#[test]
fn numbers_beyond_f32_are_refused_as_written() {
    for (number, col) in [("1e308", 25), ("-1e308", 25), ("1e400", 25)] {
        let scene = format!("map a {{ from = constant({number}) }}\noutput \"a.png\" {{ from = a }}\n");
        let err = failed_build("huge", &scene, &[]);
        assert!(err.contains(&format!("`{number}` is too large: numbers lie within ±3.4e38")), "{err}");
        assert!(!err.contains("inf"), "{err}");
        assert_eq!(location(&err), format!("scene.tess:1:{col}"));
    }
}

#[test]
fn numbers_that_round_to_zero_in_f32_are_refused_as_written() {
    // Was: `1e-50` became 0 silently, so a property documented as positive got 0.
    for number in ["1e-50", "-1e-40", "1e-300"] {
        let scene = format!("map a {{ from = constant({number}) }}\noutput \"a.png\" {{ from = a }}\n");
        let err = failed_build("tiny", &scene, &[]);
        assert!(err.contains(&format!("`{number}` is too small: it rounds to 0 in 32-bit floats")), "{err}");
        assert_eq!(location(&err), "scene.tess:1:25");
    }
    // Zero itself, and the smallest normal float, are fine.
    for number in ["0", "0.0", "1.2e-38"] {
        let p = Project::new(&[(
            "scene.tess",
            &format!("map a {{ from = constant({number}) }}\noutput \"a.png\" {{ from = a }}\n"),
        )]);
        p.tessera(&["build", "scene.tess"]).ok();
    }
}

#[test]
fn an_empty_output_name_is_named() {
    let err = failed_build("empty_output", "map a { from = constant(1) }\noutput \"\" { from = a }\n", &[]);
    assert!(err.contains("`output` needs a file name"), "{err}");
    assert!(!err.contains("`.`"), "{err}");
    assert_eq!(location(&err), "scene.tess:2:8");
}

#[test]
fn a_negative_channel_weight_is_reported_at_the_weight() {
    let scene = "sample s { image = \"s.png\" }\nlayer l {\n  quilt = s\n  block = 8 px\n  weights = [1, -1, 1]\n}\noutput \"l.png\" { from = l }\n";
    let err = failed_build("negative_weight", scene, &[("s.png", &png(32, 32))]);
    assert!(err.contains("value out of range: must be at least 0"), "{err}");
    assert_eq!(location(&err), "scene.tess:5:17");
}

#[test]
fn an_integer_an_f64_cannot_hold_is_refused_with_the_range() {
    let err = failed_build("big_seed", "scene { seed = 9007199254740993 }\n", &[]);
    assert!(err.contains("expected an integer from 0 to 9007199254740992, found 9007199254740993"), "{err}");
    assert_eq!(location(&err), "scene.tess:1:16");
    // Through a param and `--set` the digits are read the same way.
    let p = Project::new(&[("scene.tess", "param s = 1\nscene { seed = s }\n")]);
    let run = p.tessera(&["build", "--set", "s=9007199254740993", "scene.tess"]);
    run.failed();
    assert!(run.stderr().contains("found 9007199254740993"), "{}", run.stderr());
    // Whole numbers in other spellings are still integers.
    let p = Project::new(&[("scene.tess", "scene { seed = 1.5e3 }\n")]);
    p.tessera(&["build", "scene.tess"]).ok();
}

#[test]
fn a_finite_exr_near_the_f32_limit_is_not_called_infinite() {
    let mut img = tessera::raster::Image::new(32, 32, 3);
    for (i, v) in img.data.iter_mut().enumerate() {
        *v = if i % 2 == 0 { 3e38 } else { -3e38 };
    }
    let exr = tessera::raster::io::encode_exr(&img).expect("exr");
    let scene =
        "sample s { image = \"big.exr\" }\nlayer l {\n  quilt = s\n  block = 8 px\n}\noutput \"l.png\" { from = l }\n";
    let p = Project::new(&[("scene.tess", scene)]);
    p.write_bytes("big.exr", &exr);
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    let err = run.stderr();
    assert!(!err.contains("NaN or infinite"), "{err}");
    assert!(
        err.contains("the image's values (up to ±3.0e38) overflow 32-bit floats when converted to `color = srgb`"),
        "{err}"
    );
    assert_eq!(location(&err), "scene.tess:1:20");
    // Kept as stored, the same finite values are accepted.
    p.write("scene.tess", &scene.replace("\"big.exr\" }", "\"big.exr\"  color = linear }"));
    p.tessera(&["build", "scene.tess"]).ok();
}

// Item 11: `fmt` replaced a symlinked scene by a regular file and rewrote read-only files.

#[cfg(unix)]
mod fmt_files {
    use super::common::Project;
    use std::os::unix::fs::PermissionsExt;

    const MESSY: &str = "scene { seed = 1 }\n";
    const TIDY: &str = "scene {\n  seed = 1\n}\n";

    #[test]
    fn fmt_formats_a_symlinks_target_and_keeps_the_link() {
        let p = Project::new(&[("real/target.tess", MESSY)]);
        std::os::unix::fs::symlink("real/target.tess", p.path("link.tess")).unwrap();
        p.tessera(&["fmt", "link.tess"]).ok();
        let meta = std::fs::symlink_metadata(p.path("link.tess")).unwrap();
        assert!(meta.file_type().is_symlink(), "the link was replaced by a file");
        assert_eq!(p.read("real/target.tess"), TIDY.as_bytes());
        let leftovers: Vec<_> = std::fs::read_dir(p.path("real")).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(leftovers.len(), 1, "{leftovers:?}");
    }

    #[test]
    fn fmt_refuses_a_read_only_file_and_leaves_it_alone() {
        let p = Project::new(&[("scene.tess", MESSY)]);
        let path = p.path("scene.tess");
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o444)).unwrap();
        let run = p.tessera(&["fmt", "scene.tess"]);
        run.failed();
        assert!(run.stderr().contains("read-only"), "{}", run.stderr());
        assert_eq!(p.read("scene.tess"), MESSY.as_bytes());
        assert_eq!(std::fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o444);
        // A read-only file that is already formatted is not an error.
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
        std::fs::write(&path, TIDY).unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o444)).unwrap();
        p.tessera(&["fmt", "scene.tess"]).ok();
    }

    #[test]
    fn fmt_keeps_a_files_permissions() {
        let p = Project::new(&[("scene.tess", MESSY)]);
        let path = p.path("scene.tess");
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o640)).unwrap();
        p.tessera(&["fmt", "scene.tess"]).ok();
        assert_eq!(p.read("scene.tess"), TIDY.as_bytes());
        assert_eq!(std::fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o640);
    }
}

#[test]
fn a_sample_with_only_a_structure_is_not_an_image() {
    // Found by the fuzz campaign: each of these panicked in the planner ("wrong artifact type").
    let structure = std::fs::read(common::repo().join("samples/standins/wall_random.json")).expect("structure");
    for (scene, at) in [
        ("sample s {\n  structure = \"s.json\"\n}\n\noutput \"o.png\" {\n  from = s\n}\n", "6:10"),
        ("sample s {\n  structure = \"s.json\"\n}\n\nlayer q {\n  quilt = s\n}\n\noutput \"o.png\" {\n  from = q\n}\n", "6:11"),
    ] {
        let stderr = failed_build("structure-only sample", scene, &[("s.json", &structure)]);
        assert!(stderr.contains("holds only a structure file, not an image"), "{stderr}");
        assert_eq!(location(&stderr), format!("scene.tess:{at}"), "{stderr}");
    }
}
