//! The preview page of `tessera watch --serve`, over raw HTTP (what a hostile client sends,
//! unnormalised): the page and its state, an event per rebuild, the last good outputs kept
//! under the diagnostics of a broken edit, only the project's outputs, goldens and read
//! samples served, a foreign `Host` refused, and a browser that vanishes mid-stream survived.
//! `tessera gallery` writes the same page as static files.

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::Child;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use common::Project;

const SCENE: &str = "map a {\n  from = constant(0.25)\n  size = 32 x 16\n}\n\noutput \"a.png\" { from = a }\n\
                     output \"a.exr\" { from = a }\n";

struct Served {
    child: Child,
    lines: Receiver<String>,
    addr: String,
}

impl Served {
    fn start(p: &Project) -> Served {
        let (child, lines) = common::spawn_tessera(p, &["watch", "scene.tess", "--serve"]);
        let mut s = Served { child, lines, addr: String::new() };
        let line = s.until("[watch] preview at http://");
        s.addr = line.split("http://").nth(1).unwrap().trim_end_matches('/').to_string();
        s.until("[watch] built");
        s
    }

    fn until(&self, needle: &str) -> String {
        let deadline = Instant::now() + Duration::from_secs(20);
        let mut seen = Vec::new();
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            match self.lines.recv_timeout(left) {
                Ok(l) if l.contains(needle) => return l,
                Ok(l) => seen.push(l),
                Err(_) => break,
            }
        }
        panic!("no line containing {needle:?} within 20 s; saw:\n{}", seen.join("\n"));
    }

    /// A raw GET of `target` (sent as written) with `host`: status and body.
    fn get_as(&self, target: &str, host: &str) -> (u16, Vec<u8>) {
        let mut s = TcpStream::connect(&self.addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        write!(s, "GET {target} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n").unwrap();
        let mut raw = Vec::new();
        s.read_to_end(&mut raw).unwrap();
        let split = raw.windows(4).position(|w| w == b"\r\n\r\n").expect("a header");
        let head = String::from_utf8_lossy(&raw[..split]).to_string();
        let status = head.split(' ').nth(1).unwrap().parse().unwrap();
        let mut body = raw[split + 4..].to_vec();
        if head.to_ascii_lowercase().contains("transfer-encoding: chunked") {
            body = unchunk(&body);
        }
        (status, body)
    }

    fn get(&self, target: &str) -> (u16, Vec<u8>) {
        self.get_as(target, &self.addr.clone())
    }

    fn state(&self) -> serde_json::Value {
        let (status, body) = self.get("/api/state");
        assert_eq!(status, 200);
        serde_json::from_slice(&body).unwrap()
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn unchunk(mut b: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let line_end = b.windows(2).position(|w| w == b"\r\n").unwrap();
        let n = usize::from_str_radix(std::str::from_utf8(&b[..line_end]).unwrap().trim(), 16).unwrap();
        if n == 0 {
            return out;
        }
        out.extend_from_slice(&b[line_end + 2..line_end + 2 + n]);
        b = &b[line_end + 2 + n + 2..];
    }
}

fn project() -> Project {
    Project::new(&[("scene.tess", SCENE), ("secret.txt", "do not serve"), ("samples/x.txt", "x")])
}

/// Waits for a state after generation `after` that `want` accepts (an edit is a truncation
/// and then the text: a build may see the empty file first).
fn next_state(s: &Served, after: u64, want: impl Fn(&serde_json::Value) -> bool) -> serde_json::Value {
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let st = s.state();
        if st["generation"].as_u64().unwrap() > after && want(&st["scenes"][0]) {
            return st;
        }
        assert!(Instant::now() < deadline, "no such build within 20 s; the last: {st}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn output<'a>(scene: &'a serde_json::Value, name: &str) -> Option<&'a serde_json::Value> {
    scene["outputs"].as_array()?.iter().find(|o| o["name"] == name)
}

#[test]
fn the_page_shows_each_rebuild_and_keeps_the_last_good_outputs_under_a_broken_edit() {
    let p = project();
    p.tessera(&["bless", "scene.tess"]).ok();
    let s = Served::start(&p);
    let (status, page) = s.get("/");
    assert_eq!(status, 200);
    assert!(String::from_utf8_lossy(&page).contains("new EventSource(\"/events\")"));

    let st = s.state();
    assert_eq!(st["live"], true);
    let scene = &st["scenes"][0];
    assert_eq!(scene["name"], "scene");
    assert!(scene["diagnostics"].is_null());
    let outputs = scene["outputs"].as_array().unwrap();
    let png = outputs.iter().find(|o| o["name"] == "a.png").unwrap();
    assert_eq!((png["width"].as_u64(), png["height"].as_u64()), (Some(32), Some(16)));
    assert_eq!(png["compare"]["status"], "pass");
    // The PNG as written, byte for byte; the EXR tone-mapped to a PNG a browser can draw.
    let (status, bytes) = s.get(png["image"].as_str().unwrap());
    assert_eq!(status, 200);
    assert_eq!(bytes, p.read("out/scene/a.png"));
    let exr = outputs.iter().find(|o| o["name"] == "a.exr").unwrap();
    let (status, bytes) = s.get(exr["image"].as_str().unwrap());
    assert_eq!(status, 200);
    let img = tessera::raster::io::decode(&bytes).unwrap();
    assert_eq!((img.width, img.height), (32, 16));
    assert!((img.get(3, 3, 0) - tessera::raster::color::linear_to_srgb(0.25)).abs() < 0.003);
    assert!(s.get(exr["golden_image"].as_str().unwrap()).0 == 200);
    // Stage timings of the build.
    assert!(!scene["stages"].as_array().unwrap().is_empty());

    // An edit: a new generation, the new output, a difference from the golden with its image.
    let g0 = st["generation"].as_u64().unwrap();
    std::thread::sleep(Duration::from_millis(20));
    p.write("scene.tess", &SCENE.replace("0.25", "0.75"));
    let st = next_state(&s, g0, |sc| output(sc, "a.png").is_some_and(|o| o["compare"]["status"] == "fail"));
    let png = output(&st["scenes"][0], "a.png").unwrap().clone();
    let (status, bytes) = s.get(png["image"].as_str().unwrap());
    assert_eq!(status, 200);
    assert!((tessera::raster::io::decode(&bytes).unwrap().get(0, 0, 0) - 0.75).abs() < 0.003);
    let (status, diff) = s.get(png["diff_image"].as_str().expect("a diff image"));
    assert_eq!(status, 200);
    assert!(tessera::raster::io::decode(&diff).is_ok());

    // A broken edit: the diagnostic at its span on the page, the last good outputs still there.
    let g1 = st["generation"].as_u64().unwrap();
    std::thread::sleep(Duration::from_millis(20));
    p.write("scene.tess", &SCENE.replace("constant(0.25)", "constant(0.75"));
    let st = next_state(&s, g1, |sc| !sc["diagnostics"].is_null());
    let scene = &st["scenes"][0];
    let diagnostics = scene["diagnostics"].as_str().expect("diagnostics on the page");
    assert!(diagnostics.contains("[scene.tess:"), "{diagnostics}");
    assert!(!diagnostics.contains('\u{1b}'), "no terminal colours on the page");
    let png = scene["outputs"].as_array().unwrap().iter().find(|o| o["name"] == "a.png").unwrap();
    assert_eq!(s.get(png["image"].as_str().unwrap()).0, 200, "the last good output stays served");
}

#[test]
fn an_event_per_rebuild_and_a_vanished_browser_is_survived() {
    let p = project();
    let s = Served::start(&p);
    // A browser that opens the stream and goes away at once, several times.
    for _ in 0..5 {
        let mut c = TcpStream::connect(&s.addr).unwrap();
        write!(c, "GET /events HTTP/1.1\r\nHost: {}\r\n\r\n", s.addr).unwrap();
        drop(c);
    }
    let mut c = TcpStream::connect(&s.addr).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    write!(c, "GET /events HTTP/1.1\r\nHost: {}\r\n\r\n", s.addr).unwrap();
    let mut r = BufReader::new(c);
    let mut line = String::new();
    r.read_line(&mut line).unwrap();
    assert!(line.starts_with("HTTP/1.1 200"), "{line}");
    while line != "\r\n" {
        line.clear();
        r.read_line(&mut line).unwrap();
    }
    std::thread::sleep(Duration::from_millis(50));
    p.write("scene.tess", &SCENE.replace("0.25", "0.5"));
    let mut event = String::new();
    while !event.contains("event: build") {
        line.clear();
        assert!(r.read_line(&mut line).unwrap() > 0, "the stream ended");
        event.push_str(&line);
    }
    // The server still answers after all that.
    assert_eq!(s.get("/api/state").0, 200);
}

#[test]
fn only_outputs_goldens_and_read_samples_are_served() {
    let p = Project::new(&[
        ("scene.tess", "sample s { image = \"samples/in.png\" }\noutput \"a.png\" { from = s }\n"),
        ("secret.txt", "do not serve"),
        ("samples/other.png", "not read"),
    ]);
    p.write_bytes("samples/in.png", &common::png(&common::texture(16, 16, 1)));
    let s = Served::start(&p);
    assert_eq!(s.get("/files/out/scene/a.png").0, 200);
    assert_eq!(s.get("/files/samples/in.png").0, 200, "a sample the build read");
    for bad in [
        "/files/samples/other.png",
        "/files/secret.txt",
        "/files/tessera.toml",
        "/files/scene.tess",
        "/files/out/../secret.txt",
        "/files/out/%2e%2e/secret.txt",
        "/files/out/scene/..%2f..%2fsecret.txt",
        "/files/..%2fsecret.txt",
        "/files/%2fetc%2fpasswd",
        "/files//etc/passwd",
        "/files/out\\..\\secret.txt",
        "/picture/secret.txt",
        "/../secret.txt",
        "/secret.txt",
        "/files/.cache",
    ] {
        let (status, body) = s.get(bad);
        assert_eq!(status, 404, "{bad} was answered {status}: {}", String::from_utf8_lossy(&body));
    }
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(p.path("secret.txt"), p.path("out/scene/link.txt")).unwrap();
        assert_eq!(s.get("/files/out/scene/link.txt").0, 404, "a link out of the outputs");
    }
    // A page elsewhere reaching the server through a rebound name.
    assert_eq!(s.get_as("/api/state", "evil.example:80").0, 403);
    assert_eq!(s.get_as("/files/out/scene/a.png", "evil.example").0, 403);
}

#[test]
fn with_json_messages_the_address_is_a_json_line() {
    let p = project();
    let (mut child, lines) = common::spawn_tessera(&p, &["watch", "scene.tess", "--serve", "--message-format", "json"]);
    let first = lines.recv_timeout(Duration::from_secs(20)).expect("a line");
    let _ = child.kill();
    let _ = child.wait();
    let v: serde_json::Value = serde_json::from_str(&first).unwrap_or_else(|_| panic!("not JSON: {first}"));
    assert_eq!(v["type"], "preview");
    assert!(v["url"].as_str().unwrap().starts_with("http://127.0.0.1:"), "{v}");
}

#[test]
fn a_taken_address_is_a_diagnostic_not_a_panic() {
    let p = project();
    let s = Served::start(&p);
    let run = p.tessera(&["watch", "scene.tess", "--serve", &s.addr]);
    run.failed();
    assert!(run.stderr().contains("cannot serve on"), "{}", run.stderr());
}

#[test]
fn the_gallery_is_the_page_with_its_files_beside_it() {
    let p = project();
    p.tessera(&["bless", "scene.tess"]).ok();
    p.write("scene.tess", &SCENE.replace("0.25", "0.5"));
    let run = p.tessera(&["gallery"]);
    run.ok();
    assert!(run.stdout().contains("gallery: out/.gallery/index.html"), "{}", run.stdout());
    let page = p.read_text("out/.gallery/index.html");
    let start = page.find("<script id=\"state\" type=\"application/json\">").unwrap();
    let json = &page[start..].split_once('>').unwrap().1;
    let json = json.split_once("</script>").unwrap().0;
    let st: serde_json::Value = serde_json::from_str(json).unwrap();
    assert_eq!(st["live"], false);
    let outputs = st["scenes"][0]["outputs"].as_array().unwrap();
    for o in outputs {
        for key in ["file", "image", "golden_image", "diff_image"] {
            if let Some(link) = o[key].as_str() {
                assert!(!link.starts_with('/') && !link.contains(".."), "{link}");
                assert!(
                    p.path(&format!("out/.gallery/{link}")).is_file(),
                    "{key} of {}: {link} is not there",
                    o["name"]
                );
            }
        }
    }
    let png = outputs.iter().find(|o| o["name"] == "a.png").unwrap();
    assert_eq!(png["compare"]["status"], "fail");
    assert_eq!(p.read(&format!("out/.gallery/{}", png["file"].as_str().unwrap())), p.read("out/scene/a.png"));
    // A differing golden is shown, not a failure of the command; a broken scene is.
    p.write("scene.tess", "map a {");
    let run = p.tessera(&["gallery"]);
    run.failed();
    assert!(p.read_text("out/.gallery/index.html").contains("scene.tess:1:"));
}
