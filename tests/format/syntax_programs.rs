//! A generator of programs that parse (not necessarily check), for the
//! formatter's tests: every form of the grammar, written with odd spacing,
//! trailing commas or none, redundant parentheses, literals in several
//! spellings, data arrays long enough to fill lines, names long enough to
//! break lists, named arguments, materials, texture trees and scene blocks.

use proptest::prelude::*;
use proptest::strategy::BoxedStrategy;

type S = BoxedStrategy<String>;

fn pick(items: &'static [&'static str]) -> S {
    proptest::sample::select(items).prop_map(str::to_string).boxed()
}

/// `a, b, c` with a trailing comma or not (never after nothing).
fn commas(items: Vec<String>, trailing: bool) -> String {
    let mut s = items.join(", ");
    if trailing && !items.is_empty() {
        s.push_str(" ,");
    }
    s
}

fn literal() -> S {
    prop_oneof![
        pick(&["0", "1", "42", "1.0", "1.50", "0.25", ".5", "2e3", "1.5e-3", "400.0"]),
        pick(&["true", "false", "\"wood.png\""]),
        pick(&["1", "0.5", "2.0"]).prop_map(|l| format!("-{l}")),
    ]
    .boxed()
}

fn name() -> S {
    pick(&["x", "kd", "light", "N", "u", "t", "a_rather_long_name_for_a_value", "another_long_argument_name"])
}

fn data_array() -> S {
    let row = prop_oneof![
        literal(),
        (literal(), literal()).prop_map(|(a, b)| format!("({a}, {b})")),
        (literal(), literal(), any::<bool>()).prop_map(|(a, b, t)| format!("({a}, {b}{})", if t { "," } else { "" })),
    ];
    (proptest::collection::vec(row, 2..24), any::<bool>()).prop_map(|(v, t)| format!("[{}]", commas(v, t))).boxed()
}

pub fn expr() -> S {
    let leaf = prop_oneof![3 => literal(), 3 => name(), 1 => data_array()];
    leaf.prop_recursive(4, 48, 5, |e| {
        let arg = (proptest::option::of(pick(&["kd", "ks", "spline", "only"])), e.clone()).prop_map(|(n, v)| match n {
            Some(n) => format!("{n}: {v}"),
            None => v,
        });
        prop_oneof![
            (name(), proptest::collection::vec(arg.clone(), 0..5), any::<bool>())
                .prop_map(|(f, a, t)| format!("{f}({})", commas(a, t))),
            (
                pick(&["vector", "point", "normal", "vec2", "uv", "color", "matrix"]),
                proptest::collection::vec(arg, 1..4)
            )
                .prop_map(|(c, a)| format!("{c}({})", a.join(", "))),
            (pick(&["spectrum", "blend"]), data_array()).prop_map(|(f, a)| format!("{f}({a})")),
            (proptest::collection::vec(e.clone(), 0..6), any::<bool>())
                .prop_map(|(v, t)| format!("[{}]", commas(v, t))),
            (proptest::collection::vec(e.clone(), 2..4), any::<bool>())
                .prop_map(|(v, t)| format!("({})", commas(v, t))),
            e.clone().prop_map(|x| format!("({x},)")),
            e.clone().prop_map(|x| format!("({x})")),
            e.clone().prop_map(|x| format!("(({x}))")),
            (pick(&["-", "!"]), e.clone()).prop_map(|(o, x)| format!("{o}{x}")),
            (e.clone(), pick(&["+", "-", "*", "/", "%", "==", "!=", "<", "<=", ">", ">=", "&&", "||"]), e.clone())
                .prop_map(|(a, o, b)| format!("{a} {o} {b}")),
            (e.clone(), e.clone(), e.clone()).prop_map(|(c, a, b)| format!("{c} ? {a} : {b}")),
            (e.clone(), name()).prop_map(|(b, f)| format!("({b}).{f}")),
            (name(), e.clone()).prop_map(|(b, i)| format!("{b}[{i}]")),
        ]
    })
    .boxed()
}

fn ty() -> S {
    prop_oneof![
        pick(&["float", "int", "bool", "color", "vector", "point", "normal", "vec2", "uv", "matrix", "string"]),
        (pick(&["float", "int", "color"]), 1..9u32).prop_map(|(t, n)| format!("{t}[{n}]")),
    ]
    .boxed()
}

fn stmt() -> S {
    let simple = prop_oneof![
        (ty(), name(), proptest::option::of(expr())).prop_map(|(t, n, e)| match e {
            Some(e) => format!("{t} {n} = {e};"),
            None => format!("{t} {n};"),
        }),
        (name(), pick(&["=", "+=", "-=", "*=", "/="]), expr()).prop_map(|(n, o, e)| format!("{n} {o} {e};")),
        (name(), expr(), expr()).prop_map(|(n, i, e)| format!("{n}[{i}] = {e};")),
        expr().prop_map(|e| format!("{e};")),
        proptest::option::of(expr()).prop_map(|e| format!("return {};", e.unwrap_or_default())),
        pick(&["break;", "continue;"]),
    ];
    simple
        .prop_recursive(3, 12, 4, |s| {
            let block = proptest::collection::vec(s.clone(), 0..4).prop_map(|v| format!("{{ {} }}", v.join("\n")));
            prop_oneof![
                (expr(), block.clone(), proptest::option::of(block.clone())).prop_map(|(c, t, e)| match e {
                    Some(e) => format!("if {c} {t} else {e}"),
                    None => format!("if {c} {t}"),
                }),
                (expr(), block.clone(), expr(), block.clone(), block.clone())
                    .prop_map(|(c, t, d, u, e)| format!("if {c} {t} else if {d} {u} else {e}")),
                (name(), literal(), name(), block.clone())
                    .prop_map(|(v, a, b, body)| format!("for {v} in {a}..{b} {body}")),
                (expr(), block.clone()).prop_map(|(c, b)| format!("while {c} {b}")),
                block,
            ]
        })
        .boxed()
}

fn params() -> S {
    let param = (ty(), name(), proptest::option::of(expr())).prop_map(|(t, n, d)| match d {
        Some(d) => format!("{t} {n} = {d}"),
        None => format!("{t} {n}"),
    });
    (proptest::collection::vec(param, 0..5), any::<bool>()).prop_map(|(v, t)| format!("({})", commas(v, t))).boxed()
}

fn function() -> S {
    (
        pick(&["float", "color", "vector", "void", "bool", "float[3]"]),
        name(),
        params(),
        proptest::collection::vec(stmt(), 0..5),
    )
        .prop_map(|(r, n, p, b)| format!("{r} {n}{p} {{\n{}\n}}", b.join("\n")))
        .boxed()
}

fn scene_prop() -> S {
    (
        pick(&["from", "to", "fov", "center", "radius", "material", "normal", "color", "spp", "flag"]),
        proptest::option::of(expr()),
    )
        .prop_map(|(n, v)| match v {
            Some(v) => format!("{n} {v};"),
            None => format!("{n};"),
        })
        .boxed()
}

fn scene() -> S {
    let block = (
        pick(&["camera", "light", "object", "render"]),
        proptest::option::of(pick(&["point", "sphere", "mesh", "material"])),
        proptest::collection::vec(scene_prop(), 0..5),
    )
        .prop_map(|(k, kind, props)| format!("{k} {} {{ {} }}", kind.unwrap_or_default(), props.join(" ")));
    proptest::collection::vec(prop_oneof![3 => block, 1 => scene_prop()], 0..5)
        .prop_map(|v| format!("scene {{\n{}\n}}", v.join("\n")))
        .boxed()
}

fn item() -> S {
    prop_oneof![
        1 => pick(&["import \"lib/util.tsl\";", "import \"other.tsl\" ;"]),
        3 => (ty(), name(), expr()).prop_map(|(t, n, e)| format!("const {t} {n} = {e};")),
        3 => function(),
        1 => (name(), params(), proptest::collection::vec(function(), 0..3))
            .prop_map(|(n, p, ms)| format!("material {n}{p} {{\n{}\n}}", ms.join("\n"))),
        1 => (name(), proptest::option::of(params()), expr())
            .prop_map(|(n, p, e)| format!("material {n}{} = {e};", p.unwrap_or_default())),
        1 => scene(),
    ]
    .boxed()
}

/// A file of items, some separated by blank lines.
pub fn program() -> S {
    proptest::collection::vec((item(), any::<bool>()), 1..6)
        .prop_map(|v| {
            v.into_iter().map(|(i, blank)| if blank { format!("{i}\n\n") } else { format!("{i}\n") }).collect()
        })
        .boxed()
}
