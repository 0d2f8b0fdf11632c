//! The preview page in a real browser: headless Chromium loads the page of a watched scene;
//! each edit of the scene shows its new output on the page within a second, checked through
//! the DOM and through a screenshot whose pixels are the output's; a broken edit shows its
//! diagnostic while the last good output stays. Prints the edit-to-page latencies.
//!
//! Needs Chromium on the PATH (`.ci/run` installs Debian's). Without it the test says so and
//! passes, unless `TESSERA_REQUIRE_BROWSER` is set (as CI does), when it fails.
//!
//! Chromium is driven over the DevTools protocol on a pipe (`--remote-debugging-pipe`: JSON
//! messages ended by a NUL on file descriptors 3 and 4), a few lines here: the Rust clients
//! of the protocol download its definition while they build, which an offline CI cannot.

#![cfg(unix)]

mod common;

use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::os::fd::{FromRawFd, RawFd};
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use base64::Engine;
use serde_json::{json, Value};

use common::Project;
use tessera::raster::Image;

/// A headless Chromium and one page of it, over the DevTools pipe.
struct Tab {
    browser: Child,
    to: File,
    from: Receiver<Value>,
    next: u64,
    session: String,
    _profile: tempfile::TempDir,
}

/// A pipe's two ends, both close-on-exec and above the descriptors the child gets.
fn pipe() -> (RawFd, RawFd) {
    let mut fds = [0; 2];
    assert_eq!(unsafe { libc::pipe2(fds.as_mut_ptr(), libc::O_CLOEXEC) }, 0);
    let high = |fd: RawFd| {
        let h = unsafe { libc::fcntl(fd, libc::F_DUPFD_CLOEXEC, 10) };
        unsafe { libc::close(fd) };
        h
    };
    (high(fds[0]), high(fds[1]))
}

impl Tab {
    fn open(chromium: &PathBuf) -> Tab {
        let profile = tempfile::tempdir().unwrap();
        let (their_in, our_out) = pipe();
        let (our_in, their_out) = pipe();
        let mut cmd = Command::new(chromium);
        cmd.args([
            "--headless",
            "--remote-debugging-pipe",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--force-color-profile=srgb",
            "--force-device-scale-factor=1",
            "--window-size=1200,900",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg("about:blank")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null());
        // SAFETY: only async-signal-safe calls between fork and exec.
        unsafe {
            cmd.pre_exec(move || {
                if libc::dup2(their_in, 3) < 0 || libc::dup2(their_out, 4) < 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        let browser = cmd.spawn().expect("Chromium starts");
        unsafe {
            libc::close(their_in);
            libc::close(their_out);
        }
        let to = unsafe { File::from_raw_fd(our_out) };
        let reader = unsafe { File::from_raw_fd(our_in) };
        let (tx, from) = mpsc::channel();
        std::thread::spawn(move || {
            let mut r = BufReader::new(reader);
            let mut buf = Vec::new();
            while r.read_until(0, &mut buf).is_ok_and(|n| n > 0) {
                buf.pop();
                if let Ok(v) = serde_json::from_slice(&buf) {
                    if tx.send(v).is_err() {
                        return;
                    }
                }
                buf.clear();
            }
        });
        let mut tab = Tab { browser, to, from, next: 0, session: String::new(), _profile: profile };
        let target = tab.call("Target.createTarget", json!({ "url": "about:blank" }));
        let attached = tab.call("Target.attachToTarget", json!({ "targetId": target["targetId"], "flatten": true }));
        tab.session = attached["sessionId"].as_str().unwrap().to_string();
        tab
    }

    /// Sends `method` (to the page once attached) and waits for its result.
    fn call(&mut self, method: &str, params: Value) -> Value {
        self.next += 1;
        let mut msg = json!({ "id": self.next, "method": method, "params": params });
        if !self.session.is_empty() {
            msg["sessionId"] = json!(self.session);
        }
        let mut bytes = serde_json::to_vec(&msg).unwrap();
        bytes.push(0);
        self.to.write_all(&bytes).unwrap();
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            let left = deadline.checked_duration_since(Instant::now()).expect("Chromium answers within 30 s");
            let v = self.from.recv_timeout(left).expect("Chromium answers within 30 s");
            if v["id"] == json!(self.next) {
                assert!(v.get("error").is_none(), "{method}: {}", v["error"]);
                return v["result"].clone();
            }
        }
    }

    fn navigate(&mut self, url: &str) {
        self.call("Page.navigate", json!({ "url": url }));
    }

    /// The value of a JavaScript expression (JSON-serialisable).
    fn eval(&mut self, expression: &str) -> Value {
        let r = self.call("Runtime.evaluate", json!({ "expression": expression, "returnByValue": true }));
        r["result"]["value"].clone()
    }

    fn screenshot(&mut self, x: f64, y: f64, w: f64, h: f64) -> Vec<u8> {
        let clip = json!({ "x": x, "y": y, "width": w, "height": h, "scale": 1 });
        let r = self.call("Page.captureScreenshot", json!({ "format": "png", "clip": clip, "fromSurface": true }));
        base64::engine::general_purpose::STANDARD.decode(r["data"].as_str().unwrap()).unwrap()
    }
}

impl Drop for Tab {
    fn drop(&mut self) {
        let _ = self.browser.kill();
        let _ = self.browser.wait();
    }
}

fn scene(to: u32) -> String {
    format!(
        "scene {{ size = 96 x 40 }}\nmap ramp {{ from = linear(from = [0, 0], to = [{to}, 0]) }}\n\
         output \"ramp.png\" {{ from = ramp }}\n"
    )
}

fn chromium() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|d| ["chromium", "chromium-browser", "google-chrome"].map(|n| d.join(n)))
        .find(|p| p.is_file())
}

fn now_ms() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).unwrap().as_secs_f64() * 1000.0
}

struct Watch {
    child: Child,
    lines: Receiver<String>,
}

impl Drop for Watch {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn serve(p: &Project) -> (Watch, String) {
    let (child, lines) = common::spawn_tessera(p, &["watch", "scene.tess", "--serve"]);
    let w = Watch { child, lines };
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let line = w.lines.recv_timeout(deadline - Instant::now()).expect("the preview's address");
        if let Some(url) = line.split("preview at ").nth(1) {
            return (w, url.trim().to_string());
        }
    }
}

/// The pixels the page shows of the output picture (its first pane), as an RGB image.
fn shown(tab: &mut Tab) -> Option<Image> {
    let rect = tab.eval(
        "(() => { const i = document.querySelector(\".card[data-output='ramp.png'] .pane img\"); \
         if (!i || !i.complete || !i.naturalWidth) return null; const r = i.getBoundingClientRect(); \
         return [r.x, r.y, r.width, r.height]; })()",
    );
    let r: [f64; 4] = serde_json::from_value(rect).ok()?;
    tessera::raster::io::decode(&tab.screenshot(r[0], r[1], r[2], r[3])).ok()
}

/// Largest difference between what the page shows and the output file (gray, drawn as
/// three equal channels), in 8-bit steps; `None` when the sizes differ.
fn steps_off(shown: &Image, output: &Image) -> Option<u32> {
    if (shown.width, shown.height) != (output.width, output.height) {
        return None;
    }
    let mut worst = 0u32;
    for y in 0..output.height {
        for x in 0..output.width {
            let want = output.get(x, y, 0);
            for c in 0..3 {
                worst = worst.max(((shown.get(x, y, c) - want).abs() * 255.0).round() as u32);
            }
        }
    }
    Some(worst)
}

fn generation(tab: &mut Tab) -> u64 {
    tab.eval("document.body.dataset.generation || '0'").as_str().and_then(|s| s.parse().ok()).unwrap_or(0)
}

/// The `data-status` of the output's card (its golden comparison).
fn status(tab: &mut Tab) -> Value {
    tab.eval("document.querySelector(\".card[data-output='ramp.png']\")?.dataset.status")
}

/// Waits until the page shows `output` pixel for pixel; returns when the page had it all
/// loaded (its `shownAt`, ms since the epoch).
fn wait_for(tab: &mut Tab, output: &Image, after: u64, limit: Duration) -> f64 {
    let start = Instant::now();
    loop {
        if generation(tab) > after {
            if let Some(img) = shown(tab) {
                if steps_off(&img, output) == Some(0) {
                    return tab.eval("document.body.dataset.shownAt").as_str().unwrap().parse().unwrap();
                }
            }
        }
        if start.elapsed() > limit {
            let g = generation(tab);
            let off = shown(tab).map(|i| (i.width, i.height, steps_off(&i, output)));
            let srcs = tab.eval("[current && current.generation, ...[...document.querySelectorAll('img')].map(i => i.src + ' ' + i.complete)].join('; ')");
            panic!("the page did not show the output within {limit:?}: generation {g}, shown {off:?}; {srcs}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn the_page_follows_edits_within_a_second_and_shows_a_broken_one() {
    let Some(chromium) = chromium() else {
        assert!(std::env::var_os("TESSERA_REQUIRE_BROWSER").is_none(), "no Chromium on the PATH");
        eprintln!("SKIPPED: no Chromium on the PATH (`apt-get install chromium`)");
        return;
    };
    let p = Project::new(&[("scene.tess", &scene(96))]);
    p.tessera(&["bless", "scene.tess"]).ok();
    let (watch, url) = serve(&p);
    let mut tab = Tab::open(&chromium);
    tab.navigate(&url);
    let start = Instant::now();
    while generation(&mut tab) == 0 {
        assert!(start.elapsed() < Duration::from_secs(20), "the page never showed a build");
        std::thread::sleep(Duration::from_millis(20));
    }
    // Pixels as they are: the 1:1 view of the output.
    tab.eval("document.querySelector(\".card[data-output='ramp.png'] .controls button:nth-child(2)\").click()");
    let output = |p: &Project| tessera::raster::io::decode(&p.read("out/scene/ramp.png")).unwrap();
    wait_for(&mut tab, &output(&p), 0, Duration::from_secs(10));
    assert_eq!(status(&mut tab), json!("pass"));

    let mut latencies = Vec::new();
    for (i, to) in [48u32, 200, 24, 150, 64].into_iter().enumerate() {
        let before = generation(&mut tab);
        std::thread::sleep(Duration::from_millis(30));
        let edited = now_ms();
        p.write("scene.tess", &scene(to));
        // The output file is written before the page is told.
        let deadline = Instant::now() + Duration::from_secs(10);
        let want = loop {
            let img = output(&p);
            let expected = (24.5f32 / to as f32).min(1.0);
            if (img.get(24, 0, 0) - expected).abs() < 0.01 {
                break img;
            }
            assert!(Instant::now() < deadline, "edit {i}: the output was not rebuilt");
            std::thread::sleep(Duration::from_millis(5));
        };
        let shown_at = wait_for(&mut tab, &want, before, Duration::from_secs(5));
        let latency = shown_at - edited;
        assert!(latency < 1000.0, "edit {i}: the page showed it after {latency:.0} ms");
        latencies.push(latency);
        assert_eq!(status(&mut tab), json!("fail"), "edit {i} differs from the golden");
        let diff = tab.eval("!!document.querySelector(\".card[data-output='ramp.png'] .pane:nth-child(3) img\")");
        assert_eq!(diff, json!(true), "edit {i}: a difference pane");
    }
    latencies.sort_by(f64::total_cmp);
    println!("edit to page (ms, edit written to every picture loaded): {latencies:.0?}; median {:.0}", latencies[2]);

    // A broken edit: its diagnostic on the page, the last good output still shown.
    let before = generation(&mut tab);
    p.write("scene.tess", &scene(64).replace("to = [64, 0]) }", "to = [64, 0] }"));
    let start = Instant::now();
    loop {
        if generation(&mut tab) > before {
            if let Some(text) = tab.eval("document.getElementById('diagnostics')?.textContent").as_str() {
                assert!(text.contains("scene.tess"), "{text}");
                break;
            }
        }
        assert!(start.elapsed() < Duration::from_secs(5), "no diagnostic on the page");
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(steps_off(&shown(&mut tab).expect("the last good output"), &output(&p)) == Some(0));
    drop(watch);
}
