//! The user guide (`docs/book/`) and the README stay true:
//!
//! - every ```tsl block passes `tslc check` (a block marked ```tsl,fragment
//!   is skipped; a block that only includes a scene checks the scene file);
//! - every relative link and image points at a file that exists, and a
//!   `#anchor` at a heading of its page;
//! - the generated reference pages (standard materials and generators, from
//!   the stdlib's own doc comments; the command line, from clap's help) match
//!   what the code says now. `UPDATE_EXPECT=1 cargo test --test book`
//!   rewrites them; and every stdlib material, generator and parameter has
//!   the `///` comment those pages are made from;
//! - every page with a ```rust block is one `src/lib.rs` runs as doctests.

use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn book_src() -> PathBuf {
    root().join("docs/book/src")
}

/// Every `.md` file under `dir`, in a stable order (symbolic links to
/// folders, such as the gallery, are not followed).
fn markdown_files(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut entries: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap()).collect();
    entries.sort_by_key(|e| e.path());
    for entry in entries {
        let kind = entry.file_type().unwrap();
        if kind.is_dir() {
            files.extend(markdown_files(&entry.path()));
        } else if kind.is_file() && entry.path().extension().is_some_and(|e| e == "md") {
            files.push(entry.path());
        }
    }
    files
}

/// The pages these tests read: the book's, the Markdown files its pages
/// include (docs/language.md), the README and the docs pages it links to.
fn pages() -> Vec<PathBuf> {
    let mut pages = markdown_files(&book_src());
    let mut included = BTreeSet::new();
    for page in &pages {
        let text = std::fs::read_to_string(page).unwrap();
        for (_, target) in includes(&text) {
            let path = page.parent().unwrap().join(target);
            if path.extension().is_some_and(|e| e == "md") {
                included.insert(normalise(&path));
            }
        }
    }
    pages.extend(included);
    for page in ["README.md", "docs/status.md", "docs/performance.md"] {
        pages.push(root().join(page));
    }
    pages
}

/// `a/b/../c` as `a/c`, without touching the file system.
fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for part in path.components() {
        match part {
            std::path::Component::ParentDir => {
                out.pop();
            }
            std::path::Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

fn shown(path: &Path) -> String {
    path.strip_prefix(root()).unwrap_or(path).display().to_string()
}

/// The `{{#include PATH}}` directives of a page: (line number, PATH).
fn includes(text: &str) -> Vec<(usize, &str)> {
    let mut found = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let mut rest = line;
        while let Some(start) = rest.find("{{#include ") {
            let after = &rest[start + "{{#include ".len()..];
            let Some(end) = after.find("}}") else { break };
            found.push((i + 1, after[..end].trim()));
            rest = &after[end..];
        }
    }
    found
}

/// A fenced code block: its info string, the line of its opening fence and
/// its text.
struct Block {
    info: String,
    line: usize,
    text: String,
}

fn code_blocks(text: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut open: Option<Block> = None;
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        match open.as_mut() {
            None if trimmed.starts_with("```") => {
                open = Some(Block { info: trimmed[3..].trim().to_string(), line: i + 1, text: String::new() });
            }
            Some(_) if trimmed.starts_with("```") => blocks.push(open.take().unwrap()),
            Some(block) => {
                block.text.push_str(line);
                block.text.push('\n');
            }
            None => {}
        }
    }
    assert!(open.is_none(), "a code block is not closed");
    blocks
}

/// The lines of a page outside fenced code blocks, with their numbers.
fn prose_lines(text: &str) -> Vec<(usize, &str)> {
    let mut inside = false;
    let mut lines = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            inside = !inside;
        } else if !inside {
            lines.push((i + 1, line));
        }
    }
    lines
}

fn tslc() -> Command {
    Command::new(env!("CARGO_BIN_EXE_tslc"))
}

/// Runs `tslc check` on a block, as if it were a file beside its page (so
/// relative paths in it resolve from there); `Err` holds what tslc said.
fn check_block(page: &Path, block: &Block) -> Result<(), String> {
    let dir = page.parent().unwrap();
    let trimmed = block.text.trim();
    let output = match includes(trimmed).as_slice() {
        [(_, target)] if trimmed.starts_with("{{#include") && trimmed.ends_with("}}") => {
            tslc().arg("check").arg(dir.join(target)).output().unwrap()
        }
        _ => {
            let mut child = tslc()
                .args(["check", "-", "--stdin-path"])
                .arg(dir.join(format!("book-block-{}.tsl", block.line)))
                .stdin(Stdio::piped())
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap();
            child.stdin.take().unwrap().write_all(block.text.as_bytes()).unwrap();
            child.wait_with_output().unwrap()
        }
    };
    if output.status.success() { Ok(()) } else { Err(String::from_utf8_lossy(&output.stderr).into_owned()) }
}

#[test]
fn every_tsl_block_checks() {
    let mut failures = Vec::new();
    let mut checked = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        for block in code_blocks(&text) {
            let mut words = block.info.split(',').map(str::trim);
            if words.next() != Some("tsl") {
                continue;
            }
            if words.any(|w| w == "fragment") {
                continue;
            }
            checked += 1;
            if let Err(e) = check_block(&page, &block) {
                failures.push(format!("{}:{}: this tsl block does not check:\n{e}", shown(&page), block.line));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(checked >= 20, "only {checked} tsl blocks found: is the book where this test looks?");
}

/// A heading's anchor as mdBook and GitHub make it: lower case, spaces as
/// `-`, punctuation other than `-` and `_` dropped.
fn anchor_of(heading: &str) -> String {
    let mut text = heading.trim_start_matches('#').trim().to_string();
    // A link in a heading counts by its text.
    while let (Some(open), Some(mid)) = (text.find('['), text.find("](")) {
        let Some(close) = text[mid..].find(')') else { break };
        if open > mid {
            break;
        }
        text = format!("{}{}{}", &text[..open], &text[open + 1..mid], &text[mid + close + 1..]);
    }
    text.chars()
        .filter_map(|c| {
            if c.is_alphanumeric() || c == '_' || c == '-' {
                Some(c.to_lowercase().next().unwrap())
            } else if c.is_whitespace() {
                Some('-')
            } else {
                None
            }
        })
        .collect()
}

/// The anchors of a page's headings, those of the pages it includes too.
fn anchors(page: &Path) -> BTreeSet<String> {
    let text = std::fs::read_to_string(page).unwrap_or_default();
    let mut found: BTreeSet<String> =
        prose_lines(&text).into_iter().filter(|(_, l)| l.starts_with('#')).map(|(_, l)| anchor_of(l)).collect();
    for (_, target) in includes(&text) {
        let path = page.parent().unwrap().join(target);
        if path.extension().is_some_and(|e| e == "md") {
            found.extend(anchors(&path));
        }
    }
    found
}

/// The targets of a line's links and images, code spans left out.
fn link_targets(line: &str) -> Vec<String> {
    let prose: String = line.split('`').step_by(2).collect::<Vec<_>>().join(" ");
    let mut targets = Vec::new();
    let mut rest = prose.as_str();
    while let Some(start) = rest.find("](") {
        let after = &rest[start + 2..];
        let end = after.find(')').unwrap_or(after.len());
        // `[text](target "title")`: the target is the first word.
        targets.push(after[..end].split_whitespace().next().unwrap_or("").to_string());
        rest = &after[end..];
    }
    targets
}

#[test]
fn every_relative_link_and_image_resolves() {
    let mut failures = Vec::new();
    let mut links = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let dir = page.parent().unwrap();
        for (line, target) in includes(&text) {
            if !dir.join(target).is_file() {
                failures.push(format!("{}:{line}: includes `{target}`, which does not exist", shown(&page)));
            }
        }
        for (line, prose) in prose_lines(&text) {
            for target in link_targets(prose) {
                if target.contains("://") || target.starts_with("mailto:") {
                    continue;
                }
                links += 1;
                let (path, anchor) = match target.split_once('#') {
                    Some((path, anchor)) => (path, Some(anchor)),
                    None => (target.as_str(), None),
                };
                let file = if path.is_empty() { page.clone() } else { dir.join(path) };
                if !file.exists() {
                    failures.push(format!("{}:{line}: `{target}` points at nothing", shown(&page)));
                } else if let Some(anchor) = anchor
                    && file.extension().is_some_and(|e| e == "md")
                    && !anchors(&file).contains(anchor)
                {
                    failures.push(format!(
                        "{}:{line}: `{target}`: {} has no heading `#{anchor}`",
                        shown(&page),
                        shown(&file)
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(links >= 30, "only {links} links found");
}

/// Compares a generated page with the checked-in one, or rewrites it under
/// `UPDATE_EXPECT=1`.
fn expect_page(relative: &str, generated: &str) {
    let path = book_src().join(relative);
    if std::env::var_os("UPDATE_EXPECT").is_some() {
        std::fs::write(&path, generated).unwrap();
        return;
    }
    let current = std::fs::read_to_string(&path).unwrap_or_default();
    if current != generated {
        let line = current
            .lines()
            .zip(generated.lines())
            .position(|(a, b)| a != b)
            .map_or_else(|| current.lines().count().min(generated.lines().count()) + 1, |i| i + 1);
        panic!(
            "{} is stale (first difference at line {line}); regenerate it with \
             `UPDATE_EXPECT=1 cargo test --test book`",
            shown(&path)
        );
    }
}

fn generated_note(from: &str) -> String {
    format!(
        "<!-- Generated by tests/book.rs from {from}: do not edit by hand. \
         `UPDATE_EXPECT=1 cargo test --test book` rewrites it. -->\n\n"
    )
}

/// Code for a Markdown table cell: one line, `|` escaped.
fn code_cell(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ").replace('|', "\\|")
}

/// Prose for a Markdown table cell: as code, and no raw HTML.
fn cell(text: &str) -> String {
    code_cell(text).replace('<', "&lt;")
}

#[test]
fn materials_page_is_current() {
    let program = tsl::Compiler::new().source("book.tsl", "material probe = lambert;").compile().unwrap();
    let mut page = String::from("# Standard materials\n\n");
    page += &generated_note("the standard library's `///` comments (`tslc query FILE --prelude` lists the same)");
    page += "Every material here is in the prelude, so any file can use it by name. Every parameter \
             has a default: a bare name is a usable material, and named arguments change what you \
             need:\n\n```tsl\nmaterial plain = lambert;\nmaterial gold = rough_conductor(alpha: 0.05, \
             eta: AU_ETA, k: AU_K);\n```\n\nThe sources are `stdlib/materials.tsl` (the classic models), \
             `stdlib/physical.tsl` (Mitsuba's physically based ones), `stdlib/openpbr.tsl` (OpenPBR \
             Surface) and `stdlib/texturing.tsl` (the texturing techniques); each file opens with notes \
             on its conventions.\n";
    let shaders: Vec<_> = program.shaders().into_iter().filter(|s| s.in_prelude()).collect();
    assert!(shaders.len() >= 15, "only {} prelude materials", shaders.len());
    for shader in shaders {
        page += &format!("\n## `{}`\n\n", shader.name());
        if let Some(doc) = shader.doc() {
            page += &format!("{}\n\n", cell(doc));
        }
        if shader.params().is_empty() {
            page += "No parameters.\n";
            continue;
        }
        page += "| Parameter | Type | Default | Meaning |\n|---|---|---|---|\n";
        for p in shader.params() {
            let default = p.default_source.as_deref().map_or("required".to_string(), |d| format!("`{}`", code_cell(d)));
            let mut meaning = cell(p.doc.as_deref().unwrap_or(""));
            if !p.options.is_empty() {
                let options: Vec<String> = p.options.iter().map(|o| format!("`\"{o}\"`")).collect();
                meaning += &format!(" (one of {})", options.join(", "));
            }
            page += &format!("| `{}` | `{}` | {default} | {} |\n", p.name, p.type_text(), meaning.trim());
        }
    }
    page += "\n## Measured metals\n\nComplex indices of refraction for `conductor` and `rough_conductor` \
             (`stdlib/metals.tsl`), as `eta`/`k` pairs:\n\n";
    let metals = std::fs::read_to_string(root().join("stdlib/metals.tsl")).unwrap();
    let names: Vec<String> = metals
        .lines()
        .filter_map(|l| l.strip_prefix("const color "))
        .map(|l| format!("`{}`", l.split_whitespace().next().unwrap()))
        .collect();
    assert!(!names.is_empty());
    page += &format!("{}.\n", names.join(", "));
    expect_page("reference/materials.md", &page);
}

/// A stdlib file's opening comment block, without its `//`: its title (the
/// text after `--` on the first lines) and the paragraphs before the first
/// rule under it.
fn header_comment(source: &str) -> (String, String) {
    let lines: Vec<&str> = source
        .lines()
        .map_while(|l| l.strip_prefix("//"))
        .map(|l| l.strip_prefix(' ').unwrap_or(l).trim_end())
        .collect();
    let is_rule = |l: &&str| l.len() >= 3 && l.chars().all(|c| c == '=' || c == '-');
    let mut parts = lines.split(is_rule).filter(|part| part.iter().any(|l| !l.trim().is_empty()));
    let mut title_and_intro = parts.next().unwrap_or_default().split(|l| l.trim().is_empty());
    let title: Vec<&str> = title_and_intro.next().unwrap_or_default().iter().map(|l| l.trim()).collect();
    let title = title.join(" ");
    let title = title.split_once(" -- ").map_or(title.as_str(), |(_, t)| t).to_string();
    let intro = parts.next().unwrap_or_default().join("\n");
    (title, intro.trim().to_string())
}

/// The stdlib files whose functions and constants are the generators page:
/// every one of them, and every parameter, has a `///` doc comment.
const GENERATOR_FILES: [&str; 3] = ["stdlib/generators.tsl", "stdlib/texturing.tsl", "stdlib/math.tsl"];

/// A parameter of a stdlib definition as its source declares it.
struct ParamDoc {
    name: String,
    ty: String,
    default: Option<String>,
    doc: Option<String>,
}

/// A top-level definition of a stdlib file as its source declares it.
struct Definition {
    kind: &'static str,
    name: String,
    /// One line: `float fbm(point p, int octaves = 6)`, `const float PI`.
    signature: String,
    line: usize,
    doc: Option<String>,
    params: Vec<ParamDoc>,
}

/// The functions, constants and materials of a stdlib file, in source
/// order, with their `///` comments (read by the compiler's own parser and
/// `tsl::syntax::doc_comment`, as the embedding API reads materials').
fn definitions(source: &str) -> Vec<Definition> {
    use tsl::syntax::ast::{Item, Param};
    let (file, diagnostics) = tsl::syntax::parse(tsl::diag::FileId(0), source);
    assert!(diagnostics.iter().all(|d| !d.is_error()), "a stdlib file does not parse");
    let text = |span: tsl::diag::Span| source[span.start as usize..span.end as usize].to_string();
    let params = |ps: &[Param]| -> Vec<ParamDoc> {
        ps.iter()
            .map(|p| ParamDoc {
                name: p.name.name.to_string(),
                ty: text(p.ty.span),
                default: p.default.as_ref().map(|d| text(d.span)),
                doc: tsl::syntax::doc_comment(source, p.span.start as usize),
            })
            .collect()
    };
    let mut found = Vec::new();
    for item in &file.items {
        let (kind, name, start, ps, head) = match item {
            Item::Function(f) => ("function", &f.name, f.span.start, params(&f.params), text(f.ret.span)),
            Item::Const(c) => ("constant", &c.name, c.span.start, Vec::new(), format!("const {}", text(c.ty.span))),
            Item::Material(m) => ("material", &m.name, m.span.start, params(&m.params), "material".into()),
            Item::MaterialTree(t) => {
                ("material", &t.name, t.span.start, params(t.params.as_deref().unwrap_or_default()), "material".into())
            }
            Item::Import { .. } | Item::Scene(_) => continue,
        };
        let shown: Vec<String> = ps
            .iter()
            .map(|p| match &p.default {
                Some(d) => format!("{} {} = {}", p.ty, p.name, code_cell(d)),
                None => format!("{} {}", p.ty, p.name),
            })
            .collect();
        let signature = match kind {
            "function" => format!("{head} {}({})", name.name, shown.join(", ")),
            _ => format!("{head} {}", name.name),
        };
        found.push(Definition {
            kind,
            name: name.name.to_string(),
            signature,
            line: source[..start as usize].lines().count() + 1,
            doc: tsl::syntax::doc_comment(source, start as usize),
            params: ps,
        });
    }
    found
}

/// Prose for a Markdown page: `<` outside code spans escaped, so no text
/// reads as raw HTML.
fn prose(text: &str) -> String {
    text.split('`')
        .enumerate()
        .map(|(k, part)| if k % 2 == 0 { part.replace('<', "&lt;") } else { part.to_string() })
        .collect::<Vec<_>>()
        .join("`")
}

/// A doc comment as Markdown: its paragraphs as prose, and each line
/// `Example: ITEM` as a ```tsl block, so the book's tests check it.
fn doc_markdown(doc: &str) -> String {
    let mut out = String::new();
    for paragraph in doc.split("\n\n") {
        let mut words: Vec<&str> = Vec::new();
        let flush = |words: &mut Vec<&str>, out: &mut String| {
            if !words.is_empty() {
                *out += &format!("{}\n\n", prose(&words.join(" ")));
                words.clear();
            }
        };
        for line in paragraph.lines() {
            match line.trim().strip_prefix("Example: ") {
                Some(example) => {
                    flush(&mut words, &mut out);
                    out += &format!("```tsl\n{example}\n```\n\n");
                }
                None => words.extend(line.split_whitespace()),
            }
        }
        flush(&mut words, &mut out);
    }
    out
}

#[test]
fn generators_page_is_current() {
    let mut page = String::from("# Standard generators\n\n");
    page += &generated_note("the standard library's `///` comments");
    page += "A texture generator is an ordinary function of the shading globals; most return a `float` \
             in [0, 1], the `t` of a texture-tree node ([Texture trees](../tutorial/texture-trees.md)). \
             Every function here is in the prelude:\n\n```tsl\nmaterial tiled = mix(checker2(8), \
             lambert(kd: gray(0.9)), lambert(kd: gray(0.1)));\nmaterial dented = bump(fbm(Pl * 6), \
             0.02, phong);\n```\n\nThe builtins (`noise`, which is in [-1, 1], `texture`, `smoothstep`, \
             ...) are in [the language, section 14](language.md#14-builtin-functions); the materials \
             of `stdlib/texturing.tsl` are in [the standard materials](materials.md).\n";
    for file in GENERATOR_FILES {
        let source = std::fs::read_to_string(root().join(file)).unwrap();
        let (title, intro) = header_comment(&source);
        page += &format!("\n## `{file}`: {title}\n\n{}\n", prose(&intro));
        let documented: Vec<Definition> = definitions(&source).into_iter().filter(|d| d.kind != "material").collect();
        assert!(documented.iter().any(|d| d.kind == "function"), "no functions found in {file}");
        for definition in documented {
            page += &format!("\n### `{}`\n\n`{}`\n\n", definition.name, definition.signature);
            page += doc_markdown(definition.doc.as_deref().unwrap_or("")).trim_end();
            page += "\n";
            if definition.params.is_empty() {
                continue;
            }
            page += "\n| Parameter | Type | Default | Meaning |\n|---|---|---|---|\n";
            for p in &definition.params {
                let default = p.default.as_deref().map_or("required".to_string(), |d| format!("`{}`", code_cell(d)));
                let meaning = prose(&cell(p.doc.as_deref().unwrap_or("")));
                page += &format!("| `{}` | `{}` | {default} | {meaning} |\n", p.name, p.ty);
            }
        }
    }
    expect_page("reference/generators.md", &format!("{}\n", page.trim_end()));
}

/// The reference pages are only as complete as the comments they are made
/// from: every material of the prelude and every parameter of one, and every
/// function, constant and parameter of the generator files, has a `///`
/// doc comment. A new definition without one fails here, naming it.
#[test]
fn every_stdlib_material_generator_and_parameter_is_documented() {
    let mut missing = Vec::new();
    let mut seen = 0;
    for (file, source) in tsl::load::PRELUDE {
        let generators = GENERATOR_FILES.contains(file);
        for definition in definitions(source) {
            if definition.kind != "material" && !generators {
                continue;
            }
            seen += 1;
            let at = format!("{file}:{}: {} `{}`", definition.line, definition.kind, definition.name);
            if definition.doc.as_deref().is_none_or(|d| d.trim().is_empty()) {
                missing.push(format!("{at} has no `///` doc comment"));
            }
            for p in &definition.params {
                if p.doc.as_deref().is_none_or(|d| d.trim().is_empty()) {
                    missing.push(format!("{at}: parameter `{}` has no `///` doc comment", p.name));
                }
            }
        }
    }
    assert!(missing.is_empty(), "undocumented in the standard library:\n{}", missing.join("\n"));
    assert!(seen >= 60, "only {seen} definitions looked at: is the prelude where this test looks?");
}

/// The check above fails on what it should: a definition or a parameter
/// without a doc comment.
#[test]
fn an_undocumented_definition_or_parameter_is_found() {
    let source = "/// Documented.\nfloat f(\n    /// documented\n    float a,\n    float b = 1,\n) {\n    return a;\n}\n\nfloat g() {\n    return 0;\n}\n";
    let found = definitions(source);
    assert_eq!(found.len(), 2);
    assert_eq!(found[0].signature, "float f(float a, float b = 1)");
    assert_eq!(found[0].doc.as_deref(), Some("Documented."));
    assert_eq!(found[0].params[0].doc.as_deref(), Some("documented"));
    assert_eq!(found[0].params[1].doc, None, "b has no doc");
    assert_eq!((found[1].name.as_str(), found[1].line, found[1].doc.as_deref()), ("g", 10, None));
}

fn help(args: &[&str]) -> String {
    let output = tslc().args(args).output().unwrap();
    assert!(output.status.success(), "tslc {args:?} failed");
    String::from_utf8(output.stdout).unwrap().trim_end().to_string()
}

#[test]
fn cli_page_is_current() {
    let top = help(&["--help"]);
    let commands: Vec<&str> = top
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .collect();
    assert!(commands.contains(&"render") && commands.contains(&"check"), "{top}");
    let mut page = String::from("# Command line\n\n");
    page += &generated_note("`tslc --help` and each command's `--help`");
    page += "`tslc` checks, formats, queries and renders TSL files, and runs the language server. \
             Each command's `--help` prints its page below; the tutorial shows them at work \
             ([first material](../tutorial/first-material.md), [rendering](../tutorial/scenes-and-lights.md), \
             [farms](../tutorial/animation-and-farms.md), [editors](../tutorial/editors.md)).\n\n";
    page += &format!("## `tslc`\n\n```text\n{top}\n```\n");
    for command in commands {
        page += &format!("\n## `tslc {command}`\n\n```text\n{}\n```\n", help(&[command, "--help"]));
    }
    expect_page("reference/cli.md", &page);
}

#[test]
fn every_page_with_rust_blocks_runs_as_doctests() {
    let lib = std::fs::read_to_string(root().join("src/lib.rs")).unwrap();
    let mut pages_with_rust = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        if code_blocks(&text).iter().any(|b| b.info == "rust" || b.info.starts_with("rust,")) {
            pages_with_rust += 1;
            let relative = shown(&page);
            assert!(
                lib.contains(&format!("include_str!(\"../{relative}\")")),
                "{relative} has ```rust blocks, but src/lib.rs does not include it as a doctest"
            );
        }
    }
    assert!(pages_with_rust >= 2, "the README and embedding/rust.md have Rust blocks");
}
