//! Byte offsets to LSP positions and back: lines, and columns in UTF-16
//! code units (the encoding every client supports).
//!
//! A [`LineIndex`] is built once per text (one pass) and answers each
//! conversion in O(log n) plus a scan of at most [`CHUNK`] bytes, however
//! long the line: a 665 KB program on one line has as cheap positions as
//! a short one. Columns are exact byte counts in ASCII text; elsewhere the
//! index keeps, every `CHUNK` bytes, how many UTF-16 units fewer than
//! UTF-8 bytes the text has so far (rust-analyzer keeps every wide
//! character of a line instead, which a line of them makes quadratic).

use lsp_types::{Position, Range};

/// How far apart the index's checkpoints of UTF-16 columns are, in bytes:
/// the most a conversion scans, and 1/16 of the text in memory (in text
/// that is not ASCII).
const CHUNK: usize = 64;

/// Line starts and UTF-16 checkpoints of a text. Offsets are `u32`, as
/// spans are: documents and sources are bounded far below 4 GiB.
#[derive(Debug, Clone, Default)]
pub struct LineIndex {
    /// The byte offset of each line's start; the first is 0.
    line_starts: Vec<u32>,
    /// `None` for ASCII text. Else, for each `k`, the UTF-8 bytes minus
    /// the UTF-16 units of the characters before the first character
    /// boundary at or after `k * CHUNK`.
    narrowing: Option<Vec<u32>>,
    len: u32,
}

impl LineIndex {
    pub fn new(text: &str) -> LineIndex {
        let offset = |i: usize| u32::try_from(i).unwrap_or(u32::MAX);
        let line_starts = std::iter::once(0).chain(text.match_indices('\n').map(|(i, _)| offset(i + 1)));
        let narrowing = (!text.is_ascii()).then(|| {
            let mut marks = Vec::with_capacity(text.len() / CHUNK + 1);
            let mut narrowed = 0u32;
            for (i, c) in text.char_indices() {
                while marks.len() * CHUNK <= i {
                    marks.push(narrowed);
                }
                narrowed += (c.len_utf8() - c.len_utf16()) as u32;
            }
            while marks.len() * CHUNK <= text.len() {
                marks.push(narrowed);
            }
            marks
        });
        LineIndex { line_starts: line_starts.collect(), narrowing, len: offset(text.len()) }
    }

    /// The byte offset of a position, clamped into the text: a column past
    /// the end of its line is the line's end, a line past the end the end
    /// of the text (clients send both while edits race). A column inside a
    /// character (half of a surrogate pair) is the character's end.
    pub fn offset(&self, text: &str, pos: Position) -> usize {
        debug_assert_eq!(text.len(), self.len as usize, "the index of another text");
        let Some(&start) = self.line_starts.get(pos.line as usize) else {
            return text.len();
        };
        let start = start as usize;
        let end = self.line_starts.get(pos.line as usize + 1).map_or(text.len(), |&next| next as usize - 1);
        let wanted = pos.character as usize;
        let Some(marks) = &self.narrowing else {
            return (start + wanted).min(end);
        };
        // The last checkpoint of the line at or before the column, by
        // binary search (columns grow with offsets), then a short scan.
        let before_line = self.narrowing_before(text, start);
        let column = |at: usize, narrowed: usize| (at - start) - (narrowed - before_line);
        let (mut low, mut high) = (start.div_ceil(CHUNK), end / CHUNK + 1);
        while low < high {
            let k = (low + high) / 2;
            let at = ceil_char_boundary(text, k * CHUNK);
            if column(at, marks[k] as usize) <= wanted {
                low = k + 1;
            } else {
                high = k;
            }
        }
        let from = if low > start.div_ceil(CHUNK) { ceil_char_boundary(text, (low - 1) * CHUNK) } else { start };
        let mut units = column(from, self.narrowing_before(text, from));
        for (i, c) in text[from..end].char_indices() {
            if units >= wanted {
                return from + i;
            }
            units += c.len_utf16();
        }
        end
    }

    /// The position of a byte offset (clamped to the text, and back to a
    /// character boundary).
    pub fn position(&self, text: &str, offset: usize) -> Position {
        debug_assert_eq!(text.len(), self.len as usize, "the index of another text");
        let mut offset = offset.min(text.len());
        while !text.is_char_boundary(offset) {
            offset -= 1;
        }
        let line = self.line_starts.partition_point(|&s| s as usize <= offset) - 1;
        let start = self.line_starts[line] as usize;
        let character = (offset - start) - (self.narrowing_before(text, offset) - self.narrowing_before(text, start));
        Position { line: line as u32, character: character as u32 }
    }

    pub fn range(&self, text: &str, start: usize, end: usize) -> Range {
        Range { start: self.position(text, start), end: self.position(text, end.max(start)) }
    }

    /// UTF-8 bytes minus UTF-16 units of the text before `at` (a character
    /// boundary): a checkpoint and at most `CHUNK` bytes after it.
    fn narrowing_before(&self, text: &str, at: usize) -> usize {
        let Some(marks) = &self.narrowing else { return 0 };
        let k = at / CHUNK;
        let from = ceil_char_boundary(text, k * CHUNK);
        let scanned: usize = text[from..at].chars().map(|c| c.len_utf8() - c.len_utf16()).sum();
        marks[k] as usize + scanned
    }
}

/// The first character boundary at or after `at` (at most the text's end).
fn ceil_char_boundary(text: &str, at: usize) -> usize {
    let mut at = at.min(text.len());
    while !text.is_char_boundary(at) {
        at += 1;
    }
    at
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Positions as the protocol defines them, counted from the start.
    fn naive_position(text: &str, offset: usize) -> Position {
        let before = &text[..offset];
        let line = before.matches('\n').count();
        let start = before.rfind('\n').map_or(0, |i| i + 1);
        Position::new(line as u32, before[start..].encode_utf16().count() as u32)
    }

    fn naive_offset(text: &str, pos: Position) -> usize {
        let mut start = 0;
        for _ in 0..pos.line {
            match text[start..].find('\n') {
                Some(i) => start += i + 1,
                None => return text.len(),
            }
        }
        let end = text[start..].find('\n').map_or(text.len(), |i| start + i);
        let mut units = 0;
        for (i, c) in text[start..end].char_indices() {
            if units >= pos.character as usize {
                return start + i;
            }
            units += c.len_utf16();
        }
        end
    }

    #[test]
    fn positions_count_utf16_units() {
        let text = "ab\nçd 😀e\n";
        let index = LineIndex::new(text);
        assert_eq!(index.position(text, 3), Position::new(1, 0));
        let e = text.find('e').unwrap();
        // ç and d are one unit each, the space one, the emoji two.
        assert_eq!(index.position(text, e), Position::new(1, 5));
        assert_eq!(index.offset(text, Position::new(1, 5)), e);
        assert_eq!(index.offset(text, Position::new(1, 99)), text.len() - 1, "past the line: its end");
        assert_eq!(index.offset(text, Position::new(9, 0)), text.len(), "past the text: its end");
        assert_eq!(index.position(text, e - 1), Position::new(1, 3), "inside a character: its start");
        assert_eq!(index.offset(text, Position::new(1, 4)), e, "inside a surrogate pair: the character's end");
    }

    #[test]
    fn long_lines_of_wide_characters_convert_exactly() {
        // Lines far longer than a checkpoint's span, of every width.
        for piece in ["a", "é", "語", "😀", "a😀é語\r"] {
            let text = format!("{}\n{}x\n", piece.repeat(1000), piece.repeat(777));
            let index = LineIndex::new(&text);
            for (offset, _) in text.char_indices().chain([(text.len(), ' ')]) {
                let pos = index.position(&text, offset);
                assert_eq!(pos, naive_position(&text, offset), "{piece} at {offset}");
                assert_eq!(index.offset(&text, pos), offset, "{piece} back from {pos:?}");
            }
        }
    }

    fn text_strategy() -> impl Strategy<Value = String> {
        let piece = prop_oneof![
            Just("a"),
            Just("xyz "),
            Just("\n"),
            Just("\r\n"),
            Just("é"),
            Just("語"),
            Just("😀"),
            Just("\u{10000}"),
        ];
        proptest::collection::vec(piece, 0..400).prop_map(|v| v.concat())
    }

    proptest! {
        #[test]
        fn conversions_agree_with_counting_from_the_start(
            text in text_strategy(),
            offsets in proptest::collection::vec(0usize..2000, 1..20),
            positions in proptest::collection::vec((0u32..12, 0u32..600), 1..20),
        ) {
            let index = LineIndex::new(&text);
            for offset in offsets {
                let mut offset = offset.min(text.len());
                while !text.is_char_boundary(offset) {
                    offset -= 1;
                }
                let pos = index.position(&text, offset);
                prop_assert_eq!(pos, naive_position(&text, offset));
                prop_assert_eq!(index.offset(&text, pos), offset);
            }
            for (line, character) in positions {
                let pos = Position::new(line, character);
                prop_assert_eq!(index.offset(&text, pos), naive_offset(&text, pos), "{:?}", pos);
            }
        }
    }
}
