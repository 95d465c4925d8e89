//! The layout document: a small Wadler-style pretty-printing language and
//! its renderer. A group (an argument list, a chain, a scene block) is
//! printed on one line when it fits in [`WIDTH`] columns, otherwise broken
//! at its lines.
//!
//! Invariant: whatever follows a line comment starts on a new line, in any
//! layout mode. The renderer enforces it itself (it does not rely on the
//! printer to put a line break after each line comment), so no layout
//! choice can pull the next token into a `// comment` and lose it.

use super::WIDTH;

const INDENT: usize = 4;

#[derive(Debug, Clone)]
pub(super) enum Doc {
    Text(String),
    /// A space on one line, a newline when the group breaks.
    Line,
    /// Nothing on one line, a newline when the group breaks.
    SoftLine,
    /// Always a newline; the groups around it break.
    HardLine,
    /// An empty line (a kept blank line).
    Blank,
    /// Printed only when the group breaks (a trailing comma).
    IfBreak(&'static str),
    /// In a broken group, a space when the element after it (and a comma)
    /// still fits on the line, else a newline: rows of data filled like
    /// text. A space in a flat group.
    FillLine,
    /// Forces the enclosing groups to break, prints nothing.
    BreakParent,
    /// A block comment: a space before it unless at a line start or after
    /// an opening bracket.
    Comment(String),
    /// A line comment: spaced as a block comment, and what follows it
    /// starts on a new line (the group holding it cannot be flat).
    LineComment(String),
    Indent(Vec<Doc>),
    Group(Vec<Doc>),
    Concat(Vec<Doc>),
}

pub(super) fn text(s: &str) -> Doc {
    Doc::Text(s.to_string())
}

/// The renderer's output and position.
struct Out {
    text: String,
    col: usize,
    /// The indentation of the line begun by the last newline, written with
    /// its first text (so that empty lines carry no spaces).
    pending_indent: Option<usize>,
    /// The last thing written is a line comment: the next text needs a
    /// new line first.
    after_line_comment: bool,
}

impl Out {
    fn at_line_start(&self) -> bool {
        self.pending_indent.is_some() || self.text.is_empty() || self.text.ends_with('\n')
    }

    fn newline(&mut self, ind: usize) {
        self.text.push('\n');
        self.col = 0;
        self.pending_indent = Some(ind);
        self.after_line_comment = false;
    }

    fn put(&mut self, ind: usize, s: &str) {
        if s.is_empty() {
            return;
        }
        if self.after_line_comment {
            self.newline(ind);
        }
        self.push(s);
    }

    fn push(&mut self, s: &str) {
        if let Some(i) = self.pending_indent.take() {
            self.text.push_str(&" ".repeat(i));
            self.col = i;
        }
        self.text.push_str(s);
        match s.rfind('\n') {
            Some(n) => self.col = s[n + 1..].chars().count(),
            None => self.col += s.chars().count(),
        }
    }

    fn comment(&mut self, ind: usize, s: &str, line: bool) {
        if self.after_line_comment {
            self.newline(ind);
        }
        if !self.at_line_start() && !self.text.ends_with([' ', '(', '[']) {
            self.push(" ");
        }
        self.push(s);
        self.after_line_comment = line;
    }
}

pub(super) fn render(doc: &Doc) -> String {
    let mut out = Out { text: String::new(), col: 0, pending_indent: None, after_line_comment: false };
    let mut stack: Vec<(usize, bool, &Doc)> = vec![(0, false, doc)];
    while let Some((ind, flat, d)) = stack.pop() {
        match d {
            Doc::Text(s) => out.put(ind, s),
            Doc::Comment(s) => out.comment(ind, s, false),
            Doc::LineComment(s) => out.comment(ind, s, true),
            // A flat line after a line comment is a newline all the same.
            Doc::Line | Doc::SoftLine if flat && !out.after_line_comment => {
                if matches!(d, Doc::Line) {
                    out.put(ind, " ");
                }
            }
            Doc::FillLine => {
                let next = stack.last().map(|x| x.2);
                let room = WIDTH as isize - out.col as isize - 2;
                if !out.after_line_comment && (flat || next.is_some_and(|n| fits(room, n, &[]))) {
                    out.put(ind, " ");
                } else {
                    out.newline(ind);
                }
            }
            Doc::Line | Doc::SoftLine | Doc::HardLine => out.newline(ind),
            Doc::Blank => {
                out.text.push('\n');
                out.newline(ind);
            }
            Doc::IfBreak(s) => {
                if !flat {
                    out.put(ind, s);
                }
            }
            Doc::BreakParent => {}
            Doc::Indent(ds) => stack.extend(ds.iter().rev().map(|x| (ind + INDENT, flat, x))),
            Doc::Concat(ds) => stack.extend(ds.iter().rev().map(|x| (ind, flat, x))),
            Doc::Group(ds) => {
                let here = if out.pending_indent.is_some() { ind } else { out.col };
                let flat = flat || fits(WIDTH.saturating_sub(here) as isize, d, &stack);
                stack.extend(ds.iter().rev().map(|x| (ind, flat, x)));
            }
        }
    }
    out.text
}

/// Whether `group` fits flat in `room` columns, with what follows it up to
/// the next line break. A comment after the group does not count: it stays
/// at the end of its line wherever the group breaks (as in rustfmt). A line
/// comment inside the group never fits flat.
fn fits(mut room: isize, group: &Doc, rest: &[(usize, bool, &Doc)]) -> bool {
    // (flat, doc, whether it follows the group)
    let mut local: Vec<(bool, &Doc, bool)> = vec![(true, group, false)];
    let mut rest_i = rest.len();
    loop {
        let (flat, d, after) = match local.pop() {
            Some(x) => x,
            None => {
                if rest_i == 0 {
                    return true;
                }
                rest_i -= 1;
                (rest[rest_i].1, rest[rest_i].2, true)
            }
        };
        match d {
            Doc::Comment(_) | Doc::LineComment(_) if after => return true,
            Doc::LineComment(_) => return !flat,
            Doc::Text(s) | Doc::Comment(s) => {
                if s.contains('\n') {
                    return !flat;
                }
                room -= s.chars().count() as isize + isize::from(matches!(d, Doc::Comment(_)));
            }
            Doc::Line | Doc::FillLine if flat => room -= 1,
            Doc::SoftLine if flat => {}
            Doc::Line | Doc::SoftLine | Doc::FillLine => return true,
            Doc::HardLine | Doc::Blank | Doc::BreakParent => return !flat,
            Doc::IfBreak(s) => {
                if !flat {
                    room -= s.len() as isize;
                }
            }
            Doc::Indent(ds) | Doc::Concat(ds) | Doc::Group(ds) => {
                local.extend(ds.iter().rev().map(|x| (flat, x, after)))
            }
        }
        if room < 0 {
            return false;
        }
    }
}
