//! Progress bars on a terminal: a bar of scenes for a multi-scene command with the bars of
//! long stages nested under it, and nothing of the kind off a terminal, with `-q` or with
//! `--message-format json`. The terminal is a pseudo-terminal from util-linux's `script`.

mod common;

use common::Project;

/// Quilting a 768² layer from 10 px blocks overlapping by 2 px places (768 / 8)² = 9216
/// blocks: long enough (seconds) for its bar to show, which waits 400 ms.
const SCENE: &str = r#"
scene { size = 768 x 768 }
sample s { image = "s.png" }
layer q {
  quilt = s
  block = 10 px
  overlap = 2 px
}
output "q.png" { from = q }
"#;

fn project() -> Project {
    let p = Project::new(&[("a.tess", SCENE), ("b.tess", &SCENE.replace("768 x 768", "96 x 96"))]);
    p.write_bytes("s.png", &common::png(&common::texture(96, 96, 5)));
    p
}

/// Runs tessera with `args` on a pseudo-terminal; everything it drew, carriage returns and
/// escape sequences included.
fn on_terminal(p: &Project, args: &str) -> String {
    let out = std::process::Command::new("script")
        .args(["-qec", &format!("{} {args}", common::bin()), "/dev/null"])
        .current_dir(p.path(""))
        .env("NO_COLOR", "1")
        .output()
        .expect("util-linux `script` runs a command on a pseudo-terminal");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stdout));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The `done/total` positions drawn for the bar whose line contains `label`.
fn positions(screen: &str, label: &str) -> Vec<(u64, u64)> {
    screen
        .split(['\r', '\n'])
        .filter(|l| l.contains(label))
        .filter_map(|l| {
            let after = &l[l.find("] ")? + 2..];
            let (done, rest) = after.split_once('/')?;
            let total: String = rest.chars().take_while(char::is_ascii_digit).collect();
            Some((done.trim().parse().ok()?, total.parse().ok()?))
        })
        .collect()
}

#[test]
fn a_multi_scene_build_on_a_terminal_shows_scenes_and_quilting_blocks() {
    let p = project();
    let screen = on_terminal(&p, "build a.tess b.tess");
    let scenes = positions(&screen, "scenes [");
    assert!(scenes.contains(&(0, 2)) && scenes.contains(&(2, 2)), "scene bar: {scenes:?}\n{screen}");
    let blocks = positions(&screen, "layer q (quilt) [");
    assert!(!blocks.is_empty(), "no quilting bar:\n{screen}");
    assert!(blocks.iter().all(|&(_, total)| total == 96 * 96), "{blocks:?}");
    assert!(blocks.windows(2).all(|w| w[0].0 <= w[1].0), "blocks placed go down: {blocks:?}");
    // The stage bar is nested: drawn on the line under the scene bar's.
    let lines: Vec<&str> = screen.split('\n').collect();
    assert!(
        lines.windows(2).any(|w| w[0].contains("scenes [") && w[1].contains("layer q (quilt) [")),
        "the quilting bar is not under the scene bar:\n{screen}"
    );
    // The reports are still printed, whole lines between the bars.
    assert!(screen.contains("a.tess: 4 stages, 4 ran"), "{screen}");
    assert!(screen.contains("b.tess: 4 stages, 3 ran, 1 cached"), "{screen}");
}

#[test]
fn no_bars_off_a_terminal_with_quiet_or_with_json_messages() {
    let p = project();
    let quiet = on_terminal(&p, "build -q a.tess b.tess");
    assert!(!quiet.contains('['), "-q drew something:\n{quiet}");
    p.write("a.tess", &SCENE.replace("block = 10 px", "block = 11 px"));
    let json = on_terminal(&p, "--message-format json build a.tess b.tess");
    assert!(!json.contains("scenes [") && !json.contains("(quilt) ["), "{json}");
    p.write("a.tess", &SCENE.replace("block = 10 px", "block = 12 px"));
    let piped = p.tessera(&["build", "a.tess", "b.tess"]);
    piped.ok();
    assert!(!piped.stderr().contains('[') && !piped.stdout().contains('['), "{}", piped.stderr());
}
