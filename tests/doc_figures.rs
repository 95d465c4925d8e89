//! `scripts/doc-figures.sh`, which the measuring scripts run with
//! `UPDATE_DOCS=1` to write their latest figures into `docs/performance.md`:
//! on a copy of the page, the region named is replaced and every other byte
//! is kept; a missing or doubled marker is an error that names it and leaves
//! the page as it was; and every region a script writes is in the page.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Runs the script with `stdin` as the figures.
fn doc_figures(args: &[&str], stdin: &str) -> Output {
    let mut child = Command::new("bash")
        .arg(root().join("scripts/doc-figures.sh"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("bash runs");
    std::io::Write::write_all(&mut child.stdin.take().unwrap(), stdin.as_bytes()).unwrap();
    child.wait_with_output().unwrap()
}

fn start(name: &str) -> String {
    format!("<!-- figures: {name} -->\n")
}

fn end(name: &str) -> String {
    format!("<!-- end figures: {name} -->")
}

/// The page split around a region: (up to and including its start marker's
/// line, what is between, from its end marker on).
fn split<'a>(page: &'a str, name: &str) -> (&'a str, &'a str, &'a str) {
    let open = page.find(&start(name)).expect("the start marker") + start(name).len();
    let close = open + page[open..].find(&end(name)).expect("the end marker");
    (&page[..open], &page[open..close], &page[close..])
}

/// The files of a folder, to see that no temporary file is left behind.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

#[test]
fn a_region_of_a_copy_of_the_page_is_replaced_and_the_rest_is_kept() {
    let original = std::fs::read_to_string(root().join("docs/performance.md")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("performance.md");
    std::fs::write(&page, &original).unwrap();
    let figures = "scene  before  now  speed-up\ncornell  1.00s  0.50s  2.00x";
    let out = doc_figures(
        &[page.to_str().unwrap(), "compare-revisions", "--command", "scripts/compare-revisions.sh HEAD~1"],
        figures,
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let written = std::fs::read_to_string(&page).unwrap();
    let (before, old, after) = split(&original, "compare-revisions");
    let (new_before, new, new_after) = split(&written, "compare-revisions");
    assert_eq!(new_before, before, "the page before the region is unchanged");
    assert_eq!(new_after, after, "the page after the region is unchanged");
    assert_ne!(new, old, "the region changed");
    assert!(new.contains(&format!("```text\n{figures}\n```\n")), "the figures as a text block: {new}");
    assert!(new.contains("commit ") && new.contains("CPUs, load average"), "when and where: {new}");
    assert!(new.contains("`scripts/compare-revisions.sh HEAD~1`"), "the command: {new}");
    assert_eq!(listing(dir.path()), ["performance.md"], "no temporary file is left");

    // Again: the region is replaced, not appended to.
    let out = doc_figures(&[page.to_str().unwrap(), "compare-revisions"], "second run");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let again = std::fs::read_to_string(&page).unwrap();
    let (_, region, _) = split(&again, "compare-revisions");
    assert!(region.contains("second run") && !region.contains("cornell"), "{region}");
    assert_eq!(again.len() - region.len(), original.len() - old.len());
}

#[test]
fn the_bytes_around_the_region_are_kept_exactly() {
    // No final newline, CRLF lines, trailing blanks and a look-alike marker.
    let page_text = "intro  \r\n<!-- figures: other -->\r\nx\r\n<!-- figures: a b -->\nold\nold\n\
                     <!-- end figures: a b -->\n<!-- end figures: other -->\r\ntail without newline";
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("p.md");
    std::fs::write(&page, page_text).unwrap();
    let out = doc_figures(&[page.to_str().unwrap(), "a b"], "1.5x\n");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let written = std::fs::read_to_string(&page).unwrap();
    let (before, _, after) = split(page_text, "a b");
    assert!(written.starts_with(before), "{written:?}");
    assert!(written.ends_with(after), "{written:?}");
    assert!(!written.contains("old"), "{written:?}");
    assert!(written.contains("```text\n1.5x\n```\n<!-- end figures: a b -->"), "{written:?}");
}

#[test]
fn a_missing_or_doubled_marker_is_an_error_naming_it_and_the_page_is_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("p.md");
    let cases = [
        // (page, region, what the error must name)
        ("text\n", "absent", "<!-- figures: absent -->"),
        ("<!-- figures: half -->\nold\n", "half", "<!-- end figures: half -->"),
        ("<!-- end figures: back -->\n<!-- figures: back -->\n", "back", "comes before"),
        ("<!-- figures: twice -->\n<!-- figures: twice -->\n<!-- end figures: twice -->\n", "twice", "more than once"),
    ];
    for (text, name, named) in cases {
        std::fs::write(&page, text).unwrap();
        for check in [false, true] {
            let mut args = vec![page.to_str().unwrap(), name];
            if check {
                args.insert(0, "--check");
            }
            let out = doc_figures(&args, "figures");
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert!(!out.status.success(), "{name}: accepted");
            assert!(stderr.contains(named), "{name}: the error does not name `{named}`: {stderr}");
            assert_eq!(std::fs::read_to_string(&page).unwrap(), text, "{name}: the page changed");
            assert_eq!(listing(dir.path()), ["p.md"], "{name}: a temporary file was left");
        }
    }
    let out = doc_figures(&["--check", dir.path().join("none.md").to_str().unwrap(), "x"], "");
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("none.md"));
}

/// The regions the scripts write, as they name them.
const REGIONS: [&str; 10] = [
    "compare-peers cornell",
    "compare-peers whitted",
    "compare-peers procedural",
    "compare-peers glossy",
    "compare-peers envlight",
    "compare-peers spectral",
    "compare-revisions",
    "bench render",
    "bench shading",
    "bench check",
];

#[test]
fn every_region_the_scripts_write_is_in_the_page() {
    let page = root().join("docs/performance.md");
    for name in REGIONS {
        let out = doc_figures(&["--check", page.to_str().unwrap(), name], "");
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    // The scripts name these regions (a renamed one fails here or above).
    let peers = std::fs::read_to_string(root().join("scripts/compare-peers.sh")).unwrap();
    assert!(peers.contains("\"compare-peers $case\""), "compare-peers.sh writes `compare-peers CASE`");
    let revisions = std::fs::read_to_string(root().join("scripts/compare-revisions.sh")).unwrap();
    assert!(revisions.contains("docs/performance.md\" compare-revisions"));
    let benches = std::fs::read_to_string(root().join("scripts/bench-figures.sh")).unwrap();
    assert!(benches.contains("name=\"bench $bench"));
}

#[test]
fn load_prints_three_load_averages() {
    let out = doc_figures(&["--load"], "");
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let numbers: Vec<f64> = text.split_whitespace().map(|w| w.parse().expect("a number")).collect();
    assert_eq!(numbers.len(), 3, "{text}");
}
