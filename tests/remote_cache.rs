//! The remote cache against a real server: nginx with its WebDAV module, configured as a
//! Bazel HTTP cache on loopback (`tests/fixtures/nginx-remote-cache.conf`), started by the
//! harness. A second project with an empty local cache builds every example scene from the
//! remote alone; a server that fails (500s), answers slowly, serves damaged blobs, wants a
//! token it is not given, or stops mid-build costs one warning and a local build, never a
//! wrong output or a damaged local cache.
//!
//! Needs nginx (`.ci/run` installs Debian's `nginx-light`). Without it the tests say so and
//! pass, unless `TESSERA_REQUIRE_NGINX` is set (as CI does), when they fail.

#![cfg(unix)]

mod common;

use std::collections::BTreeMap;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use common::nginx::{Nginx, TOKEN};
use common::{copy_dir, parse_report, tree, Project, Run};

/// Runs tessera in `dir` with `env` set (and no credentials from the test's environment).
fn tessera(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Run {
    let mut c = Command::new(common::bin());
    c.args(args)
        .current_dir(dir)
        .env("NO_COLOR", "1")
        .env_remove("RUST_BACKTRACE")
        .env_remove("TESSERA_REMOTE_CACHE_TOKEN")
        .env_remove("TESSERA_REMOTE_CACHE_BASIC")
        .env("NO_PROXY", "127.0.0.1,localhost");
    for (k, v) in env {
        c.env(k, v);
    }
    Run { out: c.output().expect("run tessera") }
}

/// Statuses of a `--report` file's stages, counted.
fn statuses(p: &Project) -> BTreeMap<String, usize> {
    let mut m = BTreeMap::new();
    let stages = parse_report(&std::fs::read_to_string(p.path("report.json")).expect("report"));
    for s in stages {
        *m.entry(s.status).or_insert(0) += 1;
    }
    m
}

fn remote_warnings(run: &Run) -> usize {
    run.stderr().lines().filter(|l| l.starts_with("warning: remote cache")).count()
}

/// Every file of a local cache (its entries), by path below the cache, with its bytes.
fn cache_entries(p: &Project) -> BTreeMap<PathBuf, Vec<u8>> {
    tree(&p.path(".tessera/cache")).into_iter().filter(|(path, _)| path.components().count() == 2).collect()
}

/// A few quick scenes of the repository, for the fault tests (which compute them again).
const QUICK: [&str; 5] =
    ["scenes/blend.tess", "scenes/cells.tess", "scenes/quilt.tess", "scenes/noise_tiling.tess", "scenes/shaders.tess"];

fn build_args<'a>(url: Option<&'a str>, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["build", "--report", "report.json"];
    match url {
        Some(u) => args.extend(["--remote-cache", u]),
        None => args.push("--no-remote-cache"),
    }
    args.extend_from_slice(extra);
    args
}

/// The reference: the quick scenes built with no remote; their outputs and cache entries.
/// Files by path with their bytes.
type Files = Vec<(PathBuf, Vec<u8>)>;

fn reference() -> (Project, Files, BTreeMap<PathBuf, Vec<u8>>) {
    let p = Project::copy_of_repo();
    tessera(p.dir.path(), &build_args(None, &QUICK), &[]).ok();
    let out = tree(&p.path("out"));
    let cache = cache_entries(&p);
    (p, out, cache)
}

/// Nothing damaged entered `p`'s local cache: each entry is byte for byte the one a build
/// with no remote wrote under the same name.
#[track_caller]
fn cache_is_clean(p: &Project, reference: &BTreeMap<PathBuf, Vec<u8>>) {
    let entries = cache_entries(p);
    assert!(!entries.is_empty());
    for (path, bytes) in entries {
        let want = reference.get(&path).unwrap_or_else(|| panic!("{} is in no reference cache", path.display()));
        assert!(bytes == *want, "{} differs from the reference entry", path.display());
    }
}

#[test]
fn a_second_project_builds_every_scene_from_the_remote_alone() {
    let Some((server, _one)) = Nginx::start() else { return };
    let url = server.url("cache");
    let first = Project::copy_of_repo();
    let run = tessera(first.dir.path(), &build_args(Some(&url), &[]), &[]);
    run.ok();
    assert_eq!(remote_warnings(&run), 0, "{}", run.stderr());
    assert!(statuses(&first).get("ran").is_some_and(|&n| n > 100), "{:?}", statuses(&first));
    assert!(server.stored().len() > 200, "uploads reached the server");

    let second = Project::copy_of_repo();
    let run = tessera(second.dir.path(), &build_args(Some(&url), &["--timings"]), &[]);
    run.ok();
    let s = statuses(&second);
    assert_eq!(s.get("ran"), None, "nothing computed: {s:?}");
    assert_eq!(s.get("rebuilt"), None, "{s:?}");
    assert!(s.get("remote").is_some_and(|&n| n >= 31), "every scene's outputs from the remote: {s:?}");
    assert!(run.stdout().contains(" remote ") && run.stdout().contains('↓'), "timings show remote hits and bytes");
    assert_eq!(tree(&first.path("out")), tree(&second.path("out")), "outputs byte-identical to the first build");

    let stats = tessera(second.dir.path(), &["cache", "stats"], &[]);
    stats.ok();
    let line =
        |name: &str| stats.stdout().lines().find(|l| l.trim_start().starts_with(name)).unwrap_or_default().to_string();
    assert!(line("computed").split_whitespace().nth(1) == Some("0"), "{}", stats.stdout());
    assert!(line("remote hits").contains("100.0 %"), "{}", stats.stdout());
    // The JSON report has the bytes each stage moved.
    let report = std::fs::read_to_string(second.path("report.json")).expect("report");
    assert!(report.contains("\"bytes_down\""), "{report}");
    tessera(second.dir.path(), &["check", "-q", "--no-remote-cache"], &[]).ok();
}

#[test]
fn faults_cost_one_warning_and_a_local_build_never_a_wrong_output() {
    let Some((server, _one)) = Nginx::start() else { return };
    let (_reference, out, entries) = reference();
    // Fill the remote with the quick scenes.
    let filler = Project::copy_of_repo();
    tessera(filler.dir.path(), &build_args(Some(&server.url("cache")), &QUICK), &[]).ok();
    // A damaged copy: every other blob cut short, the rest with one byte flipped.
    let damaged = server.dir.path().join("damaged");
    copy_dir(&server.dir.path().join("data/cache"), &damaged);
    let mut blobs: Vec<PathBuf> =
        std::fs::read_dir(damaged.join("cas")).expect("cas").flatten().map(|e| e.path()).collect();
    blobs.sort();
    assert!(blobs.len() > 10);
    for (i, b) in blobs.iter().enumerate() {
        let mut bytes = std::fs::read(b).expect("blob");
        if i % 2 == 0 {
            bytes.truncate(bytes.len() / 2);
        } else {
            let mid = bytes.len() / 2;
            bytes[mid] ^= 0x40;
        }
        std::fs::write(b, bytes).expect("damage");
    }

    for (location, what) in
        [("broken", "HTTP 500"), ("slow", "no answer within the timeout"), ("damaged", "failed verification")]
    {
        let p = Project::copy_of_repo();
        let manifest = std::fs::read_to_string(p.path("tessera.toml")).expect("manifest");
        std::fs::write(p.path("tessera.toml"), format!("{manifest}\n[cache]\ntimeout = 1\n")).expect("manifest");
        let start = Instant::now();
        let run = tessera(p.dir.path(), &build_args(Some(&server.url(location)), &QUICK), &[]);
        run.ok();
        assert_eq!(remote_warnings(&run), 1, "{location}: one warning:\n{}", run.stderr());
        assert!(run.stderr().contains(what), "{location}: {}", run.stderr());
        assert!(start.elapsed() < Duration::from_secs(60), "{location}: the build was not held up");
        assert_eq!(tree(&p.path("out")), out, "{location}: outputs are those of a local build");
        cache_is_clean(&p, &entries);
        // And the local cache alone serves the next build.
        tessera(p.dir.path(), &build_args(None, &QUICK), &[]).ok();
        let s = statuses(&p);
        assert_eq!((s.get("ran"), s.get("rebuilt")), (None, None), "{location}: {s:?}");
    }
}

#[test]
fn a_server_stopped_mid_build_costs_one_warning() {
    let Some((mut server, _one)) = Nginx::start() else { return };
    let (_reference, out, entries) = reference();
    let p = Project::copy_of_repo();
    let url = server.url("cache");
    let args = build_args(Some(&url), &QUICK);
    let child = common::piped_tessera(p.dir.path(), &args).spawn().expect("run tessera");
    // Stop the server once the first upload has reached it.
    let start = Instant::now();
    while !server.access_log().contains("PUT") {
        assert!(start.elapsed() < Duration::from_secs(60), "no upload reached the server");
        std::thread::sleep(Duration::from_millis(1));
    }
    server.kill();
    let run = Run { out: child.wait_with_output().expect("tessera") };
    run.ok();
    assert_eq!(remote_warnings(&run), 1, "{}", run.stderr());
    assert_eq!(tree(&p.path("out")), out);
    cache_is_clean(&p, &entries);
}

#[test]
fn read_only_never_uploads_and_credentials_stay_secret() {
    let Some((server, _one)) = Nginx::start() else { return };
    let p = Project::copy_of_repo();
    let run = tessera(p.dir.path(), &build_args(Some(&server.url("cache")), &["--remote-read-only", QUICK[0]]), &[]);
    run.ok();
    assert_eq!(remote_warnings(&run), 0, "{}", run.stderr());
    assert!(server.stored().is_empty(), "read-only uploaded nothing");
    assert!(!server.access_log().contains("PUT"));
    assert!(server.access_log().contains("GET"), "but it did look");

    // Behind a token: given, it uploads and the next project reads; not given, one warning.
    let private = server.url("private");
    let token = [("TESSERA_REMOTE_CACHE_TOKEN", TOKEN)];
    let with = Project::copy_of_repo();
    let run = tessera(with.dir.path(), &build_args(Some(&private), &[QUICK[0]]), &token);
    run.ok();
    assert_eq!(remote_warnings(&run), 0, "{}", run.stderr());
    assert!(!server.stored().is_empty());
    let again = Project::copy_of_repo();
    let hit = tessera(again.dir.path(), &build_args(Some(&private), &["--timings", QUICK[0]]), &token);
    hit.ok();
    assert_eq!(statuses(&again).get("ran"), None);
    let without = Project::copy_of_repo();
    let refused = tessera(without.dir.path(), &build_args(Some(&private), &[QUICK[0]]), &[]);
    refused.ok();
    assert_eq!(remote_warnings(&refused), 1, "{}", refused.stderr());
    assert!(refused.stderr().contains("HTTP 401"), "{}", refused.stderr());
    for (run, p) in [(&run, &with), (&hit, &again)] {
        let report = std::fs::read_to_string(p.path("report.json")).expect("report");
        let stats = tessera(p.dir.path(), &["cache", "stats", "--message-format", "json"], &token);
        for text in [run.stdout(), run.stderr(), report, stats.stdout(), stats.stderr()] {
            assert!(!text.contains(TOKEN), "the token leaked:\n{text}");
        }
    }
}

#[test]
fn bad_remote_settings_get_a_diagnostic_and_no_secret_is_repeated() {
    let scene = "map a { from = constant(0.5)  size = 4 x 4 }\noutput \"a.png\" { from = a }\n";
    for (setting, message) in [
        ("remote = \"http://me:hunter2@cache.example/x\"", "credentials"),
        ("remote = \"ftp://cache.example/x\"", "http:// or https://"),
        ("remote = \"http://cache.example/x?key=1\"", "no query"),
        ("timeout = 0", "timeout is a number of seconds"),
        ("timeout = -3", "timeout is a number of seconds"),
        ("timeout = 3601", "timeout is a number of seconds"),
        ("timeout = nan", "timeout is a number of seconds"),
        ("timeout = inf", "timeout is a number of seconds"),
        ("timeout = 1e-320", "timeout is a number of seconds"),
        ("retry = -1", "retry is a number of seconds"),
        ("retry = nan", "retry is a number of seconds"),
        ("retry = 86401", "retry is a number of seconds"),
        ("max_blob = 0", "positive"),
        ("max_blob = -1", "max_blob"),
        ("max_blob = \"99999999 TiB\"", "not a usable memory size"),
        ("mode = \"sometimes\"", "unknown variant"),
    ] {
        let p = Project::new(&[("scene.tess", scene)]);
        p.write("tessera.toml", &format!("[paths]\nscenes = \".\"\n[cache]\n{setting}\n"));
        let run = p.tessera(&["build", "scene.tess"]);
        run.failed();
        let err = common::flat(&run.stderr());
        assert!(err.contains(message), "{setting}: {err}");
        let name = setting.split(" = ").next().unwrap();
        assert!(err.contains(name) || err.contains("line 4"), "{setting}: labelled: {err}");
        assert!(!err.contains("hunter2"), "{err}");
        assert!(!p.path("out").exists());
    }
    let p = Project::new(&[("scene.tess", scene)]);
    let run = p.tessera(&["build", "--remote-cache", "http://u:hunter2@h/x", "scene.tess"]);
    run.failed();
    assert!(run.stderr().contains("credentials") && !run.stderr().contains("hunter2"), "{}", run.stderr());
    let both = [("TESSERA_REMOTE_CACHE_TOKEN", "a"), ("TESSERA_REMOTE_CACHE_BASIC", "u:p")];
    let run = tessera(p.dir.path(), &["build", "--remote-cache", "http://127.0.0.1:9/x", "scene.tess"], &both);
    run.failed();
    assert!(run.stderr().contains("keep one"), "{}", run.stderr());
}

#[test]
fn a_server_that_is_not_there_costs_one_warning() {
    let port = TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port();
    let p = Project::new(&[
        ("a.tess", "map a { from = constant(0.5)  size = 4 x 4 }\noutput \"a.png\" { from = a }\n"),
        ("b.tess", "map b { from = constant(0.25)  size = 4 x 4 }\noutput \"b.png\" { from = b }\n"),
    ]);
    let url = format!("http://127.0.0.1:{port}/cache");
    let run = tessera(p.dir.path(), &["build", "--remote-cache", &url], &[]);
    run.ok();
    assert_eq!(remote_warnings(&run), 1, "one warning for two scenes:\n{}", run.stderr());
    assert!(p.path("out/a/a.png").exists() && p.path("out/b/b.png").exists());
}

#[test]
fn watch_asks_a_server_that_came_back() {
    let Some((mut server, _one)) = Nginx::start() else { return };
    let url = server.url("cache");
    let scene = |v: &str| {
        format!("map a {{\n  from = constant({v})\n  size = 32 x 32\n}}\n\noutput \"a.png\" {{ from = a }}\n")
    };
    let manifest = |extra: &str| format!("[paths]\nscenes = \".\"\n[cache]\nremote = \"{url}\"\n{extra}");
    // A first project puts the 0.75 scene on the server; then the server goes down.
    let first = Project::new(&[("scene.tess", &scene("0.75"))]);
    first.write("tessera.toml", &manifest(""));
    tessera(first.dir.path(), &["build", "scene.tess"], &[]).ok();
    assert!(!server.stored().is_empty(), "the first build uploaded");
    server.kill();

    // A second project watches the 0.25 scene with the server down: one warning, a local build.
    let p = Project::new(&[("scene.tess", &scene("0.25"))]);
    p.write("tessera.toml", &manifest("retry = 0\ntimeout = 5\n"));
    let (mut child, lines) = common::spawn_watch(&p, "scene.tess");
    let until = |needle: &str| common::lines_until(&lines, needle, Duration::from_secs(30));
    let first_build = until("[watch] built");
    let warned = |seen: &[String]| seen.iter().filter(|l| l.starts_with("warning: remote cache")).count();
    assert!(first_build.iter().any(|l| l.contains("ran 2 stage(s)")), "{first_build:?}");

    // The server comes back; the next build asks it again and takes the 0.75 scene from it:
    // no stage runs, the output holds 0.75, and no further warning is printed.
    let log_before = server.access_log().len();
    server.restart();
    std::thread::sleep(Duration::from_millis(20));
    p.write("scene.tess", &scene("0.75"));
    let mut seen = first_build.clone();
    let value = || tessera::raster::io::decode(&p.read("out/scene/a.png")).expect("decode").get(0, 0, 0);
    let start = Instant::now();
    let rebuilt = loop {
        let lines = until("[watch] built");
        seen.extend(lines.iter().cloned());
        if (value() - 0.75).abs() < 0.003 {
            break lines;
        }
        assert!(start.elapsed() < Duration::from_secs(30), "the output holds {}", value());
    };
    let _ = child.kill();
    let _ = child.wait();
    // The warning is printed as the first build ends: it may come just after its line.
    assert_eq!(warned(&seen), 1, "{seen:#?}");
    let built = rebuilt.last().expect("a line");
    assert!(built.contains("ran 0 stage(s); 1 output(s) written"), "{built}");
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p.path(".tessera/cache/stats.json")).expect("stats"))
            .expect("json");
    assert!(stats["remote_hits"].as_u64() >= Some(1), "{stats}");
    assert!(server.access_log()[log_before..].contains("GET /cache/ac/"), "asked again");
}

#[test]
fn push_fills_a_remote_from_a_local_cache() {
    let Some((server, _one)) = Nginx::start() else { return };
    let url = server.url("cache");
    let scenes = &QUICK[..2];
    // Built with no remote: the server holds nothing, and the local cache everything.
    let a = Project::copy_of_repo();
    tessera(a.dir.path(), &build_args(None, scenes), &[]).ok();
    assert!(server.stored().is_empty());
    let push = |p: &Project| {
        let mut args = vec!["--message-format", "json", "cache", "push", "--remote-cache", &url];
        args.extend_from_slice(scenes);
        let run = tessera(p.dir.path(), &args, &[]);
        run.ok();
        let line = run.stdout().lines().find(|l| l.contains("\"cache_push\"")).map(str::to_string);
        serde_json::from_str::<serde_json::Value>(&line.unwrap_or_else(|| panic!("no cache_push:\n{}", run.stdout())))
            .expect("json")
    };
    let first = push(&a);
    let uploaded = first["uploaded"].as_u64().expect("uploaded");
    assert!(uploaded > 0 && first["bytes"].as_u64() > Some(0), "{first}");
    // (A plan may hold stages no output needs: a build leaves them out, and so the cache.)
    assert_eq!(first["present"].as_u64(), Some(0), "{first}");
    // Pushing again sends nothing.
    let again = push(&a);
    assert_eq!((again["uploaded"].as_u64(), again["present"].as_u64()), (Some(0), Some(uploaded)), "{again}");
    assert_eq!(again["not_local"], first["not_local"]);

    // A second project, its local cache empty, builds the scenes from the remote alone.
    let b = Project::copy_of_repo();
    tessera(b.dir.path(), &build_args(Some(&url), scenes), &[]).ok();
    let s = statuses(&b);
    assert_eq!((s.get("ran"), s.get("rebuilt")), (None, None), "{s:?}");
    assert!(s.get("remote") > Some(&0), "{s:?}");
    assert_eq!(tree(&b.path("out")), tree(&a.path("out")));

    // Nowhere to push: no remote, or a read-only one.
    let none = tessera(a.dir.path(), &["cache", "push", "--no-remote-cache"], &[]);
    none.failed();
    assert!(none.stderr().contains("no remote cache"), "{}", none.stderr());
    let ro = tessera(a.dir.path(), &["cache", "push", "--remote-cache", &url, "--remote-read-only", scenes[0]], &[]);
    ro.failed();
    assert!(ro.stderr().contains("read-only"), "{}", ro.stderr());
    // A server that fails stops the push with an error saying so.
    let broken = server.url("broken");
    let run = tessera(a.dir.path(), &["cache", "push", "--remote-cache", &broken, scenes[0]], &[]);
    run.failed();
    let err = common::flat(&run.stderr());
    assert!(err.contains("HTTP 500") && err.contains("push stopped after 0 entries"), "{err}");
}
