//! Where documentation comes from, each written once: the doc block at the
//! top of every stdlib file, comments above a user's definitions, and
//! `docs/language.md` for builtins and interface methods (the builtin
//! table in `check::builtins` gives their parameters and signatures).

use std::collections::HashMap;
use std::sync::OnceLock;

/// The language reference, compiled in: the one text that documents builtins.
const LANGUAGE_MD: &str = include_str!("../../docs/language.md");

/// The lines of a file's leading comment block, without `//`.
fn header(text: &str) -> Vec<&str> {
    text.lines().map_while(|l| l.strip_prefix("//")).collect()
}

fn indent(line: &str) -> usize {
    line.len() - line.trim_start().len()
}

/// A rule line between sections, `// -----` or `// =====` (a table's
/// `---+---` is not one).
fn is_rule(line: &str) -> bool {
    let t = line.trim();
    t.len() >= 3 && t.chars().all(|c| c == '-' || c == '=')
}

fn is_word_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Whether `text` starts with `name` as a whole word.
fn starts_with_word(text: &str, name: &str) -> bool {
    text.starts_with(name) && !text[name.len()..].starts_with(is_word_char)
}

/// Whether a header line introduces `name`: `name(...)`,
/// `type name(...)`, or a table row whose first cell lists it.
fn introduces(line: &str, name: &str) -> bool {
    let t = line.trim_start();
    let first_cell = t.split('|').next().unwrap_or("");
    if t.contains('|') && first_cell.split(',').any(|n| n.trim() == name) {
        return true;
    }
    let after_type = t.split_once(' ').map_or("", |(word, rest)| {
        if word.chars().all(|c| is_word_char(c) || c == '[' || c == ']') { rest.trim_start() } else { "" }
    });
    [t, after_type].iter().any(|s| {
        starts_with_word(s, name) && {
            let rest = &s[name.len()..];
            rest.starts_with('(')
        }
    })
}

/// The documentation of `name` in the doc block of a stdlib file: its
/// section (`name -- title` after a rule), else its entry (the line that
/// introduces it and the lines indented under it or continuing its table
/// row), or else the first line that mentions `name(`.
pub fn stdlib_doc(file_text: &str, name: &str) -> Option<String> {
    let lines = header(file_text);
    let title = format!("{name} --");
    let section = (1..lines.len()).find(|&k| is_rule(lines[k - 1]) && lines[k].trim().starts_with(&title));
    if let Some(at) = section {
        // The title (perhaps two lines), the rule under it, then the body
        // up to the next rule.
        let mut out: Vec<&str> = Vec::new();
        let mut k = at;
        while k < lines.len() && !is_rule(lines[k]) {
            out.push(lines[k].trim());
            k += 1;
        }
        let title = out.join(" ");
        let body: Vec<&str> = lines[(k + 1).min(lines.len())..].iter().take_while(|l| !is_rule(l)).copied().collect();
        return Some(format!("{title}\n\n{}", dedent(&body)));
    }
    if let Some(at) = lines.iter().position(|l| introduces(l, name)) {
        return Some(entry_block(&lines, at));
    }
    let call = format!("{name}(");
    let at = lines.iter().position(|l| l.match_indices(&call).any(|(i, _)| !l[..i].ends_with(is_word_char)))?;
    Some(entry_block(&lines, at))
}

/// The line at `at` and what belongs to it: lines indented deeper, and
/// table rows continuing it (nothing before their first `|`).
fn entry_block(lines: &[&str], at: usize) -> String {
    let own = indent(lines[at]);
    let mut block = vec![lines[at]];
    for l in &lines[at + 1..] {
        let continues = l.trim_start().starts_with('|') || (indent(l) > own && !l.trim().is_empty());
        if !continues || is_rule(l) {
            break;
        }
        block.push(l);
    }
    dedent(&block)
}

/// The lines with their common indentation removed, trailing blank lines dropped.
fn dedent(lines: &[&str]) -> String {
    let common = lines.iter().filter(|l| !l.trim().is_empty()).map(|l| indent(l)).min().unwrap_or(0);
    let mut out: Vec<&str> = lines.iter().map(|l| l.get(common..).unwrap_or("").trim_end()).collect();
    while out.last().is_some_and(|l| l.is_empty()) {
        out.pop();
    }
    out.join("\n")
}

/// The `//` comment lines right above byte `start` of `text` (no blank
/// line between), as a user's documentation of the definition there.
pub fn comment_above(text: &str, start: usize) -> Option<String> {
    let before = text.get(..start)?;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    if !before[line_start..].trim().is_empty() {
        return None;
    }
    let mut lines: Vec<&str> = Vec::new();
    for line in before[..line_start].lines().rev() {
        match line.trim_start().strip_prefix("//") {
            Some(c) if !is_rule(c) => lines.push(c.strip_prefix(' ').unwrap_or(c).trim_end()),
            Some(_) => break,
            None => break,
        }
    }
    lines.reverse();
    (!lines.is_empty()).then(|| lines.join("\n"))
}

/// What a doc block's parameter table says of `param`: the last cell of
/// the row naming it, with the rows continuing it.
pub fn param_doc(doc: &str, param: &str) -> Option<String> {
    let rows: Vec<Vec<&str>> = doc.lines().filter(|l| l.contains('|')).map(|l| l.split('|').collect()).collect();
    let names = |row: &[&str]| -> bool {
        // A name cell lists names (`eta, k`); a function's cell shows a call.
        row.iter().take(2).any(|cell| !cell.contains('(') && cell.split(',').any(|n| n.trim() == param))
    };
    let at = rows.iter().position(|r| r.len() >= 2 && names(r))?;
    let mut meaning: Vec<&str> = vec![rows[at].last()?.trim()];
    for row in &rows[at + 1..] {
        // A continuation row has empty cells where the names would be.
        if row.len() < 2 || row[..row.len() - 1].iter().any(|c| !c.trim().is_empty()) {
            break;
        }
        meaning.push(row.last()?.trim());
    }
    let text = meaning.join(" ");
    (!text.is_empty() && text != "--").then_some(text)
}

/// One piece of `docs/language.md`: a table row's cells or a paragraph.
enum MdBlock {
    Row(Vec<String>),
    Paragraph(String),
    /// A row of a table left out.
    Skipped,
}

/// `docs/language.md` cut into numbered sections of rows and paragraphs.
fn language_sections() -> &'static HashMap<u32, Vec<MdBlock>> {
    static SECTIONS: OnceLock<HashMap<u32, Vec<MdBlock>>> = OnceLock::new();
    SECTIONS.get_or_init(|| {
        let mut sections: HashMap<u32, Vec<MdBlock>> = HashMap::new();
        let mut current: Option<u32> = None;
        let mut paragraph: Vec<&str> = Vec::new();
        let mut sampling_table = false;
        let flush = |paragraph: &mut Vec<&str>, blocks: Option<&mut Vec<MdBlock>>| {
            if let (Some(blocks), false) = (blocks, paragraph.is_empty()) {
                blocks.push(MdBlock::Paragraph(paragraph.join(" ")));
            }
            paragraph.clear();
        };
        for line in LANGUAGE_MD.lines() {
            if let Some(title) = line.strip_prefix("## ") {
                flush(&mut paragraph, current.and_then(|n| sections.get_mut(&n)));
                current = title.split('.').next().and_then(|n| n.trim().parse().ok());
                if let Some(n) = current {
                    sections.entry(n).or_default();
                }
                continue;
            }
            let Some(blocks) = current.and_then(|n| sections.get_mut(&n)) else {
                continue;
            };
            if line.starts_with('|') {
                flush(&mut paragraph, Some(blocks));
                // A table's first row is its header; the table of how tree
                // nodes sample (`| Node | `sample` | `pdf` |`) is not what
                // a node is.
                let header = !matches!(blocks.last(), Some(MdBlock::Row(_)) | Some(MdBlock::Skipped));
                if header {
                    sampling_table = line.contains("`sample`");
                }
                if sampling_table {
                    blocks.push(MdBlock::Skipped);
                } else if !line.starts_with("|-") && !line.starts_with("|:") {
                    blocks.push(MdBlock::Row(split_row(line)));
                }
            } else if line.trim().is_empty() || line.starts_with("```") || line.starts_with('#') {
                flush(&mut paragraph, Some(blocks));
            } else {
                paragraph.push(line.trim());
            }
        }
        sections
    })
}

/// The cells of a markdown table row; `\|` is a `|` inside a cell.
fn split_row(line: &str) -> Vec<String> {
    let mut cells = vec![String::new()];
    let mut chars = line.trim().trim_start_matches('|').chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\\' if chars.peek() == Some(&'|') => {
                chars.next();
                if let Some(cell) = cells.last_mut() {
                    cell.push('|');
                }
            }
            '|' => cells.push(String::new()),
            c => {
                if let Some(cell) = cells.last_mut() {
                    cell.push(c);
                }
            }
        }
    }
    if cells.last().is_some_and(|c| c.trim().is_empty()) {
        cells.pop();
    }
    cells.into_iter().map(|c| c.trim().to_string()).collect()
}

/// Whether markdown text has a code span starting with `name(`.
fn mentions_call(text: &str, name: &str) -> bool {
    text.split('`').skip(1).step_by(2).any(|code| code.strip_prefix(name).is_some_and(|rest| rest.starts_with('(')))
}

/// What `docs/language.md` says of a builtin function or type constructor
/// (sections 10 and 14): every table row whose first cell shows a call of
/// it, and every paragraph that does.
pub fn builtin_doc(name: &str) -> Option<String> {
    let sections = language_sections();
    let mut parts: Vec<String> = Vec::new();
    for n in [14, 10] {
        for block in sections.get(&n).into_iter().flatten() {
            match block {
                MdBlock::Row(cells) if cells.first().is_some_and(|c| mentions_call(c, name)) => {
                    let meaning = cells[1..].iter().filter(|c| !c.is_empty()).cloned().collect::<Vec<_>>();
                    parts.push(if meaning.is_empty() {
                        cells[0].clone()
                    } else {
                        format!("{}: {}", cells[0], meaning.join("; "))
                    });
                }
                MdBlock::Paragraph(p) if mentions_call(p, name) => parts.push(p.clone()),
                _ => {}
            }
        }
    }
    (!parts.is_empty()).then(|| parts.join("\n\n"))
}

/// The meaning of an interface method, from the table of section 8.
pub fn method_doc(name: &str) -> Option<String> {
    language_sections().get(&8)?.iter().find_map(|block| match block {
        MdBlock::Row(cells) if cells.first().map(String::as_str) == Some(name) => cells.last().cloned(),
        _ => None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{BUILTINS, INTERFACE};
    use crate::load::PRELUDE;

    fn prelude(name: &str) -> &'static str {
        PRELUDE.iter().find(|(n, _)| n.ends_with(name)).unwrap().1
    }

    #[test]
    fn generator_entries_come_with_their_table_rows() {
        let doc = stdlib_doc(prelude("generators.tsl"), "fbm").unwrap();
        assert!(doc.starts_with("fbm(p, octaves, lacunarity, gain)"), "{doc}");
        assert!(doc.contains("Fractional Brownian motion"), "{doc}");
        assert!(!doc.contains("turbulence"), "stops at the next entry: {doc}");
        assert_eq!(param_doc(&doc, "octaves").as_deref(), Some("number of noise layers"));
    }

    #[test]
    fn material_sections_and_their_parameters() {
        let doc = stdlib_doc(prelude("materials.tsl"), "phong").unwrap();
        assert!(doc.starts_with("phong -- normalised Phong"), "{doc}");
        assert!(doc.contains("Phong exponent"), "{doc}");
        assert!(!doc.contains("blinn_phong --"), "{doc}");
        assert_eq!(param_doc(&doc, "kd").as_deref(), Some("diffuse albedo"));
        let glass = stdlib_doc(prelude("materials.tsl"), "glass").unwrap();
        assert_eq!(
            param_doc(&glass, "transmittance").as_deref(),
            Some("fraction of light left after one unit of distance inside (Beer's law); gray(1) is clear")
        );
        let rough = stdlib_doc(prelude("physical.tsl"), "rough_conductor").unwrap();
        assert!(
            param_doc(&rough, "k")
                .unwrap()
                .starts_with("imaginary part (absorption) of the complex index of refraction")
        );
    }

    #[test]
    fn functions_constants_and_mentions() {
        let doc = stdlib_doc(prelude("math.tsl"), "saturate").unwrap();
        assert_eq!(doc, "float saturate(float x)\n    x clamped into [0, 1].");
        assert!(stdlib_doc(prelude("math.tsl"), "PI").unwrap().starts_with("PI        | float | 3.14159"));
        assert!(stdlib_doc(prelude("sampling.tsl"), "erf_inv").unwrap().contains("inverse"));
        assert!(stdlib_doc(prelude("generators.tsl"), "tiles").unwrap().starts_with("tiles(size, grout)"));
    }

    #[test]
    fn comments_above_a_definition() {
        let text = "// unrelated\n\n// The rings.\n// Two lines.\nfloat rings() { return 1; }\n";
        let at = text.find("float").unwrap();
        assert_eq!(comment_above(text, at).as_deref(), Some("The rings.\nTwo lines."));
        assert_eq!(comment_above("float f();", 0), None);
    }

    #[test]
    fn every_builtin_and_interface_method_is_documented_in_the_language_reference() {
        for b in BUILTINS {
            assert!(builtin_doc(b.name).is_some(), "docs/language.md does not show `{}(`", b.name);
        }
        for m in INTERFACE {
            assert!(method_doc(m.name).is_some(), "docs/language.md section 8 has no row for `{}`", m.name);
        }
        assert!(builtin_doc("noise").unwrap().contains("Perlin"));
        assert!(builtin_doc("min").unwrap().contains("T|float b"), "escaped bars are cells' text");
        assert!(builtin_doc("vec2").unwrap().contains("Type constructors"));
        assert!(!builtin_doc("transform").unwrap().contains("directions do not move"), "not the sampling table");
    }
}
