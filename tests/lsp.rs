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
    stdin: ChildStdin,
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
    fn start(tag: &str) -> Client {
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
        let mut client = Client { child, stdin, incoming, backlog: Vec::new(), next_id: 0, _cache: cache };
        let init = client.request(
            "initialize",
            json!({
                "processId": null,
                "rootUri": uri(&repo()),
                "capabilities": { "textDocument": { "completion": { "completionItem": { "snippetSupport": true } } } },
                "initializationOptions": { "importPaths": ["examples"] },
            }),
        );
        assert!(init["result"]["capabilities"]["hoverProvider"].as_bool().unwrap_or(false), "{init}");
        client.notify("initialized", json!({}));
        client
    }

    fn send(&mut self, message: Value) {
        let body = message.to_string();
        write!(self.stdin, "Content-Length: {}\r\n\r\n{body}", body.len()).unwrap();
        self.stdin.flush().unwrap();
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

    fn shutdown(mut self) {
        let response = self.request("shutdown", Value::Null);
        assert!(response.get("error").is_none(), "{response}");
        self.notify("exit", Value::Null);
        let deadline = Instant::now() + TIMEOUT;
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                assert!(status.success(), "tslc lsp exits cleanly: {status}");
                return;
            }
            assert!(Instant::now() < deadline, "tslc lsp did not exit");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
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
