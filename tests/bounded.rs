//! Small inputs, unbounded work (issue 29): constants that use the previous
//! constant twice, materials that use the previous material twice,
//! thousands of errors on one long line, control characters in a file.
//! Each class is held by counts and sizes, never by timings: a chain that
//! doubles 60 times can only finish when nothing is evaluated twice.

mod common;

use common::Rng;
use tsl::diag::{MAX_DIAGNOSTICS_PER_FILE, MAX_QUOTED_LINE_CHARS, Severity};
use tsl::{Color, ColorModel, Compiler, LoadOptions, ShadingGlobals};

fn check(src: &str) -> tsl::Checked {
    tsl::check_source("input.tsl", src, &LoadOptions::default())
}

fn assert_clean(checked: &tsl::Checked) {
    let text = checked.render_diagnostics();
    assert!(checked.is_ok(), "{}", &text[..text.len().min(3000)]);
}

const SCENE: &str = "scene {
    camera { from (0, 0, -4); to (0, 0, 0); fov FOV; }
    light point { at (2, 4, -3); intensity rgb(60, 60, 60); }
    object sphere { center (0, 0, 0); radius 1; material MATERIAL; }
}
";

fn scene(fov: &str, material: &str) -> String {
    SCENE.replace("FOV", fov).replace("MATERIAL", material)
}

/// `const TY c0 = FIRST; const TY c1 = STEP(c0); ...` to `c{n}`, `STEP`
/// written with `{p}` for the previous constant.
fn chain(ty: &str, first: &str, step: &str, n: usize) -> String {
    let mut src = format!("const {ty} c0 = {first};\n");
    for k in 1..=n {
        src += &format!("const {ty} c{k} = {};\n", step.replace("{p}", &format!("c{}", k - 1)));
    }
    src
}

// ------------------------------------------------------------------ constants

// Moved into the crate (they read the lowered IR): src/ir/tests/bounded.rs
// holds doubling_constants_are_evaluated_once,
// frame_dependent_doubling_constants_are_lowered_once,
// long_chains_and_dags_of_constants,
// materials_that_use_the_previous_twice_compile_in_linear_code and
// lowering_stops_at_its_bound_with_a_located_error.

/// Scene values share the constants they read: 500 objects whose radius
/// is the last of 20,000 constants evaluate the chain once, not 500 times.
#[test]
fn scene_values_evaluate_a_shared_chain_once() {
    let objects: String = (0..500)
        .map(|k| format!("    object sphere {{ center ({k}, 0, 10); radius c20000 * 0.25; material lambert; }}\n"))
        .collect();
    let src = chain("float", "2", "{p} * 1.0", 20_000)
        + "scene {\n    camera { from (0, 0, -4); to (0, 0, 0); fov 40; }\n"
        + &objects
        + "}\n";
    let checked = check(&src);
    assert_clean(&checked);
    let scene = checked.scene.expect("a scene");
    assert_eq!(scene.objects.len(), 500);
    let radius = |o: &tsl::scene::ObjectDesc| match &o.shape {
        tsl::scene::ShapeDesc::Sphere { radius, .. } => radius.value,
        _ => 0.0,
    };
    assert!(scene.objects.iter().all(|o| radius(o) == 0.5));
}

/// A constant that reads the point through a function is reported once,
/// not once for every constant built on it.
#[test]
fn a_varying_constant_is_reported_once_however_many_use_it() {
    for n in [10, 2_000] {
        let src = format!("float height() {{ return P.y; }}\n{}", chain("float", "height()", "{p} + {p}", n));
        let checked = check(&src);
        let errors: Vec<&str> =
            checked.diagnostics.iter().filter(|d| d.is_error()).map(|d| d.message.as_str()).collect();
        assert_eq!(errors, ["constant `c0` depends on the shading point"], "chain of {n}");
    }
}

// ------------------------------------------------------------------ materials

/// `material m0 = ...; material m1 = STEP(m0); ...` to `m{n}`, with a scene
/// that renders `m{n}`.
fn material_chain(step: &str, n: usize) -> String {
    let mut src = "material m0 = phong(kd: rgb(0.6, 0.3, 0.2));\nmaterial mirrored = mirror;\n".to_string();
    src += "material twice(material a) = mix(noise(P * 2), a, a);\n";
    for k in 1..=n {
        let prev = format!("m{}", k - 1);
        let prev2 = format!("m{}", k.saturating_sub(2));
        src += &format!("material m{k} = {};\n", step.replace("{p}", &prev).replace("{q}", &prev2));
    }
    src + &scene("40", &format!("m{n}"))
}

/// Sharing changes no result: `mix(t, a, a)` samples as `mix(t, a, a2)`
/// does, where `a2` is a copy of `a` under another name (so compiled on
/// its own, in its own branch): the same directions, the same weights
/// and densities up to rounding; likewise `blend` and `select` with
/// repeated children.
#[test]
fn shared_children_sample_as_separate_copies_do() {
    let src = "
        material a = phong(kd: rgb(0.6, 0.3, 0.2), ks: rgb(0.3, 0.3, 0.3), ns: 20);
        material a2 = phong(kd: rgb(0.6, 0.3, 0.2), ks: rgb(0.3, 0.3, 0.3), ns: 20);
        material b = mirror(kr: rgb(0.9, 0.8, 0.7));
        material shared_mix = mix(0.3 + 0.4 * noise(P * 3), a, a);
        material split_mix = mix(0.3 + 0.4 * noise(P * 3), a, a2);
        material shared_blend = blend(u, [a, b, a]);
        material split_blend = blend(u, [a, b, a2]);
        material shared_select = select(int(v * 3), [a, a, b]);
        material split_select = select(int(v * 3), [a, a2, b]);
        material shared_nested = mix(0.5, blend(u, [a, b, a]), a);
        material split_nested = mix(0.5, blend(u, [a, b, a2]), a2);
    ";
    let program = Compiler::new().source("shared.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"));
    let close = |x: f32, y: f32| (x - y).abs() <= 1e-5 * (1.0 + x.abs().max(y.abs()));
    let mut rng = Rng(29);
    for kind in ["mix", "blend", "select", "nested"] {
        let shared = program.material(&format!("shared_{kind}")).unwrap();
        let split = program.material(&format!("split_{kind}")).unwrap();
        for _ in 0..400 {
            let g = ShadingGlobals {
                p: [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.0],
                n: [0.0, 0.0, 1.0],
                ng: [0.0, 0.0, 1.0],
                u: rng.range(0.0, 1.0),
                v: rng.range(0.0, 1.0),
                dpdu: [1.0, 0.0, 0.0],
                dpdv: [0.0, 1.0, 0.0],
                ..ShadingGlobals::default()
            };
            let mut wo = rng.unit();
            wo[2] = wo[2].abs();
            let eta = program.rgb(1.0, 1.0, 1.0);
            let (uc, u2) = (rng.range(0.0, 1.0), [rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
            let (s, t) = (shared.sample(&g, wo, &eta, uc, u2), split.sample(&g, wo, &eta, uc, u2));
            assert_eq!(s.wi, t.wi, "{kind}: the same child drawn with the same numbers");
            assert_eq!(s.delta, t.delta, "{kind}");
            assert!(close(s.pdf, t.pdf), "{kind}: pdf {} against {}", s.pdf, t.pdf);
            for (x, y) in s.weight.lanes().iter().zip(t.weight.lanes()) {
                assert!(close(*x, *y), "{kind}: weight {:?} against {:?}", s.weight.lanes(), t.weight.lanes());
            }
            let wi = rng.unit();
            let light = Color::from_lanes(ColorModel::Rgb, &[1.0, 1.0, 1.0]);
            let (f, h) = (shared.reflection(&g, wi, &light, wo), split.reflection(&g, wi, &light, wo));
            for (x, y) in f.lanes().iter().zip(h.lanes()) {
                assert!(close(*x, *y), "{kind}: reflection {:?} against {:?}", f.lanes(), h.lanes());
            }
            assert!(close(shared.pdf(&g, wi, wo, &eta), split.pdf(&g, wi, wo, &eta)), "{kind}: pdf");
        }
    }
}

/// Trees that are exponential once inlined (the previous tree in two
/// different children, or under `transform` or `bump`) are refused by
/// `tslc check`, at the first level past the bound, once.
#[test]
fn exponential_material_trees_are_refused_by_check() {
    let cases = [
        ("mix(noise(P), {p}, scale(rgb(0.9, 0.8, 0.7), {p}))", "m9", 512),
        ("mix(noise(P), {p}, bump(noise(P * 3), 0.1, {p}))", "m9", 512),
        ("mix(noise(P), {p}, transform(rotate(30, (0, 1, 0)), {p}))", "m9", 512),
        ("blend(u, [{p}, mirrored, transform(rotate(30, (0, 1, 0)), {p})])", "m8", 511),
        ("mix(noise(P), {p}, {q})", "m13", 377),
    ];
    for (step, first, size) in cases {
        let src = material_chain(step, 40);
        let checked = check(&src);
        let errors: Vec<&tsl::diag::Diagnostic> = checked.diagnostics.iter().filter(|d| d.is_error()).collect();
        assert_eq!(errors.len(), 1, "{step}: {}", checked.render_diagnostics());
        assert_eq!(errors[0].message, format!("material `{first}` is too large to compile"), "{step}");
        let line = src.lines().position(|l| l.starts_with(&format!("material {first} "))).unwrap() + 1;
        let text = checked.render_diagnostics();
        assert!(text.contains(&format!("input.tsl:{line}:10")), "{text}");
        assert!(text.contains(&format!("it holds {size} material definitions; the most is 256")), "{text}");
    }
    // Templates that double through their arguments: reported where a
    // tree uses them (counts saturate, so 2^(2^40) is not computed).
    for t0 in ["mix(noise(P), a, scale(rgb(0.5, 0.5, 0.5), a))", "blend(u, [a, transform(rotate(9, (0, 0, 1)), a)])"] {
        let mut src = format!("material t0(material a) = {t0};\n");
        for k in 1..=40 {
            src += &format!("material t{k}(material a) = t{}(t{}(a));\n", k - 1, k - 1);
        }
        src += "material m = t40(lambert);\n";
        let checked = check(&src);
        let text = checked.render_diagnostics();
        assert_eq!(checked.count(Severity::Error), 1, "{text}");
        assert!(text.starts_with("error: material `m` is too large to compile\n"), "{text}");
        assert!(text.contains("┌─ input.tsl:42:10\n"), "{text}");
        assert!(text.contains("it holds more than 10^19 material definitions"), "{text}");
    }
    // A scene's own expression over a tree just within the bound.
    let src = material_chain("mix(noise(P), {p}, scale(rgb(0.9, 0.8, 0.7), {p}))", 8)
        .replace("material m8;", "material mix(u, m8, scale(rgb(0.5, 0.5, 0.5), m8));");
    let checked = check(&src);
    let text = checked.render_diagnostics();
    assert_eq!(checked.count(Severity::Error), 1, "{text}");
    assert!(text.contains("error: this material is too large to compile"), "{text}");
}

// ------------------------------------------------------------------ diagnostics

/// A 110 KB line holding 4,000 errors: the first 99, then a count, every
/// quoted line cut short (it printed 488 MB).
#[test]
fn thousands_of_errors_on_one_long_line_print_a_bounded_report() {
    let terms: Vec<String> = (0..4000).map(|k| format!("zq{}", k % 10)).collect();
    let mut src = format!("float f() {{ return {}", terms.join(" + "));
    while src.len() < 110_000 {
        src += " + 0";
    }
    src += "; }";
    let checked = check(&src);
    assert_eq!(checked.count(Severity::Error), 4000, "every error is still found");
    let text = checked.render_diagnostics();
    assert!(text.len() < 64 * 1024, "{} bytes", text.len());
    assert_eq!(text.matches("error: cannot find value").count(), MAX_DIAGNOSTICS_PER_FILE - 1);
    assert!(text.ends_with("error: 3901 more errors in input.tsl not shown\n"), "{}", &text[text.len() - 300..]);
    let longest = text.lines().map(|l| l.chars().count()).max().unwrap_or(0);
    assert!(longest <= MAX_QUOTED_LINE_CHARS, "a quoted line of {longest} characters");
    let json = tsl::diag::json_lines(&checked.program.loaded.sources, &checked.diagnostics);
    assert_eq!(json.len(), MAX_DIAGNOSTICS_PER_FILE);
    assert!(json.last().unwrap().contains("3901 more errors in input.tsl not shown"));
}

/// A cut line still shows the span under its carets, and the location
/// is the file's own column: errors at the start, the middle and the end
/// of long lines, and a label spanning most of one.
#[test]
fn cut_lines_keep_the_carets_under_the_span() {
    let filler = "1 + ".repeat(3000);
    let cases = [
        format!("float f() {{ return nowhere + {filler}1; }}"),
        format!("float f() {{ return {filler}nowhere + {filler}1; }}"),
        format!("float f() {{ return {filler}nowhere; }}"),
        format!("float f() {{ return {filler}1 +\n nowhere; }}"),
        format!("float f() {{ /* é ü */ return {filler}nowhere; }}"),
    ];
    for src in &cases {
        let checked = check(src);
        let d = checked.diagnostics.iter().find(|d| d.message.contains("nowhere")).expect("an error at `nowhere`");
        let (line, col) = checked.program.loaded.sources.line_col(d.span.file, d.span.start);
        let text = checked.render_diagnostics();
        assert!(text.contains(&format!("input.tsl:{line}:{col}\n")), "{}", &text[..text.len().min(600)]);
        let lines: Vec<&str> = text.lines().collect();
        let quoted = lines.iter().position(|l| l.contains(" │ ") && l.contains("nowhere")).expect("the quoted line");
        let (source, carets) = (lines[quoted], lines[quoted + 1]);
        let at = carets.chars().position(|c| c == '^').expect("carets");
        let under: String = source.chars().skip(at).take("nowhere".len()).collect();
        assert_eq!(under, "nowhere", "\n{source}\n{carets}");
        assert!(source.chars().count() <= MAX_QUOTED_LINE_CHARS, "{source}");
    }
    // A label over 12,000 characters: both of its ends are quoted.
    let src = format!("float f() {{ return select(0, [{}1]); }}", "1, ".repeat(4100));
    let text = check(&src).render_diagnostics();
    assert!(text.contains("an array has at most 4096 items"), "{text}");
    assert!(text.contains("[1, 1,") && text.contains("1, 1]"), "{text}");
    assert!(text.lines().all(|l| l.chars().count() <= MAX_QUOTED_LINE_CHARS), "{text}");
}

/// No control character of a file reaches the terminal: not from a quoted
/// line, a string literal quoted in a message, or the file's name; each is
/// shown as one character, so carets stay aligned.
#[test]
fn control_characters_never_reach_the_terminal() {
    let hostile = ["\x1b[31m", "\x1b]0;title\x07", "\r", "\x7f", "\u{9b}2J", "\u{202e}", "\x00"];
    for h in hostile {
        let cases = [
            // In a comment on the line of an error.
            (format!("float f() {{ return nowhere; }} // {h}"), "input.tsl".to_string()),
            // Before the error on its line: the caret must still fall on it.
            (format!("float f() {{ /*{h}*/ return nowhere; }}"), "input.tsl".to_string()),
            // In a string quoted by a message.
            (
                format!("material m = lambert(kd: texture(\"no{h}ne.png\", (u, v)));\n{}", scene("40", "m")),
                "input.tsl".to_string(),
            ),
            // In the file's name.
            ("float f() { return nowhere; }".to_string(), format!("in{h}put.tsl")),
        ];
        for (src, name) in &cases {
            let checked = tsl::check_source(name, src, &LoadOptions::default());
            assert!(!checked.is_ok(), "{src:?}");
            let text = checked.render_diagnostics();
            let bad: Vec<char> = text
                .chars()
                .filter(|c| {
                    (c.is_control() && *c != '\n')
                        || ('\u{202a}'..='\u{202e}').contains(c)
                        || ('\u{2066}'..='\u{2069}').contains(c)
                })
                .collect();
            assert!(bad.is_empty(), "{h:?} reached the output as {bad:?}:\n{text}");
            if let Some(quoted) = text.lines().position(|l| l.contains(" │ ") && l.contains("nowhere")) {
                let lines: Vec<&str> = text.lines().collect();
                let at = lines[quoted + 1].chars().position(|c| c == '^').expect("carets");
                let under: String = lines[quoted].chars().skip(at).take(7).collect();
                assert_eq!(under, "nowhere", "{h:?}\n{}\n{}", lines[quoted], lines[quoted + 1]);
            }
        }
    }
}

/// One bound for every file's diagnostics: 500 syntax errors and 300 type
/// errors each show 99 and a count, in text and in JSON.
#[test]
fn every_kind_of_error_shares_one_bound_per_file() {
    let syntax: String = (0..500).map(|k| format!("float f{k}() {{ return 1 +; }}\n")).collect();
    let types: String = (0..300).map(|k| format!("float g{k}() {{ return nowhere{k}; }}\n")).collect();
    for (src, more) in [(syntax, "more syntax errors not shown"), (types, "201 more errors in input.tsl not shown")] {
        let checked = check(&src);
        let text = checked.render_diagnostics();
        let shown = text.lines().filter(|l| l.starts_with("error: ")).count();
        assert_eq!(shown, MAX_DIAGNOSTICS_PER_FILE, "{}", &text[text.len().saturating_sub(500)..]);
        assert!(text.contains(more), "{}", &text[text.len().saturating_sub(500)..]);
        let json = tsl::diag::json_lines(&checked.program.loaded.sources, &checked.diagnostics);
        assert_eq!(json.len(), MAX_DIAGNOSTICS_PER_FILE);
    }
}
