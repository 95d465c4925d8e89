//! Small inputs, unbounded work (issue 29), held where it shows: in the
//! lowered IR. Moved from tests/bounded.rs (the IR is crate-private); the
//! diagnostics bounds stay there. Counts and sizes, never timings.

use crate::ir::Module;
use crate::{ColorModel, Compiler, LoadOptions, ShadingGlobals};

fn check(src: &str) -> crate::Checked {
    crate::check_source("input.tsl", src, &LoadOptions::default())
}

fn assert_clean(checked: &crate::Checked) {
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

/// Lowers the entry points of the root program's names `keep` accepts.
fn lower(checked: &crate::Checked, keep: impl Fn(&str) -> bool) -> Module {
    let (module, _, diags) = crate::ir::lower::lower_entries(&checked.program, ColorModel::Rgb, |n, s| {
        !checked.program.loaded.modules[s.module].is_prelude && keep(n)
    });
    assert!(diags.is_empty(), "{diags:?}");
    module
}

/// Runs entry `name` of `module` with no arguments at frame `frame`.
fn run(module: &Module, name: &str, frame: i32) -> Vec<u32> {
    let f = module.function(name).unwrap_or_else(|| panic!("`{name}` is lowered"));
    let globals = ShadingGlobals { frame, ..ShadingGlobals::default() }.words();
    let mut out = vec![0u32; f.results.len()];
    crate::interp::run(f, &globals, &[], &mut out);
    out
}

fn floats(words: &[u32]) -> Vec<f32> {
    words.iter().map(|w| f32::from_bits(*w)).collect()
}

/// The instructions of a module's functions, nested bodies included.
fn size(module: &Module) -> usize {
    module.functions.iter().map(|f| crate::ir::count_insts(&f.body)).sum()
}

/// Each constant uses the previous one twice: 2^60 evaluations unless each
/// is evaluated once. Floats, vectors, ints and colors, read by a function,
/// a scene value and a material.
#[test]
fn doubling_constants_are_evaluated_once() {
    let cases = [
        ("float", "1", "{p} + {p}", "c60", vec![2f32.powi(60)]),
        ("vector", "(1, 2, 3)", "{p} + {p}", "length(c60)", vec![2f32.powi(60), 2f32.powi(61), 3.0 * 2f32.powi(60)]),
        (
            "color",
            "rgb(0.5, 0.25, 1)",
            "{p} + {p}",
            "brightness(c60)",
            vec![2f32.powi(59), 2f32.powi(58), 2f32.powi(60)],
        ),
        ("float", "1", "max({p}, {p}) * 2", "c60", vec![2f32.powi(60)]),
    ];
    for (ty, first, step, used, want) in cases {
        // Read by a function and by a scene value (which check evaluates).
        let src = chain(ty, first, step, 60)
            + &format!("{ty} value() {{ return c60; }}\n")
            + &scene(&format!("40 + 0 * {used}"), "lambert");
        let checked = check(&src);
        assert_clean(&checked);
        let fov = checked.scene.as_ref().expect("a scene").camera.fov.value;
        assert_eq!(fov, 40.0, "{ty} {step}");
        let module = lower(&checked, |n| n == "value");
        assert_eq!(floats(&run(&module, "value", 0)), want, "{ty} {step}");
    }
    // Ints: 2^30 is the largest power of two an int holds.
    let checked = check(&(chain("int", "1", "{p} + {p}", 30) + "int value() { return c30; }\n"));
    assert_clean(&checked);
    assert_eq!(run(&lower(&checked, |n| n == "value"), "value", 0), vec![1u32 << 30]);
    // Used from a material: the value folds into its code.
    let checked = check(
        &(chain("float", "1", "{p} + {p}", 60)
            + "material m = lambert(kd: rgb(0.5, 0.5, 0.5) * (c60 / c59 - 1));\n"
            + &scene("40", "m")),
    );
    assert_clean(&checked);
    let module = lower(&checked, |n| n == "m");
    assert!(module.function("m.diffuse").is_some());
}

/// A constant that reads `frame` does not fold: it is lowered once per
/// function, at the top, and each use reads it back (60 additions, not
/// 2^60).
#[test]
fn frame_dependent_doubling_constants_are_lowered_once() {
    let src = chain("float", "frame", "{p} + {p}", 60)
        + "float value() { return c60; }\n"
        + "float branchy(float x) { if (x > 0) { return c60 + x; } return c60 - x; }\n";
    let checked = check(&src);
    assert_clean(&checked);
    let module = lower(&checked, |n| n == "value" || n == "branchy");
    assert_eq!(floats(&run(&module, "value", 3)), vec![3.0 * 2f32.powi(60)]);
    let insts = crate::ir::count_insts(&module.function("value").unwrap().body);
    assert!(insts <= 70, "60 additions and the frame's load, not more: {insts}");
    let branchy = crate::ir::count_insts(&module.function("branchy").unwrap().body);
    assert!(branchy <= 90, "the constant computed once above both branches: {branchy}");
}

/// Chains and DAGs of many constants check and evaluate (the checker's
/// searches are linear, the lowering iterative: no deep recursion).
#[test]
fn long_chains_and_dags_of_constants() {
    const N: usize = 100_000;
    let src = chain("float", "0", "{p} + 1", N)
        + &format!("float value() {{ return c{N}; }}\n")
        + &scene(&format!("40 + c{N} * 0"), "lambert");
    let checked = check(&src);
    assert_clean(&checked);
    assert_eq!(floats(&run(&lower(&checked, |n| n == "value"), "value", 0)), vec![N as f32]);

    // Each constant uses the previous one and the one at half its index.
    const D: usize = 50_000;
    let mut src = "const float c0 = 1;\n".to_string();
    let mut want = vec![1f32];
    for k in 1..=D {
        src += &format!("const float c{k} = c{} * 0.5 + c{};\n", k - 1, k / 2);
        want.push(want[k - 1] * 0.5 + want[k / 2]);
    }
    src += &format!("float value() {{ return c{D}; }}\n");
    let checked = check(&src);
    assert_clean(&checked);
    assert_eq!(floats(&run(&lower(&checked, |n| n == "value"), "value", 0)), vec![want[D]]);

    // One constant summing 20,000 others.
    const W: usize = 20_000;
    let mut src: String = (0..W).map(|k| format!("const float c{k} = {k};\n")).collect();
    src += &format!(
        "const float total = {};\nfloat value() {{ return total; }}\n",
        (0..W).map(|k| format!("c{k}")).collect::<Vec<_>>().join(" + ")
    );
    let checked = check(&src);
    assert_clean(&checked);
    let sum: f32 = (0..W).fold(0.0, |acc, k| acc + k as f32);
    assert_eq!(floats(&run(&lower(&checked, |n| n == "value"), "value", 0)), vec![sum]);
}

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

/// The children of a node that are the same material (by name, or through
/// a template parameter) are compiled once: a tree that uses the previous
/// one twice at every level grows by a constant per level, in every entry
/// point and in the renderer's hit groups.
#[test]
fn materials_that_use_the_previous_twice_compile_in_linear_code() {
    let steps = [
        "mix(noise(P), {p}, {p})",
        "blend(noise(P), [{p}, {p}, {p}])",
        "select(int(noise(P) * 3), [{p}, mirrored, {p}])",
        "u > 0.5 ? {p} : {p}",
        "twice({p})",
        "mix(noise(P), {p}, {p}, only: \"reflection\")",
        "scale(rgb(0.9, 0.9, 0.9), blend(u, [{p}, {p}]))",
    ];
    for step in steps {
        let sizes: Vec<(usize, usize)> = [10, 40]
            .iter()
            .map(|n| {
                let checked = check(&material_chain(step, *n));
                assert_clean(&checked);
                let name = format!("m{n}");
                let entries = size(&lower(&checked, |x| x == name));
                let sym = checked.program.symbols[&name];
                let r = crate::check::MaterialRef::TreeBody { module: sym.module as u32, item: sym.item as u32 };
                let body = checked.program.material_expr(r).expect("a tree body");
                let (groups, diags) = crate::ir::lower::lower_hit_groups(
                    &checked.program,
                    ColorModel::Rgb,
                    &[(name.clone(), body)],
                    &[crate::HitMethod::Interface(crate::check::Method::Sample), crate::HitMethod::EvalPdf],
                );
                assert!(diags.is_empty(), "{diags:?}");
                (entries, crate::ir::count_insts(&groups[0].combined.body))
            })
            .collect();
        let ((e10, h10), (e40, h40)) = (sizes[0], sizes[1]);
        // Linear growth: 30 more levels cost at most a few times 10 levels.
        assert!(e40 <= 4 * e10 + 2000, "{step}: entries {e10} instructions at depth 10, {e40} at 40");
        assert!(h40 <= 4 * h10 + 2000, "{step}: hit group {h10} instructions at depth 10, {h40} at 40");
    }
}

/// What check cannot count (functions that call the previous one twice
/// with other arguments) is stopped while lowering, past
/// `MAX_FUNCTION_VALUES`, with an error at the material that uses it.
#[test]
fn lowering_stops_at_its_bound_with_a_located_error() {
    let mut src = "float f0(float x) { return sin(x); }\n".to_string();
    for k in 1..=30 {
        src += &format!("float f{k}(float x) {{ return f{}(x * 2) + f{}(x * 3); }}\n", k - 1, k - 1);
    }
    src += "material m = lambert(kd: rgb(0.5, 0.5, 0.5) * f30(u));\n";
    let program = Compiler::new().source("input.tsl", &src).compile().unwrap_or_else(|e| panic!("{e}"));
    let Err(err) = program.material("m") else { panic!("`m` compiled, but it is too large") };
    let text = err.to_string();
    assert!(text.contains("error: material `m` is too large to compile"), "{text}");
    assert!(text.contains("input.tsl:32:10"), "{text}");
    assert!(text.contains(&format!("more than {} IR values", crate::ir::MAX_FUNCTION_VALUES)), "{text}");
}
