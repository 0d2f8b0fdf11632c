//! `tessera lsp` driven as an editor drives it: a client speaking JSON-RPC with
//! `Content-Length` framing to the real binary over stdio. It opens a scene, gets the
//! diagnostic of a misspelt property at its exact range, completions at a property position,
//! hover for a kind, a definition in an imported file, a rename, the formatting `tessera fmt`
//! does; hostile input gets errors or empty answers and the server lives on; and the time
//! from a keystroke to its diagnostics is measured on every bundled scene.

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

/// Long enough for a loaded CI machine; a hang fails instead of stalling.
const WAIT: Duration = Duration::from_secs(60);

struct Client {
    child: Child,
    stdin: ChildStdin,
    incoming: Receiver<Value>,
    /// Notifications that arrived while waiting for something else.
    held: Vec<Value>,
    next_id: i64,
}

fn uri(path: &Path) -> String {
    format!("file://{}", path.display())
}

impl Client {
    fn start(dir: &Path) -> Client {
        let mut child = Command::new(common::bin())
            .arg("lsp")
            .current_dir(dir)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start tessera lsp");
        let stdin = child.stdin.take().unwrap();
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let (tx, incoming) = channel();
        std::thread::spawn(move || loop {
            let mut len = None;
            loop {
                let mut line = String::new();
                if out.read_line(&mut line).unwrap_or(0) == 0 {
                    return;
                }
                let line = line.trim_end();
                if line.is_empty() {
                    break;
                }
                if let Some(n) = line.strip_prefix("Content-Length: ") {
                    len = n.parse::<usize>().ok();
                }
            }
            let mut body = vec![0; len.expect("a Content-Length header")];
            out.read_exact(&mut body).expect("a whole message");
            if tx.send(serde_json::from_slice(&body).expect("a JSON message")).is_err() {
                return;
            }
        });
        let mut c = Client { child, stdin, incoming, held: Vec::new(), next_id: 0 };
        let root = uri(dir);
        let init = c.request("initialize", json!({ "processId": null, "rootUri": root, "capabilities": {} }));
        let caps = &init["result"]["capabilities"];
        assert_eq!(caps["hoverProvider"], true, "{init}");
        assert_eq!(caps["definitionProvider"], true);
        assert_eq!(caps["renameProvider"], true);
        assert_eq!(caps["documentFormattingProvider"], true);
        c.notify("initialized", json!({}));
        c
    }

    fn send(&mut self, msg: Value) {
        let body = msg.to_string();
        write!(self.stdin, "Content-Length: {}\r\n\r\n{body}", body.len()).unwrap();
        self.stdin.flush().unwrap();
    }

    fn notify(&mut self, method: &str, params: Value) {
        self.send(json!({ "jsonrpc": "2.0", "method": method, "params": params }));
    }

    fn next(&mut self) -> Value {
        match self.incoming.recv_timeout(WAIT) {
            Ok(v) => v,
            Err(RecvTimeoutError::Timeout) => panic!("no message from the server within {WAIT:?}"),
            Err(RecvTimeoutError::Disconnected) => {
                let mut err = String::new();
                self.child.stderr.take().map(|mut e| e.read_to_string(&mut err));
                panic!("the server closed its output; stderr:\n{err}")
            }
        }
    }

    /// Sends a request and returns its whole response (`result` or `error`).
    fn request(&mut self, method: &str, params: Value) -> Value {
        self.next_id += 1;
        let id = self.next_id;
        self.send(json!({ "jsonrpc": "2.0", "id": id, "method": method, "params": params }));
        loop {
            let m = self.next();
            if m["id"] == id && m.get("method").is_none() {
                return m;
            }
            self.held.push(m);
        }
    }

    /// The next diagnostics published for `uri`.
    fn diagnostics(&mut self, uri: &str) -> Vec<Value> {
        let is = |m: &Value| m["method"] == "textDocument/publishDiagnostics" && m["params"]["uri"] == uri;
        if let Some(i) = self.held.iter().position(is) {
            return self.held.remove(i)["params"]["diagnostics"].as_array().unwrap().clone();
        }
        loop {
            let m = self.next();
            if is(&m) {
                return m["params"]["diagnostics"].as_array().unwrap().clone();
            }
            self.held.push(m);
        }
    }

    fn open(&mut self, uri: &str, text: &str) {
        let doc = json!({ "uri": uri, "languageId": "tessera", "version": 1, "text": text });
        self.notify("textDocument/didOpen", json!({ "textDocument": doc }));
    }

    fn change(&mut self, uri: &str, version: i64, text: &str) {
        let params =
            json!({ "textDocument": { "uri": uri, "version": version }, "contentChanges": [{ "text": text }] });
        self.notify("textDocument/didChange", params);
    }

    fn at(&mut self, method: &str, uri: &str, line: u32, character: u32) -> Value {
        let params = json!({ "textDocument": { "uri": uri }, "position": { "line": line, "character": character } });
        self.request(method, params)
    }

    /// `shutdown`, `exit`, and the process ends by itself with status 0.
    fn finish(mut self) {
        let r = self.request("shutdown", Value::Null);
        assert!(r.get("error").is_none(), "{r}");
        self.notify("exit", Value::Null);
        let start = Instant::now();
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                assert!(status.success(), "exit status {status}");
                return;
            }
            assert!(start.elapsed() < WAIT, "the server did not exit");
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

impl Drop for Client {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The line and UTF-16 column of the first `needle` in `text`.
fn pos(text: &str, needle: &str) -> (u32, u32) {
    let at = text.find(needle).unwrap_or_else(|| panic!("`{needle}` in the text"));
    let line = text[..at].matches('\n').count();
    let start = text[..at].rfind('\n').map_or(0, |i| i + 1);
    (line as u32, text[start..at].encode_utf16().count() as u32)
}

fn range(r: &Value) -> ((u64, u64), (u64, u64)) {
    let p = |v: &Value| (v["line"].as_u64().unwrap(), v["character"].as_u64().unwrap());
    (p(&r["start"]), p(&r["end"]))
}

fn labels(items: &Value) -> Vec<String> {
    let list = items.as_array().or_else(|| items["items"].as_array()).expect("completion items");
    list.iter().map(|i| i["label"].as_str().unwrap().to_string()).collect()
}

const LIB: &str = "# Shared by scene.tess.\nmap falloff {\n  from = radial(radius = 16 px)\n  invert = true\n}\n";

const SCENE: &str = "import \"_lib.tess\"

scene {
  size = 64 x 64
}

# A mask of 45° × 2 shapes.
map shape { from = ellipse(center = [32, 32], radii = [20, 10], angle = 30 deg)
  blurr = 2 px
}

map mask {
  from = combine(a = falloff, b = shape, op = max)
}
";

#[test]
fn an_editor_session() {
    let p = common::Project::new(&[("_lib.tess", LIB), ("scene.tess", SCENE)]);
    let scene = uri(&p.path("scene.tess"));
    let lib = uri(&p.path("_lib.tess"));
    let mut c = Client::start(p.dir.path());

    // A misspelt property: its diagnostic sits on the name, with the suggestion.
    c.open(&scene, SCENE);
    let d = c.diagnostics(&scene);
    assert_eq!(d.len(), 1, "{d:#?}");
    let (line, col) = pos(SCENE, "blurr");
    assert_eq!(range(&d[0]["range"]), ((line as u64, col as u64), (line as u64, col as u64 + 5)), "{:#}", d[0]);
    let message = d[0]["message"].as_str().unwrap();
    assert!(message.contains("blurr") && message.contains("did you mean `blur`?"), "{message}");
    assert_eq!(d[0]["source"], "tessera");

    // On a line holding `°` and `×` (two bytes each, one UTF-16 unit each), the range is in
    // UTF-16 units: a wrong unit after them.
    let broken = SCENE.replace("angle = 30 deg)", "angle = 30 px)");
    c.change(&scene, 2, &broken);
    let d = c.diagnostics(&scene);
    assert_eq!(d.len(), 2, "{d:#?}");
    let (line, col) = pos(&broken, "30 px");
    let r = range(&d.iter().find(|d| d["message"].as_str().unwrap().contains("px")).expect("the unit's")["range"]);
    assert_eq!(r.0, (line as u64, col as u64), "{d:#?}");

    // Fixed: no diagnostics.
    let fixed = SCENE.replace("blurr", "blur");
    c.change(&scene, 3, &fixed);
    assert_eq!(c.diagnostics(&scene), Vec::<Value>::new());

    // Completion at a property position: the kind's properties not yet set.
    let typing = fixed.replace("  blur = 2 px\n", "  blur = 2 px\n  in\n");
    c.change(&scene, 4, &typing);
    c.diagnostics(&scene);
    let (line, col) = pos(&typing, "  in\n");
    let names = labels(&c.at("textDocument/completion", &scene, line, col + 4)["result"]);
    assert!(names.contains(&"invert".to_string()) && names.contains(&"threshold".to_string()), "{names:?}");
    assert!(!names.contains(&"blur".to_string()) && !names.contains(&"from".to_string()), "set already: {names:?}");
    // An enum value of a constructor's argument, and the maps a reference may name.
    let (line, col) = pos(&typing, "max)");
    let names = labels(&c.at("textDocument/completion", &scene, line, col)["result"]);
    assert!(names.contains(&"multiply".to_string()) && names.contains(&"max".to_string()), "{names:?}");
    let (line, col) = pos(&typing, "shape, op");
    let names = labels(&c.at("textDocument/completion", &scene, line, col)["result"]);
    for n in ["falloff", "shape", "mask"] {
        assert!(names.contains(&n.to_string()), "{n} in {names:?}");
    }
    // A kind at the start of a line; a file in a string.
    let (line, _) = pos(&typing, "map mask");
    let names = labels(&c.at("textDocument/completion", &scene, line, 0)["result"]);
    assert!(names.len() > 10 && names.contains(&"import".to_string()), "{names:?}");
    let names = labels(&c.at("textDocument/completion", &scene, 0, 8)["result"]);
    assert!(names.contains(&"_lib.tess".to_string()), "{names:?}");
    c.change(&scene, 5, &fixed);
    c.diagnostics(&scene);

    // Hover on a kind: its reference, from the schema.
    let (line, col) = pos(&fixed, "map mask");
    let kind = &fixed[fixed.find("map mask").unwrap()..][..3];
    let spec = tessera::kinds::registry().into_iter().find(|k| k.name == kind).unwrap();
    let h = c.at("textDocument/hover", &scene, line, col + 1);
    let text = h["result"]["contents"]["value"].as_str().unwrap_or_else(|| panic!("{h}"));
    assert!(text.contains(spec.doc), "{text}");
    // On a property: its type, default and doc.
    let (line, col) = pos(&fixed, "blur =");
    let h = c.at("textDocument/hover", &scene, line, col + 2);
    let text = h["result"]["contents"]["value"].as_str().unwrap_or_else(|| panic!("{h}"));
    let blur = spec.prop("blur").unwrap();
    assert!(text.contains(blur.doc) && text.contains("`blur`"), "{text}");

    // Definition: `falloff` is declared in the imported file.
    let (line, col) = pos(&fixed, "falloff,");
    let d = c.at("textDocument/definition", &scene, line, col + 2);
    assert_eq!(d["result"]["uri"], lib.as_str(), "{d}");
    let (l, k) = pos(LIB, "falloff");
    assert_eq!(range(&d["result"]["range"]), ((l as u64, k as u64), (l as u64, k as u64 + 7)));

    // Rename `shape`: its declaration and its reference.
    let (line, col) = pos(&fixed, "shape {");
    let params =
        json!({ "textDocument": { "uri": scene }, "position": { "line": line, "character": col }, "newName": "oval" });
    let r = c.request("textDocument/rename", params);
    let edits = r["result"]["changes"][&scene].as_array().unwrap_or_else(|| panic!("{r}"));
    assert_eq!(edits.len(), 2, "{r}");
    assert!(edits.iter().all(|e| e["newText"] == "oval"));
    let mut starts: Vec<_> = edits.iter().map(|e| range(&e["range"]).0).collect();
    starts.sort();
    let (a, b) = (pos(&fixed, "shape {"), pos(&fixed, "shape, op"));
    assert_eq!(starts, vec![(a.0 as u64, a.1 as u64), (b.0 as u64, b.1 as u64)]);
    // Renaming a declaration of the imported file edits both files.
    let (line, col) = pos(&fixed, "falloff,");
    let params =
        json!({ "textDocument": { "uri": scene }, "position": { "line": line, "character": col }, "newName": "fade" });
    let r = c.request("textDocument/rename", params);
    let changes = r["result"]["changes"].as_object().unwrap_or_else(|| panic!("{r}"));
    assert_eq!(changes.len(), 2, "{r}");
    let (l, k) = pos(LIB, "falloff");
    assert_eq!(range(&changes[&lib][0]["range"]).0, (l as u64, k as u64));
    assert_eq!(range(&changes[&scene][0]["range"]).0, (line as u64, col as u64));
    // Renaming to a taken name or a non-name is refused.
    let (line, col) = pos(&fixed, "shape {");
    for bad in ["mask", "2x", "a b"] {
        let params =
            json!({ "textDocument": { "uri": scene }, "position": { "line": line, "character": col }, "newName": bad });
        assert!(c.request("textDocument/rename", params).get("error").is_some(), "{bad}");
    }

    // Formatting: one edit, to exactly what `tessera fmt` writes.
    let r = c.request(
        "textDocument/formatting",
        json!({ "textDocument": { "uri": scene }, "options": { "tabSize": 2, "insertSpaces": true } }),
    );
    let edits = r["result"].as_array().unwrap_or_else(|| panic!("{r}"));
    assert_eq!(edits.len(), 1);
    p.write("scene.tess", &fixed);
    p.tessera(&["fmt", "scene.tess"]).ok();
    let formatted = p.read_text("scene.tess");
    assert_ne!(formatted, fixed, "the scene was not formatted to begin with");
    assert_eq!(edits[0]["newText"], formatted.as_str());
    let end = fixed.lines().count() as u64;
    assert_eq!(range(&edits[0]["range"]), ((0, 0), (end, 0)));

    // The imported file opened and edited: the scene that reads it is checked again against
    // the editor's text of it, not the file on disk.
    c.open(&lib, LIB);
    assert_eq!(c.diagnostics(&lib), Vec::<Value>::new());
    assert_eq!(c.diagnostics(&scene), Vec::<Value>::new(), "the scene reads it: checked again");
    c.change(&lib, 2, &LIB.replace("falloff", "fade"));
    assert_eq!(c.diagnostics(&lib), Vec::<Value>::new());
    let d = c.diagnostics(&scene);
    assert_eq!(d.len(), 1, "{d:#?}");
    let (line, col) = pos(&fixed, "falloff,");
    assert_eq!(range(&d[0]["range"]).0, (line as u64, col as u64), "{d:#?}");
    c.notify("textDocument/didClose", json!({ "textDocument": { "uri": lib } }));
    assert_eq!(c.diagnostics(&lib), Vec::<Value>::new());
    assert_eq!(c.diagnostics(&scene), Vec::<Value>::new(), "the file on disk again");
    c.finish();
}

#[test]
fn hostile_input_gets_errors_or_nothing_and_the_server_lives_on() {
    let p = common::Project::new(&[("scene.tess", SCENE)]);
    let scene = uri(&p.path("scene.tess"));
    let mut c = Client::start(p.dir.path());

    // Garbage text: a syntax diagnostic, and every request answered.
    let garbage = "}}{{ map \"\u{0}\n× ((([ = = sample {\n";
    c.open(&scene, garbage);
    let d = c.diagnostics(&scene);
    assert!(!d.is_empty());
    for (line, col) in [(0, 0), (1, 3), (2, 99), (999, 999)] {
        for method in ["textDocument/hover", "textDocument/completion", "textDocument/definition"] {
            let r = c.at(method, &scene, line, col);
            assert!(r.get("result").is_some() || r.get("error").is_some(), "{method}: {r}");
        }
    }
    let r = c.request(
        "textDocument/formatting",
        json!({ "textDocument": { "uri": scene }, "options": { "tabSize": 2, "insertSpaces": true } }),
    );
    assert!(r["result"].is_null() || r["result"] == json!([]), "no edits for what does not parse: {r}");
    // A ranged change past the end, and half-typed declarations at every prefix.
    let params = json!({ "textDocument": { "uri": scene, "version": 9 }, "contentChanges": [
        { "range": { "start": { "line": 50, "character": 3 }, "end": { "line": 2, "character": 0 } }, "text": "x" } ] });
    c.notify("textDocument/didChange", params);
    c.diagnostics(&scene);
    for cut in (0..SCENE.len()).step_by(17).filter(|&i| SCENE.is_char_boundary(i)) {
        c.change(&scene, 10, &SCENE[..cut]);
        c.diagnostics(&scene);
        let (line, col) = pos(SCENE, "blurr");
        c.at("textDocument/completion", &scene, line, col);
    }

    // Documents the server does not hold, URIs that are no files, malformed requests.
    let unknown = uri(&p.path("nowhere.tess"));
    assert!(c.at("textDocument/hover", &unknown, 0, 0)["result"].is_null());
    assert_eq!(c.at("textDocument/completion", &unknown, 0, 0)["result"], json!([]));
    let params =
        json!({ "textDocument": { "uri": unknown }, "position": { "line": 0, "character": 0 }, "newName": "x" });
    assert!(c.request("textDocument/rename", params).get("error").is_some());
    c.change(&unknown, 2, "map x {}");
    let r = c.request("textDocument/hover", json!({ "nonsense": true }));
    assert_eq!(r["error"]["code"], -32602, "invalid params: {r}");
    let r = c.request(
        "textDocument/hover",
        json!({ "textDocument": { "uri": "::not a uri" }, "position": { "line": 0, "character": 0 } }),
    );
    assert!(r.get("error").is_some(), "{r}");
    let r = c.request("workspace/nothing", json!({}));
    assert_eq!(r["error"]["code"], -32601, "method not found: {r}");
    c.notify("textDocument/didOpen", json!({ "bogus": 1 }));
    c.open("untitled:Untitled-1", "map m {\n  blurr = 1\n}\n");
    let d = c.diagnostics("untitled:Untitled-1");
    assert!(!d.is_empty(), "an unsaved buffer is checked too");
    c.notify("textDocument/didClose", json!({ "textDocument": { "uri": "untitled:Untitled-1" } }));
    assert_eq!(c.diagnostics("untitled:Untitled-1"), Vec::<Value>::new());

    // Still answering.
    c.change(&scene, 11, SCENE);
    assert_eq!(c.diagnostics(&scene).len(), 1);
    c.finish();
    let mut left: Vec<_> = std::fs::read_dir(p.dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    left.sort();
    assert_eq!(left, ["scene.tess", "tessera.toml"], "the server writes no file");
}

/// From a keystroke (`didChange`) to its diagnostics, on each bundled scene (each checked
/// as `tessera check` checks it before running stages). Issue 18 asks for under 50 ms.
#[test]
fn diagnostics_after_a_keystroke_are_fast_on_the_bundled_scenes() {
    let p = common::Project::copy_of_repo();
    let mut c = Client::start(p.dir.path());
    let mut scenes: Vec<_> = std::fs::read_dir(p.path("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "tess"))
        .collect();
    scenes.sort();
    let mut all = Vec::new();
    for path in &scenes {
        let u = uri(path);
        let text = std::fs::read_to_string(path).unwrap();
        c.open(&u, &text);
        let d = c.diagnostics(&u);
        assert_eq!(d, Vec::<Value>::new(), "{} checks clean", path.display());
        let mut times = Vec::new();
        for i in 0..7 {
            // A keystroke: one more character in a trailing comment.
            let edited = format!("{text}\n# {}\n", "x".repeat(i + 1));
            let start = Instant::now();
            c.change(&u, i as i64 + 2, &edited);
            let d = c.diagnostics(&u);
            times.push(start.elapsed().as_secs_f64() * 1000.0);
            assert_eq!(d, Vec::<Value>::new());
        }
        c.notify("textDocument/didClose", json!({ "textDocument": { "uri": u } }));
        c.diagnostics(&u);
        times.sort_by(f64::total_cmp);
        eprintln!(
            "lsp diagnostics {:<24} median {:6.2} ms  max {:6.2} ms",
            path.file_name().unwrap().to_string_lossy(),
            times[times.len() / 2],
            times[times.len() - 1]
        );
        all.extend(times);
    }
    all.sort_by(f64::total_cmp);
    let (median, max) = (all[all.len() / 2], all[all.len() - 1]);
    eprintln!("lsp diagnostics, all {} scenes: median {median:.2} ms, max {max:.2} ms", scenes.len());
    assert!(scenes.len() > 20);
    // The target; measured at about 1 ms, so a loaded machine has room to spare.
    assert!(median < 50.0, "median {median:.1} ms");
    c.finish();
}
