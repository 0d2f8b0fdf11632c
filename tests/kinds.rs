//! The kinds list (issue 11): references are typed by what a declaration produces, so any
//! image-producing kind is accepted wherever an image is, with colour space carried along;
//! a reference of the wrong type names what would do.

mod common;

use common::Project;
use tessera::raster::{io, Image};

fn texture(w: usize, h: usize) -> Vec<u8> {
    let img = Image::from_fn(w, h, 3, |x, y, c| {
        let (x, y) = (x as f32, y as f32);
        (0.5 + 0.3 * ((x * 0.37).sin() * (y * 0.29).cos()) + 0.05 * c as f32).clamp(0.0, 1.0)
    });
    io::encode_png(&img, 8).expect("png")
}

#[test]
fn a_layer_is_accepted_wherever_an_image_is() {
    // `quilt`, `mix` and a library query's `to` once accepted only samples; a layer is an
    // image too, in the colour space of the sample it grows from.
    let scene = r#"scene { size = 48 x 48 }
sample s {
  image = "s.png"
  color = lab
}
layer first {
  quilt = s
  block = 12 px
  overlap = 3 px
}
layer second {
  quilt = first
  block = 12 px
  overlap = 3 px
}
library lib { dir = "lib" }
sample near { from = similar(lib, to = second) }
output "second.png" { from = second }
output "near.json" { from = near }
"#;
    let p = Project::new(&[("scene.tess", scene)]);
    p.write_bytes("s.png", &texture(40, 40));
    p.write_bytes("lib/a.png", &texture(32, 32));
    p.write_bytes("lib/b.png", &io::encode_png(&Image::filled(32, 32, 3, 0.2), 8).expect("png"));
    p.tessera(&["build", "scene.tess"]).ok();
    let out = io::decode(&p.read("out/scene/second.png")).expect("decode");
    assert_eq!((out.width, out.height, out.channels), (48, 48, 3));
    // Lab values written as if sRGB would be far outside [0, 1] and clip to a flat image;
    // converted from the sample's space they keep the texture's range.
    let (lo, hi) = out.data.iter().fold((1f32, 0f32), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    assert!(lo > 0.05 && hi < 0.95 && hi - lo > 0.2, "values {lo}..{hi}");
    let ranking = String::from_utf8(p.read("out/scene/near.json")).expect("utf-8");
    assert!(ranking.find("a.png").unwrap() < ranking.find("b.png").unwrap(), "{ranking}");
}

#[test]
fn a_reference_of_the_wrong_type_says_what_would_do() {
    let scene =
        "map m { from = constant(0.5) }\nlayer l {\n  quilt = m\n  block = 8 px\n}\noutput \"l.png\" { from = l }\n";
    let err = common::failed_build("wrong_type", scene, &[]);
    assert!(err.contains("`m` is a map, but an image is expected here"), "{err}");
    assert!(
        err.contains("an image comes from a sample, a representation, an appearance, a shader or a layer"),
        "{err}"
    );
}

#[test]
fn a_fractional_pixel_count_is_refused_where_it_is_written() {
    // Was: `block = 32.4 px` silently became 32.
    let scene =
        "sample s { image = \"s.png\" }\nlayer l {\n  quilt = s\n  block = 32.4 px\n}\noutput \"l.png\" { from = l }\n";
    let err = common::failed_build("fractional_block", scene, &[("s.png", &texture(40, 40))]);
    assert!(err.contains("`32.4 px` is not a whole number of pixels"), "{err}");
    assert!(err.contains("use `32 px`") && err.contains("scene.tess:4:11"), "{err}");
    // Whole values, with or without the unit, are fine.
    for block in ["16 px", "16"] {
        let scene = format!(
            "scene {{ size = 32 x 32 }}\nsample s {{ image = \"s.png\" }}\nlayer l {{\n  quilt = s\n  block = {block}\n}}\noutput \"l.png\" {{ from = l }}\n"
        );
        let p = Project::new(&[("scene.tess", &scene)]);
        p.write_bytes("s.png", &texture(40, 40));
        p.tessera(&["build", "scene.tess"]).ok();
    }
}
