//! Scene values compute scalar arithmetic constants without IR
//! (`ir::lower::arithmetic`): the same words as compiled code reads, and
//! no IR value per constant.

use crate::check::Ty;
use crate::ir::Function;
use crate::ir::lower::ValueLowerer;
use crate::syntax::ast::{Expr, Item, StmtKind};
use crate::{ColorModel, LoadOptions, ShadingGlobals};

/// The checked program of `src`, which has no error.
fn check(src: &str) -> crate::Checked {
    let checked = crate::check_source("input.tsl", src, &LoadOptions::default());
    assert!(checked.is_ok(), "{src}\n{}", checked.render_diagnostics());
    checked
}

/// The expression `value()` returns, in the root program.
fn returned(checked: &crate::Checked) -> &Expr {
    let functions = checked.program.loaded.modules.iter().filter(|m| !m.is_prelude).flat_map(|m| m.ast.items.iter());
    for item in functions {
        if let Item::Function(f) = item
            && f.name.name.as_str() == "value"
            && let Some(StmtKind::Return(Some(e))) = f.body.stmts.first().map(|s| &s.kind)
        {
            return e;
        }
    }
    panic!("no `value()` returning an expression");
}

fn run(f: &Function, frame: i32) -> Vec<u32> {
    let globals = ShadingGlobals { frame, ..ShadingGlobals::default() }.words();
    let mut out = vec![0u32; f.results.len()];
    crate::interp::run(f, &globals, &[], &mut out);
    out
}

/// `value()`'s words as a scene value reads them (and the function it ran),
/// and as compiled code computes them.
fn both_ways(src: &str, ty: &Ty, frame: i32) -> (Vec<u32>, Function, Vec<u32>) {
    let checked = check(src);
    let (scene_value, diags) =
        ValueLowerer::new(&checked.program, ColorModel::Rgb).lower("value", returned(&checked), ty, false);
    assert!(diags.is_empty(), "{diags:?}");
    let (module, _, diags) = crate::ir::lower::lower_entries(&checked.program, ColorModel::Rgb, |n, s| {
        !checked.program.loaded.modules[s.module].is_prelude && n == "value"
    });
    assert!(diags.is_empty(), "{diags:?}");
    let compiled = run(module.function("value").expect("`value` is lowered"), frame);
    (run(&scene_value, frame), scene_value, compiled)
}

/// Every rule of the arithmetic, and values that leave it (calls, globals,
/// vectors, a constant that does not fold): the same bits both ways.
#[test]
fn scene_values_read_the_words_compiled_code_computes() {
    let float = [
        "a * 3 - 7 / 2",
        "1.0 / 0.0",
        "-1.0 / 0.0",
        "0.0 / 0.0",
        "(0.0 / 0.0) * 1 + -0.0",
        "-7.5 % 2",
        "7.5 % -2.25",
        "a % 0",
        "-0.0 - 0.0",
        "-0.0 + -0.0",
        "-(a - a)",
        "a * 1 / 1 - 0",
        "0.1 + 0.2 * 3 - n",
        "n / 2 + n % 3 * a",
        "16777217 + a",
        "1e38 * 10 - 1e38 * 10",
        "PI * 2 - HALF_PI",
        "b + b * b",
        "sin(a) + b",
        "(frame + 1) * a",
        "length(vector(a, b, 1))",
        "f + 1",
    ];
    let int = [
        "n / 0 + n % 0",
        "-7 % 3 + -7 / 2",
        "2147483647 + n",
        "-(-2147483647 - 1)",
        "(-2147483647 - 1) / -1 + (-2147483647 - 1) % -1",
        "65536 * 65536 + 3 * -n",
        "m * m - m",
        "frame * n",
    ];
    let cases = float.iter().map(|e| ("float", e)).chain(int.iter().map(|e| ("int", e)));
    for (ty, expr) in cases {
        let src = format!(
            "const float a = 1.25;\nconst int n = 7;\nconst float b = a * a - n;\nconst int m = n * n - 1;\n\
             const float f = frame * 0.5;\nconst {ty} c = {expr};\n{ty} value() {{ return c; }}\n"
        );
        let ty = if ty == "int" { Ty::Int } else { Ty::Float };
        for frame in [0, 3] {
            let (scene, _, compiled) = both_ways(&src, &ty, frame);
            assert_eq!(scene, compiled, "`{expr}` at frame {frame}");
        }
    }
}

/// Many constants, each read once: the scene value's function holds a few
/// values, not one or more per constant (which it did when every
/// constant was lowered through IR).
#[test]
fn scene_values_compute_arithmetic_constants_without_ir() {
    const N: usize = 2_000;
    let dag: String = (1..=N).map(|k| format!("const float c{k} = c{} * 0.5 + c{};\n", k - 1, k / 2)).collect();
    let chain: String = (1..=N).map(|k| format!("const int c{k} = c{} * 3 % 1000 - 2;\n", k - 1)).collect();
    let negated: String = (1..=N).map(|k| format!("const float c{k} = -c{} / 2 + {k};\n", k - 1)).collect();
    for (ty, first, body) in [
        (Ty::Float, "const float c0 = 1;", dag),
        (Ty::Int, "const int c0 = 5;", chain),
        (Ty::Float, "const float c0 = 0.5;", negated),
    ] {
        let src = format!("{first}\n{body}{} value() {{ return c{N} * 1; }}\n", ty);
        let (scene, f, compiled) = both_ways(&src, &ty, 0);
        assert_eq!(scene, compiled, "{first}");
        assert!(f.values.len() < 10, "{first}: {} IR values for one scene value", f.values.len());
    }
}
