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
fn a_100000_term_chain_formats_flat_without_overflowing() {
    let src = format!("float f(float x) {{ return (x+x)*x{}; }}", "+x-x".repeat(50_000));
    let out = fmt(&src);
    assert!(out.starts_with("float f(float x) {\n    return (x + x) * x + x - x + x"), "{}", &out[..200]);
    assert!(out.ends_with(" + x - x;\n}\n"));
}
