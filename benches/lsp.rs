//! How fast `tslc lsp` answers: every example opened in the server (in
//! process, over an in-memory connection: the stdio transport adds a copy
//! and a pipe), each request timed at every name of the file, right after
//! an edit (the document is checked again: the cost an editor sees while
//! typing) and again without one. Prints medians and maxima per request
//! kind and the ratio of the worst to the 50 ms goal of issue 14.
//!
//! Then two large documents, each request timed once: a 665 KB program
//! on one line (semantic tokens, symbols, hover, highlights, diagnostics),
//! and a function with 20,000 references (issue 29: positions counted
//! from the line start per token, the file indexed again per reference).
//!
//! `cargo bench --bench lsp` (release build); `cargo bench --bench lsp --
//! large` runs the large documents only.

use lsp_server::{Connection, Message, Notification, Request, RequestId};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

const GOAL_MS: f64 = 50.0;

struct Client {
    conn: Connection,
    next: i32,
    /// Notifications read while waiting for a response, with when they came.
    backlog: Vec<(Instant, Notification)>,
}

impl Client {
    fn request(&mut self, method: &str, params: Value) -> (Value, f64) {
        self.next += 1;
        let id = RequestId::from(self.next);
        let start = Instant::now();
        self.conn.sender.send(Message::Request(Request::new(id.clone(), method.into(), params))).unwrap();
        loop {
            match self.conn.receiver.recv_timeout(Duration::from_secs(900)).expect("an answer") {
                Message::Response(r) if r.id == id => {
                    let ms = start.elapsed().as_secs_f64() * 1000.0;
                    match r.response_result {
                        Ok(result) => return (result, ms),
                        Err(e) => panic!("{method}: {}", e.message),
                    }
                }
                Message::Notification(n) => self.backlog.push((Instant::now(), n)),
                _ => {}
            }
        }
    }

    fn notify(&self, method: &str, params: Value) {
        self.conn.sender.send(Message::Notification(Notification::new(method.into(), params))).unwrap();
    }

    /// Time from a save to the diagnostics of `version`.
    fn diagnostics_after_save(&mut self, uri: &str, version: i32) -> f64 {
        let start = Instant::now();
        self.notify("textDocument/didSave", json!({ "textDocument": { "uri": uri } }));
        self.diagnostics(uri, version, start)
    }

    /// Time from `start` to the diagnostics of `version`.
    fn diagnostics(&mut self, uri: &str, version: i32, start: Instant) -> f64 {
        let wanted = |n: &Notification| {
            n.method == "textDocument/publishDiagnostics"
                && n.params["uri"] == uri
                && n.params["version"] == json!(version)
        };
        if let Some(k) = self.backlog.iter().position(|(_, n)| wanted(n)) {
            let (at, _) = self.backlog.swap_remove(k);
            return at.duration_since(start).as_secs_f64() * 1000.0;
        }
        loop {
            if let Message::Notification(n) =
                self.conn.receiver.recv_timeout(Duration::from_secs(120)).expect("diagnostics")
                && wanted(&n)
            {
                return start.elapsed().as_secs_f64() * 1000.0;
            }
        }
    }
}

fn examples(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let p = entry.path();
        if p.is_dir() {
            out.extend(examples(&p));
        } else if p.extension().is_some_and(|e| e == "tsl") {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// Byte offsets of the middle of every identifier-like word outside comments.
fn word_offsets(text: &str) -> Vec<usize> {
    let mut out = Vec::new();
    for (line_start, line) in text.split_inclusive('\n').scan(0, |at, l| {
        let s = *at;
        *at += l.len();
        Some((s, l))
    }) {
        let code = line.split("//").next().unwrap_or("");
        let mut start = None;
        for (i, c) in code.char_indices().chain(std::iter::once((code.len(), ' '))) {
            let word = c.is_ascii_alphanumeric() || c == '_';
            match (word, start) {
                (true, None) => start = Some(i),
                (false, Some(s)) => {
                    if !code[s..i].starts_with(|c: char| c.is_ascii_digit()) {
                        out.push(line_start + (s + i) / 2);
                    }
                    start = None;
                }
                _ => {}
            }
        }
    }
    out
}

fn position(text: &str, offset: usize) -> Value {
    let before = &text[..offset];
    let line = before.matches('\n').count();
    let start = before.rfind('\n').map_or(0, |i| i + 1);
    json!({ "line": line, "character": before[start..].encode_utf16().count() })
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// A program of `functions` small functions, all on one line.
fn one_line_program(functions: usize) -> String {
    let mut text = String::from("float f0(float x) { return x; } ");
    for k in 1..functions {
        text.push_str(&format!("float f{k}(float x) {{ float y = f{}(x) * 0.5; return y + x; }} ", k - 1));
    }
    text
}

/// A program in which `f` is called `calls` times, one function a line.
fn many_references(calls: usize) -> String {
    let mut text = String::from("float f(float x) {\n    return x;\n}\n");
    for k in 0..calls {
        text.push_str(&format!("float g{k}(float x) {{ return f(x); }}\n"));
    }
    text
}

/// Times each request on the large documents once.
fn large_documents(c: &mut Client, repo: &Path) {
    println!("large documents (release, in process, one request each):");
    let time = |c: &mut Client, what: &str, method: &str, params: Value| {
        let (result, ms) = c.request(method, params);
        let size = result.as_array().map(Vec::len).or_else(|| result["data"].as_array().map(|d| d.len() / 5));
        println!("  {what:<44} {ms:>9.1} ms  ({} items)", size.unwrap_or(1));
    };
    let text = one_line_program(10_300);
    let uri = format!("file://{}", repo.join("large_one_line.tsl").display());
    let opened = Instant::now();
    c.notify(
        "textDocument/didOpen",
        json!({ "textDocument": { "uri": uri, "languageId": "tsl", "version": 1, "text": text } }),
    );
    let doc = json!({ "uri": uri });
    let end = position(&text, text.rfind("f10298").unwrap() + 2);
    let label = format!("one line, {} KB: first hover (analysis)", text.len() / 1000);
    time(c, &label, "textDocument/hover", json!({ "textDocument": doc, "position": end }));
    time(c, "  hover at the end", "textDocument/hover", json!({ "textDocument": doc, "position": end }));
    time(c, "  semantic tokens", "textDocument/semanticTokens/full", json!({ "textDocument": doc }));
    time(c, "  document symbols", "textDocument/documentSymbol", json!({ "textDocument": doc }));
    time(c, "  highlights", "textDocument/documentHighlight", json!({ "textDocument": doc, "position": end }));
    let refs = json!({ "textDocument": doc, "position": end, "context": { "includeDeclaration": true } });
    time(c, "  references", "textDocument/references", refs);
    println!("  {:<44} {:>9.1} ms", "  diagnostics after opening", c.diagnostics(&uri, 1, opened));
    c.notify("textDocument/didClose", json!({ "textDocument": doc }));

    let text = many_references(20_000);
    let uri = format!("file://{}", repo.join("large_references.tsl").display());
    let opened = Instant::now();
    c.notify(
        "textDocument/didOpen",
        json!({ "textDocument": { "uri": uri, "languageId": "tsl", "version": 1, "text": text } }),
    );
    let doc = json!({ "uri": uri });
    let f = position(&text, 7);
    let label = format!("20,000 calls, {} KB: first hover (analysis)", text.len() / 1000);
    time(c, &label, "textDocument/hover", json!({ "textDocument": doc, "position": f }));
    let refs = json!({ "textDocument": doc, "position": f, "context": { "includeDeclaration": true } });
    time(c, "  references", "textDocument/references", refs);
    time(c, "  highlights", "textDocument/documentHighlight", json!({ "textDocument": doc, "position": f }));
    time(c, "  semantic tokens", "textDocument/semanticTokens/full", json!({ "textDocument": doc }));
    println!("  {:<44} {:>9.1} ms", "  diagnostics after opening", c.diagnostics(&uri, 1, opened));
    c.notify("textDocument/didClose", json!({ "textDocument": doc }));
}

fn main() {
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let only_large = std::env::args().any(|a| a == "large");
    let (server, client) = Connection::memory();
    let thread =
        std::thread::Builder::new().stack_size(64 << 20).spawn(move || tsl::lsp::run(server, Vec::new())).unwrap();
    let mut c = Client { conn: client, next: 0, backlog: Vec::new() };
    c.request(
        "initialize",
        json!({ "processId": null, "rootUri": format!("file://{}", repo.display()), "capabilities": {} }),
    );
    c.notify("initialized", json!({}));

    let methods = [
        "textDocument/hover",
        "textDocument/completion",
        "textDocument/signatureHelp",
        "textDocument/definition",
        "textDocument/references",
        "textDocument/documentHighlight",
    ];
    let whole = ["textDocument/documentSymbol", "textDocument/semanticTokens/full", "textDocument/formatting"];
    let mut cold: Vec<(String, f64, String)> = Vec::new();
    let mut warm: Vec<(String, f64, String)> = Vec::new();
    let mut diagnostics: Vec<(f64, String)> = Vec::new();
    let mut on_open: Vec<(f64, String)> = Vec::new();
    let all = if only_large { Vec::new() } else { examples(&repo.join("examples")) };
    for path in all {
        let text = std::fs::read_to_string(&path).unwrap();
        let uri = format!("file://{}", path.display());
        let name = path.strip_prefix(&repo).unwrap().display().to_string();
        let opened = Instant::now();
        c.notify(
            "textDocument/didOpen",
            json!({ "textDocument": { "uri": uri, "languageId": "tsl", "version": 1, "text": text } }),
        );
        on_open.push((c.diagnostics(&uri, 1, opened), name.clone()));
        let mut version = 1;
        let mut run = |c: &mut Client, method: &str, params: Value, edit_first: bool, version: &mut i32| {
            if edit_first {
                // A change that keeps the text: the server checks it again.
                *version += 1;
                c.notify(
                    "textDocument/didChange",
                    json!({ "textDocument": { "uri": uri, "version": *version }, "contentChanges": [{ "text": text }] }),
                );
            }
            let (_, ms) = c.request(method, params);
            let into = if edit_first { &mut cold } else { &mut warm };
            into.push((method.to_string(), ms, name.clone()));
        };
        for (k, offset) in word_offsets(&text).into_iter().enumerate() {
            let method = methods[k % methods.len()];
            let mut params = json!({ "textDocument": { "uri": uri }, "position": position(&text, offset) });
            if method == "textDocument/references" {
                params["context"] = json!({ "includeDeclaration": true });
            }
            // Every other round of the methods follows an edit.
            run(&mut c, method, params.clone(), (k / methods.len()).is_multiple_of(2), &mut version);
            run(&mut c, method, params, false, &mut version);
        }
        for method in whole {
            let mut params = json!({ "textDocument": { "uri": uri } });
            if method == "textDocument/formatting" {
                params["options"] = json!({ "tabSize": 4, "insertSpaces": true });
            }
            run(&mut c, method, params.clone(), true, &mut version);
            run(&mut c, method, params, false, &mut version);
        }
        // Let the debounced diagnostics of the edits go, then time a save.
        std::thread::sleep(Duration::from_millis(300));
        while c.conn.receiver.try_recv().is_ok() {}
        c.backlog.clear();
        diagnostics.push((c.diagnostics_after_save(&uri, version), name.clone()));
        c.notify("textDocument/didClose", json!({ "textDocument": { "uri": uri } }));
    }
    large_documents(&mut c, &repo);
    c.request("shutdown", Value::Null);
    c.notify("exit", Value::Null);
    let _ = thread.join();
    if only_large {
        return;
    }

    println!("tslc lsp response times (release, in process), every example, each name of each file:");
    let mut worst = 0f64;
    for (label, samples) in [("after an edit", &cold), ("unchanged", &warm)] {
        for method in methods.iter().chain(&whole) {
            let mut ms: Vec<f64> = samples.iter().filter(|s| s.0 == *method).map(|s| s.1).collect();
            if ms.is_empty() {
                continue;
            }
            let max = samples.iter().filter(|s| s.0 == *method).max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
            worst = worst.max(max.1);
            println!(
                "  {label:<14} {:<34} n={:<4} median {:>6.2} ms  max {:>6.2} ms ({})",
                method.trim_start_matches("textDocument/"),
                ms.len(),
                median(&mut ms),
                max.1,
                max.2
            );
        }
    }
    for (label, samples) in [("on open", &on_open), ("after a save (files reused)", &diagnostics)] {
        let mut ms: Vec<f64> = samples.iter().map(|d| d.0).collect();
        let slowest = samples.iter().max_by(|a, b| a.0.total_cmp(&b.0)).unwrap();
        println!(
            "  diagnostics {label} (worker thread: tslc check's full check): median {:.1} ms, max {:.1} ms ({})",
            median(&mut ms),
            slowest.0,
            slowest.1
        );
    }
    println!("worst request / {GOAL_MS} ms goal: {:.2} x", worst / GOAL_MS);
}
