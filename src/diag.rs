//! Diagnostics as plain data, and the source map they point into.
//!
//! Front-end passes never fail: they return a value plus a list of
//! [`Diagnostic`]s. Rendering for people (with codespan-reporting) or as JSON
//! happens only at the edge, through [`render_text`] and [`json_lines`].
//!
//! What is rendered is bounded whatever the input: at most
//! [`MAX_DIAGNOSTICS_PER_FILE`] diagnostics per file, then one line saying
//! how many more there are; quoted lines cut to windows around the labels
//! ([`MAX_QUOTED_LINE_CHARS`]); and no control character from a file's
//! text reaches the terminal ([`escape_char`]).

mod quote;

pub use quote::{MAX_QUOTED_LINE_CHARS, QUOTE_CONTEXT_CHARS};

use codespan_reporting::term;
use serde::Serialize;
use std::ops::Range;

/// The most diagnostics rendered for one file (100, as clang's error
/// limit): past them, most are echoes of one mistake, and a file of
/// thousands of errors would print megabytes. A file with more shows its
/// first 99 and, last, one line counting the rest: `error: 3901 more errors
/// in input.tsl not shown`. The parser stops collecting syntax errors at
/// the same bound (99 and its own count).
pub const MAX_DIAGNOSTICS_PER_FILE: usize = 100;

/// How a character of a file's text is shown in a terminal. Control
/// characters would let a file drive the terminal (move the cursor, change
/// colours, rewrite the title), so: C0 controls other than tab and newline
/// become their Unicode control pictures (U+2400 + code: ESC is `␛`), DEL
/// becomes `␡`, and the C1 controls (U+0080 to U+009F) and the
/// bidirectional overrides (U+202A to U+202E, U+2066 to U+2069), which
/// have no picture, become `�` (U+FFFD). Each is one column wide, so carets
/// under a quoted line stay aligned. Tabs are kept (codespan expands them);
/// a newline is never part of a quoted line.
pub fn escape_char(c: char) -> char {
    match c {
        '\t' => c,
        '\u{0}'..='\u{1f}' => char::from_u32(0x2400 + c as u32).unwrap_or('\u{fffd}'),
        '\u{7f}' => '\u{2421}',
        '\u{80}'..='\u{9f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}' => '\u{fffd}',
        _ => c,
    }
}

/// `text` as a terminal may show it: every character through
/// [`escape_char`], newlines too (one-line values such as file names and
/// EXR header strings; quoted source lines keep their newlines apart).
/// Borrowed when nothing needs escaping.
pub fn printable(text: &str) -> std::borrow::Cow<'_, str> {
    let shown = |c: char| c == '\t' || escape_char(c) == c;
    if text.chars().all(shown) {
        return std::borrow::Cow::Borrowed(text);
    }
    std::borrow::Cow::Owned(text.chars().map(|c| if c == '\t' { c } else { escape_char(c) }).collect())
}

/// Index of a source file in a [`SourceMap`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct FileId(pub u32);

/// A byte range in one source file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Span {
    pub file: FileId,
    pub start: u32,
    pub end: u32,
}

impl Span {
    pub fn new(file: FileId, start: usize, end: usize) -> Span {
        Span { file, start: start as u32, end: end as u32 }
    }

    /// The smallest span covering both (which must be in the same file).
    pub fn to(self, other: Span) -> Span {
        Span { file: self.file, start: self.start.min(other.start), end: self.end.max(other.end) }
    }

    pub fn range(self) -> Range<usize> {
        self.start as usize..self.end as usize
    }
}

/// The source texts of a program, by [`FileId`].
#[derive(Debug, Clone, Default)]
pub struct SourceMap {
    files: Vec<SourceFileText>,
}

#[derive(Debug, Clone)]
struct SourceFileText {
    name: String,
    text: String,
    line_starts: Vec<usize>,
}

impl SourceMap {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn add(&mut self, name: impl Into<String>, text: impl Into<String>) -> FileId {
        let text = text.into();
        let line_starts = std::iter::once(0).chain(text.match_indices('\n').map(|(i, _)| i + 1)).collect();
        self.files.push(SourceFileText { name: name.into(), text, line_starts });
        FileId(self.files.len() as u32 - 1)
    }

    pub fn name(&self, id: FileId) -> &str {
        &self.files[id.0 as usize].name
    }

    pub fn text(&self, id: FileId) -> &str {
        &self.files[id.0 as usize].text
    }

    pub fn len(&self) -> usize {
        self.files.len()
    }

    pub fn is_empty(&self) -> bool {
        self.files.is_empty()
    }

    /// The byte offset where each line of a file starts.
    pub fn line_starts(&self, id: FileId) -> &[usize] {
        &self.files[id.0 as usize].line_starts
    }

    /// The 1-based line and column (in characters) of a byte offset.
    pub fn line_col(&self, id: FileId, offset: u32) -> (usize, usize) {
        let file = &self.files[id.0 as usize];
        let offset = (offset as usize).min(file.text.len());
        let line = file.line_starts.partition_point(|&s| s <= offset) - 1;
        let start = file.line_starts[line];
        let col = file.text.get(start..offset).map_or(offset - start, |s| s.chars().count());
        (line + 1, col + 1)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    Warning,
    Error,
}

/// A secondary location with a message.
#[derive(Debug, Clone, PartialEq)]
pub struct Label {
    pub span: Span,
    pub message: String,
}

/// One message for the user: a primary location, optional secondary labels
/// and an optional help line.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    pub severity: Severity,
    pub message: String,
    pub span: Span,
    /// Text under the primary caret; often empty.
    pub primary_label: String,
    pub labels: Vec<Label>,
    pub help: Option<String>,
    pub notes: Vec<String>,
}

impl Diagnostic {
    pub fn error(span: Span, message: impl Into<String>) -> Self {
        Diagnostic {
            severity: Severity::Error,
            message: message.into(),
            span,
            primary_label: String::new(),
            labels: Vec::new(),
            help: None,
            notes: Vec::new(),
        }
    }

    pub fn warning(span: Span, message: impl Into<String>) -> Self {
        Diagnostic { severity: Severity::Warning, ..Diagnostic::error(span, message) }
    }

    /// Text under the primary caret.
    pub fn with_primary(mut self, label: impl Into<String>) -> Self {
        self.primary_label = label.into();
        self
    }

    pub fn with_label(mut self, span: Span, message: impl Into<String>) -> Self {
        self.labels.push(Label { span, message: message.into() });
        self
    }

    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    pub fn with_note(mut self, note: impl Into<String>) -> Self {
        self.notes.push(note.into());
        self
    }

    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }
}

/// Whether rendered text uses ANSI colours.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Colors {
    Never,
    Always,
}

/// The file name of diagnostics that are about no source text
/// (`Error::plain`); [`render_text`] prints them as one line.
pub const UNLOCATED: &str = "<tsl>";

/// Renders diagnostics as rustc-style text: `file:line:col`, the source
/// line, carets, labels, help. At most [`MAX_DIAGNOSTICS_PER_FILE`] per
/// file, then a line counting the rest; long lines cut to windows around
/// the labels; control characters escaped ([`escape_char`]).
pub fn render_text(sources: &SourceMap, diags: &[Diagnostic], colors: Colors) -> String {
    let config = term::Config::default();
    let mut out: Vec<u8> = Vec::new();
    let mut hidden = Hidden::new(sources, diags);
    for d in diags {
        if hidden.hides(d) {
            continue;
        }
        // Not about any source text (a bad override, a failed write): one line.
        if sources.name(d.span.file) == UNLOCATED && sources.text(d.span.file).is_empty() {
            let severity = if d.is_error() { "error" } else { "warning" };
            out.extend(format!("{severity}: {}\n", quote::escape(&d.message)).bytes());
            for line in d
                .help
                .iter()
                .map(|h| format!("  = help: {}\n", quote::escape(h)))
                .chain(d.notes.iter().map(|n| format!("  = note: {}\n", quote::escape(n))))
            {
                out.extend(line.bytes());
            }
            continue;
        }
        let (files, cs_diag) = quote::Quote::new(sources, d, &config);
        // Writing into a Vec cannot fail; a bad span could, and then the
        // plain one-line form below still tells the user what happened.
        let ok = match colors {
            Colors::Never => {
                let mut w = term::termcolor::NoColor::new(&mut out);
                term::emit(&mut w, &config, &files, &cs_diag).is_ok()
            }
            Colors::Always => {
                let mut w = term::termcolor::Ansi::new(&mut out);
                term::emit(&mut w, &config, &files, &cs_diag).is_ok()
            }
        };
        if !ok {
            let (line, col) = sources.line_col(d.span.file, d.span.start);
            let (message, name) = (quote::escape(&d.message), quote::escape(sources.name(d.span.file)));
            out.extend(format!("error: {message}\n  at {name}:{line}:{col}\n").bytes());
        }
    }
    for (file, errors, warnings) in hidden.counts() {
        let severity = if errors > 0 { "error" } else { "warning" };
        out.extend(format!("{severity}: {}\n", hidden_message(sources, file, errors, warnings)).bytes());
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The diagnostics left out per file: a file with more than
/// [`MAX_DIAGNOSTICS_PER_FILE`] shows the first `MAX - 1`, and a last line
/// counts the rest (so the parser's own count, its hundredth diagnostic,
/// passes through).
struct Hidden {
    /// Per file, in order of first appearance: its diagnostics in all,
    /// those seen so far, and the errors and warnings left out.
    files: Vec<HiddenIn>,
}

struct HiddenIn {
    file: FileId,
    total: usize,
    seen: usize,
    errors: usize,
    warnings: usize,
}

impl Hidden {
    fn new(sources: &SourceMap, diags: &[Diagnostic]) -> Hidden {
        let mut files: Vec<HiddenIn> = Vec::new();
        for d in diags.iter().filter(|d| sources.name(d.span.file) != UNLOCATED) {
            match files.iter_mut().find(|f| f.file == d.span.file) {
                Some(f) => f.total += 1,
                None => files.push(HiddenIn { file: d.span.file, total: 1, seen: 0, errors: 0, warnings: 0 }),
            }
        }
        Hidden { files }
    }

    /// Counts `d` (the diagnostics in the order given to [`Hidden::new`]);
    /// whether it is left out.
    fn hides(&mut self, d: &Diagnostic) -> bool {
        let Some(f) = self.files.iter_mut().find(|f| f.file == d.span.file) else { return false };
        f.seen += 1;
        if f.total <= MAX_DIAGNOSTICS_PER_FILE || f.seen < MAX_DIAGNOSTICS_PER_FILE {
            return false;
        }
        if d.is_error() {
            f.errors += 1;
        } else {
            f.warnings += 1;
        }
        true
    }

    /// (file, errors, warnings) for each file that lost some.
    fn counts(&self) -> impl Iterator<Item = (FileId, usize, usize)> + '_ {
        self.files.iter().filter(|f| f.errors + f.warnings > 0).map(|f| (f.file, f.errors, f.warnings))
    }
}

/// `3900 more errors and 2 more warnings in input.tsl not shown`.
fn hidden_message(sources: &SourceMap, file: FileId, errors: usize, warnings: usize) -> String {
    let count = |n: usize, what: &str| format!("{n} more {what}{}", if n == 1 { "" } else { "s" });
    let parts: Vec<String> =
        [(errors, "error"), (warnings, "warning")].iter().filter(|(n, _)| *n > 0).map(|(n, w)| count(*n, w)).collect();
    format!("{} in {} not shown", parts.join(" and "), quote::escape(sources.name(file)))
}

/// One diagnostic as the JSON object `--message-format json` prints.
#[derive(Debug, Serialize)]
pub struct JsonDiagnostic<'a> {
    pub severity: Severity,
    pub message: &'a str,
    pub file: &'a str,
    pub line: usize,
    pub column: usize,
    pub end_line: usize,
    pub end_column: usize,
    pub byte_start: u32,
    pub byte_end: u32,
    pub labels: Vec<JsonLabel<'a>>,
    pub help: Option<&'a str>,
    pub notes: &'a [String],
}

#[derive(Debug, Serialize)]
pub struct JsonLabel<'a> {
    pub message: &'a str,
    pub file: &'a str,
    pub line: usize,
    pub column: usize,
    pub byte_start: u32,
    pub byte_end: u32,
}

/// The JSON lines `--message-format json` prints for `diags`: one object
/// per diagnostic, at most [`MAX_DIAGNOSTICS_PER_FILE`] per file, the last
/// of a file that has more saying how many are left out (at the position
/// of the first of them).
pub fn json_lines(sources: &SourceMap, diags: &[Diagnostic]) -> Vec<String> {
    let mut hidden = Hidden::new(sources, diags);
    let mut first_hidden: Vec<(FileId, Span)> = Vec::new();
    let mut lines = Vec::new();
    for d in diags {
        if hidden.hides(d) {
            if !first_hidden.iter().any(|(f, _)| *f == d.span.file) {
                first_hidden.push((d.span.file, d.span));
            }
            continue;
        }
        lines.push(to_json(sources, d));
    }
    for (file, errors, warnings) in hidden.counts() {
        let span = first_hidden.iter().find(|(f, _)| *f == file).map_or(Span { file, start: 0, end: 0 }, |(_, s)| *s);
        let message = hidden_message(sources, file, errors, warnings);
        let d = if errors > 0 { Diagnostic::error(span, message) } else { Diagnostic::warning(span, message) };
        lines.push(to_json(sources, &d));
    }
    lines
}

/// The JSON form of one diagnostic, on one line.
pub fn to_json(sources: &SourceMap, d: &Diagnostic) -> String {
    let (line, column) = sources.line_col(d.span.file, d.span.start);
    let (end_line, end_column) = sources.line_col(d.span.file, d.span.end);
    let labels = d
        .labels
        .iter()
        .map(|l| {
            let (line, column) = sources.line_col(l.span.file, l.span.start);
            JsonLabel {
                message: &l.message,
                file: sources.name(l.span.file),
                line,
                column,
                byte_start: l.span.start,
                byte_end: l.span.end,
            }
        })
        .collect();
    let json = JsonDiagnostic {
        severity: d.severity,
        message: &d.message,
        file: sources.name(d.span.file),
        line,
        column,
        end_line,
        end_column,
        byte_start: d.span.start,
        byte_end: d.span.end,
        labels,
        help: d.help.as_deref(),
        notes: &d.notes,
    };
    serde_json::to_string(&json).unwrap_or_else(|e| format!("{{\"severity\":\"error\",\"message\":\"{e}\"}}"))
}

/// Edit distance for "did you mean" suggestions: insertions, deletions,
/// substitutions and swaps of neighbours each cost one (optimal string
/// alignment), so `lihgt` is one edit from `light`.
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let mut rows = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in rows.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in rows[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut d = (rows[i - 1][j] + 1).min(rows[i][j - 1] + 1).min(rows[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                d = d.min(rows[i - 2][j - 2] + 1);
            }
            rows[i][j] = d;
        }
    }
    rows[a.len()][b.len()]
}

/// The candidate closest to `name`, if it is close enough to be a likely typo.
pub fn did_you_mean<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    // Very short names are one edit away from everything: only a change of
    // case (distance 0 once lowercased) is a likely typo there.
    let len = name.chars().count();
    let limit = if len < 3 { 0 } else { (len / 3).max(1) };
    candidates
        .into_iter()
        .filter(|c| *c != name)
        .map(|c| (edit_distance(&name.to_lowercase(), &c.to_lowercase()), c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, c)| (*d, *c))
        .map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_col_counts_characters() {
        let mut sm = SourceMap::new();
        let f = sm.add("a.tsl", "ab\nçd e\n");
        assert_eq!(sm.line_col(f, 0), (1, 1));
        assert_eq!(sm.line_col(f, 3), (2, 1));
        assert_eq!(sm.line_col(f, 6), (2, 3)); // after the two-byte ç and d
    }

    #[test]
    fn suggestions_are_close_names_only() {
        assert_eq!(did_you_mean("normalise", ["normalize", "noise"]), Some("normalize"));
        assert_eq!(did_you_mean("xyz", ["normalize"]), None);
        assert_eq!(did_you_mean("z", ["N", "P"]), None);
        assert_eq!(did_you_mean("n", ["N", "P"]), Some("N"));
        assert_eq!(did_you_mean("lihgt", ["light", "object"]), Some("light"));
        assert_eq!(did_you_mean("fvo", ["fov", "from"]), Some("fov"));
    }

    #[test]
    fn control_characters_become_one_visible_character() {
        let shown: String = "a\x1b\x07\t\r\x7f\u{9b}\u{202e}é".chars().map(escape_char).collect();
        assert_eq!(shown, "a␛␇\t␍␡\u{fffd}\u{fffd}é");
    }

    /// A label from the middle of one long line to the middle of another:
    /// both ends quoted in windows, the lines between as codespan shows
    /// them, every line short.
    #[test]
    fn a_multi_line_label_over_long_lines_is_cut_at_both_ends() {
        let long = "x".repeat(1000);
        let text = format!("{long}START{long}\nshort\n{long}END{long}\n");
        let mut sm = SourceMap::new();
        let f = sm.add("a.tsl", text.as_str());
        let (start, end) = (text.find("START").unwrap(), text.find("END").unwrap() + 3);
        let d = Diagnostic::error(Span::new(f, start, end), "here").with_primary("spans two lines");
        let out = render_text(&sm, &[d], Colors::Never);
        assert!(out.contains("a.tsl:1:1001\n"), "{out}");
        assert!(out.contains(&format!("1 │   ...{}START", "x".repeat(QUOTE_CONTEXT_CHARS))), "{out}");
        assert!(out.contains(&format!("END{}...\n", "x".repeat(QUOTE_CONTEXT_CHARS))), "{out}");
        assert!(out.contains("2 │ │ short"), "{out}");
        assert!(out.lines().all(|l| l.chars().count() <= 2 * QUOTE_CONTEXT_CHARS + 20), "{out}");
    }
}
