//! Doc comments: the `///` lines directly above a parameter or an item, as
//! in Rust. They are comments to the lexer and the parser (so the
//! formatter keeps them as it keeps every comment); whoever documents a
//! definition (the embedding API's shader descriptions, `tslc query`, the
//! language server's hovers) reads them from the source text here.

/// The doc comment of what starts at byte `at` of `src`: the `///` lines
/// right above its line, each without `///` and one space after it, joined
/// by newlines. `None` when there is none, or when something else precedes
/// `at` on its line (`material lambert(color kd)`: a comment above the line
/// documents the material, not `kd`). A `////` line is an ordinary comment.
///
/// ```
/// let src = "material m(\n    /// microfacet roughness\n    float alpha = 0.1,\n) = lambert;";
/// let at = src.find("float").unwrap();
/// assert_eq!(tsl::syntax::doc_comment(src, at).as_deref(), Some("microfacet roughness"));
/// ```
pub fn doc_comment(src: &str, at: usize) -> Option<String> {
    let before = src.get(..at)?;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    if !before[line_start..].trim().is_empty() || line_start == 0 {
        return None;
    }
    let mut lines: Vec<&str> = Vec::new();
    for line in before[..line_start - 1].rsplit('\n') {
        let text = line.trim();
        match text.strip_prefix("///") {
            Some(rest) if !rest.starts_with('/') => lines.push(rest.strip_prefix(' ').unwrap_or(rest)),
            _ => break,
        }
    }
    if lines.is_empty() {
        return None;
    }
    lines.reverse();
    Some(lines.join("\n"))
}

#[cfg(test)]
mod tests {
    use super::doc_comment;

    fn doc_of(src: &str, word: &str) -> Option<String> {
        doc_comment(src, src.find(word).expect("the word is in the source"))
    }

    #[test]
    fn lines_above_are_joined_and_stop_at_anything_else() {
        let src = "// plain\n/// first\n///second\n  ///  third  \r\nfloat x;";
        assert_eq!(doc_of(src, "float").as_deref(), Some("first\nsecond\n third"));
        assert_eq!(doc_of("/// a\n\nfloat x;", "float"), None, "an empty line ends a doc comment");
        assert_eq!(doc_of("//// ruler\nfloat x;", "float"), None);
        assert_eq!(doc_of("float x;", "float"), None);
    }

    #[test]
    fn only_what_starts_its_line_is_documented() {
        let src = "/// the material\nmaterial m(float a) = lambert;";
        assert_eq!(doc_of(src, "material m").as_deref(), Some("the material"));
        assert_eq!(doc_of(src, "float"), None);
    }
}
