//! `tslc query`: a file's material templates and their parameters, for
//! people and (`--json`) for tools, as `oslquery` lists a shader's.

mod common;

use common::{stderr, tslc};
use std::path::Path;

const PAINT: &str = r#"/// A car paint.
material car_paint(
    /// The paint's colour.
    color base = rgb(0.5, 0.02, 0.02),
    /// "ggx" has the longer highlight.
    string distribution = "ggx" in ("beckmann", "ggx"),
    material under = lambert,
    float[2] weights = [0.5, 0.5],
) = rough_plastic(diffuse_reflectance: base, distribution: distribution);
material plain = car_paint();
"#;

fn write(name: &str, text: &str) -> String {
    let dir = common::temp_dir(name);
    let path = Path::new(&dir).join(format!("{name}.tsl"));
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn lists_the_files_templates_with_types_defaults_docs_and_options() {
    let o = tslc(&["query", &write("query-paint", PAINT)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let expected = r#"material car_paint
    A car paint.
    color base = rgb(0.5, 0.02, 0.02)
        The paint's colour.
    string distribution = "ggx" in ("beckmann", "ggx")
        "ggx" has the longer highlight.
    material under = lambert
    float[2] weights = [0.5, 0.5]
"#;
    assert_eq!(stdout(&o), expected);
}

#[test]
fn one_prelude_template_by_name_and_as_json() {
    let path = write("query-json", PAINT);
    let o = tslc(&["query", &path, "rough_conductor"]);
    let text = stdout(&o);
    assert!(text.starts_with("material rough_conductor\n    Rough metal (Mitsuba: roughconductor).\n"), "{text}");
    assert!(text.contains("    float alpha = 0.1\n        microfacet roughness\n"), "{text}");
    assert!(text.contains("    color k = gray(1)  (= rgb(1, 1, 1))\n"), "{text}");

    let o = tslc(&["query", "--json", "--color-model", "spectral8", &path, "rough_conductor"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let lines: Vec<&str> = std::str::from_utf8(&o.stdout).unwrap().lines().collect();
    assert_eq!(lines.len(), 1, "one object per template");
    let v: serde_json::Value = serde_json::from_str(lines[0]).unwrap();
    assert_eq!(v["name"], "rough_conductor");
    assert_eq!(v["prelude"], true);
    let params = v["params"].as_array().unwrap();
    let distribution = params.iter().find(|p| p["name"] == "distribution").unwrap();
    assert_eq!(distribution["type"], "string");
    assert_eq!(distribution["options"], serde_json::json!(["beckmann", "ggx"]));
    assert_eq!(distribution["default"], "beckmann");
    let k = params.iter().find(|p| p["name"] == "k").unwrap();
    assert_eq!(k["default_source"], "gray(1)");
    assert_eq!(k["default"].as_array().unwrap().len(), 8, "colors as lanes of the chosen model: {k}");
    assert_eq!(params[0]["doc"], "microfacet roughness");

    // Without a name, --prelude lists the standard library's too.
    let o = tslc(&["query", "--json", "--prelude", &path]);
    let names: Vec<serde_json::Value> =
        stdout(&o).lines().map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["name"].clone()).collect();
    assert!(names.contains(&"lambert".into()) && names.contains(&"car_paint".into()), "{names:?}");
}

#[test]
fn unknown_names_and_bad_files_are_errors() {
    let path = write("query-errors", PAINT);
    let o = tslc(&["query", &path, "car_pain"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(o.stdout.is_empty());
    assert!(stderr(&o).contains("no material template named `car_pain` (did you mean `car_paint`?)"), "{}", stderr(&o));
    let o = tslc(&["query", &path, "plain"]);
    assert!(stderr(&o).contains("`plain` is a material tree without parameters"), "{}", stderr(&o));

    let none = write("query-none", "material plain = lambert;\n");
    let o = tslc(&["query", &none]);
    assert_eq!(o.status.code(), Some(0), "nothing to list is no error");
    assert!(o.stdout.is_empty());
    assert!(stderr(&o).contains("defines no material template (`--prelude` lists"), "{}", stderr(&o));

    let bad = write("query-bad", "material m(string d = \"x\" in (\"y\")) = lambert;\n");
    let o = tslc(&["query", &bad]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains(&format!("{bad}:1:23")), "located: {}", stderr(&o));
}

#[test]
fn control_characters_of_a_doc_comment_are_escaped() {
    let path =
        write("query-controls", "material m(\n    /// a \u{1b}[31mred\u{202e} doc\n    float x = 1,\n) = lambert;\n");
    let text = stdout(&tslc(&["query", &path]));
    assert!(!text.contains('\u{1b}') && !text.contains('\u{202e}'), "{text:?}");
    let json = stdout(&tslc(&["query", "--json", &path]));
    assert!(!json.contains('\u{1b}') && !json.contains('\u{202e}'), "{json:?}");
    let v: serde_json::Value = serde_json::from_str(json.trim()).unwrap();
    assert_eq!(v["params"][0]["doc"], "a \u{1b}[31mred\u{202e} doc", "JSON keeps the text, escaped");
}
