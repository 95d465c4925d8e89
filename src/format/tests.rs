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

// ------------------------------------------------ a line comment ends its line

/// The case: a data array filled onto full lines put the elements
/// after a `// comment` into the comment (5 elements became 2).
#[test]
fn a_line_comment_in_a_data_array_keeps_the_elements_after_it() {
    let out = fmt("const float[5] W = [0.1, 0.2, // low\n    0.3, 0.4, 0.5];");
    assert_eq!(out, "const float[5] W = [\n    0.1, 0.2, // low\n    0.3, 0.4, 0.5,\n];\n");
    let out = fmt("material m = blend(noise(), [0.1, // a\n 0.2, 0.3, 0.4, 0.5]);");
    assert!(out.contains("0.1, // a\n"), "{out}");
    assert!(out.contains("0.2, 0.3, 0.4, 0.5,\n"), "{out}");
}

/// Every layout that puts something after a line comment on its line:
/// filled rows, the hugged sole array argument, a flat chain, a flat
/// conditional, a scene block that would fit on one line.
#[test]
fn whatever_the_layout_nothing_follows_a_line_comment_on_its_line() {
    let cases = [
        "const color S = spectrum([(400.0, 0.1), // blue\n (500.0, 0.5), (600.0, 0.9)]);",
        "const float[3] A = [1, 2 // two\n , 3];",
        "const float B = 1 + // one\n 2 + 3;",
        "const float C = true ? 1 // then\n : 2;",
        "scene { camera { from (0, 1, -4) // eye\n ; to (0, 1, 0); } }",
        "const float D = f(1 // one\n);",
        "const vector E = (1, /* x */ 2 // y\n, 3);",
        "const float F = g(a: 1 // named\n, b: [2, 3 // three\n]);",
    ];
    for src in cases {
        let out = fmt(src);
        for line in out.lines() {
            if let Some(i) = line.find("//") {
                let rest = &line[i..];
                assert!(!rest.contains(',') && !rest.contains(')') && !rest.contains(';'), "{src:?} gave\n{out}");
            }
        }
    }
}

// ------------------------------------------------ comments before separators

/// The case: a comment between the last argument and a trailing
/// comma went with the comma, which the style drops on one line.
#[test]
fn a_comment_before_a_trailing_comma_is_kept() {
    let two = "float h() {\n    return g(\n        1,\n        2, /* two */\n    );\n}\n";
    assert_eq!(fmt("float h() { return g(1, 2 /* two */ ,); }"), two);
    assert_eq!(fmt("float h() { return g(1, 2 /* two */); }"), two);
    assert_eq!(
        fmt("float f(float a) { return g(a // last\n , ); }"),
        "float f(float a) {\n    return g(\n        a, // last\n    );\n}\n"
    );
}

/// Parameters, arrays (of data and not), tuples, the sole array argument
/// and statements' semicolons: a comment before the separator survives,
/// a line comment goes after it.
#[test]
fn comments_before_every_kind_of_separator_are_kept() {
    let cases = [
        ("float f(float a, float b /* bee */ ,) { return a; }", "float b, /* bee */\n) {"),
        ("float f(float a // first\n , float b) { return a; }", "float a, // first\n"),
        ("const float[2] A = [1, 2 // two\n ,];", "1, 2, // two\n"),
        ("material m = blend(noise(), [mirror, glass /* g */ ,]);", "glass, /* g */\n"),
        ("const vector V = (1, 2, 3 // z\n ,);", "3, // z\n"),
        ("const float T = (1 /* one */ ,);", "1, /* one */\n"),
        ("const color S = spectrum([(400.0, 0.1), (500.0, 0.5)] // data\n ,);", "] // data\n"),
        ("float f() { return 1 // one\n ; }", "return 1; // one\n"),
        ("float f() { return 1 /* one */ ; }", "return 1 /* one */;"),
        ("scene { camera { fov 40 // wide\n ; } }", "fov 40; // wide\n"),
    ];
    for (src, expected) in cases {
        let out = fmt(src);
        assert!(out.contains(expected), "{src:?} gave\n{out}\nexpected to contain {expected:?}");
    }
}

/// Comments in the other awkward places: before and after every kind of
/// bracket, in types, after the last token without a line end, several in
/// one gap, and a block comment holding what looks like an opening one.
#[test]
fn comments_in_awkward_places_are_kept() {
    let cases = [
        "const float /* a */ [ /* b */ 4 /* c */ ] /* d */ A = [1, 2, 3, 4];",
        "import /* a */ \"x.tsl\" /* b */ ;",
        "float f( /* a */ ) /* b */ { /* c */ }",
        "float f() { return ( /* a */ 1 /* b */ ) ; }",
        "const float A = 1; // the end, no line end",
        "const float A = 1; /* the end, no line end */",
        "const float A = 1; /* one */ /* two */ // three\n/* four /* not nested */",
        "const float A = f(/* a */) + g( // b\n);",
        "scene { /* a */ camera /* b */ { /* c */ } /* d */ }",
        "/* only a comment */",
        "// only a comment",
        "const float A = 1; /* a\n   multi-line\n      comment */ const float B = 2;",
    ];
    for src in cases {
        let out = fmt(src);
        let count = |s: &str| s.matches("/*").count() + s.matches("//").count();
        assert_eq!(count(&out), count(src), "{src:?} gave\n{out}");
    }
}

// ------------------------------------------------ the verifier refuses

/// The verifier's answer for `src` printed as `printed` (a printer bug
/// simulated by hand).
fn refusal(src: &str, printed: &str) -> crate::diag::Diagnostic {
    let (ast, diags) = crate::syntax::parse(crate::diag::FileId(0), src);
    assert!(diags.is_empty(), "{diags:?}");
    let lexed = super::lexed::lex(src).unwrap();
    let mut ds = super::verify::same_program(src, &lexed, &ast, printed).expect_err("the verifier accepted it");
    assert_eq!(ds.len(), 1);
    let d = ds.remove(0);
    assert!(d.is_error());
    assert!(d.help.as_deref().is_some_and(|h| h.contains("nothing was written")), "{d:?}");
    d
}

#[track_caller]
fn assert_refused(src: &str, printed: &str, message: &str, at: &str) {
    let d = refusal(src, printed);
    assert_eq!(d.message, message);
    assert_eq!(&src[d.span.range()], at, "{d:?}");
}

#[test]
fn the_verifier_refuses_a_different_tree_naming_the_node_at_the_input_location() {
    // The two bugs of the issue, as the old printer printed them.
    assert_refused(
        "const float[5] W = [0.1, 0.2, // low\n    0.3, 0.4, 0.5];",
        "const float[5] W = [\n    0.1, 0.2, // low 0.3, 0.4, 0.5,\n];\n",
        "formatting refused because it would change the program: the array at 1:20 would have 2 elements instead of 5",
        "[0.1, 0.2, // low\n    0.3, 0.4, 0.5]",
    );
    assert_refused(
        "float h() { return g(1, 2 /* two */ ,); }",
        "float h() {\n    return g(1, 2);\n}\n",
        "formatting refused because it would lose or change a comment: the comment at 1:27 would be lost",
        "/* two */",
    );
    assert_refused(
        "const float A = (1 + 2) * 3;",
        "const float A = 1 + 2 * 3;\n",
        "formatting refused because it would change the program: the `*` operation at 1:17 would become the `+` operation",
        "(1 + 2) * 3",
    );
    assert_refused(
        "const float A = ((1));",
        "const float A = (1);\n",
        "formatting refused because it would change the program: the parentheses around the literal `1` at 1:19 would change",
        "1",
    );
    assert_refused(
        "const float T = (1,);",
        "const float T = (1);\n",
        "formatting refused because it would change the program: the tuple at 1:17 would become the literal `1`",
        "(1,)",
    );
    assert_refused(
        "const int A = 1;\nconst int B = 2;",
        "const int A = 1;\nconst int C = 2;\n",
        "formatting refused because it would change the program: the name `B` at 2:11 would become `C`",
        "B",
    );
    assert_refused(
        "float f(float x) { if x > 0 { return x; } return 0; }",
        "float f(float x) {\n    if x > 0 {\n        return x;\n    }\n}\n",
        "formatting refused because it would change the program: the block at 1:18 would have 1 statement instead of 2",
        "{ if x > 0 { return x; } return 0; }",
    );
}

#[test]
fn the_verifier_refuses_a_respelled_token_and_a_changed_comment() {
    assert_refused(
        "const float A = 1.50;",
        "const float A = 1.5;\n",
        "formatting refused because it would change the program: `1.50` at 1:17 would become `1.5`",
        "1.50",
    );
    assert_refused(
        "const vec2 A = uv(1, 2);",
        "const vec2 A = vec2(1, 2);\n",
        "formatting refused because it would change the program: `uv` at 1:16 would become `vec2`",
        "uv",
    );
    assert_refused(
        "const int A = 1; // one\n/* two */",
        "const int A = 1; // one /* two */\n",
        "formatting refused because it would lose or change a comment: the comment at 1:18 would be lost",
        "// one",
    );
    assert_refused(
        "const int A = 1; // one",
        "const int A = 1; // on\n",
        "formatting refused because it would lose or change a comment: the comment at 1:18 would become \"// on\"",
        "// one",
    );
    assert_refused(
        "const int A = 1; /* one */",
        "const int A = 1; // one\n",
        "formatting refused because it would lose or change a comment: the comment at 1:18 would become \"// one\"",
        "/* one */",
    );
    let d = refusal("const int A = 1;", "const int A = 1; // new\n");
    assert!(d.message.ends_with("would gain the comment \"// new\""), "{}", d.message);
    // Trailing white space inside a comment's lines is not part of it.
    let src = "const int A = 1; /* a   \n   b */ // c  ";
    let (ast, _) = crate::syntax::parse(crate::diag::FileId(0), src);
    let lexed = super::lexed::lex(src).unwrap();
    assert!(super::verify::same_program(src, &lexed, &ast, "const int A = 1; /* a\n   b */ // c\n").is_ok());
}

/// What a refusal quotes from the file is escaped and cut: a comment
/// cannot send escape sequences to the terminal or fill it.
#[test]
fn the_verifier_quotes_escaped_and_bounded_text() {
    let d = refusal("const int A = 1; // \u{1b}[31mred", "const int A = 1; // \u{1b}[31mre\n");
    assert!(d.message.ends_with("would become \"// ␛[31mre\""), "{}", d.message);
    let long = format!("// {}", "x".repeat(100));
    let d = refusal(&format!("const int A = 1; {long}"), &format!("const int A = 1; {long}y\n"));
    let quoted = format!("\"{}…\"", &long[..super::QUOTED_CHARS]);
    assert!(d.message.ends_with(&quoted), "{}", d.message);
    let d = refusal("const string S = \"\u{1b}[2J\";", "const string S = \"\u{1b}[2K\";\n");
    assert!(!d.message.contains('\u{1b}') && d.message.contains('␛'), "{}", d.message);
}

#[test]
fn the_verifier_refuses_output_that_does_not_parse() {
    let d = refusal("const float A = (1);\nconst float B = 2;", "const float A = (1;\nconst float B = 2;\n");
    assert!(d.message.starts_with("formatting refused because its output would not parse ("), "{}", d.message);
    let d = refusal("const float A = 1;", "const float A = 1; /* never closed\n");
    assert!(d.message.starts_with("formatting refused because its output would not parse ("), "{}", d.message);
}

#[test]
fn refusals_are_told_apart_from_the_sources_own_syntax_errors() {
    let d = refusal("const float A = (1);", "const float A = 1;\n");
    assert!(super::is_refusal(&d), "{}", d.message);
    let syntax = format_source("const float A = ;").unwrap_err();
    assert!(!syntax.is_empty() && !syntax.iter().any(super::is_refusal), "{syntax:?}");
}

#[test]
fn parameter_options_and_doc_comments() {
    let out = fmt("material m(/// the lobe\nstring d=\"a\"in(\"a\",\"b\"),string e in ( \"x\" )) = lambert;");
    assert_eq!(
        out,
        "material m(\n    /// the lobe\n    string d = \"a\" in (\"a\", \"b\"),\n    string e in (\"x\"),\n) = lambert;\n"
    );
    // A list too long for its line breaks one option a line, as arguments do.
    let long: Vec<String> = (0..12).map(|k| format!("\"option_number_{k}\"")).collect();
    let out = fmt(&format!("float f(string s = \"option_number_0\" in ({})) {{ return 0; }}", long.join(", ")));
    assert!(out.contains("in (\n        \"option_number_0\",\n        \"option_number_1\",\n"), "{out}");
    assert!(out.lines().all(|l| l.len() <= 100), "{out}");
}

#[test]
fn changed_options_are_a_refusal() {
    // The verifier compares options: a printer that dropped one would be caught.
    let a = crate::syntax::parse(crate::diag::FileId(0), "float f(string s in (\"a\", \"b\")) { return 0; }").0;
    let b = crate::syntax::parse(crate::diag::FileId(0), "float f(string s in (\"a\")) { return 0; }").0;
    let difference = super::same_tree::same_file(&a, &b).unwrap_err();
    assert_eq!(difference.subject, "the options (\"a\", \"b\")");
    assert_eq!(difference.change, "would become (\"a\")");
}
