//! The editor grammar (`editors/tsl.tmLanguage.json`) and the VS Code
//! extension folder: every keyword and type the lexer knows is highlighted,
//! the extension's copy of the grammar is the canonical one, and the
//! extension's manifests are valid JSON naming files that exist. Tokenizing
//! the examples with a real TextMate engine is `scripts/test-editor-grammar.sh`
//! (needs npm; not run in CI).

use std::path::{Path, PathBuf};

use serde_json::Value;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(root().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

fn json(rel: &str) -> Value {
    serde_json::from_str(&read(rel)).unwrap_or_else(|e| panic!("{rel} is not valid JSON: {e}"))
}

/// The word tokens of the lexer: `#[token("word")]` entries that are identifiers.
fn lexer_words() -> Vec<String> {
    let src = read("src/syntax/lexer.rs");
    let mut words = Vec::new();
    for piece in src.split("#[token(\"").skip(1) {
        let text = &piece[..piece.find('"').expect("closing quote")];
        let ident = text.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && text.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if ident && piece[text.len()..].starts_with("\")]") {
            words.push(text.to_string());
        }
    }
    words
}

/// The `match` regexes of the grammar's keyword, type and constant rules.
fn keyword_patterns(grammar: &Value) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for section in ["keywords", "types", "constants"] {
        let patterns = grammar["repository"][section]["patterns"]
            .as_array()
            .unwrap_or_else(|| panic!("repository.{section}.patterns missing"));
        for p in patterns {
            let name = p["name"].as_str().expect("rule has a scope name").to_string();
            let re = p["match"].as_str().expect("rule has a match").to_string();
            out.push((name, re));
        }
    }
    out
}

/// The words of a rule of the form `\b(a|b|c)\b`.
fn alternatives(re: &str) -> Vec<String> {
    let inner = re
        .strip_prefix("\\b(")
        .and_then(|r| r.strip_suffix(")\\b"))
        .unwrap_or_else(|| panic!("keyword rule is not `\\b(a|b|...)\\b`: {re}"));
    inner.split('|').map(str::to_string).collect()
}

#[test]
fn the_lexer_has_keywords() {
    let words = lexer_words();
    for w in ["if", "material", "float", "vec2", "true", "void"] {
        assert!(words.iter().any(|x| x == w), "`{w}` not found in lexer.rs: {words:?}");
    }
}

#[test]
fn every_keyword_and_type_is_highlighted() {
    let grammar = json("editors/tsl.tmLanguage.json");
    assert_eq!(grammar["scopeName"], "source.tsl");
    let rules = keyword_patterns(&grammar);
    let mut missing = Vec::new();
    for w in lexer_words() {
        let scope = rules.iter().find(|(_, re)| alternatives(re).contains(&w)).map(|(n, _)| n.as_str());
        let want = match w.as_str() {
            "true" | "false" => "constant.language.",
            _ => "",
        };
        match scope {
            Some(s) if want.is_empty() && (s.starts_with("keyword.") || s.starts_with("storage.")) => {}
            Some(s) if !want.is_empty() && s.starts_with(want) => {}
            other => missing.push(format!("{w} ({other:?})")),
        }
    }
    assert!(missing.is_empty(), "lexer words without a keyword/type/constant rule: {missing:?}");
}

#[test]
fn every_builtin_name_in_the_grammar_is_a_builtin() {
    let grammar = json("editors/tsl.tmLanguage.json");
    let re = grammar["repository"]["builtins"]["patterns"][0]["match"].as_str().expect("builtins rule");
    let names = re.strip_prefix("\\b(").and_then(|r| r.split_once(")\\b")).expect("`\\b(a|b)\\b...`").0;
    let table = read("src/check/builtins.rs");
    for name in names.split('|') {
        assert!(table.contains(&format!("\"{name}\"")), "`{name}` is not in the builtin table");
    }
}

#[test]
fn the_extension_grammar_is_the_canonical_one() {
    assert!(
        read("editors/tsl.tmLanguage.json") == read("editors/vscode/syntaxes/tsl.tmLanguage.json"),
        "editors/vscode/syntaxes/tsl.tmLanguage.json differs from editors/tsl.tmLanguage.json: copy it"
    );
}

fn assert_exists(dir: &Path, rel: &str, from: &str) {
    assert!(dir.join(rel).is_file(), "{from} names {rel}, which does not exist");
}

#[test]
fn the_extension_manifest_is_valid_and_its_paths_exist() {
    let dir = root().join("editors/vscode");
    let pkg = json("editors/vscode/package.json");
    assert_exists(&dir, pkg["main"].as_str().expect("main"), "package.json");
    let c = &pkg["contributes"];
    let lang = &c["languages"][0];
    assert_eq!(lang["id"], "tsl");
    assert!(lang["extensions"].as_array().expect("extensions").contains(&Value::from(".tsl")));
    assert_exists(&dir, lang["configuration"].as_str().expect("configuration"), "package.json");
    let g = &c["grammars"][0];
    assert_eq!(g["language"], "tsl");
    assert_eq!(g["scopeName"], "source.tsl");
    assert_exists(&dir, g["path"].as_str().expect("grammar path"), "package.json");
    assert_eq!(c["configuration"]["properties"]["tsl.server.path"]["default"], "tslc");

    let conf = json("editors/vscode/language-configuration.json");
    assert_eq!(conf["comments"]["lineComment"], "//");
    assert_eq!(conf["comments"]["blockComment"], serde_json::json!(["/*", "*/"]));
    assert!(conf["brackets"].as_array().is_some_and(|b| b.len() == 3));
    assert!(conf["autoClosingPairs"].as_array().is_some_and(|b| !b.is_empty()));

    let ext = read("editors/vscode/extension.js");
    assert!(ext.contains("\"lsp\""), "extension.js should start `tslc lsp`");
}
