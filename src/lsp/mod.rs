//! `tslc lsp`: a language server over stdio (the Language Server Protocol,
//! with rust-analyzer's `lsp-server` and `lsp-types`; no async runtime).
//!
//! The main loop owns the open documents and answers requests on its own
//! thread from an [`analysis::Analysis`] of the current text (the
//! compiler's front end, cached per document version). Diagnostics are
//! computed on a worker thread, as `tslc check` would report them, when a
//! document opens or is saved and 150 ms after the last change, so typing
//! never waits for a scene's meshes to be read. Every request and
//! notification runs under `catch_unwind`: a bug answers one request with
//! an error and the server goes on.
//!
//! The modules: `documents` (texts, positions, the workspace's paths and
//! the prelude's files), `analysis` (checking a document, what is under a
//! position and what it refers to), `context` (where the cursor is, from
//! the tokens before it), `docs` (stdlib doc blocks, docs/language.md),
//! and one module per feature: `diagnostics`, `hover`, `navigation`
//! (definition, references, highlights), `symbols`, `completion`,
//! `signature`, `semantic` (semantic tokens).

mod analysis;
mod completion;
mod context;
mod diagnostics;
mod docs;
mod documents;
mod hover;
mod navigation;
mod semantic;
mod signature;
mod symbols;

use analysis::Analysis;
use crossbeam_channel::{RecvTimeoutError, Sender};
use documents::{Document, Workspace};
use lsp_server::{Connection, ErrorCode, Message, Notification, Request, Response};
use lsp_types::notification::Notification as _;
use lsp_types::*;
use serde_json::Value;
use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

/// How long after the last change diagnostics are computed.
pub const DEBOUNCE: Duration = Duration::from_millis(150);

/// Runs the server over standard input and output until the client
/// sends `exit`. `import_paths` are searched for imports after those of
/// the initialization options (`{"importPaths": [...]}`).
pub fn run_stdio(import_paths: Vec<PathBuf>) -> Result<(), String> {
    let (connection, io_threads) = Connection::stdio();
    run(connection, import_paths)?;
    io_threads.join().map_err(|e| format!("tslc lsp: {e}"))
}

/// Runs the server on a connection (stdio, or in memory for tests).
pub fn run(connection: Connection, import_paths: Vec<PathBuf>) -> Result<(), String> {
    let protocol = |e: lsp_server::ProtocolError| format!("tslc lsp: {e}");
    let (id, params) = connection.initialize_start().map_err(protocol)?;
    let init: InitializeParams = serde_json::from_value(params).map_err(|e| format!("tslc lsp: initialize: {e}"))?;
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
    connection.initialize_finish(id, result).map_err(protocol)?;
    let mut server = Server::new(connection.sender.clone(), workspace, snippets);
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
            Some(Message::Request(req)) => {
                if connection.handle_shutdown(&req).map_err(protocol)? {
                    break;
                }
                server.on_request(req);
            }
            Some(Message::Notification(n)) if n.method == notification::Exit::METHOD => break,
            Some(Message::Notification(n)) => server.on_notification(n),
            Some(Message::Response(_)) | None => {}
        }
        server.publish_due();
    }
    server.stop();
    Ok(())
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

/// A diagnostics job for the worker: a document's text, or `None` to
/// clear its diagnostics (closed, or a prelude file).
struct Job {
    uri: Url,
    version: Option<i32>,
    text: Option<String>,
}

struct Server {
    sender: Sender<Message>,
    workspace: Arc<Workspace>,
    options: crate::LoadOptions,
    docs: HashMap<Url, Document>,
    analyses: HashMap<Url, (i32, Rc<Analysis>)>,
    /// Documents changed since their diagnostics, and when to compute them.
    pending: HashMap<Url, Instant>,
    jobs: Option<mpsc::Sender<Job>>,
    worker: Option<std::thread::JoinHandle<()>>,
    snippets: bool,
}

/// The message of a caught panic.
fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

type Handled = Result<Value, (ErrorCode, String)>;

/// Decodes a request's parameters, runs `f` and encodes its answer.
fn handle<R: request::Request>(req: Request, f: impl FnOnce(R::Params) -> R::Result) -> Handled {
    let params: R::Params =
        serde_json::from_value(req.params).map_err(|e| (ErrorCode::InvalidParams, format!("{}: {e}", R::METHOD)))?;
    serde_json::to_value(f(params)).map_err(|e| (ErrorCode::InternalError, e.to_string()))
}

impl Server {
    fn new(sender: Sender<Message>, workspace: Arc<Workspace>, snippets: bool) -> Server {
        let options = workspace.load_options();
        let (jobs, rx) = mpsc::channel::<Job>();
        let worker = {
            let (sender, workspace, options) = (sender.clone(), workspace.clone(), options.clone());
            std::thread::Builder::new()
                .name("tslc-lsp-diagnostics".into())
                .stack_size(64 << 20)
                .spawn(move || diagnostics_worker(&rx, &sender, &workspace, &options))
                .ok()
        };
        Server {
            sender,
            workspace,
            options,
            docs: HashMap::new(),
            analyses: HashMap::new(),
            pending: HashMap::new(),
            jobs: Some(jobs),
            worker,
            snippets,
        }
    }

    fn stop(&mut self) {
        self.jobs = None;
        if let Some(worker) = self.worker.take() {
            let _ = worker.join();
        }
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
        let text = self.workspace.prelude_name(uri).is_none().then(|| doc.text.clone());
        if let Some(jobs) = &self.jobs {
            let _ = jobs.send(Job { uri: uri.clone(), version: Some(doc.version), text });
        }
    }

    fn on_notification(&mut self, n: Notification) {
        let method = n.method.clone();
        if let Err(panic) = catch_unwind(AssertUnwindSafe(|| self.notification(n))) {
            self.log(MessageType::ERROR, format!("tslc lsp: {method} failed: {}", panic_message(&*panic)));
        }
    }

    fn notification(&mut self, n: Notification) {
        match n.method.as_str() {
            notification::DidOpenTextDocument::METHOD => {
                let Ok(p) = serde_json::from_value::<DidOpenTextDocumentParams>(n.params) else { return };
                let uri = p.text_document.uri;
                self.docs.insert(uri.clone(), Document::new(p.text_document.text, p.text_document.version));
                self.diagnose(&uri);
            }
            notification::DidChangeTextDocument::METHOD => {
                let Ok(p) = serde_json::from_value::<DidChangeTextDocumentParams>(n.params) else { return };
                let uri = p.text_document.uri;
                if let Some(doc) = self.docs.get_mut(&uri) {
                    // Applied to a copy: a bad edit leaves the document as it was.
                    let mut changed = doc.clone();
                    changed.apply(p.content_changes, p.text_document.version);
                    *doc = changed;
                    self.pending.insert(uri, Instant::now() + DEBOUNCE);
                }
            }
            notification::DidSaveTextDocument::METHOD => {
                let Ok(p) = serde_json::from_value::<DidSaveTextDocumentParams>(n.params) else { return };
                self.pending.remove(&p.text_document.uri);
                self.diagnose(&p.text_document.uri);
            }
            notification::DidCloseTextDocument::METHOD => {
                let Ok(p) = serde_json::from_value::<DidCloseTextDocumentParams>(n.params) else { return };
                let uri = p.text_document.uri;
                self.docs.remove(&uri);
                self.analyses.remove(&uri);
                self.pending.remove(&uri);
                if let Some(jobs) = &self.jobs {
                    let _ = jobs.send(Job { uri, version: None, text: None });
                }
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
            Formatting::METHOD => handle::<Formatting>(req, |p| {
                let doc = self.docs.get(&p.text_document.uri)?;
                // A file that does not parse is left alone; its errors are
                // already shown.
                let formatted = crate::format::format_source(&doc.text).ok()?;
                if formatted == doc.text {
                    return Some(Vec::new());
                }
                Some(vec![TextEdit { range: doc.range(0, doc.text.len()), new_text: formatted }])
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
        let doc = self.docs.get(uri)?;
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

/// A scene described by a check whose mesh and environment files have not been
/// modified since it started (a 1M-triangle mesh takes seconds to read).
fn unchanged_scene(
    scene: &crate::scene::SceneDesc,
    started: std::time::SystemTime,
) -> Option<&crate::scene::SceneDesc> {
    let meshes = scene.objects.iter().filter_map(|o| match &o.shape {
        crate::scene::ShapeDesc::Mesh { file } => Some(file.value.path.clone()),
        _ => None,
    });
    let environment = scene.environment.iter().filter_map(|e| match &e.source {
        crate::scene::EnvironmentSourceDesc::Image(image) => Some(image.value.path.clone()),
        crate::scene::EnvironmentSourceDesc::Constant(_) => None,
    });
    let unchanged =
        |path: std::path::PathBuf| std::fs::metadata(path).and_then(|m| m.modified()).is_ok_and(|t| t < started);
    meshes.chain(environment).all(unchanged).then_some(scene)
}

/// Computes and publishes diagnostics, newest text first: a burst of
/// jobs for one document is one check.
fn diagnostics_worker(
    jobs: &mpsc::Receiver<Job>,
    sender: &Sender<Message>,
    ws: &Workspace,
    options: &crate::LoadOptions,
) {
    // The scene of each document's last check (and when it started): its
    // meshes and environment image are reused while their files are
    // unchanged. (Texture images are decoded again: the texture manager's
    // cache cannot tell a file that changed.)
    let mut last: HashMap<Url, (crate::scene::SceneDesc, std::time::SystemTime)> = HashMap::new();
    while let Ok(first) = jobs.recv() {
        let mut batch = vec![first];
        batch.extend(jobs.try_iter());
        let mut latest: Vec<Job> = Vec::new();
        for job in batch {
            latest.retain(|j| j.uri != job.uri);
            latest.push(job);
        }
        for job in latest {
            let diagnostics = match &job.text {
                None => {
                    last.remove(&job.uri);
                    Vec::new()
                }
                Some(text) => {
                    let name = Workspace::source_name(&job.uri);
                    let previous = last.get(&job.uri).and_then(|(scene, at)| unchanged_scene(scene, *at));
                    let run = || {
                        let started = std::time::SystemTime::now();
                        let checked = crate::check_source_reusing(&name, text, options, previous);
                        let shown = diagnostics::diagnostics(ws, &checked, text);
                        (checked, started, shown)
                    };
                    catch_unwind(AssertUnwindSafe(run))
                        .map(|(checked, started, shown)| {
                            // The last scene described stays while the text
                            // has errors: its files are reused once it is fixed.
                            if let Some(scene) = checked.scene {
                                last.insert(job.uri.clone(), (scene, started));
                            }
                            shown
                        })
                        .unwrap_or_else(|panic| {
                            vec![Diagnostic {
                                message: format!(
                                    "internal error in tslc (please report it): {}",
                                    panic_message(&*panic)
                                ),
                                severity: Some(DiagnosticSeverity::ERROR),
                                source: Some("tslc".into()),
                                ..Diagnostic::default()
                            }]
                        })
                }
            };
            let params = PublishDiagnosticsParams { uri: job.uri, diagnostics, version: job.version };
            let note = Notification::new(notification::PublishDiagnostics::METHOD.into(), params);
            if sender.send(note.into()).is_err() {
                return;
            }
        }
    }
}
