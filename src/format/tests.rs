use super::format_source;

fn fmt(src: &str) -> String {
    let once = format_source(src).unwrap();
    assert_eq!(format_source(&once).unwrap(), once, "not idempotent");
    once
}

#[test]
fn comment_at_end_of_file() {
    assert_eq!(fmt("const float A = 1; // a\n// end"), "const float A = 1; // a\n// end\n");
}

#[test]
fn comments_between_arguments() {
    let out = fmt("float f() { return g(1, // one\n 2); }");
    assert_eq!(out, "float f() {\n    return g(\n        1, // one\n        2,\n    );\n}\n");
}

#[test]
fn nested_blocks() {
    let out = fmt("void f(){if x {for i in 0..3 {y=1;}} else {return;}}");
    assert_eq!(
        out,
        "void f() {\n    if x {\n        for i in 0..3 {\n            y = 1;\n        }\n    } else {\n        return;\n    }\n}\n"
    );
}

#[test]
fn long_calls_break_one_argument_per_line() {
    let src = "const float A = some_function(first_argument_name, second_argument_name, third_argument_name, fourth);";
    let out = fmt(src);
    assert!(out.contains("(\n    first_argument_name,\n"), "{out}");
    assert!(out.lines().all(|l| l.len() <= 100));
}

#[test]
fn parentheses_are_kept() {
    assert_eq!(fmt("const float A = (1+2)*((3));"), "const float A = (1 + 2) * ((3));\n");
}

#[test]
fn blank_lines_at_most_one() {
    assert_eq!(
        fmt("const int A = 1;\n\n\n\nconst int B = 2;\nconst int C = 3;"),
        "const int A = 1;\n\nconst int B = 2;\nconst int C = 3;\n"
    );
}

#[test]
fn a_100000_term_chain_formats_without_overflowing_broken_before_its_loosest_operators() {
    let src = format!("float f(float x) {{ return (x+x)*x{}; }}", "+x-x".repeat(50_000));
    let out = fmt(&src);
    assert!(
        out.starts_with("float f(float x) {\n    return (x + x) * x\n        + x\n        - x\n"),
        "{}",
        &out[..200]
    );
    assert!(out.ends_with("\n        + x\n        - x;\n}\n"));
}

#[test]
fn long_chains_break_before_their_loosest_operators() {
    let src =
        "const float A = first_long_name * second_long_name + third_long_name * fourth_long_name - fifth_name * 2;";
    assert_eq!(
        fmt(src),
        "const float A = first_long_name * second_long_name\n    + third_long_name * fourth_long_name\n    - fifth_name * 2;\n"
    );
    assert_eq!(fmt("const float B = 1+2*3;"), "const float B = 1 + 2 * 3;\n");
}

#[test]
fn long_conditionals_break_before_the_question_mark_and_the_colon() {
    let src = "float f(float u) { return u < some_probability(u, 2.0) ? first_branch_value(u, 3.0, 5.0) : second_branch_value(u, 4.0); }";
    assert_eq!(
        fmt(src),
        "float f(float u) {\n    return u < some_probability(u, 2.0)\n        ? first_branch_value(u, 3.0, 5.0)\n        : second_branch_value(u, 4.0);\n}\n"
    );
    assert_eq!(fmt("const float C = true?1:2;"), "const float C = true ? 1 : 2;\n");
}

#[test]
fn scene_blocks_stay_on_one_line_when_they_fit() {
    let src = "scene { camera { from (0, 1, -4); to (0, 1, 0); } object sphere { center (0, 1, 0); radius 1; material lambert(kd: rgb(0.25, 0.5, 0.75), sigma: 0.5); } }";
    assert_eq!(
        fmt(src),
        "scene {\n    camera { from (0, 1, -4); to (0, 1, 0); }\n    object sphere {\n        center (0, 1, 0);\n        radius 1;\n        material lambert(kd: rgb(0.25, 0.5, 0.75), sigma: 0.5);\n    }\n}\n"
    );
    // A line comment inside keeps the block broken.
    let out = fmt("scene { camera { from (0, 1, -4); // eye\n to (0, 0, 0); } }");
    assert_eq!(out, "scene {\n    camera {\n        from (0, 1, -4); // eye\n        to (0, 0, 0);\n    }\n}\n");
}

#[test]
fn data_arrays_fill_their_lines_and_a_sole_array_argument_is_hugged() {
    let rows: Vec<String> = (0..20).map(|i| format!("({}.5, 0.{i})", 400 + 10 * i)).collect();
    let out = fmt(&format!("const color S = spectrum([{}]);", rows.join(",")));
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[0], "const color S = spectrum([");
    assert_eq!(lines[1], "    (400.5, 0.0), (410.5, 0.1), (420.5, 0.2), (430.5, 0.3), (440.5, 0.4), (450.5, 0.5),");
    assert!(lines[2].starts_with("    (460.5, 0.6), "), "{out}");
    assert_eq!(*lines.last().unwrap(), "]);");
    assert!(lines.iter().all(|l| l.len() <= 100));
    assert_eq!(fmt("const float[2] D = [1,2];"), "const float[2] D = [1, 2];\n");
}
