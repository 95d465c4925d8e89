//! `tslc lsp` end to end: the binary is spawned and spoken to in JSON-RPC
//! over its standard input and output, as an editor would.

use serde_json::{Value, json};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const TIMEOUT: Duration = Duration::from_secs(60);

struct Client {
    child: Child,
    /// `None` once closed.
    stdin: Option<ChildStdin>,
    incoming: mpsc::Receiver<Value>,
    /// Notifications read while waiting for something else.
    backlog: Vec<Value>,
    next_id: i64,
    _cache: tempfile_dir::TempDir,
}

/// A temporary directory removed on drop (std only).
mod tempfile_dir {
    use std::path::{Path, PathBuf};

    pub struct TempDir(PathBuf);

    impl TempDir {
        pub fn new(tag: &str) -> TempDir {
            let unique = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap().as_nanos();
            let dir = std::env::temp_dir().join(format!("tsl-lsp-test-{tag}-{}-{unique}", std::process::id()));
            std::fs::create_dir_all(&dir).unwrap();
            TempDir(dir)
        }

        pub fn path(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn uri(path: &Path) -> String {
    format!("file://{}", path.display())
}

fn read_message(reader: &mut impl BufRead) -> Option<Value> {
    let mut length = None;
    loop {
        let mut line = String::new();
        if reader.read_line(&mut line).ok()? == 0 {
            return None;
        }
        let line = line.trim_end();
        if line.is_empty() {
            break;
        }
        if let Some(n) = line.strip_prefix("Content-Length: ") {
            length = n.parse::<usize>().ok();
        }
    }
    let mut body = vec![0; length?];
    reader.read_exact(&mut body).ok()?;
    serde_json::from_slice(&body).ok()
}

impl Client {
    /// The server started and initialized.
    fn start(tag: &str) -> Client {
        let mut client = Client::spawn(tag);
        client.initialize();
        client
    }

    /// The server started, not yet initialized.
    fn spawn(tag: &str) -> Client {
        let cache = tempfile_dir::TempDir::new(tag);
        let mut child = Command::new(env!("CARGO_BIN_EXE_tslc"))
            .arg("lsp")
            .env("XDG_CACHE_HOME", cache.path())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("tslc starts");
        let stdin = child.stdin.take().unwrap();
        let mut stdout = BufReader::new(child.stdout.take().unwrap());
        let (tx, incoming) = mpsc::channel();
        std::thread::spawn(move || {
            while let Some(m) = read_message(&mut stdout) {
                if tx.send(m).is_err() {
                    break;
                }
            }
        });
        Client { child, stdin: Some(stdin), incoming, backlog: Vec::new(), next_id: 0, _cache: cache }
    }

    fn initialize(&mut self) {
        let init = self.request(
            "initialize",
            json!({
                "processId": null,
                "rootUri": uri(&repo()),
                "capabilities": { "textDocument": { "completion": { "completionItem": { "snippetSupport": true } } } },
                "initializationOptions": { "importPaths": ["examples"] },
            }),
        );
        assert!(init["result"]["capabilities"]["hoverProvider"].as_bool().unwrap_or(false), "{init}");
        self.notify("initialized", json!({}));
    }

    fn send(&mut self, message: Value) {
        self.send_raw(&framed(message.to_string().as_bytes()));
    }

    /// Bytes as they are, framed or not.
    fn send_raw(&mut self, bytes: &[u8]) {
        let stdin = self.stdin.as_mut().expect("the input is open");
        stdin.write_all(bytes).unwrap();
        stdin.flush().unwrap();
    }

    /// The next message that is not a notification with `id` (`null`
    /// for the refusal of a message that could not be read).
    fn response_to(&mut self, id: Value) -> Value {
        let wanted = |m: &Value| m.get("method").is_none() && m["id"] == id;
        if let Some(k) = self.backlog.iter().position(wanted) {
            return self.backlog.remove(k);
        }
        loop {
            let m = self.receive();
            if wanted(&m) {
                return m;
            }
            self.backlog.push(m);
        }
    }

    /// The diagnostics published for `uri` so far (read so far).
    fn published(&self, uri: &str) -> Vec<Value> {
        let of = |m: &&Value| m["method"] == "textDocument/publishDiagnostics" && m["params"]["uri"] == uri;
        self.backlog.iter().filter(of).cloned().collect()
    }

    fn notify(&mut self, method: &str, params: Value) {
        self.send(json!({ "jsonrpc": "2.0", "method": method, "params": params }));
    }

    fn receive(&mut self) -> Value {
        self.incoming.recv_timeout(TIMEOUT).expect("the server answers (it did not die or hang)")
    }

    /// Sends a request and returns the whole response (`result` or `error`).
    fn request(&mut self, method: &str, params: Value) -> Value {
        self.next_id += 1;
        let id = self.next_id;
        self.send(json!({ "jsonrpc": "2.0", "id": id, "method": method, "params": params }));
        loop {
            let m = self.receive();
            if m["id"] == json!(id) && m.get("method").is_none() {
                return m;
            }
            self.backlog.push(m);
        }
    }

    fn result(&mut self, method: &str, params: Value) -> Value {
        let response = self.request(method, params);
        assert!(response.get("error").is_none(), "{method} failed: {response}");
        response["result"].clone()
    }

    /// The diagnostics published for `uri` at `version`.
    fn diagnostics(&mut self, uri: &str, version: i64) -> Vec<Value> {
        let wanted = |m: &Value| {
            m["method"] == "textDocument/publishDiagnostics"
                && m["params"]["uri"] == uri
                && m["params"]["version"] == json!(version)
        };
        let deadline = Instant::now() + TIMEOUT;
        loop {
            if let Some(k) = self.backlog.iter().position(wanted) {
                let m = self.backlog.remove(k);
                return m["params"]["diagnostics"].as_array().cloned().unwrap_or_default();
            }
            assert!(Instant::now() < deadline, "no diagnostics for {uri} version {version}");
            let m = self.receive();
            self.backlog.push(m);
        }
    }

    fn open(&mut self, uri: &str, text: &str) {
        self.notify(
            "textDocument/didOpen",
            json!({ "textDocument": { "uri": uri, "languageId": "tsl", "version": 1, "text": text } }),
        );
    }

    fn change(&mut self, uri: &str, version: i64, changes: Value) {
        self.notify(
            "textDocument/didChange",
            json!({ "textDocument": { "uri": uri, "version": version }, "contentChanges": changes }),
        );
    }

    fn shutdown(self) {
        self.finish();
    }

    /// Shuts the server down and returns every message it sent that was
    /// not read yet.
    fn finish(mut self) -> Vec<Value> {
        let response = self.request("shutdown", Value::Null);
        assert!(response.get("error").is_none(), "{response}");
        self.notify("exit", Value::Null);
        let status = self.wait();
        assert!(status.success(), "tslc lsp exits cleanly: {status}");
        // The reader thread ends with the server's output.
        self.backlog.extend(self.incoming.iter());
        self.backlog
    }

    /// The server's exit status, once it has exited (it must, within the
    /// timeout).
    fn wait(&mut self) -> std::process::ExitStatus {
        let deadline = Instant::now() + TIMEOUT;
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                return status;
            }
            assert!(Instant::now() < deadline, "tslc lsp did not exit");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

/// A message body with its header.
fn framed(body: &[u8]) -> Vec<u8> {
    [format!("Content-Length: {}\r\n\r\n", body.len()).as_bytes(), body].concat()
}

/// The LSP position (line, UTF-16 column) of byte `offset` of `text`.
fn position(text: &str, offset: usize) -> Value {
    let before = &text[..offset];
    let line = before.matches('\n').count();
    let start = before.rfind('\n').map_or(0, |i| i + 1);
    json!({ "line": line, "character": before[start..].encode_utf16().count() })
}

/// The position just after the first `needle` that follows `after`.
fn at(text: &str, after: &str, needle: &str) -> Value {
    let from = text.find(after).expect("anchor");
    let k = from + text[from..].find(needle).expect("needle");
    position(text, k + 1)
}

fn text_of(result: &Value) -> String {
    result["contents"]["value"].as_str().unwrap_or_default().to_string()
}

#[test]
fn the_editor_walk_through_of_issue_14() {
    let mut client = Client::start("walk");
    let path = repo().join("examples/texture_tree.tsl");
    let text = std::fs::read_to_string(&path).unwrap();
    let doc = uri(&path);
    client.open(&doc, &text);
    assert_eq!(client.diagnostics(&doc, 1), Vec::<Value>::new(), "the example checks clean");

    // An error appears as it is typed, and disappears when it is removed.
    let line = text.lines().position(|l| l.starts_with("material white")).unwrap();
    let typo = json!([{ "range": { "start": { "line": line, "character": 17 }, "end": { "line": line, "character": 24 } },
                        "text": "lambret" }]);
    client.change(&doc, 2, typo);
    let diagnostics = client.diagnostics(&doc, 2);
    assert_eq!(diagnostics.len(), 1, "{diagnostics:?}");
    let message = diagnostics[0]["message"].as_str().unwrap();
    assert!(message.contains("lambret") && message.contains("lambert"), "{message}");
    assert_eq!(diagnostics[0]["range"]["start"], json!({ "line": line, "character": 17 }));
    let fix = json!([{ "range": { "start": { "line": line, "character": 17 }, "end": { "line": line, "character": 24 } },
                       "text": "lambert" }]);
    client.change(&doc, 3, fix);
    assert_eq!(client.diagnostics(&doc, 3), Vec::<Value>::new(), "the error is gone");

    // Hover on `fbm`: its signature and the stdlib's documentation.
    let hover = client.result(
        "textDocument/hover",
        json!({ "textDocument": { "uri": doc }, "position": at(&text, "color dirt", "fbm") }),
    );
    let shown = text_of(&hover);
    assert!(shown.contains("float fbm(point p, int octaves = 6, float lacunarity = 2, float gain = 0.5)"), "{shown}");
    assert!(shown.contains("Fractional Brownian motion"), "{shown}");
    // A builtin's documentation comes from docs/language.md.
    let hover = client.result(
        "textDocument/hover",
        json!({ "textDocument": { "uri": doc }, "position": at(&text, "color dirt", "smoothstep") }),
    );
    assert!(text_of(&hover).contains("Hermite"), "{hover}");
    // A local's type.
    let hover = client.result(
        "textDocument/hover",
        json!({ "textDocument": { "uri": doc }, "position": at(&text, "return cpg_union", "disc") }),
    );
    assert!(text_of(&hover).contains("float disc"), "{hover}");

    // Go to the definition of `wood_rings`: in the prelude.
    let definition = client.result(
        "textDocument/definition",
        json!({ "textDocument": { "uri": doc }, "position": at(&text, "material wood =", "wood_rings") }),
    );
    let target = definition["uri"].as_str().unwrap().strip_prefix("file://").unwrap().to_string();
    assert!(target.ends_with("stdlib/generators.tsl"), "{definition}");
    let line = definition["range"]["start"]["line"].as_u64().unwrap() as usize;
    let prelude = std::fs::read_to_string(&target).expect("the prelude file is written for the editor");
    assert!(prelude.lines().nth(line).unwrap().starts_with("float wood_rings("), "{definition}");

    // References of a material: its definition and its two uses.
    let refs = client.result(
        "textDocument/references",
        json!({ "textDocument": { "uri": doc }, "position": at(&text, "material light_brown", "light_brown"),
                "context": { "includeDeclaration": true } }),
    );
    assert_eq!(refs.as_array().unwrap().len(), text.matches("light_brown").count(), "{refs}");

    // The outline.
    let symbols = client.result("textDocument/documentSymbol", json!({ "textDocument": { "uri": doc } }));
    let names: Vec<&str> = symbols.as_array().unwrap().iter().filter_map(|s| s["name"].as_str()).collect();
    for name in ["picture", "contour", "wood", "decal", "framed", "scene"] {
        assert!(names.contains(&name), "{name} in {names:?}");
    }

    // Completing `phong(` offers its parameters, with their defaults and meaning.
    let probe = uri(&repo().join("examples/probe.tsl"));
    let typed = "material probe = phong(";
    client.open(&probe, typed);
    let end = position(typed, typed.len());
    let items = client.result("textDocument/completion", json!({ "textDocument": { "uri": probe }, "position": end }));
    let items = items.as_array().unwrap();
    let kd = items.iter().find(|i| i["label"] == "kd:").expect("kd: offered");
    assert_eq!(kd["detail"], "color kd = gray(0.5)");
    assert_eq!(kd["documentation"]["value"], "diffuse albedo");
    assert!(items.iter().any(|i| i["label"] == "ns:") && items.iter().any(|i| i["label"] == "ks:"));
    let help =
        client.result("textDocument/signatureHelp", json!({ "textDocument": { "uri": probe }, "position": end }));
    let label = help["signatures"][0]["label"].as_str().unwrap();
    assert_eq!(label, "material phong(color kd = gray(0.5), color ks = gray(0.2), float ns = 32)");
    assert_eq!(help["activeParameter"], 0);

    // Formatting.
    let messy = uri(&repo().join("examples/messy.tsl"));
    client.open(&messy, "float  f(float x){return x*2;}");
    let edits = client.result(
        "textDocument/formatting",
        json!({ "textDocument": { "uri": messy }, "options": { "tabSize": 4, "insertSpaces": true } }),
    );
    assert_eq!(edits[0]["newText"], "float f(float x) {\n    return x * 2;\n}\n", "{edits}");

    client.shutdown();
}

#[test]
fn hover_on_a_named_argument_shows_the_parameter_doc_comment_and_options() {
    let mut client = Client::start("param-docs");
    let doc = uri(&repo().join("examples/param_docs.tsl"));
    let text = "material tinted(\n    /// How much of the tint shows.\n    float amount = 0.5,\n    string tone = \"warm\" in (\"warm\", \"cold\"),\n) = lambert;\nmaterial m = tinted(amount: 0.2, tone: \"cold\");\n";
    client.open(&doc, text);
    let hover = |client: &mut Client, name: &str| {
        text_of(&client.result(
            "textDocument/hover",
            json!({ "textDocument": { "uri": doc }, "position": at(text, "material m", name) }),
        ))
    };
    let amount = hover(&mut client, "amount:");
    assert!(amount.contains("float amount = 0.5"), "{amount}");
    assert!(amount.contains("parameter of `tinted`: How much of the tint shows."), "{amount}");
    // On the declaration itself, too.
    let declared = text_of(&client.result(
        "textDocument/hover",
        json!({ "textDocument": { "uri": doc }, "position": at(text, "float", "amount") }),
    ));
    assert!(declared.contains("parameter: How much of the tint shows."), "{declared}");
    let tone = hover(&mut client, "tone:");
    assert!(tone.contains("string tone = \"warm\" in (\"warm\", \"cold\")"), "{tone}");
    client.shutdown();
}

#[test]
fn functions_show_their_doc_comments_and_parameter_docs() {
    let mut client = Client::start("function-docs");
    let doc = uri(&repo().join("examples/function_docs.tsl"));
    let text = "/// Rings of my own.\nfloat rings() {\n    return cpg_coverage(0.1, 0);\n}\n\
                material m = mix(cpg_ngon(vec2(0.5, 0.5), 0.4, 6), lambert, phong);\n";
    client.open(&doc, text);
    let hover =
        |client: &mut Client, after: &str, name: &str| {
            text_of(&client.result(
                "textDocument/hover",
                json!({ "textDocument": { "uri": doc }, "position": at(text, after, name) }),
            ))
        };
    // A `///` comment is shown without its slashes, the user's and the stdlib's.
    let own = hover(&mut client, "float", "rings");
    assert!(own.contains("Rings of my own.") && !own.contains("/ Rings"), "{own}");
    let coverage = hover(&mut client, "return", "cpg_coverage");
    assert!(coverage.contains("The coverage of a shape from its signed distance"), "{coverage}");
    assert!(!coverage.contains("/ The"), "{coverage}");
    // Signature help gives each parameter its own `///` comment.
    let help = client.result(
        "textDocument/signatureHelp",
        json!({ "textDocument": { "uri": doc }, "position": position(text, text.find("0.4, 6").unwrap() + 5) }),
    );
    assert_eq!(help["activeParameter"], 2, "{help}");
    let sides = &help["signatures"][0]["parameters"][2]["documentation"];
    assert!(sides.as_str().is_some_and(|d| d.contains("number of sides")), "{help}");
    client.shutdown();
}

#[test]
fn completion_knows_materials_and_scenes() {
    let mut client = Client::start("places");
    let doc = uri(&repo().join("examples/places.tsl"));
    let text = "material m(color kd = gray(0.5)) {\n    color diffuse() { return kd; }\n    \n}\nscene {\n    \n    object sphere { center (0, 1, 0);  }\n}\n";
    client.open(&doc, text);
    let complete = |client: &mut Client, offset: usize| -> Vec<Value> {
        let items = client.result(
            "textDocument/completion",
            json!({ "textDocument": { "uri": doc }, "position": position(text, offset) }),
        );
        items.as_array().cloned().unwrap_or_default()
    };
    let in_material = complete(&mut client, text.find("}\n    \n}").unwrap() + 6);
    let reflection = in_material.iter().find(|i| i["label"] == "reflection").expect("interface methods offered");
    assert_eq!(reflection["detail"], "color reflection(vector wi, color light, vector wo)");
    assert!(
        reflection["insertText"].as_str().unwrap().starts_with("color reflection(vector wi, color light, vector wo) {")
    );
    assert!(!in_material.iter().any(|i| i["label"] == "diffuse"), "defined methods are not offered again");

    let in_scene = complete(&mut client, text.find("scene {\n").unwrap() + 12);
    let labels: Vec<&str> = in_scene.iter().filter_map(|i| i["label"].as_str()).collect();
    for block in ["camera", "light point", "object sphere", "render", "background"] {
        assert!(labels.contains(&block), "{block} in {labels:?}");
    }
    let in_object = complete(&mut client, text.find("1, 0);").unwrap() + 7);
    let labels: Vec<&str> = in_object.iter().filter_map(|i| i["label"].as_str()).collect();
    assert!(labels.contains(&"radius") && labels.contains(&"material") && labels.contains(&"translate"), "{labels:?}");
    assert!(!labels.contains(&"center"), "given properties are not offered again: {labels:?}");
    client.shutdown();
}

/// A small deterministic generator (xorshift), so a failure repeats.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

#[test]
fn random_edits_never_crash_the_server() {
    let mut client = Client::start("fuzz");
    let path = repo().join("examples/texture_tree.tsl");
    let mut text = std::fs::read_to_string(&path).unwrap();
    let doc = uri(&path);
    client.open(&doc, &text);
    let (deep, chain) = ("(".repeat(300), "x + ".repeat(500));
    let pieces = [
        "(",
        ")",
        "{",
        "}",
        "[",
        "]",
        ";",
        ",",
        ".",
        ":",
        "\"",
        "/*",
        "*/",
        "//",
        "=",
        "..",
        "mix(",
        "phong(kd: ",
        "material ",
        "scene {",
        "light point {",
        "float x = ",
        "return ",
        "é",
        "😀",
        "\n",
        " ",
        "0.5",
        "1e99",
        "for i in 0..",
        "import \"nowhere.tsl\";",
        "fbm(",
        ".x",
        "select(face, [",
        "camera { from (0, 0, 0); }",
        "material m(float x) { color reflection(vector wi, color light, vector wo) { return ",
        // Deeper than the parser's nesting limit, and a long flat chain.
        &deep,
        &chain,
    ];
    let requests = [
        "textDocument/hover",
        "textDocument/completion",
        "textDocument/signatureHelp",
        "textDocument/definition",
        "textDocument/references",
        "textDocument/documentHighlight",
        "textDocument/documentSymbol",
        "textDocument/semanticTokens/full",
        "textDocument/formatting",
    ];
    // A longer campaign: TSL_LSP_FUZZ_SEED=N TSL_LSP_FUZZ_EDITS=M cargo test --test lsp random.
    let env = |name: &str, default: u64| std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default);
    let mut rng = Rng(env("TSL_LSP_FUZZ_SEED", 0x9e37_79b9_7f4a_7c15) | 1);
    let edits = env("TSL_LSP_FUZZ_EDITS", 120) as usize;
    for version in 2..2 + edits {
        // An edit: delete a few characters and insert a piece, in UTF-16
        // positions as an editor sends them.
        let mut start = rng.below(text.len() + 1);
        while !text.is_char_boundary(start) {
            start -= 1;
        }
        let mut end = (start + rng.below(8)).min(text.len());
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        let piece = pieces[rng.below(pieces.len())];
        let range = json!({ "start": position(&text, start), "end": position(&text, end) });
        client.change(&doc, version as i64, json!([{ "range": range, "text": piece }]));
        text.replace_range(start..end, piece);
        for _ in 0..3 {
            let method = requests[rng.below(requests.len())];
            let mut at = rng.below(text.len() + 1);
            while !text.is_char_boundary(at) {
                at -= 1;
            }
            // Sometimes a position past the end of its line or the text.
            let pos = if rng.below(10) == 0 {
                json!({ "line": rng.below(200), "character": rng.below(300) })
            } else {
                position(&text, at)
            };
            let mut params = json!({ "textDocument": { "uri": doc }, "position": pos });
            match method {
                "textDocument/references" => params["context"] = json!({ "includeDeclaration": true }),
                "textDocument/formatting" => params["options"] = json!({ "tabSize": 4, "insertSpaces": true }),
                _ => {}
            }
            let response = client.request(method, params);
            assert!(
                response.get("error").is_none(),
                "{method} at {pos} failed after edit {version}: {response}\n--- text ---\n{text}"
            );
        }
    }
    // The diagnostics worker is alive and saw the last text.
    let last = 1 + edits as i64;
    client.notify("textDocument/didSave", json!({ "textDocument": { "uri": doc } }));
    client.diagnostics(&doc, last);
    client.shutdown();
}

#[test]
fn imports_are_followed() {
    let mut client = Client::start("imports");
    let path = repo().join("tests/check/ok/imports.tsl");
    let text = std::fs::read_to_string(&path).unwrap();
    let doc = uri(&path);
    client.open(&doc, &text);
    let ends = |location: &Value, file: &str| location["uri"].as_str().unwrap().ends_with(file);

    let target = client.result(
        "textDocument/definition",
        json!({ "textDocument": { "uri": doc }, "position": at(&text, "material dartboard", "target") }),
    );
    assert!(ends(&target, "lib/shapes.tsl"), "{target}");
    let file = repo().join("tests/check/ok/lib/shapes.tsl");
    let line = target["range"]["start"]["line"].as_u64().unwrap() as usize;
    assert!(std::fs::read_to_string(file).unwrap().lines().nth(line).unwrap().starts_with("float target("));

    let import = client.result(
        "textDocument/definition",
        json!({ "textDocument": { "uri": doc }, "position": at(&text, "import \"lib/shapes", "shapes") }),
    );
    assert!(ends(&import, "lib/shapes.tsl") && import["range"]["start"]["line"] == 0, "{import}");

    // `ring_count` is defined in lib/rings.tsl and used here and in lib/shapes.tsl.
    let refs = client.result(
        "textDocument/references",
        json!({ "textDocument": { "uri": doc }, "position": at(&text, "float both", "ring_count"),
                "context": { "includeDeclaration": true } }),
    );
    let refs = refs.as_array().unwrap();
    for file in ["imports.tsl", "lib/shapes.tsl", "lib/rings.tsl"] {
        assert!(refs.iter().any(|r| ends(r, file)), "a reference in {file}: {refs:?}");
    }

    // An error inside an imported file is shown at the import.
    let dir = tempfile_dir::TempDir::new("broken-import");
    std::fs::write(dir.path().join("lib.tsl"), "float half() {\n    return 0.5 +;\n}\n").unwrap();
    let main = "import \"lib.tsl\";\nfloat f() { return half(); }\n";
    let main_uri = uri(&dir.path().join("main.tsl"));
    client.open(&main_uri, main);
    let diagnostics = client.diagnostics(&main_uri, 1);
    assert!(!diagnostics.is_empty(), "the imported file's error is reported");
    let d = &diagnostics[0];
    assert_eq!(d["range"]["start"]["line"], 0, "at the import: {d}");
    assert!(d["message"].as_str().unwrap().contains("lib.tsl"), "{d}");
    assert!(d["relatedInformation"][0]["location"]["uri"].as_str().unwrap().ends_with("lib.tsl"), "{d}");
    client.shutdown();
}

/// Answers a hover on `doc`: the server is alive and in step.
fn still_answers(client: &mut Client, doc: &str, after: &str) {
    let hover = client.request(
        "textDocument/hover",
        json!({ "textDocument": { "uri": doc }, "position": { "line": 0, "character": 7 } }),
    );
    assert!(hover.get("error").is_none() && hover["result"].is_object(), "after {after}: {hover}");
}

#[test]
fn unreadable_messages_are_answered_and_the_server_goes_on() {
    let mut client = Client::start("unreadable");
    let doc = uri(&repo().join("examples/unreadable.tsl"));
    client.open(&doc, "float f(float x) { return x; }\n");
    let (parse_error, invalid_request) = (-32700, -32600);
    let cases: Vec<(&str, Vec<u8>, i64)> = vec![
        // Bodies that are not JSON.
        ("truncated JSON", framed(br#"{"jsonrpc":"2.0","id":1,"method":"#), parse_error),
        ("a word", framed(b"hello"), parse_error),
        ("an empty body", framed(b""), parse_error),
        ("two objects", framed(b"{} {}"), parse_error),
        ("nesting past serde's limit", framed("[".repeat(10_000).as_bytes()), parse_error),
        // Bodies that are not UTF-8.
        (
            "invalid UTF-8 in a string",
            framed(b"{\"jsonrpc\":\"2.0\",\"method\":\"x\",\"params\":\"\xff\xfe\"}"),
            parse_error,
        ),
        ("a lone continuation byte", framed(b"\x80"), parse_error),
        ("a truncated character", framed(b"{\"a\":\"\xe2\x82\"}"), parse_error),
        // JSON that is not a request, notification or response.
        ("an empty batch", framed(b"[]"), invalid_request),
        ("a batch", framed(br#"[{"jsonrpc":"2.0","id":99,"method":"shutdown"}]"#), invalid_request),
        ("a number", framed(b"42"), invalid_request),
        ("a string", framed(br#""initialize""#), invalid_request),
        ("null", framed(b"null"), invalid_request),
        ("a fractional id", framed(br#"{"jsonrpc":"2.0","id":1.5,"method":"textDocument/hover"}"#), invalid_request),
        ("an id past 32 bits", framed(br#"{"jsonrpc":"2.0","id":4294967296,"method":"x"}"#), invalid_request),
        ("a method that is a number", framed(br#"{"jsonrpc":"2.0","method":7}"#), invalid_request),
        // Lengths over the bound, refused unread.
        ("a Content-Length of 10^14", b"Content-Length: 100000000000000\r\n\r\n".to_vec(), invalid_request),
        ("a length past 64 bits", b"Content-Length: 99999999999999999999999\r\n\r\n{}".to_vec(), invalid_request),
        ("a length of 2^40 with a body", b"Content-Length: 1099511627776\r\n\r\n{\"id\":1}".to_vec(), invalid_request),
        // Lengths that cannot be read, and headers that are not headers.
        ("a negative length", b"Content-Length: -5\r\n\r\n{}".to_vec(), parse_error),
        ("a length that is a word", b"Content-Length: twelve\r\n\r\n{}".to_vec(), parse_error),
        ("an empty length", b"Content-Length: \r\n\r\n{}".to_vec(), parse_error),
        ("no length", b"Content-Type: application/json\r\n\r\n{}".to_vec(), parse_error),
        ("two lengths", b"Content-Length: 2\r\nContent-Length: 3\r\n\r\n{}".to_vec(), parse_error),
        ("a header line without a colon", b"hello\r\n\r\n".to_vec(), parse_error),
        ("JSON without a header", b"{\"jsonrpc\":\"2.0\",\"id\":5,\"method\":\"shutdown\"}\r\n".to_vec(), parse_error),
        ("a header line of 1 MB", [vec![b'x'; 1 << 20], b"\r\n\r\n".to_vec()].concat(), parse_error),
        (
            "a length of 1 MB of digits",
            [b"Content-Length: ".to_vec(), vec![b'7'; 1 << 20], b"\r\n\r\n".to_vec()].concat(),
            parse_error,
        ),
    ];
    for (what, bytes, code) in cases {
        client.send_raw(&bytes);
        let refusal = client.response_to(Value::Null);
        assert_eq!(refusal["error"]["code"], code, "{what}: {refusal}");
        still_answers(&mut client, &doc, what);
    }
    // An unknown header of 1 MB is skipped: its message is answered.
    client.next_id += 1;
    let body = json!({ "jsonrpc": "2.0", "id": client.next_id, "method": "textDocument/documentSymbol",
                       "params": { "textDocument": { "uri": doc } } })
    .to_string();
    let padding = "p".repeat(1 << 20);
    client.send_raw(format!("X-Padding: {padding}\r\nContent-Length: {}\r\n\r\n{body}", body.len()).as_bytes());
    let symbols = client.response_to(json!(client.next_id));
    assert_eq!(symbols["result"][0]["name"], "f", "{symbols}");
    // Headers as some clients write them: only line feeds, any case, a content type.
    let body = br#"{"jsonrpc":"2.0","id":"lf","method":"textDocument/documentSymbol","params":{"textDocument":{"uri":"DOC"}}}"#;
    let body = String::from_utf8_lossy(body).replace("DOC", &doc);
    let header = format!("content-length:{}\nContent-Type: application/vscode-jsonrpc; charset=utf-8\n\n", body.len());
    client.send_raw(format!("{header}{body}").as_bytes());
    assert_eq!(client.response_to(json!("lf"))["result"][0]["name"], "f");
    client.shutdown();
}

#[test]
fn bad_requests_get_errors_with_their_ids() {
    let mut client = Client::start("bad-requests");
    let doc = uri(&repo().join("examples/bad_requests.tsl"));
    client.open(&doc, "float f(float x) { return x; }\n");
    let (invalid_request, method_not_found, invalid_params) = (-32600, -32601, -32602);
    let hover = "textDocument/hover";
    let cases = [
        (json!({ "jsonrpc": "2.0", "id": 7 }), invalid_request),
        (json!({ "jsonrpc": "2.0", "id": 8, "method": "textDocument/noSuchThing", "params": {} }), method_not_found),
        (json!({ "jsonrpc": "2.0", "id": 9, "method": "$/noSuchThing" }), method_not_found),
        (json!({ "jsonrpc": "2.0", "id": 10, "method": hover, "params": { "textDocument": 5 } }), invalid_params),
        (json!({ "jsonrpc": "2.0", "id": 11, "method": hover }), invalid_params),
        (json!({ "jsonrpc": "2.0", "id": 12, "method": hover, "params": [1, 2] }), invalid_params),
        (json!({ "jsonrpc": "2.0", "id": "thirteen", "method": hover, "params": "x" }), invalid_params),
        (
            json!({ "jsonrpc": "2.0", "id": 14, "method": "textDocument/semanticTokens/full",
                    "params": { "textDocument": { "uri": "not a uri" } } }),
            invalid_params,
        ),
        (
            json!({ "jsonrpc": "2.0", "id": 15, "method": hover,
                    "params": { "textDocument": { "uri": doc }, "position": { "line": -1, "character": 0 } } }),
            invalid_params,
        ),
    ];
    for (message, code) in cases {
        let id = message["id"].clone();
        client.send(message.clone());
        let answer = client.response_to(id.clone());
        assert_eq!(answer["error"]["code"], code, "{message}: {answer}");
        still_answers(&mut client, &doc, &message.to_string());
    }
    // Notifications with bad parameters are dropped (and logged).
    for params in [json!({ "textDocument": 1 }), json!(null), json!([]), json!({ "contentChanges": "x" })] {
        for method in ["textDocument/didOpen", "textDocument/didChange", "textDocument/didClose"] {
            client.notify(method, params.clone());
            still_answers(&mut client, &doc, method);
        }
    }
    client.shutdown();
}

#[test]
fn initialization_and_shutdown_survive_bad_messages() {
    let mut client = Client::spawn("init");
    client.send(json!({ "jsonrpc": "2.0", "id": 1, "method": "textDocument/hover", "params": {} }));
    assert_eq!(client.response_to(json!(1))["error"]["code"], -32002, "not initialized yet");
    client.send_raw(&framed(b"[]"));
    assert_eq!(client.response_to(Value::Null)["error"]["code"], -32600);
    for params in [json!({ "capabilities": 5 }), json!([]), json!("x")] {
        client.send(json!({ "jsonrpc": "2.0", "id": 2, "method": "initialize", "params": params }));
        assert_eq!(client.response_to(json!(2))["error"]["code"], -32602, "{params}");
    }
    client.initialize();
    // A request before `initialized` is answered all the same.
    let doc = uri(&repo().join("examples/init.tsl"));
    client.open(&doc, "float f(float x) { return x; }\n");
    still_answers(&mut client, &doc, "initialize");
    // After `shutdown`, requests are refused until `exit`.
    assert!(client.request("shutdown", Value::Null).get("error").is_none());
    let late = client.request("textDocument/documentSymbol", json!({ "textDocument": { "uri": doc } }));
    assert_eq!(late["error"]["code"], -32600, "{late}");
    client.notify("exit", Value::Null);
    assert!(client.wait().success());
}

#[test]
fn input_that_ends_mid_message_stops_the_server_with_an_error() {
    for ending in [&b"Content-Length: 100\r\n\r\n{\"jsonrpc\":"[..], b"Content-Len", b"Content-Length: 10\r\n"] {
        let mut client = Client::start("ending");
        client.send_raw(ending);
        client.stdin = None;
        // The protocol's exit status for a client gone without `shutdown`.
        let status = client.wait();
        assert_eq!(status.code(), Some(1), "{}: {status}", String::from_utf8_lossy(ending));
    }
}

/// `functions` small functions on one line (10,300: 667 KB, 72,096
/// semantic tokens).
fn one_line_program(functions: usize) -> String {
    let mut text = String::from("float f0(float x) { return x; } ");
    for k in 1..functions {
        text.push_str(&format!("float f{k}(float x) {{ float y = f{}(x) * 0.5; return y + x; }} ", k - 1));
    }
    text
}

#[test]
fn requests_on_a_665_kb_line_take_linear_time() {
    // Each within the client's 60 s timeout in a debug build; counting
    // every position from the line's start took 80 s (semantic tokens)
    // and 35 s (symbols) in a release build.
    let mut client = Client::start("one-line");
    let text = one_line_program(10_300);
    assert!(text.len() > 665_000);
    let doc = uri(&repo().join("examples/one_line.tsl"));
    client.open(&doc, &text);
    let tokens = client.result("textDocument/semanticTokens/full", json!({ "textDocument": { "uri": doc } }));
    let data: Vec<u64> = tokens["data"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect();
    // f0, x, x; then each function: its name, x, y, the call, x, y, x.
    assert_eq!(data.len() / 5, 3 + 7 * 10_299);
    assert!(data.chunks(5).all(|t| t[0] == 0), "one line");
    let last: u64 = data.chunks(5).map(|t| t[1]).sum();
    assert_eq!(last as usize, text.rfind("+ x").unwrap() + 2, "the last token's column");

    let symbols = client.result("textDocument/documentSymbol", json!({ "textDocument": { "uri": doc } }));
    let symbols = symbols.as_array().unwrap();
    assert_eq!(symbols.len(), 10_300);
    assert_eq!(symbols[10_299]["selectionRange"]["start"]["character"], text.rfind("f10299").unwrap());

    let at = json!({ "line": 0, "character": text.rfind("f10298").unwrap() + 1 });
    let hover = client.result("textDocument/hover", json!({ "textDocument": { "uri": doc }, "position": at }));
    assert!(text_of(&hover).contains("float f10298(float x)"), "{hover}");
    let highlights =
        client.result("textDocument/documentHighlight", json!({ "textDocument": { "uri": doc }, "position": at }));
    assert_eq!(highlights.as_array().unwrap().len(), 2, "the definition and the call");
    let end = json!({ "line": 0, "character": text.encode_utf16().count() + 10 });
    client.result("textDocument/completion", json!({ "textDocument": { "uri": doc }, "position": end }));
    assert_eq!(client.diagnostics(&doc, 1), Vec::<Value>::new());
    client.shutdown();
}

#[test]
fn references_index_the_file_once() {
    // 40,000 references in a 1.5 MB file: indexing it per reference took
    // 30 s for half as many in a release build.
    let mut client = Client::start("references");
    let mut text = String::from("float f(float x) {\n    return x;\n}\n");
    for k in 0..40_000 {
        text.push_str(&format!("float g{k}(float x) {{ return f(x); }}\n"));
    }
    let doc = uri(&repo().join("examples/references.tsl"));
    client.open(&doc, &text);
    let at = json!({ "line": 0, "character": 6 });
    let refs = client.result(
        "textDocument/references",
        json!({ "textDocument": { "uri": doc }, "position": at, "context": { "includeDeclaration": true } }),
    );
    let refs = refs.as_array().unwrap();
    assert_eq!(refs.len(), 40_001);
    assert_eq!(refs[40_000]["range"]["start"], json!({ "line": 40_002, "character": 31 }), "{}", refs[40_000]);
    client.shutdown();
}

/// A program the checker takes seconds on in a debug build (4 MB).
fn slow_program() -> String {
    let mut text = String::from("float f0(float x) { return x; }\n");
    for k in 1..60_000 {
        text.push_str(&format!("float f{k}(float x) {{ float y = f{}(x) * 0.5; return y + x; }}\n", k - 1));
    }
    text
}

#[test]
fn a_slow_document_does_not_delay_the_others() {
    let mut client = Client::start("slow");
    let slow = uri(&repo().join("examples/slow.tsl"));
    client.open(&slow, &slow_program());
    for k in 0..3 {
        let fast = uri(&repo().join(format!("examples/fast{k}.tsl")));
        client.open(&fast, "float f() { return nowhere; }\n");
        let diagnostics = client.diagnostics(&fast, 1);
        assert!(diagnostics[0]["message"].as_str().unwrap().contains("nowhere"), "{diagnostics:?}");
    }
    assert_eq!(client.published(&slow), Vec::<Value>::new(), "the others did not wait for the slow one");
    // Shutting down cancels the slow check.
    client.finish();
}

#[test]
fn stale_versions_are_never_published() {
    let mut client = Client::start("stale");
    let doc = uri(&repo().join("examples/stale.tsl"));
    // A slow first version, replaced at once.
    client.open(&doc, &slow_program());
    client.change(&doc, 2, json!([{ "text": "float f() { return version_two; }\n" }]));
    let diagnostics = client.diagnostics(&doc, 2);
    assert!(diagnostics[0]["message"].as_str().unwrap().contains("version_two"), "{diagnostics:?}");
    // A document's checks run one at a time: a check of version 1 would
    // have been published before version 2's.
    assert!(client.published(&doc).is_empty(), "{:?}", client.published(&doc));

    // Several slow versions in a row, saved (checked at once) and closed.
    for version in 3..6 {
        client.change(&doc, version, json!([{ "text": slow_program() }]));
        client.notify("textDocument/didSave", json!({ "textDocument": { "uri": doc } }));
    }
    client.notify("textDocument/didClose", json!({ "textDocument": { "uri": doc } }));
    let rest = client.finish();
    let published: Vec<&Value> = rest.iter().filter(|m| m["params"]["uri"] == doc).collect();
    assert_eq!(published.len(), 1, "only the clearing on close: {published:?}");
    assert_eq!(published[0]["params"]["diagnostics"], json!([]));
    assert_eq!(published[0]["params"]["version"], Value::Null);
}
