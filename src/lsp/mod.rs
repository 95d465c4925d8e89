//! `tslc lsp`: a language server over stdio (the Language Server Protocol,
//! with rust-analyzer's `lsp-server` types and `lsp-types`; no async
//! runtime).
//!
//! `transport` reads and writes the framed messages (a bad message is
//! answered and the server goes on). The main loop owns the open
//! documents and answers requests on its own thread from an
//! `analysis::Analysis` of the current text (the compiler's front end,
//! cached per document version). Diagnostics are computed by a pool of
//! workers (`scheduler`), as `tslc check` would report them, when a
//! document opens or is saved and 150 ms after the last change, so typing
//! never waits for a scene's meshes to be read and a slow document never
//! holds up the others. Every request and notification runs under
//! `catch_unwind`: a bug answers one request with an error and the server
//! goes on.
//!
//! The modules: `documents` (texts, the workspace's paths and the
//! prelude's files), `line_index` (positions as LSP counts them),
//! `analysis` (checking a document, what is under a position and what it
//! refers to), `context` (where the cursor is, from the tokens before it),
//! `docs` (stdlib doc blocks, docs/language.md), and one module per
//! feature: `diagnostics`, `hover`, `navigation` (definition, references,
//! highlights), `symbols`, `completion`, `signature`, `semantic`
//! (semantic tokens).

mod analysis;
mod completion;
mod context;
mod diagnostics;
mod docs;
mod documents;
mod hover;
mod line_index;
mod navigation;
mod scheduler;
mod semantic;
mod signature;
mod symbols;
mod transport;

use analysis::Analysis;
use crossbeam_channel::{RecvTimeoutError, Sender};
use documents::{Document, Workspace};
use lsp_server::{Connection, ErrorCode, Message, Notification, Request, RequestId, Response};
use lsp_types::notification::Notification as _;
use lsp_types::request::Request as _;
use lsp_types::*;
use scheduler::{Scheduler, Work};
use serde_json::Value;
use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::Arc;
use std::time::{Duration, Instant};

pub use documents::MAX_DOCUMENT_BYTES;
pub use scheduler::DIAGNOSTICS_WORKERS;
pub use transport::{MAX_HEADER_LINE_BYTES, MAX_JSON_VALUES, MAX_MESSAGE_BYTES};

/// How long after the last change diagnostics are computed.
pub const DEBOUNCE: Duration = Duration::from_millis(150);

/// Runs the server over standard input and output until the client
/// sends `exit` or the input ends (an error unless `shutdown` came
/// first). `import_paths` are searched for imports after those of the
/// initialization options (`{"importPaths": [...]}`).
pub fn run_stdio(import_paths: Vec<PathBuf>) -> Result<(), String> {
    let (connection, io_threads) = transport::stdio().map_err(|e| format!("tslc lsp: {e}"))?;
    run(connection, import_paths)?;
    io_threads.join()
}

/// Runs the server on a connection (stdio, or in memory for tests).
pub fn run(connection: Connection, import_paths: Vec<PathBuf>) -> Result<(), String> {
    let Some((id, init)) = initialize(&connection) else {
        return Err("tslc lsp: the client left before `initialize`".into());
    };
    let workspace = Arc::new(workspace_of(&init, import_paths));
    let snippets = init
        .capabilities
        .text_document
        .as_ref()
        .and_then(|t| t.completion.as_ref()?.completion_item.as_ref()?.snippet_support)
        .unwrap_or(false);
    let result = serde_json::json!({
        "capabilities": capabilities(),
        "serverInfo": { "name": "tslc", "version": env!("CARGO_PKG_VERSION") },
    });
    let _ = connection.sender.send(Response::new_ok(id, result).into());
    let mut server = Server::new(connection.sender.clone(), workspace, snippets);
    let mut shut_down = false;
    loop {
        let message = match server.next_deadline() {
            Some(deadline) => {
                match connection.receiver.recv_timeout(deadline.saturating_duration_since(Instant::now())) {
                    Ok(m) => Some(m),
                    Err(RecvTimeoutError::Timeout) => None,
                    Err(RecvTimeoutError::Disconnected) => break,
                }
            }
            None => match connection.receiver.recv() {
                Ok(m) => Some(m),
                Err(_) => break,
            },
        };
        match message {
            Some(Message::Request(req)) if shut_down => {
                let message = format!("tslc lsp: `{}` after `shutdown`", req.method);
                let _ =
                    connection.sender.send(Response::new_err(req.id, ErrorCode::InvalidRequest as i32, message).into());
            }
            Some(Message::Request(req)) if req.method == request::Shutdown::METHOD => {
                shut_down = true;
                let _ = connection.sender.send(Response::new_ok(req.id, ()).into());
            }
            Some(Message::Request(req)) => server.on_request(req),
            Some(Message::Notification(n)) if n.method == notification::Exit::METHOD => break,
            Some(Message::Notification(n)) => server.on_notification(n),
            Some(Message::Response(_)) | None => {}
        }
        server.publish_due();
    }
    server.stop();
    // As the protocol asks: a client that leaves without `shutdown` has
    // the server exit with an error.
    if shut_down { Ok(()) } else { Err("tslc lsp: the client left without `shutdown`".into()) }
}

/// Waits for the `initialize` request: other requests are answered
/// ServerNotInitialized, an `initialize` whose parameters cannot be read
/// InvalidParams, and other notifications are dropped. `None` when the
/// client leaves first.
fn initialize(connection: &Connection) -> Option<(RequestId, InitializeParams)> {
    loop {
        match connection.receiver.recv().ok()? {
            Message::Request(req) if req.method == request::Initialize::METHOD => {
                match serde_json::from_value::<InitializeParams>(req.params) {
                    Ok(params) => return Some((req.id, params)),
                    Err(e) => {
                        let message = format!("tslc lsp: initialize: {e}");
                        let answer = Response::new_err(req.id, ErrorCode::InvalidParams as i32, message);
                        connection.sender.send(answer.into()).ok()?;
                    }
                }
            }
            Message::Request(req) => {
                let message = format!("tslc lsp: `{}` before `initialize`", req.method);
                let answer = Response::new_err(req.id, ErrorCode::ServerNotInitialized as i32, message);
                connection.sender.send(answer.into()).ok()?;
            }
            Message::Notification(n) if n.method == notification::Exit::METHOD => return None,
            Message::Notification(_) | Message::Response(_) => {}
        }
    }
}

fn workspace_of(init: &InitializeParams, mut import_paths: Vec<PathBuf>) -> Workspace {
    let mut roots: Vec<PathBuf> =
        init.workspace_folders.iter().flatten().filter_map(|f| f.uri.to_file_path().ok()).collect();
    #[allow(deprecated)] // Older clients send only `rootUri`.
    if roots.is_empty()
        && let Some(root) = init.root_uri.as_ref().and_then(|u| u.to_file_path().ok())
    {
        roots.push(root);
    }
    let given = init.initialization_options.as_ref().and_then(|o| o.get("importPaths")).and_then(Value::as_array);
    let mut paths: Vec<PathBuf> = given.into_iter().flatten().filter_map(Value::as_str).map(PathBuf::from).collect();
    paths.append(&mut import_paths);
    Workspace::new(roots, &paths)
}

fn capabilities() -> ServerCapabilities {
    ServerCapabilities {
        position_encoding: Some(PositionEncodingKind::UTF16),
        text_document_sync: Some(TextDocumentSyncCapability::Options(TextDocumentSyncOptions {
            open_close: Some(true),
            change: Some(TextDocumentSyncKind::INCREMENTAL),
            save: Some(TextDocumentSyncSaveOptions::Supported(true)),
            ..TextDocumentSyncOptions::default()
        })),
        hover_provider: Some(HoverProviderCapability::Simple(true)),
        completion_provider: Some(CompletionOptions {
            trigger_characters: Some(vec![".".into(), "(".into(), ",".into()]),
            ..CompletionOptions::default()
        }),
        signature_help_provider: Some(SignatureHelpOptions {
            trigger_characters: Some(vec!["(".into(), ",".into()]),
            retrigger_characters: Some(vec![":".into()]),
            work_done_progress_options: WorkDoneProgressOptions::default(),
        }),
        definition_provider: Some(OneOf::Left(true)),
        references_provider: Some(OneOf::Left(true)),
        document_highlight_provider: Some(OneOf::Left(true)),
        document_symbol_provider: Some(OneOf::Left(true)),
        document_formatting_provider: Some(OneOf::Left(true)),
        semantic_tokens_provider: Some(SemanticTokensServerCapabilities::SemanticTokensOptions(
            SemanticTokensOptions {
                legend: semantic::legend(),
                full: Some(SemanticTokensFullOptions::Bool(true)),
                range: None,
                work_done_progress_options: WorkDoneProgressOptions::default(),
            },
        )),
        ..ServerCapabilities::default()
    }
}

struct Server {
    sender: Sender<Message>,
    workspace: Arc<Workspace>,
    options: crate::LoadOptions,
    docs: HashMap<Url, Document>,
    analyses: HashMap<Url, (i32, Rc<Analysis>)>,
    /// Documents changed since their diagnostics, and when to compute them.
    pending: HashMap<Url, Instant>,
    scheduler: Scheduler,
    snippets: bool,
}

/// The message of a caught panic.
pub(crate) fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

type Handled = Result<Value, (ErrorCode, String)>;

/// Decodes a request's parameters, runs `f` and encodes its answer.
fn handle<R: request::Request>(req: Request, f: impl FnOnce(R::Params) -> R::Result) -> Handled {
    handle_fallible::<R>(req, |p| Ok(f(p)))
}

/// [`handle`] for a request that can fail with an error the editor shows.
fn handle_fallible<R: request::Request>(
    req: Request,
    f: impl FnOnce(R::Params) -> Result<R::Result, (ErrorCode, String)>,
) -> Handled {
    let params: R::Params =
        serde_json::from_value(req.params).map_err(|e| (ErrorCode::InvalidParams, format!("{}: {e}", R::METHOD)))?;
    serde_json::to_value(f(params)?).map_err(|e| (ErrorCode::InternalError, e.to_string()))
}

impl Server {
    fn new(sender: Sender<Message>, workspace: Arc<Workspace>, snippets: bool) -> Server {
        let options = workspace.load_options();
        let scheduler = Scheduler::new(sender.clone(), workspace.clone(), options.clone());
        Server {
            sender,
            workspace,
            options,
            docs: HashMap::new(),
            analyses: HashMap::new(),
            pending: HashMap::new(),
            scheduler,
            snippets,
        }
    }

    fn stop(&mut self) {
        self.scheduler.stop();
    }

    fn log(&self, kind: MessageType, message: String) {
        let params = LogMessageParams { typ: kind, message };
        let _ = self.sender.send(Notification::new(notification::LogMessage::METHOD.into(), params).into());
    }

    /// When the next debounced diagnostics are due.
    fn next_deadline(&self) -> Option<Instant> {
        self.pending.values().min().copied()
    }

    /// Sends the documents whose debounce has run out to the worker.
    fn publish_due(&mut self) {
        let now = Instant::now();
        let due: Vec<Url> = self.pending.iter().filter(|(_, t)| **t <= now).map(|(u, _)| u.clone()).collect();
        for uri in due {
            self.pending.remove(&uri);
            self.diagnose(&uri);
        }
    }

    fn diagnose(&self, uri: &Url) {
        let Some(doc) = self.docs.get(uri) else { return };
        let work = if let Some(size) = doc.too_large {
            Work::Publish(vec![too_large(size)])
        } else if self.workspace.prelude_name(uri).is_some() {
            Work::Publish(Vec::new())
        } else {
            Work::Check(doc.text.clone())
        };
        self.scheduler.submit(uri, doc.version, work);
    }

    fn on_notification(&mut self, n: Notification) {
        let method = n.method.clone();
        if let Err(panic) = catch_unwind(AssertUnwindSafe(|| self.notification(n))) {
            self.log(MessageType::ERROR, format!("tslc lsp: {method} failed: {}", panic_message(&*panic)));
        }
    }

    fn notification(&mut self, n: Notification) {
        /// The parameters of a notification, or a log message saying why not.
        fn params<N: notification::Notification>(server: &Server, n: lsp_server::Notification) -> Option<N::Params> {
            serde_json::from_value(n.params)
                .map_err(|e| server.log(MessageType::WARNING, format!("tslc lsp: {} ignored: {e}", N::METHOD)))
                .ok()
        }
        use notification::*;
        match n.method.as_str() {
            DidOpenTextDocument::METHOD => {
                let Some(p) = params::<DidOpenTextDocument>(self, n) else { return };
                let uri = p.text_document.uri;
                self.docs.insert(uri.clone(), Document::new(p.text_document.text, p.text_document.version));
                self.analyses.remove(&uri);
                self.diagnose(&uri);
            }
            DidChangeTextDocument::METHOD => {
                let Some(p) = params::<DidChangeTextDocument>(self, n) else { return };
                let uri = p.text_document.uri;
                if let Some(doc) = self.docs.get_mut(&uri) {
                    // Applied to a copy: a bad edit leaves the document as it was.
                    let mut changed = doc.clone();
                    changed.apply(p.content_changes, p.text_document.version);
                    *doc = changed;
                    self.analyses.remove(&uri);
                    // The check of the text it had is stale from now on.
                    self.scheduler.supersede(&uri);
                    self.pending.insert(uri, Instant::now() + DEBOUNCE);
                }
            }
            DidSaveTextDocument::METHOD => {
                let Some(p) = params::<DidSaveTextDocument>(self, n) else { return };
                self.pending.remove(&p.text_document.uri);
                self.diagnose(&p.text_document.uri);
            }
            DidCloseTextDocument::METHOD => {
                let Some(p) = params::<DidCloseTextDocument>(self, n) else { return };
                let uri = p.text_document.uri;
                self.docs.remove(&uri);
                self.analyses.remove(&uri);
                self.pending.remove(&uri);
                self.scheduler.close(&uri);
            }
            _ => {}
        }
    }

    fn on_request(&mut self, req: Request) {
        let (id, method) = (req.id.clone(), req.method.clone());
        let response = match catch_unwind(AssertUnwindSafe(|| self.request(req))) {
            Ok(Ok(value)) => Response::new_ok(id, value),
            Ok(Err((code, message))) => Response::new_err(id, code as i32, message),
            Err(panic) => {
                let message = format!("tslc lsp: {method} failed: {}", panic_message(&*panic));
                self.log(MessageType::ERROR, message.clone());
                Response::new_err(id, ErrorCode::InternalError as i32, message)
            }
        };
        let _ = self.sender.send(response.into());
    }

    fn request(&mut self, req: Request) -> Handled {
        use request::*;
        let (workspace, snippets) = (self.workspace.clone(), self.snippets);
        match req.method.as_str() {
            HoverRequest::METHOD => handle::<HoverRequest>(req, |p| {
                let (doc, a) = self.at(&p.text_document_position_params.text_document.uri)?;
                let offset = doc.offset(p.text_document_position_params.position);
                let (value, (start, end)) = hover::hover(&a, offset)?;
                Some(Hover {
                    contents: HoverContents::Markup(MarkupContent { kind: MarkupKind::Markdown, value }),
                    range: Some(doc.range(start, end)),
                })
            }),
            GotoDefinition::METHOD => handle::<GotoDefinition>(req, |p| {
                let (doc, a) = self.at(&p.text_document_position_params.text_document.uri)?;
                let offset = doc.offset(p.text_document_position_params.position);
                navigation::definition(&workspace, &a, offset).map(GotoDefinitionResponse::Scalar)
            }),
            References::METHOD => handle::<References>(req, |p| {
                let (doc, a) = self.at(&p.text_document_position.text_document.uri)?;
                let offset = doc.offset(p.text_document_position.position);
                Some(navigation::references(&workspace, &a, offset, p.context.include_declaration))
            }),
            DocumentHighlightRequest::METHOD => handle::<DocumentHighlightRequest>(req, |p| {
                let (doc, a) = self.at(&p.text_document_position_params.text_document.uri)?;
                let offset = doc.offset(p.text_document_position_params.position);
                Some(navigation::document_highlights(&a, offset))
            }),
            DocumentSymbolRequest::METHOD => handle::<DocumentSymbolRequest>(req, |p| {
                let (doc, a) = self.at(&p.text_document.uri)?;
                Some(DocumentSymbolResponse::Nested(symbols::document_symbols(&a, doc)))
            }),
            Completion::METHOD => handle::<Completion>(req, |p| {
                let (doc, a) = self.at(&p.text_document_position.text_document.uri)?;
                let cx = context::context_at(&doc.text, doc.offset(p.text_document_position.position));
                let completer = completion::Completer { analysis: &a, snippets };
                Some(CompletionResponse::Array(completer.complete(&cx)))
            }),
            SignatureHelpRequest::METHOD => handle::<SignatureHelpRequest>(req, |p| {
                let (doc, a) = self.at(&p.text_document_position_params.text_document.uri)?;
                let cx = context::context_at(&doc.text, doc.offset(p.text_document_position_params.position));
                let in_material = matches!(cx.place, context::Place::Code { in_material: true });
                signature::signature_help(&a, cx.call.as_ref()?, in_material)
            }),
            Formatting::METHOD => handle_fallible::<Formatting>(req, |p| {
                let Some(doc) = self.docs.get(&p.text_document.uri).filter(|d| d.too_large.is_none()) else {
                    return Ok(None);
                };
                let formatted = match crate::format::format_source(&doc.text) {
                    Ok(text) => text,
                    // A refusal is a failed request, so the editor shows why
                    // nothing changed.
                    Err(diags) if diags.iter().any(crate::format::is_refusal) => {
                        let mut sources = crate::diag::SourceMap::new();
                        sources.add(Workspace::source_name(&p.text_document.uri), doc.text.as_str());
                        let message = crate::diag::render_text(&sources, &diags, crate::diag::Colors::Never);
                        return Err((ErrorCode::RequestFailed, message));
                    }
                    // A file that does not parse is left alone; its errors
                    // are already shown.
                    Err(_) => return Ok(None),
                };
                if formatted == doc.text {
                    return Ok(Some(Vec::new()));
                }
                Ok(Some(vec![TextEdit { range: doc.range(0, doc.text.len()), new_text: formatted }]))
            }),
            SemanticTokensFullRequest::METHOD => handle::<SemanticTokensFullRequest>(req, |p| {
                let (doc, a) = self.at(&p.text_document.uri)?;
                Some(SemanticTokensResult::Tokens(semantic::tokens(&a, doc)))
            }),
            _ => Err((ErrorCode::MethodNotFound, format!("tslc lsp does not answer `{}`", req.method))),
        }
    }

    /// An open document and its analysis (cached per version).
    fn at(&mut self, uri: &Url) -> Option<(&Document, Rc<Analysis>)> {
        let doc = self.docs.get(uri).filter(|d| d.too_large.is_none())?;
        let fresh = self.analyses.get(uri).filter(|(version, _)| *version == doc.version);
        let analysis = match fresh {
            Some((_, analysis)) => analysis.clone(),
            None => {
                let name = Workspace::source_name(uri);
                let prelude = self.workspace.prelude_name(uri);
                let analysis = Rc::new(Analysis::new(&name, &doc.text, &self.options, prelude));
                self.analyses.insert(uri.clone(), (doc.version, analysis.clone()));
                analysis
            }
        };
        Some((self.docs.get(uri)?, analysis))
    }
}

/// The diagnostic of a document over [`MAX_DOCUMENT_BYTES`].
fn too_large(size: usize) -> lsp_types::Diagnostic {
    lsp_types::Diagnostic {
        message: format!(
            "this document is {size} bytes, larger than {} MiB, the most a source file may be: it is not checked",
            MAX_DOCUMENT_BYTES >> 20
        ),
        severity: Some(DiagnosticSeverity::ERROR),
        source: Some("tslc".into()),
        ..lsp_types::Diagnostic::default()
    }
}
