//! A shared cache under the local one, over Bazel's HTTP remote-cache protocol: `GET`/`PUT`
//! of `/ac/<sha256>` (action results) and `/cas/<sha256>` (blobs), as bazel-remote and
//! nginx with WebDAV serve it (docs/remote-cache.md).
//!
//! A stage key maps to an action-cache entry: a Bazel `ActionResult` naming the stage's
//! payload (and its warnings, when it gave some) as output files by SHA-256 digest. The
//! payload itself is a CAS blob, so one blob serves every key that produced the same bytes.
//!
//! The remote can cost speed, never correctness: every blob is checked against its digest
//! and size before use; a server that is down, slow, refuses or answers garbage turns the
//! remote off for the rest of the process with one warning, and the build goes on locally.
//! Uploads run on their own threads beside the build; [`Remote::settle`] waits for them at
//! most one timeout.

use std::collections::HashMap;
use std::fmt;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Sender};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use prost::Message;
use sha2::{Digest as _, Sha256};

use super::cache::{Cache, Lookup};
use super::key::Key;

/// How to reach a remote cache.
#[derive(Clone)]
pub struct RemoteConfig {
    /// `http://host:port/prefix` or `https://…`, without a trailing `/`.
    pub url: String,
    /// Read from the remote but never write to it (developer machines).
    pub read_only: bool,
    /// The longest any one request, or the wait for uploads at the end of a build, may take.
    pub timeout: Duration,
    /// Blobs larger than this are neither uploaded nor downloaded.
    pub max_blob: u64,
    /// How long a remote that faulted rests before a build asks it again ([`Remote::wake`]).
    pub retry: Duration,
    pub auth: Option<Auth>,
}

/// Credentials, from the environment only; never printed.
#[derive(Clone)]
pub enum Auth {
    Bearer(String),
    /// `user:password`, sent as HTTP basic authentication.
    Basic(String),
}

impl fmt::Debug for Auth {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Auth::Bearer(_) => "Bearer(…)",
            Auth::Basic(_) => "Basic(…)",
        })
    }
}

impl Auth {
    fn header(&self) -> String {
        match self {
            Auth::Bearer(t) => format!("Bearer {t}"),
            Auth::Basic(up) => format!("Basic {}", base64(up.as_bytes())),
        }
    }
}

/// Where a stage's bytes are in the CAS, read from its action-cache entry.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Entry {
    pub payload: BlobRef,
    pub warnings: Option<BlobRef>,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BlobRef {
    /// Lower-case hex SHA-256.
    pub hash: String,
    pub size: u64,
}

impl BlobRef {
    fn of(bytes: &[u8]) -> BlobRef {
        BlobRef { hash: sha256_hex(bytes), size: bytes.len() as u64 }
    }
}

/// What the remote saw: lookups, bytes and faults (hits are the report's `remote` stages).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Traffic {
    pub lookups: u64,
    pub bytes_down: u64,
    pub bytes_up: u64,
    pub faults: u64,
}

/// What [`Remote::push`] did with each key.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Pushed {
    /// Entries sent, and their bytes on the wire (blobs and action-cache entries).
    pub uploaded: u64,
    pub bytes: u64,
    /// Entries the remote had already.
    pub present: u64,
    /// Keys with no entry in the local cache (stages not built, or collected).
    pub not_local: u64,
    /// Entries larger than `max_blob`.
    pub too_large: u64,
}

pub struct Remote {
    cfg: RemoteConfig,
    agent: ureq::Agent,
    /// Set at a fault; from then on the remote is not asked again until [`Remote::wake`].
    off: AtomicBool,
    /// When the remote was turned off.
    off_since: Mutex<Option<Instant>>,
    /// What went wrong in the fault that turned the remote off, until it is taken.
    fault: Mutex<Option<String>>,
    lookups: AtomicU64,
    bytes_down: AtomicU64,
    bytes_up: AtomicU64,
    faults: AtomicU64,
    uploads: Uploads,
}

/// The upload queue: jobs go to a few threads; `pending` counts those not yet done, and
/// `sent` the bytes each key's upload put on the wire.
struct Uploads {
    queue: Mutex<Option<Sender<Upload>>>,
    pending: Arc<(Mutex<usize>, Condvar)>,
    sent: Arc<Mutex<HashMap<Key, u64>>>,
}

struct Upload {
    key: Key,
    payload: Vec<u8>,
    warnings: Option<Vec<u8>>,
}

const UPLOAD_THREADS: usize = 4;
const PAYLOAD_PATH: &str = "payload";
const WARNINGS_PATH: &str = "warnings.json";

impl Remote {
    pub fn new(cfg: RemoteConfig) -> Arc<Remote> {
        let agent: ureq::Agent = ureq::Agent::config_builder()
            .timeout_global(Some(cfg.timeout))
            .http_status_as_error(false)
            .user_agent(concat!("tessera/", env!("CARGO_PKG_VERSION")))
            .build()
            .into();
        Arc::new(Remote {
            cfg,
            agent,
            off: AtomicBool::new(false),
            off_since: Mutex::new(None),
            fault: Mutex::new(None),
            lookups: AtomicU64::new(0),
            bytes_down: AtomicU64::new(0),
            bytes_up: AtomicU64::new(0),
            faults: AtomicU64::new(0),
            uploads: Uploads {
                queue: Mutex::new(None),
                pending: Arc::new((Mutex::new(0), Condvar::new())),
                sent: Arc::new(Mutex::new(HashMap::new())),
            },
        })
    }

    pub fn url(&self) -> &str {
        &self.cfg.url
    }

    pub fn read_only(&self) -> bool {
        self.cfg.read_only
    }

    /// Whether the remote is still asked (no fault so far).
    pub fn active(&self) -> bool {
        !self.off.load(Ordering::Relaxed)
    }

    /// The warning of the fault that turned the remote off, once.
    pub fn take_warning(&self) -> Option<String> {
        let what = self.take_fault()?;
        let again = match self.cfg.retry {
            r if r.is_zero() => "in the next build".to_string(),
            r => format!("in a build {} s from now at the earliest", r.as_secs_f64()),
        };
        Some(format!("remote cache {}: {what}; building locally without it, and asking it again {again}", self.cfg.url))
    }

    fn take_fault(&self) -> Option<String> {
        self.fault.lock().ok()?.take()
    }

    /// What the remote saw so far, counted from the start of the process.
    pub fn traffic(&self) -> Traffic {
        Traffic {
            lookups: self.lookups.load(Ordering::Relaxed),
            bytes_down: self.bytes_down.load(Ordering::Relaxed),
            bytes_up: self.bytes_up.load(Ordering::Relaxed),
            faults: self.faults.load(Ordering::Relaxed),
        }
    }

    /// Turns the remote off with one warning (the first fault's).
    fn fault(&self, what: String) {
        self.faults.fetch_add(1, Ordering::Relaxed);
        if !self.off.swap(true, Ordering::Relaxed) {
            if let Ok(mut since) = self.off_since.lock() {
                *since = Some(Instant::now());
            }
            if let Ok(mut f) = self.fault.lock() {
                *f = Some(what);
            }
        }
    }

    /// Called as a build starts: turns a remote that has been off for its `retry` or longer
    /// back on, so one process (`watch`, a `build` of many scenes) uses a server that came
    /// back, while one still down costs a warning per `retry` at most. Whether it did.
    pub fn wake(&self) -> bool {
        let Ok(mut since) = self.off_since.lock() else { return false };
        match *since {
            Some(t) if t.elapsed() >= self.cfg.retry => {
                *since = None;
                self.off.store(false, Ordering::Relaxed);
                true
            }
            _ => false,
        }
    }

    /// The action-cache entry of a stage key: `None` when the remote has none, is off, or
    /// fails (which turns it off).
    pub fn lookup(&self, key: &Key) -> Option<Entry> {
        if !self.active() {
            return None;
        }
        self.lookups.fetch_add(1, Ordering::Relaxed);
        let url = format!("{}/ac/{}", self.cfg.url, ac_hash(key));
        let bytes = match self.get(&url, ENTRY_LIMIT) {
            Ok(Some(b)) => b,
            Ok(None) => return None,
            Err(e) => {
                self.fault(e);
                return None;
            }
        };
        match decode_entry(&bytes) {
            Some(entry) => Some(entry),
            None => {
                self.fault(format!("the action-cache entry for stage {} is not one tessera wrote", key.short()));
                None
            }
        }
    }

    /// A blob named by an entry, verified against its digest and size. `None` (and the
    /// remote off) when it is missing, damaged or cannot be fetched; `None` alone when it is
    /// larger than the blob limit.
    pub fn fetch(&self, blob: &BlobRef) -> Option<Vec<u8>> {
        if !self.active() || blob.size > self.cfg.max_blob {
            return None;
        }
        let url = format!("{}/cas/{}", self.cfg.url, blob.hash);
        let bytes = match self.get(&url, blob.size.saturating_add(1)) {
            Ok(Some(b)) => b,
            Ok(None) => {
                self.fault(format!("blob {} is named by an action result but missing", &blob.hash[..12]));
                return None;
            }
            Err(e) => {
                self.fault(e);
                return None;
            }
        };
        self.bytes_down.fetch_add(bytes.len() as u64, Ordering::Relaxed);
        if bytes.len() as u64 != blob.size || sha256_hex(&bytes) != blob.hash {
            self.fault(format!(
                "blob {} failed verification ({} bytes, expected {}); it was not used",
                &blob.hash[..12],
                bytes.len(),
                blob.size
            ));
            return None;
        }
        Some(bytes)
    }

    /// Queues a stage's payload (and warnings) for upload: blobs first, then the entry that
    /// names them, so no reader ever sees an entry whose blobs are missing.
    pub fn upload(self: &Arc<Self>, key: Key, payload: Vec<u8>, warnings: Option<Vec<u8>>) {
        if self.cfg.read_only || !self.active() || payload.len() as u64 > self.cfg.max_blob {
            return;
        }
        let Ok(mut queue) = self.uploads.queue.lock() else { return };
        let queue = queue.get_or_insert_with(|| self.start_uploads());
        {
            let (count, _) = &*self.uploads.pending;
            *count.lock().expect("upload count") += 1;
        }
        if queue.send(Upload { key, payload, warnings }).is_err() {
            self.done_one();
        }
    }

    fn start_uploads(self: &Arc<Self>) -> Sender<Upload> {
        let (tx, rx) = mpsc::channel::<Upload>();
        let rx = Arc::new(Mutex::new(rx));
        for _ in 0..UPLOAD_THREADS {
            let rx = Arc::clone(&rx);
            // A weak handle: the threads end when the remote is dropped (and the queue with it).
            let me = Arc::downgrade(self);
            std::thread::spawn(move || loop {
                let job = match rx.lock() {
                    Ok(rx) => rx.recv(),
                    Err(_) => return,
                };
                let Ok(job) = job else { return };
                let Some(me) = me.upgrade() else { return };
                me.send_upload(job);
                me.done_one();
            });
        }
        tx
    }

    fn done_one(&self) {
        let (count, cv) = &*self.uploads.pending;
        let mut c = count.lock().expect("upload count");
        *c = c.saturating_sub(1);
        cv.notify_all();
    }

    fn send_upload(&self, job: Upload) {
        if !self.active() {
            return;
        }
        let mut sent = 0u64;
        let payload = BlobRef::of(&job.payload);
        let mut files = vec![(PAYLOAD_PATH, &payload)];
        let warnings = job.warnings.as_ref().map(|w| BlobRef::of(w));
        if let Some(w) = &warnings {
            files.push((WARNINGS_PATH, w));
        }
        let blobs = [Some(&job.payload), job.warnings.as_ref()];
        for (bytes, (_, blob)) in blobs.into_iter().flatten().zip(&files) {
            if let Err(e) = self.put(&format!("{}/cas/{}", self.cfg.url, blob.hash), bytes) {
                return self.fault(e);
            }
            sent += bytes.len() as u64;
        }
        let entry = encode_entry(&files);
        if let Err(e) = self.put(&format!("{}/ac/{}", self.cfg.url, ac_hash(&job.key)), &entry) {
            return self.fault(e);
        }
        sent += entry.len() as u64;
        self.bytes_up.fetch_add(sent, Ordering::Relaxed);
        if let Ok(mut s) = self.uploads.sent.lock() {
            *s.entry(job.key).or_default() += sent;
        }
    }

    /// Waits for the queued uploads, at most one timeout, and gives the bytes sent per key
    /// since the last call. Uploads still running go on in the background.
    pub fn settle(&self) -> HashMap<Key, u64> {
        let deadline = Instant::now() + self.cfg.timeout;
        let (count, cv) = &*self.uploads.pending;
        let mut c = count.lock().expect("upload count");
        while *c > 0 {
            let now = Instant::now();
            if now >= deadline {
                break;
            }
            c = cv.wait_timeout(c, deadline - now).expect("upload count").0;
        }
        if *c > 0 {
            drop(c);
            self.fault("uploads did not finish within the timeout".into());
        } else {
            drop(c);
        }
        self.uploads.sent.lock().map(|mut s| std::mem::take(&mut *s)).unwrap_or_default()
    }

    /// Uploads the local entries of `keys` that the remote has no entry for (with their
    /// warnings), a few at a time so memory holds at most one batch. An error when the
    /// remote is read-only or fails (what was sent before stays there: entries go up after
    /// their blobs, so it is never half an entry).
    pub fn push(self: &Arc<Self>, cache: &Cache, keys: &[Key]) -> Result<Pushed, String> {
        if self.cfg.read_only {
            return Err(format!("remote cache {} is read-only here: nothing to push", self.cfg.url));
        }
        let mut pushed = Pushed::default();
        let settle = |pushed: &mut Pushed| {
            for bytes in self.settle().into_values() {
                pushed.uploaded += 1;
                pushed.bytes += bytes;
            }
        };
        let mut batch = 0;
        for key in keys {
            let Lookup::Hit(payload) = cache.get(key) else {
                pushed.not_local += 1;
                continue;
            };
            if self.lookup(key).is_some() {
                pushed.present += 1;
                continue;
            }
            if payload.len() as u64 > self.cfg.max_blob {
                pushed.too_large += 1;
                continue;
            }
            if !self.active() {
                break;
            }
            let warnings = match cache.get(&key.warnings()) {
                Lookup::Hit(w) => Some(w),
                Lookup::Miss | Lookup::Corrupt => None,
            };
            self.upload(*key, payload, warnings);
            batch += 1;
            if batch == UPLOAD_THREADS {
                settle(&mut pushed);
                batch = 0;
            }
        }
        settle(&mut pushed);
        match self.take_fault() {
            Some(what) => Err(format!(
                "remote cache {}: {what}; push stopped after {} entries, each complete on the server",
                self.cfg.url, pushed.uploaded
            )),
            None => Ok(pushed),
        }
    }

    /// `GET url`: `Ok(None)` on 404, the body (at most `limit` bytes) on 200, a fault
    /// description otherwise.
    fn get(&self, url: &str, limit: u64) -> Result<Option<Vec<u8>>, String> {
        let mut req = self.agent.get(url);
        if let Some(a) = &self.cfg.auth {
            req = req.header("Authorization", a.header());
        }
        let mut resp = req.call().map_err(|e| describe(&e))?;
        match resp.status().as_u16() {
            200 => resp.body_mut().with_config().limit(limit).read_to_vec().map(Some).map_err(|e| describe(&e)),
            404 => Ok(None),
            s => Err(format!("GET answered HTTP {s}")),
        }
    }

    fn put(&self, url: &str, body: &[u8]) -> Result<(), String> {
        let mut req = self.agent.put(url);
        if let Some(a) = &self.cfg.auth {
            req = req.header("Authorization", a.header());
        }
        let resp = req.send(body).map_err(|e| describe(&e))?;
        match resp.status().as_u16() {
            200..=299 => Ok(()),
            s => Err(format!("PUT answered HTTP {s}")),
        }
    }
}

/// A remote cache's address as tessera uses it: `http` or `https`, a host, perhaps a port and
/// a path prefix, no trailing `/`. Credentials, queries and fragments are refused: secrets
/// come from the environment, never from a file under version control.
pub fn parse_url(s: &str) -> Result<String, String> {
    // A URL with credentials is never repeated, not even in the error that refuses it.
    if s.contains('@') {
        return Err(
            "the remote cache URL holds credentials (`user@`); put them in TESSERA_REMOTE_CACHE_TOKEN or TESSERA_REMOTE_CACHE_BASIC instead"
                .into(),
        );
    }
    let uri: ureq::http::Uri =
        s.parse().map_err(|e| format!("`{s}` is not a URL ({e}); expected http://host:port/prefix"))?;
    match uri.scheme_str() {
        Some("http" | "https") => {}
        _ => return Err(format!("`{s}`: a remote cache is reached over http:// or https://")),
    }
    let Some(authority) = uri.authority() else { return Err(format!("`{s}` names no host")) };
    if authority.host().is_empty() {
        return Err(format!("`{s}` names no host"));
    }
    if uri.query().is_some() || s.contains('#') {
        return Err(format!("`{s}`: a remote cache URL has no query or fragment"));
    }
    Ok(s.trim_end_matches('/').to_string())
}

/// Action-cache entries are a few hundred bytes; anything much larger is not one.
const ENTRY_LIMIT: u64 = 64 << 10;

/// A transport error in words, without the URL (which names the server already shown).
fn describe(e: &ureq::Error) -> String {
    match e {
        ureq::Error::Timeout(_) => "no answer within the timeout".into(),
        ureq::Error::Io(io) => format!("connection failed ({})", io.kind()),
        ureq::Error::ConnectionFailed => "connection failed".into(),
        ureq::Error::BodyExceedsLimit(_) => "an answer longer than announced".into(),
        other => format!("{other}"),
    }
}

/// The action-cache key of a stage key: a SHA-256, as the protocol names actions, of the
/// stage key in a namespace of tessera's own (so it can never name another tool's action).
pub fn ac_hash(key: &Key) -> String {
    let mut h = Sha256::new();
    h.update(b"tessera-remote-ac-v1\0");
    h.update(key.0);
    hex(&h.finalize())
}

pub fn sha256_hex(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn base64(bytes: &[u8]) -> String {
    use base64::Engine as _;
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

// The fields of Bazel's `ActionResult` (remote_execution.proto) that an entry uses.
#[derive(Clone, PartialEq, prost::Message)]
struct ActionResult {
    #[prost(message, repeated, tag = "2")]
    output_files: Vec<OutputFile>,
}

#[derive(Clone, PartialEq, prost::Message)]
struct OutputFile {
    #[prost(string, tag = "1")]
    path: String,
    #[prost(message, optional, tag = "2")]
    digest: Option<ProtoDigest>,
}

#[derive(Clone, PartialEq, prost::Message)]
struct ProtoDigest {
    #[prost(string, tag = "1")]
    hash: String,
    #[prost(int64, tag = "2")]
    size_bytes: i64,
}

fn encode_entry(files: &[(&str, &BlobRef)]) -> Vec<u8> {
    ActionResult {
        output_files: files
            .iter()
            .map(|(path, b)| OutputFile {
                path: (*path).into(),
                digest: Some(ProtoDigest { hash: b.hash.clone(), size_bytes: b.size as i64 }),
            })
            .collect(),
    }
    .encode_to_vec()
}

/// An entry as tessera writes it: a payload and perhaps warnings, each with a well-formed
/// digest; anything else is `None`.
fn decode_entry(bytes: &[u8]) -> Option<Entry> {
    let result = ActionResult::decode(bytes).ok()?;
    let mut payload = None;
    let mut warnings = None;
    for f in result.output_files {
        let d = f.digest?;
        let ok = d.hash.len() == 64 && d.hash.bytes().all(|c| matches!(c, b'0'..=b'9' | b'a'..=b'f'));
        if !ok || d.size_bytes < 0 {
            return None;
        }
        let blob = BlobRef { hash: d.hash, size: d.size_bytes as u64 };
        match f.path.as_str() {
            PAYLOAD_PATH => payload = Some(blob),
            WARNINGS_PATH => warnings = Some(blob),
            _ => return None,
        }
    }
    Some(Entry { payload: payload?, warnings })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_round_trip_and_garbage_is_refused() {
        let p = BlobRef::of(b"payload bytes");
        let w = BlobRef::of(b"[\"a warning\"]");
        let bytes = encode_entry(&[(PAYLOAD_PATH, &p), (WARNINGS_PATH, &w)]);
        assert_eq!(decode_entry(&bytes), Some(Entry { payload: p.clone(), warnings: Some(w) }));
        assert_eq!(
            decode_entry(&encode_entry(&[(PAYLOAD_PATH, &p)])),
            Some(Entry { payload: p.clone(), warnings: None })
        );
        assert_eq!(decode_entry(b""), None, "no payload");
        assert_eq!(decode_entry(b"\xff\xff\xff\xff"), None);
        assert_eq!(decode_entry(&bytes[..bytes.len() - 3]), None, "truncated");
        let bad = BlobRef { hash: "../../etc/passwd".into(), size: 3 };
        assert_eq!(decode_entry(&encode_entry(&[(PAYLOAD_PATH, &bad)])), None, "a hash that is not hex");
        assert_eq!(decode_entry(&encode_entry(&[("other", &p)])), None);
    }

    #[test]
    fn urls_are_http_without_secrets() {
        assert_eq!(parse_url("http://127.0.0.1:9090/cache/").unwrap(), "http://127.0.0.1:9090/cache");
        assert_eq!(parse_url("https://cache.example.com").unwrap(), "https://cache.example.com");
        for bad in
            ["ftp://host/x", "http://user:pw@host/x", "host:80", "http://h/x?token=1", "http://h/x#f", "", "http://"]
        {
            let e = parse_url(bad).expect_err(bad);
            assert!(!e.contains("pw"), "{e}");
        }
    }

    #[test]
    fn digests_and_keys_are_sha256_hex() {
        assert_eq!(sha256_hex(b"abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
        let k = Key([7; 32]);
        assert_eq!(ac_hash(&k).len(), 64);
        assert_ne!(ac_hash(&k), ac_hash(&Key([8; 32])));
    }

    #[test]
    fn basic_credentials_are_base64_and_never_printed() {
        assert_eq!(base64(b"user:pass"), "dXNlcjpwYXNz");
        assert_eq!(base64(b"a"), "YQ==");
        assert_eq!(base64(b"ab"), "YWI=");
        let a = Auth::Basic("user:secret".into());
        assert_eq!(a.header(), format!("Basic {}", base64(b"user:secret")));
        assert!(!format!("{a:?}").contains("secret"));
        assert!(!format!("{:?}", Auth::Bearer("tok3n".into())).contains("tok3n"));
    }

    #[test]
    fn a_server_that_is_not_there_turns_the_remote_off_with_one_warning() {
        // A port nothing listens on: bind one, then let it go.
        let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let r = Remote::new(RemoteConfig {
            url: format!("http://127.0.0.1:{port}/cache"),
            read_only: false,
            timeout: Duration::from_secs(2),
            max_blob: 1 << 20,
            retry: Duration::from_secs(60),
            auth: Some(Auth::Bearer("s3cret".into())),
        });
        assert_eq!(r.lookup(&Key([1; 32])), None);
        assert!(!r.active());
        assert_eq!(r.lookup(&Key([2; 32])), None, "not asked again");
        let w = r.take_warning().expect("one warning");
        assert!(w.contains("building locally") && !w.contains("s3cret"), "{w}");
        assert_eq!(r.take_warning(), None, "only once");
        assert_eq!(r.traffic().lookups, 1);
        // A build before the rest is over leaves it off; one after asks again, and a second
        // fault costs a second warning.
        assert!(w.contains("60 s"), "{w}");
        assert!(!r.wake() && !r.active());
        if let Ok(mut since) = r.off_since.lock() {
            // As if the fault were 61 s old.
            *since = since.map(|t| t.checked_sub(Duration::from_secs(61)).expect("up for a minute"));
        }
        assert!(r.wake() && r.active());
        assert!(!r.wake(), "awake already");
        assert_eq!(r.lookup(&Key([3; 32])), None);
        assert!(!r.active());
        assert!(r.take_warning().is_some());
        assert_eq!((r.traffic().lookups, r.traffic().faults), (2, 2));
    }
}
