//! The source text one diagnostic quotes, as codespan-reporting reads it:
//! only the lines its labels touch (and the context codespan shows around
//! them), each long line cut to windows around the labels, and control
//! characters shown as pictures.
//!
//! codespan prints whole lines, so a diagnostic on a 110 KB line printed
//! 110 KB, and the caret line under it as many spaces; 4,000 such errors
//! printed half a gigabyte. Here every quoted line is at most a few hundred
//! characters ([`MAX_QUOTED_LINE_CHARS`], [`QUOTE_CONTEXT_CHARS`]), as
//! rustc cuts long lines, and the text codespan sees is a small view: each
//! label's range is moved into the view, while line and column numbers are
//! still the file's own (this type answers codespan's `Files` questions
//! with them).

use super::{FileId, SourceMap, escape_char};
use codespan_reporting::diagnostic as cs;
use codespan_reporting::files::{Error as FilesError, Files};
use codespan_reporting::term::Config;
use std::collections::BTreeSet;
use std::ops::Range;

/// Lines longer than this many characters are cut to windows around the
/// labels on them; shorter lines are quoted whole.
pub const MAX_QUOTED_LINE_CHARS: usize = 160;

/// How many characters a cut line keeps on each side of a label's start
/// and end.
pub const QUOTE_CONTEXT_CHARS: usize = 40;

/// The most windows one cut line keeps (labels beyond them point at the
/// last `...`), so a line quotes at most about 8 x 160 characters.
const MAX_WINDOWS: usize = 8;

/// What marks text left out of a cut line.
const ELLIPSIS: &str = "...";

/// One diagnostic's quoted files, in the order its labels name them.
pub(super) struct Quote<'s> {
    sources: &'s SourceMap,
    files: Vec<QuotedFile>,
}

struct QuotedFile {
    id: FileId,
    /// The file's name, control characters escaped.
    name: String,
    /// The quoted lines, each ending in `\n`.
    text: String,
    /// The lines quoted, by their index in the file, ascending.
    lines: Vec<QuotedLine>,
    /// How many lines the file has.
    line_count: usize,
}

struct QuotedLine {
    index: usize,
    /// The line's start in the file.
    start: usize,
    /// Its range in `QuotedFile::text`, the newline included.
    range: Range<usize>,
    /// (offset in the file, offset in `text`) at every character boundary
    /// kept, and at the start of every stretch left out (which maps to its
    /// `...`): in ascending order of both.
    map: Vec<(usize, usize)>,
}

impl<'s> Quote<'s> {
    /// The view of the files `d` points into, and `d` as codespan's
    /// diagnostic with its labels moved into the view.
    pub(super) fn new(sources: &'s SourceMap, d: &super::Diagnostic, config: &Config) -> (Self, cs::Diagnostic<usize>) {
        let mut labels: Vec<(FileId, Range<usize>, bool, &str)> =
            vec![(d.span.file, d.span.range(), true, d.primary_label.as_str())];
        labels.extend(d.labels.iter().map(|l| (l.span.file, l.span.range(), false, l.message.as_str())));
        let mut files: Vec<FileId> = Vec::new();
        for (file, _, _, _) in &labels {
            if !files.contains(file) {
                files.push(*file);
            }
        }
        let quoted: Vec<QuotedFile> = files
            .iter()
            .map(|file| {
                let ranges: Vec<Range<usize>> =
                    labels.iter().filter(|(f, ..)| f == file).map(|(_, r, ..)| r.clone()).collect();
                QuotedFile::new(sources, *file, &ranges, config)
            })
            .collect();
        let cs_labels = labels
            .iter()
            .map(|(file, range, primary, message)| {
                let k = files.iter().position(|f| f == file).unwrap_or(0);
                let q = &quoted[k];
                let moved = q.moved(range.start)..q.moved(range.end).max(q.moved(range.start));
                let label = if *primary { cs::Label::primary(k, moved) } else { cs::Label::secondary(k, moved) };
                label.with_message(escape(message))
            })
            .collect();
        let severity = match d.severity {
            super::Severity::Error => cs::Severity::Error,
            super::Severity::Warning => cs::Severity::Warning,
        };
        let mut notes: Vec<String> = d.notes.iter().map(|n| format!("note: {}", escape(n))).collect();
        if let Some(help) = &d.help {
            notes.push(format!("help: {}", escape(help)));
        }
        let diagnostic =
            cs::Diagnostic::new(severity).with_message(escape(&d.message)).with_labels(cs_labels).with_notes(notes);
        (Quote { sources, files: quoted }, diagnostic)
    }

    fn file(&self, k: usize) -> Result<&QuotedFile, FilesError> {
        self.files.get(k).ok_or(FilesError::FileMissing)
    }
}

/// `text` with control characters shown as [`escape_char`] shows them.
pub(super) fn escape(text: &str) -> String {
    text.chars().map(|c| if c == '\n' || c == '\t' { c } else { escape_char(c) }).collect()
}

impl QuotedFile {
    fn new(sources: &SourceMap, id: FileId, labels: &[Range<usize>], config: &Config) -> QuotedFile {
        let text = sources.text(id);
        let starts = sources.line_starts(id);
        let line_of = |offset: usize| starts.partition_point(|s| *s <= offset.min(text.len())).saturating_sub(1);
        let line_count = starts.len();
        // The lines codespan renders, and the label ends on each.
        let mut wanted: BTreeSet<usize> = BTreeSet::new();
        let mut points: Vec<(usize, usize)> = Vec::new();
        for r in labels {
            let (first, last) = (line_of(r.start), line_of(r.end));
            wanted.insert(first);
            wanted.insert(last);
            points.push((first, r.start));
            points.push((last, r.end));
            for k in 1..=config.before_label_lines {
                wanted.extend(first.checked_sub(k));
            }
            for k in 1..=config.after_label_lines {
                wanted.extend(Some(last + k).filter(|l| *l < line_count));
            }
            if first != last {
                wanted.extend(first + 1..=(first + config.start_context_lines).min(last));
                wanted.extend(last.saturating_sub(config.end_context_lines).max(first)..last);
            }
        }
        // A single line between two rendered lines is rendered too.
        let gaps: Vec<usize> =
            wanted.iter().zip(wanted.iter().skip(1)).filter(|(a, b)| **b == **a + 2).map(|(a, _)| a + 1).collect();
        wanted.extend(gaps);
        let mut quoted = QuotedFile {
            id,
            name: escape(sources.name(id)),
            text: String::new(),
            lines: Vec::with_capacity(wanted.len()),
            line_count,
        };
        for index in wanted {
            let start = starts[index];
            let end = starts.get(index + 1).map_or(text.len(), |next| next - 1);
            let mut line = &text[start..end.max(start)];
            // A line ending "\r\n" ends before the carriage return.
            if starts.get(index + 1).is_some() {
                line = line.strip_suffix('\r').unwrap_or(line);
            }
            let here: Vec<usize> = points.iter().filter(|(l, _)| *l == index).map(|(_, p)| p - start).collect();
            quoted.push_line(index, start, line, &here);
        }
        quoted
    }

    /// Appends line `index` (starting at `start` in the file), cut around
    /// `points` (byte offsets in the line) when it is long.
    fn push_line(&mut self, index: usize, start: usize, line: &str, points: &[usize]) {
        let chars: Vec<(usize, char)> = line.char_indices().collect();
        let n = chars.len();
        let windows = windows(&chars, n, points);
        let begin = self.text.len();
        let mut map = Vec::new();
        let mut at = 0;
        for w in &windows {
            if w.start > at {
                map.push((start + byte_at(&chars, line, at), self.text.len()));
                self.text.push_str(ELLIPSIS);
            }
            for &(offset, c) in &chars[w.start..w.end] {
                map.push((start + offset, self.text.len()));
                self.text.push(escape_char(c));
            }
            at = w.end;
        }
        map.push((start + byte_at(&chars, line, at), self.text.len()));
        if at < n {
            self.text.push_str(ELLIPSIS);
        }
        self.text.push('\n');
        self.lines.push(QuotedLine { index, start, range: begin..self.text.len(), map });
    }

    /// Where offset `offset` of the file is in the view.
    fn moved(&self, offset: usize) -> usize {
        let at = self.lines.partition_point(|l| l.start <= offset).saturating_sub(1);
        let Some(line) = self.lines.get(at) else { return 0 };
        let k = line.map.partition_point(|(o, _)| *o <= offset).saturating_sub(1);
        line.map.get(k).map_or(line.range.start, |(_, q)| *q)
    }

    /// The quoted line holding offset `q` of the view.
    fn line_at(&self, q: usize) -> Option<&QuotedLine> {
        let at = self.lines.partition_point(|l| l.range.start <= q).saturating_sub(1);
        self.lines.get(at)
    }
}

/// The byte offset of character `k` of a line (its length past the end).
fn byte_at(chars: &[(usize, char)], line: &str, k: usize) -> usize {
    chars.get(k).map_or(line.len(), |(b, _)| *b)
}

/// The ranges of characters of a line of `n` characters to quote: all of
/// a short line; around `points` (byte offsets) on a long one.
fn windows(chars: &[(usize, char)], n: usize, points: &[usize]) -> Vec<Range<usize>> {
    if n <= MAX_QUOTED_LINE_CHARS {
        return std::iter::once(0..n).collect();
    }
    let char_of = |b: usize| chars.partition_point(|(o, _)| *o < b);
    let mut marks: Vec<usize> = points.iter().map(|p| char_of(*p)).collect();
    marks.sort_unstable();
    if marks.is_empty() {
        // A context line: its start.
        return std::iter::once(0..MAX_QUOTED_LINE_CHARS).collect();
    }
    let mut out: Vec<Range<usize>> = Vec::new();
    for m in marks {
        let w = m.saturating_sub(QUOTE_CONTEXT_CHARS)..(m + QUOTE_CONTEXT_CHARS).min(n);
        match out.last_mut() {
            // Overlapping, or closer than an ellipsis is long: one window.
            Some(last) if w.start <= last.end + ELLIPSIS.len() => last.end = last.end.max(w.end),
            _ => out.push(w),
        }
    }
    out.truncate(MAX_WINDOWS);
    out
}

impl<'a> Files<'a> for Quote<'_> {
    type FileId = usize;
    type Name = &'a str;
    type Source = &'a str;

    fn name(&'a self, id: usize) -> Result<&'a str, FilesError> {
        Ok(&self.file(id)?.name)
    }

    fn source(&'a self, id: usize) -> Result<&'a str, FilesError> {
        Ok(&self.file(id)?.text)
    }

    /// The index in the file of the line holding view offset `byte_index`.
    fn line_index(&'a self, id: usize, byte_index: usize) -> Result<usize, FilesError> {
        self.file(id)?.line_at(byte_index).map(|l| l.index).ok_or(FilesError::FileMissing)
    }

    /// A quoted line's range in the view; a line not quoted (codespan
    /// walks the lines a long label spans, rendering only a few) is empty.
    fn line_range(&'a self, id: usize, line_index: usize) -> Result<Range<usize>, FilesError> {
        let file = self.file(id)?;
        if line_index >= file.line_count {
            return Err(FilesError::LineTooLarge { given: line_index, max: file.line_count.saturating_sub(1) });
        }
        match file.lines.binary_search_by_key(&line_index, |l| l.index) {
            Ok(k) => Ok(file.lines[k].range.clone()),
            Err(_) => Ok(file.text.len()..file.text.len()),
        }
    }

    /// The column in the file (1-based, in characters) of view offset
    /// `byte_index`.
    fn column_number(&'a self, id: usize, _line_index: usize, byte_index: usize) -> Result<usize, FilesError> {
        let file = self.file(id)?;
        let line = file.line_at(byte_index).ok_or(FilesError::FileMissing)?;
        let k = line.map.partition_point(|(_, q)| *q <= byte_index).saturating_sub(1);
        let offset = line.map.get(k).map_or(line.start, |(o, _)| *o);
        let text = self.sources.text(file.id);
        Ok(text.get(line.start..offset).map_or(offset - line.start, |s| s.chars().count()) + 1)
    }
}
