//! `tslc check` as users and CI run it: exit codes, streams, formats.

mod common;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn tslc(args: &[&str], stdin: Option<&str>) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_tslc"))
        .args(args)
        .stdin(if stdin.is_some() { Stdio::piped() } else { Stdio::null() })
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("tslc runs");
    if let Some(text) = stdin {
        child.stdin.take().unwrap().write_all(text.as_bytes()).unwrap();
    }
    child.wait_with_output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A scratch directory unique to one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tslc-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

const GOOD: &str = "float half(float x) { return x * 0.5; }\n";
const BAD: &str = "float f(color c) {\n    return c.r;\n}\n";

#[test]
fn clean_file_exits_zero_silently() {
    let dir = scratch("clean");
    let o = tslc(&["check", &write(&dir, "good.tsl", GOOD)], None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(o.stdout.is_empty() && o.stderr.is_empty());
}

#[test]
fn errors_exit_one_with_located_messages_on_stderr() {
    let dir = scratch("errors");
    let path = write(&dir, "bad.tsl", BAD);
    let o = tslc(&["check", "--color", "never", &path], None);
    assert_eq!(o.status.code(), Some(1));
    assert!(o.stdout.is_empty(), "diagnostics go to stderr");
    let err = stderr(&o);
    assert!(err.contains(&format!("{path}:2:14")), "{err}");
    assert!(err.contains("help:"), "{err}");
    assert!(!err.contains('\u{1b}'), "no colour when asked for none");
}

#[test]
fn every_file_is_checked_and_all_errors_reported() {
    let dir = scratch("many");
    let a = write(&dir, "a.tsl", "float f() { return x; }\nfloat g() { return y; }\n");
    let b = write(&dir, "b.tsl", GOOD);
    let c = write(&dir, "c.tsl", BAD);
    let o = tslc(&["check", &a, &b, &c], None);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.contains("`x`") && err.contains("`y`") && err.contains("`r`"), "{err}");
}

#[test]
fn colour_is_used_only_when_asked_or_on_a_terminal() {
    let dir = scratch("color");
    let path = write(&dir, "bad.tsl", BAD);
    let o = tslc(&["check", "--color", "always", &path], None);
    assert!(stderr(&o).contains('\u{1b}'));
    let o = tslc(&["check", &path], None);
    assert!(!stderr(&o).contains('\u{1b}'), "auto: stderr is a pipe here");
}

#[test]
fn json_messages_go_to_stdout_one_object_per_line() {
    let dir = scratch("json");
    let path = write(&dir, "bad.tsl", "float f(color c) { return c.r + q; }\n");
    let o = tslc(&["check", "--message-format", "json", &path], None);
    assert_eq!(o.status.code(), Some(1));
    let out = String::from_utf8(o.stdout).unwrap();
    let lines: Vec<serde_json::Value> = out.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 2, "{out}");
    let first = &lines[0];
    assert_eq!(first["severity"], "error");
    assert_eq!(first["file"], path.as_str());
    assert_eq!(first["line"], 1);
    assert_eq!(first["column"], 29);
    assert_eq!(first["byte_start"], 28);
    assert!(first["help"].as_str().unwrap().contains("brightness"));
    assert!(first["labels"].is_array());
    assert!(lines[1]["message"].as_str().unwrap().contains("`q`"));
}

#[test]
fn standard_input_with_a_reported_name_and_imports() {
    let dir = scratch("stdin");
    write(&dir, "lib.tsl", GOOD);
    let name = dir.join("main.tsl").display().to_string();
    let src = "import \"lib.tsl\";\nfloat g() { return half(2) + zz; }\n";
    let o = tslc(&["check", "--stdin-path", &name, "-"], Some(src));
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.contains(&format!("{name}:2:")), "named as given: {err}");
    assert!(!err.contains("cannot find imported"), "the import resolved next to the named path: {err}");
    assert!(err.contains("cannot find value `zz`"), "{err}");
}

#[test]
fn include_directories_are_searched() {
    let dir = scratch("include");
    let libdir = dir.join("lib");
    std::fs::create_dir_all(&libdir).unwrap();
    write(&libdir, "shapes.tsl", GOOD);
    let main = write(&dir, "main.tsl", "import \"shapes.tsl\";\nfloat g() { return half(2); }\n");
    let o = tslc(&["check", &main], None);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("cannot find imported file `shapes.tsl`"), "{}", stderr(&o));
    let o = tslc(&["check", "-I", &libdir.display().to_string(), &main], None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn warnings_fail_only_under_w_error() {
    let dir = scratch("warn");
    let path = write(&dir, "warn.tsl", "float f() { float unused = 1; return 2; }\n");
    let o = tslc(&["check", &path], None);
    assert_eq!(o.status.code(), Some(0));
    assert!(stderr(&o).contains("unused variable"));
    let o = tslc(&["check", "-W", "error", &path], None);
    assert_eq!(o.status.code(), Some(1));
}

#[test]
fn bad_paths_are_clear_errors() {
    let dir = scratch("paths");
    let missing = dir.join("nope.tsl").display().to_string();
    let o = tslc(&["check", &missing], None);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("no such file"), "{}", stderr(&o));

    let o = tslc(&["check", &dir.display().to_string()], None);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("is a directory"), "{}", stderr(&o));

    let empty = write(&dir, "empty.tsl", "");
    let o = tslc(&["check", &empty], None);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains(&format!("{empty}:1:1")), "{}", stderr(&o));
}

#[test]
fn usage_errors_exit_two() {
    assert_eq!(tslc(&["check"], None).status.code(), Some(2));
    assert_eq!(tslc(&["check", "--colour", "x", "a.tsl"], None).status.code(), Some(2));
    assert_eq!(tslc(&["frobnicate"], None).status.code(), Some(2));
}

#[test]
fn stdlib_and_examples_check_clean_from_the_command_line() {
    let mut files: Vec<String> = Vec::new();
    for dir in ["stdlib", "examples"] {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            // heavy.tsl's mesh is generated (`tslc make-mesh heavy`), and
            // checking reads it: without it, tests/check.rs expects the
            // one error that says so.
            let generated = Path::new("examples/gen/heavy.obj").exists();
            if p.extension().is_some_and(|x| x == "tsl") && (generated || p != Path::new("examples/heavy.tsl")) {
                files.push(p.display().to_string());
            }
        }
    }
    let mut args = vec!["check"];
    args.extend(files.iter().map(String::as_str));
    let o = tslc(&args, None);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn check_and_render_report_every_scene_error_at_once() {
    // Errors only the scene's values and files show: checking finds them
    // all, and rendering reports the same ones (it compiles through the
    // same checks) instead of stopping at the first.
    let file = "tests/check/err/scene_several_value_errors.tsl";
    let check = tslc(&["check", "--color", "never", file], None);
    assert_eq!(check.status.code(), Some(1));
    let checked = stderr(&check);
    let errors = checked.lines().filter(|l| l.starts_with("error: ")).count();
    assert!(checked.ends_with("error: could not check due to 8 errors\n"), "{checked}");
    assert_eq!(errors, 9, "eight errors and the summary:\n{checked}");
    let dir = scratch("scene-errors");
    let out = dir.join("never.png");
    let render = tslc(&["render", file, "-o", &out.display().to_string()], None);
    assert_eq!(render.status.code(), Some(1));
    let rendered = stderr(&render);
    assert_eq!(rendered, checked.trim_end_matches("error: could not check due to 8 errors\n"));
    assert!(!out.exists());
}

#[test]
fn emit_hit_prints_each_material_split() {
    let dir = scratch("emit_hit");
    let file = write(&dir, "m.tsl", "material bumpy = bump(fbm(P * 4), 0.1, lambert);\nmaterial plain = lambert;\n");
    let out = tslc(&["emit", &file, "--emit", "hit"], None);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("// bumpy: a ") && text.contains("the renderer prepares it"), "{text}");
    assert!(text.contains("fn bumpy.hit.prepare(") && text.contains("fn bumpy.hit.sample(hit: ["), "{text}");
    assert!(text.contains("hit[0]"), "the methods read the record:\n{text}");
    assert!(text.contains("// plain: a ") && text.contains("calls each method on its own"), "{text}");
}

/// An endless input (`/dev/zero`) is refused with a clear error instead of
/// being read until memory runs out: it is a device, which is refused
/// before a byte is read (a regular file over the size limit is refused
/// too: tests/files.rs).
#[test]
fn endless_input_stops_at_the_source_size_limit() {
    if !Path::new("/dev/zero").exists() {
        return;
    }
    let o = tslc(&["check", "/dev/zero"], None);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("cannot read `/dev/zero`: it is a character device, not a regular file"),
        "{}",
        stderr(&o)
    );
}

/// Output piped into a reader that stops early (`tslc fmt --check DIR |
/// head`): the closed pipe ends the output quietly, never a panic.
#[test]
fn a_closed_stdout_is_no_panic() {
    let dir = scratch("closed-stdout");
    for k in 0..40 {
        // Unformatted: every file gives a diff, far more than a pipe holds.
        let body: String = (0..60).map(|i| format!("float f{i}(float x){{return x*{i};}}\n")).collect();
        write(&dir, &format!("f{k}.tsl"), &body);
    }
    let mut child = Command::new(env!("CARGO_BIN_EXE_tslc"))
        .args(["fmt", "--check", &dir.display().to_string()])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("tslc runs");
    drop(child.stdout.take()); // the reader goes away at once
    let o = child.wait_with_output().unwrap();
    let err = stderr(&o);
    assert!(!err.contains("panicked") && !err.contains("internal compiler error"), "{err}");
    assert_eq!(o.status.code(), Some(1), "unformatted files still fail the check: {err}");
    let _ = std::fs::remove_dir_all(&dir);
}
