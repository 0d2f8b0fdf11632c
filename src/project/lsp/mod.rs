//! `tessera lsp`: a language server over stdio. Diagnostics as you type (the compiler's own,
//! parse to plan, on the text in the editor), hover from the kinds' schemas, completion,
//! definition across imports, rename, and formatting by `tessera fmt`'s formatter.
//!
//! Invariants: the server never writes a file (rename and formatting answer with edits the
//! editor applies), and no message a client sends ends it but `exit`: a request it cannot
//! read is answered with an error, one about a document it does not hold with an empty
//! answer, and a panic inside a handler with an internal error.
//!
//! `position` converts byte offsets to the protocol's UTF-16 positions, `context` reads
//! what a position is from the text alone, `scene` checks a document and loads what it
//! imports, `features` answers the requests.

mod context;
mod features;
mod position;
mod scene;

use std::collections::{BTreeSet, HashMap};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::Arc;

use lsp_server::{Connection, ErrorCode, Message, Notification, Request, Response};
use lsp_types::notification::Notification as _;
use lsp_types::request::Request as _;
use lsp_types::{
    notification, request, CompletionOptions, HoverProviderCapability, OneOf, ServerCapabilities,
    TextDocumentSyncCapability, TextDocumentSyncKind, Uri,
};
use serde::de::DeserializeOwned;
use serde_json::Value as Json;

use position::LineIndex;
use scene::{path_of, Open, Unit};

/// An open document.
struct Doc {
    path: PathBuf,
    /// What checking it last read (itself, its imports, listed directories).
    read: BTreeSet<PathBuf>,
}

/// The open documents: their text by path (what the compiler reads), and by URI.
#[derive(Default)]
struct State {
    open: Open,
    docs: HashMap<Uri, Doc>,
}

/// A request's failure: its error code and message.
type Failure = (ErrorCode, String);

/// Serves the protocol on stdin and stdout until the client says `exit` or closes stdin.
pub fn serve() -> Result<(), String> {
    let (connection, io) = Connection::stdio();
    let result = run(&connection);
    drop(connection);
    io.join().map_err(|e| e.to_string())?;
    result
}

fn capabilities() -> ServerCapabilities {
    ServerCapabilities {
        text_document_sync: Some(TextDocumentSyncCapability::Kind(TextDocumentSyncKind::FULL)),
        hover_provider: Some(HoverProviderCapability::Simple(true)),
        completion_provider: Some(CompletionOptions {
            trigger_characters: Some(vec!["=".into(), "\"".into(), "/".into(), " ".into()]),
            ..Default::default()
        }),
        definition_provider: Some(OneOf::Left(true)),
        rename_provider: Some(OneOf::Left(true)),
        document_formatting_provider: Some(OneOf::Left(true)),
        ..Default::default()
    }
}

/// Runs the server on a connection: the initialize handshake, then one message at a time.
pub fn run(connection: &Connection) -> Result<(), String> {
    let caps = serde_json::to_value(capabilities()).map_err(|e| e.to_string())?;
    connection.initialize(caps).map_err(|e| e.to_string())?;
    let mut state = State::default();
    for msg in &connection.receiver {
        match msg {
            Message::Request(req) => {
                if connection.handle_shutdown(&req).map_err(|e| e.to_string())? {
                    return Ok(());
                }
                let id = req.id.clone();
                let response = match catch_unwind(AssertUnwindSafe(|| answer(&state, req))) {
                    Ok(Ok(result)) => Response::new_ok(id, result),
                    Ok(Err((code, message))) => Response::new_err(id, code as i32, message),
                    Err(_) => Response::new_err(id, ErrorCode::InternalError as i32, "internal error".into()),
                };
                send(connection, response.into())?;
            }
            Message::Notification(n) => {
                if n.method == notification::Exit::METHOD {
                    return Ok(());
                }
                let out = catch_unwind(AssertUnwindSafe(|| notice(&mut state, n))).unwrap_or_default();
                for m in out {
                    send(connection, m)?;
                }
            }
            Message::Response(_) => {}
        }
    }
    Ok(())
}

fn send(connection: &Connection, m: Message) -> Result<(), String> {
    connection.sender.send(m).map_err(|e| e.to_string())
}

fn params<P: DeserializeOwned>(value: Json) -> Result<P, Failure> {
    serde_json::from_value(value).map_err(|e| (ErrorCode::InvalidParams, format!("invalid parameters: {e}")))
}

fn json<T: serde::Serialize>(value: T) -> Result<Json, Failure> {
    serde_json::to_value(value).map_err(|e| (ErrorCode::InternalError, e.to_string()))
}

/// The text of an open document, with its path.
fn text_of<'a>(state: &'a State, uri: &Uri) -> Option<(&'a Arc<str>, &'a PathBuf)> {
    let doc = state.docs.get(uri)?;
    Some((state.open.get(&doc.path)?, &doc.path))
}

/// Answers one request. A document that is not open gets `null` (or no items).
fn answer(state: &State, req: Request) -> Result<Json, Failure> {
    match req.method.as_str() {
        request::HoverRequest::METHOD => {
            let p: lsp_types::HoverParams = params(req.params)?;
            let at = &p.text_document_position_params;
            let Some((text, path)) = text_of(state, &at.text_document.uri) else { return Ok(Json::Null) };
            let offset = LineIndex::new(text).offset(at.position);
            json(features::hover(text, offset, &Unit::load(path, &state.open)))
        }
        request::Completion::METHOD => {
            let p: lsp_types::CompletionParams = params(req.params)?;
            let at = &p.text_document_position;
            let Some((text, path)) = text_of(state, &at.text_document.uri) else { return json(Vec::<Json>::new()) };
            let offset = LineIndex::new(text).offset(at.position);
            let real = path_of(&at.text_document.uri).map(|_| path.as_path());
            json(features::complete(text, offset, real, &Unit::load(path, &state.open)))
        }
        request::GotoDefinition::METHOD => {
            let p: lsp_types::GotoDefinitionParams = params(req.params)?;
            let at = &p.text_document_position_params;
            let Some((text, path)) = text_of(state, &at.text_document.uri) else { return Ok(Json::Null) };
            let offset = LineIndex::new(text).offset(at.position);
            let unit = Unit::load(path, &state.open);
            json(features::definition(text, offset, &unit, &at.text_document.uri))
        }
        request::Rename::METHOD => {
            let p: lsp_types::RenameParams = params(req.params)?;
            let at = &p.text_document_position;
            let uri = &at.text_document.uri;
            let (text, path) =
                text_of(state, uri).ok_or((ErrorCode::InvalidParams, "not an open document".to_string()))?;
            let offset = LineIndex::new(text).offset(at.position);
            let unit = Unit::load(path, &state.open);
            let edit =
                features::rename(text, offset, &p.new_name, &unit, uri).map_err(|e| (ErrorCode::RequestFailed, e))?;
            json(edit)
        }
        request::Formatting::METHOD => {
            let p: lsp_types::DocumentFormattingParams = params(req.params)?;
            let Some((text, _)) = text_of(state, &p.text_document.uri) else { return Ok(Json::Null) };
            json(features::format(text))
        }
        method => Err((ErrorCode::MethodNotFound, format!("unsupported request `{method}`"))),
    }
}

/// Where a document's text lives for the compiler: its file, or for a URI that names none
/// (an unsaved buffer) a path in the working directory that no file need have.
fn path_for(uri: &Uri) -> PathBuf {
    path_of(uri).unwrap_or_else(|| {
        let cwd = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("/"));
        let name: String =
            uri.as_str().chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).take(64).collect();
        cwd.join(format!(".untitled-{name}.tess"))
    })
}

/// Handles a notification; returns the diagnostics to publish.
fn notice(state: &mut State, n: Notification) -> Vec<Message> {
    let changed = match n.method.as_str() {
        notification::DidOpenTextDocument::METHOD => {
            let Ok(p) = serde_json::from_value::<lsp_types::DidOpenTextDocumentParams>(n.params) else {
                return Vec::new();
            };
            let path = path_for(&p.text_document.uri);
            state.open.insert(path.clone(), p.text_document.text.into());
            state.docs.insert(p.text_document.uri.clone(), Doc { path, read: BTreeSet::new() });
            p.text_document.uri
        }
        notification::DidChangeTextDocument::METHOD => {
            let Ok(p) = serde_json::from_value::<lsp_types::DidChangeTextDocumentParams>(n.params) else {
                return Vec::new();
            };
            let uri = p.text_document.uri;
            let Some(doc) = state.docs.get(&uri) else { return Vec::new() };
            let mut text = state.open.get(&doc.path).map(|t| t.to_string()).unwrap_or_default();
            for change in p.content_changes {
                match change.range {
                    // Full sync is what the server asks for; a ranged change is applied anyway.
                    Some(r) => {
                        let ix = LineIndex::new(&text);
                        let (a, b) = (ix.offset(r.start), ix.offset(r.end));
                        let (a, b) = (a.min(b), a.max(b));
                        text.replace_range(a..b, &change.text);
                    }
                    None => text = change.text,
                }
            }
            state.open.insert(doc.path.clone(), text.into());
            uri
        }
        notification::DidCloseTextDocument::METHOD => {
            let Ok(p) = serde_json::from_value::<lsp_types::DidCloseTextDocumentParams>(n.params) else {
                return Vec::new();
            };
            let Some(doc) = state.docs.remove(&p.text_document.uri) else { return Vec::new() };
            if !state.docs.values().any(|d| d.path == doc.path) {
                state.open.remove(&doc.path);
            }
            // Documents that read the closed one read the file on disk from now on.
            let mut out = vec![publish(&p.text_document.uri, Vec::new())];
            out.extend(recheck(state, |d| d.read.contains(&doc.path)));
            return out;
        }
        _ => return Vec::new(),
    };
    let Some(path) = state.docs.get(&changed).map(|d| d.path.clone()) else { return Vec::new() };
    // The changed document first (its diagnostics are what the typist waits for), then the
    // open documents that read it.
    let mut out = Vec::new();
    out.extend(recheck(state, |d| d.path == path));
    out.extend(recheck(state, |d| d.path != path && d.read.contains(&path)));
    out
}

/// Checks the open documents `which` selects and returns their diagnostics.
fn recheck(state: &mut State, which: impl Fn(&Doc) -> bool) -> Vec<Message> {
    let uris: Vec<Uri> = state.docs.iter().filter(|(_, d)| which(d)).map(|(u, _)| u.clone()).collect();
    let mut out = Vec::new();
    for uri in uris {
        let Some(doc) = state.docs.get(&uri) else { continue };
        let checked = scene::check(&doc.path, &state.open);
        if let Some(doc) = state.docs.get_mut(&uri) {
            doc.read = checked.read;
        }
        out.push(publish(&uri, checked.diagnostics));
    }
    out
}

fn publish(uri: &Uri, diagnostics: Vec<lsp_types::Diagnostic>) -> Message {
    let params = lsp_types::PublishDiagnosticsParams { uri: uri.clone(), diagnostics, version: None };
    Notification::new(notification::PublishDiagnostics::METHOD.to_string(), params).into()
}
