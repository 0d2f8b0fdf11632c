//! The live preview server of `tessera watch --serve`: the page, its state as JSON, a
//! server-sent event per rebuild, and the files the page shows (only those [`Allowed`]).
//!
//! axum on a tokio runtime of two threads of its own, beside the synchronous watch loop,
//! which hands it each build through [`Preview::publish`]. An event stream sends a comment
//! every few seconds, so a browser that went away fails a write and its stream ends.
//! Requests whose `Host` is not the address served are refused, so a web page elsewhere
//! cannot reach a loopback server through a name it rebinds to 127.0.0.1.

use std::convert::Infallible;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use axum::extract::State;
use axum::http::{header, HeaderMap, HeaderValue, Method, StatusCode, Uri};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use futures_util::stream::{self, Stream};
use tokio::sync::{broadcast, oneshot};

use super::paths::Allowed;
use super::{content_type, converted, link_path, page, picture_bytes, relative, Links, PageState, SceneView, Use};

/// Largest file served (outputs are bounded by the build's memory budget; this bounds what
/// a request can make the server read).
const MAX_FILE: u64 = 1 << 30;
/// How often an idle event stream is written to, to notice a browser that left.
const KEEP_ALIVE: Duration = Duration::from_secs(5);

struct Shared {
    state: Mutex<PageState>,
    allowed: Mutex<Allowed>,
    builds: broadcast::Sender<u64>,
    hosts: Vec<String>,
}

/// A running preview server; stops when dropped.
pub struct Preview {
    shared: Arc<Shared>,
    stop: Option<oneshot::Sender<()>>,
    pub addr: SocketAddr,
}

impl Preview {
    /// Serves on `addr` (`127.0.0.1:0` picks a free port).
    pub fn start(addr: &str) -> Result<Preview, String> {
        let listener = std::net::TcpListener::bind(addr).map_err(|e| format!("cannot serve on {addr}: {e}"))?;
        let bound = listener.local_addr().map_err(|e| format!("cannot serve on {addr}: {e}"))?;
        listener.set_nonblocking(true).map_err(|e| format!("cannot serve on {addr}: {e}"))?;
        let port = bound.port();
        let mut hosts = vec![bound.to_string()];
        if bound.ip().is_loopback() {
            hosts.extend([format!("localhost:{port}"), format!("127.0.0.1:{port}"), format!("[::1]:{port}")]);
        }
        let shared = Arc::new(Shared {
            state: Mutex::new(PageState { live: true, ..PageState::default() }),
            allowed: Mutex::new(Allowed::default()),
            builds: broadcast::channel(16).0,
            hosts,
        });
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("tessera-preview")
            .enable_all()
            .build()
            .map_err(|e| format!("cannot start the preview server: {e}"))?;
        let app = Router::new().route("/events", get(events)).fallback(files).with_state(shared.clone());
        let (stop, stopped) = oneshot::channel::<()>();
        std::thread::Builder::new()
            .name("tessera-preview".into())
            .spawn(move || {
                runtime.block_on(async move {
                    let Ok(listener) = tokio::net::TcpListener::from_std(listener) else { return };
                    let serve = axum::serve(listener, app).with_graceful_shutdown(async {
                        let _ = stopped.await;
                    });
                    let _ = serve.await;
                });
                // Open event streams do not hold the process (or a test) up.
                runtime.shutdown_background();
            })
            .map_err(|e| format!("cannot start the preview server: {e}"))?;
        Ok(Preview { shared, stop: Some(stop), addr: bound })
    }

    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// Links to files below `root` for the build about to be published.
    pub fn links(&self, root: &Path) -> impl Links {
        ServerLinks { root: root.to_path_buf(), generation: self.generation() + 1 }
    }

    fn generation(&self) -> u64 {
        self.shared.state.lock().expect("preview state").generation
    }

    /// The scene as last published, if any.
    pub fn scene(&self) -> Option<SceneView> {
        self.shared.state.lock().expect("preview state").scenes.first().cloned()
    }

    /// Shows `scene` (the build just made or failed) and, when given, lets `allowed` be
    /// served instead of the files before; every open page is told.
    pub fn publish(&self, scene: SceneView, allowed: Option<Allowed>) {
        let generation = {
            let mut state = self.shared.state.lock().expect("preview state");
            state.generation += 1;
            state.scenes = vec![scene];
            if let Some(allowed) = allowed {
                *self.shared.allowed.lock().expect("preview files") = allowed;
            }
            state.generation
        };
        // No page open: nobody to tell.
        let _ = self.shared.builds.send(generation);
    }
}

impl Drop for Preview {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
    }
}

struct ServerLinks {
    root: PathBuf,
    generation: u64,
}

impl Links for ServerLinks {
    fn link(&mut self, path: &Path, how: Use) -> Option<String> {
        let rel = relative(&self.root, path)?;
        let route = if how == Use::Picture && converted(path) { "picture" } else { "files" };
        // The generation makes a rebuilt file a new URL, so no browser shows a stale copy.
        Some(format!("/{route}/{}?g={}", link_path(&rel, ""), self.generation))
    }
}

fn host_ok(shared: &Shared, headers: &HeaderMap) -> bool {
    headers
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .is_some_and(|h| shared.hosts.iter().any(|ok| h.eq_ignore_ascii_case(ok)))
}

fn reply(status: StatusCode, content_type: &'static str, body: Vec<u8>) -> Response {
    let mut r = (status, body).into_response();
    let h = r.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    h.insert(header::X_CONTENT_TYPE_OPTIONS, HeaderValue::from_static("nosniff"));
    r
}

/// Everything but the event stream: the page, its state, and files by their path below the
/// project root (`/files/…` as they are, `/picture/…` drawn as a PNG).
async fn files(State(shared): State<Arc<Shared>>, method: Method, uri: Uri, headers: HeaderMap) -> Response {
    if !host_ok(&shared, &headers) {
        return reply(StatusCode::FORBIDDEN, "text/plain", b"unknown host".to_vec());
    }
    if method != Method::GET && method != Method::HEAD {
        return reply(StatusCode::METHOD_NOT_ALLOWED, "text/plain", b"GET only".to_vec());
    }
    // The path as sent, still percent-encoded: `Allowed::file` decodes it once, itself.
    let path = uri.path();
    match path {
        "/" | "/index.html" => reply(StatusCode::OK, "text/html; charset=utf-8", page(None).into_bytes()),
        "/api/state" => {
            let json = serde_json::to_vec(&*shared.state.lock().expect("preview state")).unwrap_or_default();
            reply(StatusCode::OK, "application/json", json)
        }
        _ => {
            let (route, rel) = path.trim_start_matches('/').split_once('/').unwrap_or(("", ""));
            let file = match route {
                "files" | "picture" => shared.allowed.lock().expect("preview files").file(rel),
                _ => None,
            };
            let Some(file) = file else {
                return reply(StatusCode::NOT_FOUND, "text/plain", b"not found".to_vec());
            };
            let picture = route == "picture";
            // Reading (and drawing an EXR) blocks: off the runtime's threads.
            let answer = tokio::task::spawn_blocking(move || {
                let bytes = match std::fs::metadata(&file) {
                    Ok(m) if m.len() <= MAX_FILE => std::fs::read(&file),
                    Ok(_) => return reply(StatusCode::PAYLOAD_TOO_LARGE, "text/plain", b"too large".to_vec()),
                    Err(e) => Err(e),
                };
                let Ok(bytes) = bytes else {
                    return reply(StatusCode::NOT_FOUND, "text/plain", b"not found".to_vec());
                };
                if picture {
                    match picture_bytes(&file, bytes) {
                        Ok(png) => reply(StatusCode::OK, "image/png", png),
                        Err(e) => reply(StatusCode::UNPROCESSABLE_ENTITY, "text/plain", e.into_bytes()),
                    }
                } else {
                    reply(StatusCode::OK, content_type(&file), bytes)
                }
            })
            .await;
            answer.unwrap_or_else(|_| reply(StatusCode::INTERNAL_SERVER_ERROR, "text/plain", Vec::new()))
        }
    }
}

/// A server-sent event stream: `build` with the generation on every publish.
async fn events(State(shared): State<Arc<Shared>>, headers: HeaderMap) -> Response {
    if !host_ok(&shared, &headers) {
        return reply(StatusCode::FORBIDDEN, "text/plain", b"unknown host".to_vec());
    }
    let builds = shared.builds.subscribe();
    Sse::new(build_events(builds)).keep_alive(KeepAlive::new().interval(KEEP_ALIVE)).into_response()
}

fn build_events(builds: broadcast::Receiver<u64>) -> impl Stream<Item = Result<Event, Infallible>> {
    stream::unfold(builds, |mut rx| async move {
        loop {
            match rx.recv().await {
                Ok(generation) => return Some((Ok(Event::default().event("build").data(generation.to_string())), rx)),
                // A page that fell behind only needs the latest state, which it fetches.
                Err(broadcast::error::RecvError::Lagged(_)) => continue,
                Err(broadcast::error::RecvError::Closed) => return None,
            }
        }
    })
}
