//! The generator of random well-typed programs (see `tests/random_programs.rs`).

use proptest::prelude::*;
use proptest::strategy::{BoxedStrategy, Union};
use std::cell::RefCell;
use std::collections::HashMap;
use std::fmt;

// ---------------------------------------------------------------- types and environments

/// The types the generator produces expressions of. Arrays (`FA`, `IA`,
/// `BA`) are only variables and literals, indexed dynamically.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
enum T {
    F,
    I,
    B,
    V,
    C,
    M,
    /// `vec2`
    W,
    FA,
    IA,
    /// `bool[2]`
    BA,
}

impl T {
    fn keyword(self) -> &'static str {
        match self {
            T::F => "float",
            T::I => "int",
            T::B => "bool",
            T::V => "vector",
            T::C => "color",
            T::M => "matrix",
            T::W => "vec2",
            T::BA => "bool[2]",
            T::FA => "float[4]",
            T::IA => "int[3]",
        }
    }
}

/// A helper function the expression being generated may call. Every helper
/// takes `(float a, int n = .., vector d = .., color c = .., bool flag = ..)`
/// except `g_arr(float[4] xs, int k)`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
struct Helper {
    name: &'static str,
    ret: T,
}

/// What an expression may refer to.
#[derive(Clone, Debug)]
struct Env {
    /// Variables: name, type, assignable.
    vars: Vec<(String, T, bool)>,
    /// Shading globals (not in constants).
    globals: bool,
    /// The constants `K0`, `K1`, `KC` (not inside their own definitions).
    consts: bool,
    helpers: Vec<Helper>,
    /// `g_arr` may be called.
    arr_helper: bool,
    /// Inside a material method that may call `diffuse()` and `normal()`.
    methods: bool,
}

impl Env {
    fn empty() -> Env {
        Env { vars: Vec::new(), globals: true, consts: true, helpers: Vec::new(), arr_helper: false, methods: false }
    }

    fn with(&self, name: &str, ty: T, assignable: bool) -> Env {
        let mut e = self.clone();
        e.vars.push((name.to_string(), ty, assignable));
        e
    }

    fn key(&self) -> String {
        format!("{self:?}")
    }

    fn vars_of(&self, ty: T) -> Vec<String> {
        self.vars.iter().filter(|(_, t, _)| *t == ty).map(|(n, _, _)| n.clone()).collect()
    }

    fn assignable_of(&self, ty: T) -> Vec<String> {
        self.vars.iter().filter(|(_, t, a)| *t == ty && *a).map(|(n, _, _)| n.clone()).collect()
    }
}

/// The return type and loop nesting of the body being generated.
#[derive(Clone, Debug)]
struct Ctx {
    env: Env,
    ret: T,
    loops: u32,
}

// ---------------------------------------------------------------- strategy helpers

type S = BoxedStrategy<String>;

fn pick(items: &[&str]) -> S {
    let v: Vec<String> = items.iter().map(|s| s.to_string()).collect();
    proptest::sample::select(v).boxed()
}

fn pick_owned(v: Vec<String>) -> S {
    proptest::sample::select(v).boxed()
}

fn lit(s: &str) -> S {
    Just(s.to_string()).boxed()
}

fn map1(a: S, f: impl Fn(String) -> String + 'static) -> S {
    a.prop_map(f).boxed()
}

fn map2(a: S, b: S, f: impl Fn(String, String) -> String + 'static) -> S {
    (a, b).prop_map(move |(x, y)| f(x, y)).boxed()
}

fn map3(a: S, b: S, c: S, f: impl Fn(String, String, String) -> String + 'static) -> S {
    (a, b, c).prop_map(move |(x, y, z)| f(x, y, z)).boxed()
}

/// `name(a, b, ...)`.
fn call(name: &'static str, args: Vec<S>) -> S {
    args.prop_map(move |a| format!("{name}({})", a.join(", "))).boxed()
}

fn binop(a: S, ops: &[&str], b: S) -> S {
    (a, pick(ops), b).prop_map(|(x, o, y)| format!("({x} {o} {y})")).boxed()
}

fn union(arms: Vec<(u32, S)>) -> S {
    Union::new_weighted(arms).boxed()
}

// ---------------------------------------------------------------- the generator

/// Builds strategies, caching one per (environment, type, depth) so that
/// construction stays linear in the depth.
#[derive(Default)]
struct Gen {
    cache: RefCell<HashMap<(String, T, u32), S>>,
}

const FLOAT_LITS: &[&str] =
    &["0.0", "1.0", "0.5", "2.5", "(-1.5)", "3.0", "1e-3", "1000.0", "1e6", "0.25", "7.0", "(-0.0)", "2"];
const INT_LITS: &[&str] = &["0", "1", "2", "3", "(-1)", "7", "100", "(-5)", "2147483647", "(-2147483647 - 1)"];

impl Gen {
    fn expr(&self, env: &Env, ty: T, depth: u32) -> S {
        let key = (env.key(), ty, depth);
        if let Some(s) = self.cache.borrow().get(&key) {
            return s.clone();
        }
        let s = self.build(env, ty, depth);
        self.cache.borrow_mut().insert(key, s.clone());
        s
    }

    fn leaf(&self, env: &Env, ty: T) -> S {
        let mut arms: Vec<(u32, S)> = Vec::new();
        let vars = env.vars_of(ty);
        if !vars.is_empty() {
            arms.push((6, pick_owned(vars)));
        }
        match ty {
            T::F => {
                arms.push((4, pick(FLOAT_LITS)));
                if env.globals {
                    arms.push((
                        4,
                        pick(&[
                            "u", "v", "t", "dudx", "dvdy", "P.x", "Pl.y", "N.z", "Ng.x", "dPdu.y", "dPdv.z", "time",
                        ]),
                    ));
                }
                if env.consts {
                    arms.push((1, pick(&["PI", "K0", "EPSILON"])));
                }
            }
            T::I => {
                arms.push((4, pick(INT_LITS)));
                if env.globals {
                    arms.push((2, lit("face")));
                }
                if env.consts {
                    arms.push((1, lit("K1")));
                }
            }
            T::B => arms.push((3, pick(&["true", "false"]))),
            T::V => {
                arms.push((2, pick(&["vector(1, 0, 0)", "vector(0.5, -2, 3)", "vector(0)", "vector(1e30, 1, -1e30)"])));
                if env.globals {
                    arms.push((4, pick(&["P", "Pl", "N", "Ng", "dPdu", "dPdv", "dPdx"])));
                }
            }
            T::C => {
                arms.push((
                    3,
                    pick(&[
                        "gray(0.5)",
                        "rgb(0.2, 0.4, 0.9)",
                        "black()",
                        "rgb(1, 0, 0)",
                        "spectrum([(400, 0.1), (550, 0.6), (700, 1.0)])",
                    ]),
                ));
                if env.consts {
                    arms.push((1, lit("KC")));
                }
            }
            T::M => arms.push((1, pick(&["rotate(30, vector(0, 0, 1))", "translate(vector(1, 2, 3))", "scale(2)"]))),
            T::W => {
                arms.push((2, pick(&["vec2(0.5, -1)", "vec2(0)", "vec2(3, 1e-3)"])));
                if env.globals {
                    arms.push((2, lit("vec2(u, v)")));
                }
            }
            T::BA => arms.push((1, lit("[true, false]"))),
            T::FA => arms.push((1, lit("[0.5, 1, 2, 4]"))),
            T::IA => arms.push((1, lit("[1, 2, 3]"))),
        }
        union(arms)
    }

    /// A dynamic array index: an int expression, but never an out-of-range
    /// constant (the checker rejects those; literals in range are fine).
    fn index(&self, env: &Env, d: u32, len: i32) -> S {
        let dynamic = self.expr(env, T::I, d).prop_filter("constant index", |s| const_int(s).is_none()).boxed();
        union(vec![(1, (0..len).prop_map(|k| k.to_string()).boxed()), (4, dynamic)])
    }

    /// A call to a helper returning `ty`, with optional named arguments.
    fn helper_calls(&self, env: &Env, ty: T, d: u32) -> Vec<(u32, S)> {
        let mut arms = Vec::new();
        for h in env.helpers.iter().filter(|h| h.ret == ty) {
            let name = h.name;
            let args = (
                self.expr(env, T::F, d),
                proptest::option::of(self.expr(env, T::I, d)),
                proptest::option::of(self.expr(env, T::V, d)),
                proptest::option::of(self.expr(env, T::C, d)),
                proptest::option::of(self.expr(env, T::B, d)),
                any::<bool>(),
            );
            arms.push((
                1,
                args.prop_map(move |(a, n, dd, c, flag, positional)| {
                    let mut s = format!("{name}({a}");
                    if positional && n.is_some() {
                        // Positional second argument, then named ones.
                        s += &format!(", {}", n.clone().unwrap_or_default());
                    } else if let Some(n) = &n {
                        s += &format!(", n: {n}");
                    }
                    if let Some(c) = c {
                        s += &format!(", c: {c}");
                    }
                    if let Some(flag) = flag {
                        s += &format!(", flag: {flag}");
                    }
                    if let Some(dd) = dd {
                        s += &format!(", d: {dd}");
                    }
                    s + ")"
                })
                .boxed(),
            ));
        }
        if ty == T::F && env.globals {
            // Its value three times, in the coordinate contexts of the axes.
            arms.push((
                1,
                map2(self.expr(env, T::F, d), self.expr(env, T::F, d), |x, s| {
                    format!("triplanar({x}, sharpness: {s})")
                }),
            ));
        }
        if ty == T::F && env.arr_helper {
            let fa = self.expr(env, T::FA, d);
            arms.push((2, map2(fa, self.expr(env, T::I, d), |a, k| format!("g_arr({a}, {k})"))));
            let items = vec![self.expr(env, T::F, d); 4];
            arms.push((
                1,
                map2(items.prop_map(|v| v.join(", ")).boxed(), self.expr(env, T::I, d), |a, k| {
                    format!("g_arr([{a}], k: {k})")
                }),
            ));
        }
        arms
    }

    fn build(&self, env: &Env, ty: T, depth: u32) -> S {
        if depth == 0 {
            return self.leaf(env, ty);
        }
        let d = depth - 1;
        let f = || self.expr(env, T::F, d);
        let i = || self.expr(env, T::I, d);
        let b = || self.expr(env, T::B, d);
        let v = || self.expr(env, T::V, d);
        let c = || self.expr(env, T::C, d);
        let m = || self.expr(env, T::M, d);
        let w = || self.expr(env, T::W, d);
        let mut arms: Vec<(u32, S)> = vec![(6, self.leaf(env, ty))];
        arms.extend(self.helper_calls(env, ty, d));
        let cond = map3(b(), self.expr(env, ty, d), self.expr(env, ty, d), |c, x, y| format!("({c} ? {x} : {y})"));
        match ty {
            T::F => {
                arms.extend([
                    (6, binop(f(), &["+", "-", "*", "/", "%"], f())),
                    (2, binop(f(), &["+", "-", "*", "/"], i())),
                    (2, binop(i(), &["+", "*", "/", "%"], f())),
                    (2, map1(f(), |x| format!("(-{x})"))),
                    (
                        4,
                        map2(
                            pick(&[
                                "abs", "floor", "ceil", "fract", "sqrt", "sin", "cos", "exp", "log", "round", "sign",
                                "tan", "atan", "asin", "acos", "degrees", "radians",
                            ]),
                            f(),
                            |n, x| format!("{n}({x})"),
                        ),
                    ),
                    (
                        3,
                        map3(pick(&["pow", "min", "max", "atan2", "mod", "step"]), f(), f(), |n, x, y| {
                            format!("{n}({x}, {y})")
                        }),
                    ),
                    (2, map2(pick(&["min", "max", "mod"]), (f(), i()).boxed_tuple(), |n, xy| format!("{n}({xy})"))),
                    (
                        3,
                        (pick(&["clamp", "mix", "smoothstep"]), f(), f(), f())
                            .prop_map(|(n, x, y, z)| format!("{n}({x}, {y}, {z})"))
                            .boxed(),
                    ),
                    (2, call("dot", vec![v(), v()])),
                    (2, map2(pick(&["length", "noise", "cellnoise"]), v(), |n, x| format!("{n}({x})"))),
                    (1, call("distance", vec![v(), v()])),
                    (1, map2(pick(&["noise", "cellnoise"]), f(), |n, x| format!("{n}({x})"))),
                    (
                        1,
                        map3(f(), f(), pick(&["noise", "length", "cellnoise"]), |x, y, n| {
                            format!("{n}(vec2({x}, {y}))")
                        }),
                    ),
                    (
                        1,
                        map2(v(), pick(&["vector(4)", "vector(1, 2, 3)", "vector(256)"]), |x, p| {
                            format!("pnoise({x}, {p})")
                        }),
                    ),
                    (2, map1(c(), |x| format!("brightness({x})"))),
                    (3, map2(v(), pick(&["x", "y", "z"]), |x, k| format!("({x}).{k}"))),
                    (2, map1(i(), |x| format!("float({x})"))),
                    (1, map1(i(), |x| format!("abs({x})"))),
                    (2, cond),
                    (
                        1,
                        map2(i(), vec![f(); 3].prop_map(|v| v.join(", ")).boxed(), |k, xs| {
                            format!("select({k}, [{xs}])")
                        }),
                    ),
                    (
                        1,
                        (f(), vec![f(); 3], any::<bool>())
                            .prop_map(|(x, xs, s)| format!("blend({x}, [{}], spline: {s})", xs.join(", ")))
                            .boxed(),
                    ),
                ]);
                let arrays = env.vars_of(T::FA);
                if !arrays.is_empty() {
                    arms.push((3, map2(pick_owned(arrays), self.index(env, d, 4), |a, k| format!("{a}[{k}]"))));
                }
                arms.extend([
                    (2, map2(w(), pick(&["x", "y"]), |x, k| format!("({x}).{k}"))),
                    (1, map2(pick(&["length", "noise", "cellnoise"]), w(), |n, x| format!("{n}({x})"))),
                    (1, map3(pick(&["dot", "distance"]), w(), w(), |n, x, y| format!("{n}({x}, {y})"))),
                    (1, map2(w(), self.index(env, d, 2), |x, k| format!("({x})[{k}]"))),
                ]);
                // Triples can be indexed too.
                arms.push((1, map2(v(), self.index(env, d, 3), |x, k| format!("({x})[{k}]"))));
            }
            T::I => {
                arms.extend([
                    (6, binop(i(), &["+", "-", "*", "/", "%"], i())),
                    (2, map1(i(), |x| format!("(-{x})"))),
                    (3, map1(f(), |x| format!("int({x})"))),
                    (2, map3(pick(&["min", "max", "mod"]), i(), i(), |n, x, y| format!("{n}({x}, {y})"))),
                    (1, call("clamp", vec![i(), i(), i()])),
                    (2, cond),
                    (
                        1,
                        map2(i(), vec![i(); 3].prop_map(|v| v.join(", ")).boxed(), |k, xs| {
                            format!("select({k}, [{xs}])")
                        }),
                    ),
                ]);
                let arrays = env.vars_of(T::IA);
                if !arrays.is_empty() {
                    arms.push((3, map2(pick_owned(arrays), self.index(env, d, 3), |a, k| format!("{a}[{k}]"))));
                }
            }
            T::B => {
                arms.extend([
                    (4, binop(f(), &["<", "<=", ">", ">=", "==", "!="], f())),
                    (3, binop(i(), &["<", "<=", ">", ">=", "==", "!="], i())),
                    (1, binop(i(), &["<", ">=", "=="], f())),
                    (2, binop(v(), &["==", "!="], v())),
                    (1, binop(b(), &["==", "!="], b())),
                    (1, binop(w(), &["==", "!="], w())),
                    (2, map1(b(), |x| format!("(!{x})"))),
                    (3, binop(b(), &["&&", "||"], b())),
                    (1, cond),
                ]);
                let arrays = env.vars_of(T::BA);
                if !arrays.is_empty() {
                    arms.push((2, map2(pick_owned(arrays), self.index(env, d, 2), |a, k| format!("{a}[{k}]"))));
                }
            }
            T::V => {
                arms.extend([
                    (4, binop(v(), &["+", "-", "*", "/"], v())),
                    (2, binop(v(), &["*", "/", "+", "-"], f())),
                    (2, binop(f(), &["*", "+", "-"], v())),
                    (1, map1(v(), |x| format!("(-{x})"))),
                    (3, call("vector", vec![f(), f(), f()])),
                    (1, call("vector", vec![f()])),
                    (1, map1(f(), |x| format!("point({x}, 1, 2)"))),
                    (2, call("cross", vec![v(), v()])),
                    (2, call("normalize", vec![v()])),
                    (2, map2(pick(&["abs", "floor", "fract", "sqrt", "sin"]), v(), |n, x| format!("{n}({x})"))),
                    (1, map3(pick(&["min", "max", "step"]), v(), v(), |n, x, y| format!("{n}({x}, {y})"))),
                    (1, map3(pick(&["min", "max", "pow", "mod"]), v(), f(), |n, x, y| format!("{n}({x}, {y})"))),
                    (1, call("clamp", vec![v(), f(), f()])),
                    (1, call("mix", vec![f(), v(), v()])),
                    (1, call("smoothstep", vec![f(), f(), v()])),
                    (1, call("reflect", vec![v(), v()])),
                    (1, call("refract", vec![v(), v(), f()])),
                    (1, call("faceforward", vec![v(), v()])),
                    (1, map2(pick(&["to_rgb", "to_xyz"]), c(), |n, x| format!("{n}({x})"))),
                    (
                        2,
                        map3(
                            pick(&["transform_point", "transform_vector", "transform_normal"]),
                            m(),
                            v(),
                            |n, x, y| format!("{n}({x}, {y})"),
                        ),
                    ),
                    (2, cond),
                    (
                        1,
                        map2(i(), vec![v(); 2].prop_map(|v| v.join(", ")).boxed(), |k, xs| {
                            format!("select({k}, [{xs}])")
                        }),
                    ),
                    (
                        1,
                        map2(f(), vec![v(); 3].prop_map(|v| v.join(", ")).boxed(), |x, xs| {
                            format!("blend({x}, [{xs}], spline: true)")
                        }),
                    ),
                ]);
                if env.methods {
                    arms.push((1, lit("normal()")));
                }
            }
            T::C => {
                arms.extend([
                    (4, binop(c(), &["+", "*", "/"], c())),
                    (3, binop(c(), &["*", "/"], f())),
                    (2, binop(f(), &["*"], c())),
                    (1, call("pow", vec![c(), f()])),
                    (2, call("mix", vec![f(), c(), c()])),
                    (
                        2,
                        map2(pick(&["rgb", "hsv", "xyz"]), vec![f(); 3].prop_map(|v| v.join(", ")).boxed(), |n, xs| {
                            format!("{n}({xs})")
                        }),
                    ),
                    (2, call("gray", vec![f()])),
                    (2, cond),
                    (
                        1,
                        map2(f(), vec![c(); 3].prop_map(|v| v.join(", ")).boxed(), |x, xs| {
                            format!("blend({x}, [{xs}])")
                        }),
                    ),
                    (
                        1,
                        map2(i(), vec![c(); 2].prop_map(|v| v.join(", ")).boxed(), |k, xs| {
                            format!("select({k}, [{xs}])")
                        }),
                    ),
                ]);
                if env.methods {
                    arms.push((1, lit("diffuse()")));
                }
            }
            T::M => {
                arms.extend([
                    (2, call("rotate", vec![f(), v()])),
                    (1, call("translate", vec![v()])),
                    (1, call("scale", vec![f()])),
                    (1, call("scale", vec![v()])),
                    (1, binop(m(), &["*"], m())),
                    (1, call("inverse", vec![m()])),
                ]);
            }
            T::W => {
                arms.extend([
                    (4, binop(w(), &["+", "-", "*", "/"], w())),
                    (2, binop(w(), &["*", "/", "+", "-"], f())),
                    (1, binop(f(), &["*", "-"], w())),
                    (1, map1(w(), |x| format!("(-{x})"))),
                    (3, call("vec2", vec![f(), f()])),
                    (1, call("uv", vec![f(), f()])),
                    (1, call("vec2", vec![f()])),
                    (2, map2(pick(&["normalize", "abs", "floor", "fract", "cos"]), w(), |n, x| format!("{n}({x})"))),
                    (1, map3(pick(&["min", "max", "mod"]), w(), f(), |n, x, y| format!("{n}({x}, {y})"))),
                    (1, map3(pick(&["step", "max"]), w(), w(), |n, x, y| format!("{n}({x}, {y})"))),
                    (1, call("step", vec![f(), w()])),
                    (1, call("mix", vec![f(), w(), w()])),
                    (1, call("clamp", vec![w(), w(), w()])),
                    (2, cond),
                    (
                        1,
                        map2(i(), vec![w(); 2].prop_map(|v| v.join(", ")).boxed(), |k, xs| {
                            format!("select({k}, [{xs}])")
                        }),
                    ),
                ]);
            }
            T::FA | T::IA | T::BA => {}
        }
        union(arms)
    }

    // ------------------------------------------------------------ statements

    /// A sequence of up to `n` statements.
    fn stmts(&self, cx: &Ctx, depth: u32, n: usize) -> S {
        proptest::collection::vec(self.stmt(cx, depth), 0..=n).prop_map(|v| v.join("")).boxed()
    }

    /// `{ statements }`, sometimes ending in `return`, `break` or `continue`
    /// followed by a dead statement.
    fn block(&self, cx: &Ctx, depth: u32, n: usize) -> S {
        let mut tails: Vec<(u32, S)> =
            vec![(8, lit("")), (1, map1(self.expr(&cx.env, cx.ret, 1), |x| format!("return {x};\n")))];
        if cx.loops > 0 {
            tails.push((2, pick(&["break;\n", "continue;\n"])));
        }
        let dead = proptest::option::weighted(0.3, self.stmt(cx, 0));
        (self.stmts(cx, depth, n), union(tails), dead)
            .prop_map(|(s, t, d)| {
                if t.is_empty() { format!("{{\n{s}}}") } else { format!("{{\n{s}{t}{}}}", d.unwrap_or_default()) }
            })
            .boxed()
    }

    fn stmt(&self, cx: &Ctx, depth: u32) -> S {
        let env = &cx.env;
        let ed = 2;
        let e = |ty| self.expr(env, ty, ed);
        let mut arms: Vec<(u32, S)> = Vec::new();
        for (ty, ops) in [
            (T::F, &["=", "+=", "-=", "*=", "/="][..]),
            (T::I, &["=", "+=", "-=", "*=", "/="][..]),
            (T::B, &["="][..]),
            (T::V, &["=", "+=", "-=", "*=", "/="][..]),
            (T::C, &["=", "+=", "*=", "/="][..]),
            (T::W, &["=", "+=", "-=", "*=", "/="][..]),
            (T::M, &["=", "*="][..]),
        ] {
            let targets = env.assignable_of(ty);
            if targets.is_empty() {
                continue;
            }
            arms.push((3, map3(pick_owned(targets.clone()), pick(ops), e(ty), |x, o, y| format!("{x} {o} {y};\n"))));
            match ty {
                T::V | T::W => {
                    let fields: &[&str] = if ty == T::V { &["x", "y", "z"] } else { &["x", "y"] };
                    arms.push((
                        1,
                        (pick_owned(targets.clone()), pick(fields), pick(&["=", "+=", "*="]), e(T::F))
                            .prop_map(|(x, k, o, y)| format!("{x}.{k} {o} {y};\n"))
                            .boxed(),
                    ));
                    arms.push((1, map2(pick_owned(targets), e(T::F), |x, y| format!("{x} *= {y};\n"))));
                }
                T::C => arms.push((1, map2(pick_owned(targets), e(T::F), |x, y| format!("{x} *= {y};\n")))),
                T::F => arms.push((1, map2(pick_owned(targets), e(T::I), |x, y| format!("{x} += {y};\n")))),
                _ => {}
            }
        }
        for (ty, elem, len) in [(T::FA, T::F, 4), (T::IA, T::I, 3), (T::BA, T::B, 2)] {
            let arrays = env.assignable_of(ty);
            if arrays.is_empty() {
                continue;
            }
            let ops: &[&str] = if ty == T::BA { &["="] } else { &["=", "+=", "-=", "*="] };
            arms.push((
                3,
                (pick_owned(arrays), self.index(env, ed, len), pick(ops), e(elem))
                    .prop_map(|(a, k, o, x)| format!("{a}[{k}] {o} {x};\n"))
                    .boxed(),
            ));
        }
        // Early return.
        arms.push((1, map2(e(T::B), self.expr(env, cx.ret, ed), |c, x| format!("if {c} {{\nreturn {x};\n}}\n"))));
        if cx.loops > 0 {
            arms.push((2, map2(e(T::B), pick(&["break", "continue"]), |c, k| format!("if {c} {{\n{k};\n}}\n"))));
        }
        if depth > 0 {
            let inner = depth - 1;
            // if / else if / else
            arms.push((
                3,
                (e(T::B), self.block(cx, inner, 2), proptest::option::of(self.block(cx, inner, 1)))
                    .prop_map(|(c, t, f)| match f {
                        Some(f) => format!("if {c} {t} else {f}\n"),
                        None => format!("if {c} {t}\n"),
                    })
                    .boxed(),
            ));
            arms.push((
                1,
                (e(T::B), self.block(cx, inner, 1), e(T::B), self.block(cx, inner, 1))
                    .prop_map(|(c, t, c2, t2)| format!("if ({c}) {t} else if {c2} {t2}\n"))
                    .boxed(),
            ));
            // A bounded loop, with literal or clamped dynamic bounds.
            let var = format!("k{}", cx.loops);
            let body_cx = Ctx { env: env.with(&var, T::I, false), ret: cx.ret, loops: cx.loops + 1 };
            let body = self.block(&body_cx, inner, 3);
            let bounds = union(vec![
                (3, (-1i32..3, 0i32..6).prop_map(|(a, b)| format!("{a}..{b}")).boxed()),
                (1, map1(self.expr(env, T::I, 1), |x| format!("0..clamp({x}, -2, 5)"))),
                (1, map1(self.expr(env, T::I, 1), |x| format!("max({x}, -3)..3"))),
            ]);
            arms.push((3, map2(bounds, body, move |r, b| format!("for {var} in {r} {b}\n"))));
            // A block with its own local.
            let tmp = format!("tmp{depth}");
            let block_cx = Ctx { env: env.with(&tmp, T::F, true), ret: cx.ret, loops: cx.loops };
            arms.push((
                1,
                map2(e(T::F), self.stmts(&block_cx, inner, 2), move |x, s| format!("{{\nfloat {tmp} = {x};\n{s}}}\n")),
            ));
        }
        union(arms)
    }

    /// Local declarations (each initialiser sees the ones before it), then
    /// statements, then the final return.
    fn body(&self, env: &Env, ret: T, locals: bool) -> S {
        let mut env = env.clone();
        let mut decls: Vec<S> = Vec::new();
        if locals {
            for (name, ty) in [
                ("x0", T::F),
                ("i0", T::I),
                ("v0", T::V),
                ("c0", T::C),
                ("b0", T::B),
                ("w0", T::W),
                ("mx", T::M),
                ("fa", T::FA),
                ("ia", T::IA),
                ("ba", T::BA),
            ] {
                let init = match ty {
                    T::FA => vec![self.expr(&env, T::F, 1); 4].prop_map(|v| format!("[{}]", v.join(", "))).boxed(),
                    T::IA => vec![self.expr(&env, T::I, 1); 3].prop_map(|v| format!("[{}]", v.join(", "))).boxed(),
                    T::BA => vec![self.expr(&env, T::B, 1); 2].prop_map(|v| format!("[{}]", v.join(", "))).boxed(),
                    T::W => union(vec![
                        (3, self.expr(&env, T::W, 1)),
                        (1, vec![self.expr(&env, T::F, 1); 2].prop_map(|v| format!("({})", v.join(", "))).boxed()),
                    ]),
                    T::V => union(vec![
                        (3, self.expr(&env, T::V, 1)),
                        (1, vec![self.expr(&env, T::F, 1); 3].prop_map(|v| format!("({})", v.join(", "))).boxed()),
                    ]),
                    _ => self.expr(&env, ty, 1),
                };
                let decl = ty.keyword();
                // Sometimes no initialiser: the zero value.
                decls.push(
                    proptest::option::weighted(0.85, init)
                        .prop_map(move |i| match i {
                            Some(i) => format!("{decl} {name} = {i};\n"),
                            None => format!("{decl} {name};\n"),
                        })
                        .boxed(),
                );
                env = env.with(name, ty, true);
            }
        }
        let cx = Ctx { env: env.clone(), ret, loops: 0 };
        let stmts = self.stmts(&cx, 2, 3);
        let ret = self.expr(&env, ret, 2);
        (decls, stmts, ret).prop_map(|(d, s, r)| format!("{}{s}return {r};\n", d.join(""))).boxed()
    }
}

/// The value of an integer literal, possibly negated and parenthesised, as
/// the checker sees it.
fn const_int(s: &str) -> Option<i64> {
    let s = s.trim();
    if let Some(inner) = s.strip_prefix('(').and_then(|r| r.strip_suffix(')')) {
        return const_int(inner);
    }
    if let Some(rest) = s.strip_prefix('-') {
        return const_int(rest).map(|v| -v);
    }
    s.parse().ok()
}

// Tuples of two strategies as "a, b" text.
trait BoxedTuple {
    fn boxed_tuple(self) -> S;
}

impl BoxedTuple for (S, S) {
    fn boxed_tuple(self) -> S {
        self.prop_map(|(a, b)| format!("{a}, {b}")).boxed()
    }
}

// ---------------------------------------------------------------- programs

/// Program text, shown as is when a case fails.
#[derive(Clone)]
pub struct Source(pub String);

impl fmt::Debug for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "\n{}\n", self.0)
    }
}

const HELPER_PARAMS: &str =
    "float a, int n = 3, vector d = vector(0.5, 1, -2), color c = rgb(0.2, 0.5, 0.9), bool flag = true";

fn helper_env(helpers: &[Helper]) -> Env {
    let mut env = Env { helpers: helpers.to_vec(), arr_helper: true, ..Env::empty() };
    for (n, t) in [("a", T::F), ("n", T::I), ("d", T::V), ("c", T::C), ("flag", T::B)] {
        env = env.with(n, t, true);
    }
    env
}

/// A material method the generator may define.
struct Method {
    name: &'static str,
    /// The return type as written (`normal` for the `normal` method).
    ret_keyword: &'static str,
    ret: T,
    params: &'static [(&'static str, T)],
    /// May call `diffuse()` and `normal()` (which never call back).
    calls: bool,
}

const fn method(
    name: &'static str,
    ret_keyword: &'static str,
    ret: T,
    params: &'static [(&'static str, T)],
    calls: bool,
) -> Method {
    Method { name, ret_keyword, ret, params, calls }
}

const METHODS: &[Method] = &[
    method("reflection", "color", T::C, &[("wi", T::V), ("light", T::C), ("wo", T::V)], true),
    method("emission", "color", T::C, &[("wo", T::V)], true),
    method("reflection_dir", "vector", T::V, &[("wo", T::V)], true),
    method("refraction_index", "color", T::C, &[], false),
    // `distance` is a builtin function, so the parameter has another name.
    method("absorption", "color", T::C, &[("light", T::C), ("dist", T::F)], true),
    method("normal", "normal", T::V, &[], false),
    method("diffuse", "color", T::C, &[], false),
    method("opaque", "bool", T::B, &[], false),
    method("pdf", "float", T::F, &[("wi", T::V), ("wo", T::V), ("eta", T::C)], true),
];

fn material(g: &Gen, name: &'static str, helpers: &[Helper]) -> S {
    let mut base = Env { helpers: helpers.to_vec(), ..Env::empty() };
    for (n, t) in [("kd", T::C), ("k", T::F), ("count", T::I), ("shiny", T::B), ("dir", T::V)] {
        base = base.with(n, t, false);
    }
    let mut methods: Vec<S> = Vec::new();
    for m in METHODS {
        let mut env = Env { methods: m.calls, ..base.clone() };
        let mut sig = Vec::new();
        for (p, t) in m.params {
            env = env.with(p, *t, true);
            sig.push(format!("{} {p}", t.keyword()));
        }
        let header = format!("    {} {}({}) ", m.ret_keyword, m.name, sig.join(", "));
        // Method bodies: short ones without locals, or full ones.
        let body = union(vec![(4, g.body(&env, m.ret, false)), (1, g.body(&env, m.ret, true))]);
        methods.push(
            proptest::option::weighted(0.45, body)
                .prop_map(move |b| b.map(|b| format!("{header}{{\n{b}}}\n")).unwrap_or_default())
                .boxed(),
        );
    }
    let kd = g.expr(&Env { globals: false, ..Env::empty() }, T::C, 1);
    (kd, methods)
        .prop_map(move |(kd, ms)| format!(
            "material {name}(color kd = {kd}, float k = 0.5, int count = 2, bool shiny = true, vector dir = vector(0, 1, 0)) {{\n{}}}\n",
            ms.join("")
        ))
        .boxed()
}

/// A material value (texture tree) of bounded depth.
fn tree(g: &Gen, env: &Env, depth: u32, leaves: &[&str]) -> S {
    let e = |ty| g.expr(env, ty, 2);
    let mut arms: Vec<(u32, S)> = vec![
        (4, pick(leaves)),
        (1, map1(g.expr(env, T::C, 1), |kd| format!("m1(kd: {kd})"))),
        (
            1,
            (g.expr(env, T::I, 1), g.expr(env, T::B, 1), g.expr(env, T::V, 1), g.expr(env, T::F, 1))
                .prop_map(|(n, b, d, k)| format!("m0(count: {n}, shiny: {b}, dir: {d}, k: {k})"))
                .boxed(),
        ),
        (1, map1(g.expr(env, T::C, 1), |kd| format!("lambert(kd: {kd})"))),
        (1, map2(g.expr(env, T::C, 1), g.expr(env, T::F, 1), |kd, ns| format!("phong(kd: {kd}, ns: {ns})"))),
    ];
    if depth > 0 {
        let sub = || tree(g, env, depth - 1, leaves);
        arms.extend([
            (3, map3(e(T::F), sub(), sub(), |t, a, b| format!("mix({t}, {a}, {b})"))),
            (
                1,
                (e(T::F), sub(), sub(), pick(&["reflection", "refraction_index", "normal", "opaque", "diffuse"]))
                    .prop_map(|(t, a, b, o)| format!("mix({t}, {a}, {b}, only: \"{o}\")"))
                    .boxed(),
            ),
            (
                2,
                (e(T::F), proptest::collection::vec(sub(), 1..3), proptest::option::of(e(T::B)))
                    .prop_map(|(t, ms, s)| match s {
                        Some(s) => format!("blend({t}, [{}], spline: {s})", ms.join(", ")),
                        None => format!("blend({t}, [{}])", ms.join(", ")),
                    })
                    .boxed(),
            ),
            (
                2,
                map2(e(T::I), proptest::collection::vec(sub(), 1..3).prop_map(|v| v.join(", ")).boxed(), |i, ms| {
                    format!("select({i}, [{ms}])")
                }),
            ),
            (
                1,
                map2(
                    lit("face"),
                    proptest::collection::vec(sub(), 2..3).prop_map(|v| v.join(", ")).boxed(),
                    |i, ms| format!("select({i}, [{ms}])"),
                ),
            ),
            (2, map3(e(T::F), e(T::F), sub(), |h, a, m| format!("bump({h}, {a}, {m})"))),
            (
                2,
                (e(T::V), sub(), e(T::F), pick(&["opengl", "directx"]), e(T::B))
                    .prop_map(|(n, m, s, c, sh)| {
                        format!("normal_map({n}, {m}, strength: {s}, convention: \"{c}\", shadowing: {sh})")
                    })
                    .boxed(),
            ),
            (2, map2(e(T::C), sub(), |c, m| format!("scale({c}, {m})"))),
            (2, map2(g.expr(env, T::M, 2), sub(), |x, m| format!("transform({x}, {m})"))),
            (1, map3(e(T::B), sub(), sub(), |c, a, b| format!("({c} ? {a} : {b})"))),
            (1, map3(sub(), sub(), e(T::F), |a, b, s| format!("tm({a}, {b}, s: {s})"))),
        ]);
    }
    union(arms)
}

pub fn program() -> impl Strategy<Value = Source> {
    let g = Gen::default();
    let const_env = Env { globals: false, consts: false, ..Env::empty() };
    let consts = (g.expr(&const_env, T::F, 2), g.expr(&const_env, T::I, 2), g.expr(&const_env, T::C, 2))
        .prop_map(|(f, i, c)| format!("const float K0 = {f};\nconst int K1 = {i};\nconst color KC = {c};\n"));

    // Helpers in dependency order: each may call the ones before it.
    let order = [
        Helper { name: "g_bool", ret: T::B },
        Helper { name: "g_int", ret: T::I },
        Helper { name: "g_matrix", ret: T::M },
        Helper { name: "g_vector", ret: T::V },
        Helper { name: "g_color", ret: T::C },
        Helper { name: "g_float", ret: T::F },
    ];
    // g_arr comes first: it calls no helper.
    let arr_env = Env::empty().with("xs", T::FA, true).with("k", T::I, true);
    let g_arr = g.body(&arr_env, T::F, false).prop_map(|b| format!("float g_arr(float[4] xs, int k) {{\n{b}}}\n"));
    let mut helpers: Vec<S> = Vec::new();
    for (k, h) in order.iter().enumerate() {
        let env = helper_env(&order[..k]);
        let kw = h.ret.keyword();
        let name = h.name;
        // Each helper has a wrapper calling it with constant arguments, so
        // that lowering specialises (constant-folds) its body: `w_x()` must
        // equal `g_x` called with the same argument words (see `FOLD_ARGS`).
        let wrapper = format!(
            "{kw} {}() {{\nreturn {name}(0.75, 2, d: vector(0.25, -1, 2), flag: false);\n}}\n",
            name.replacen("g_", "w_", 1)
        );
        helpers.push(
            g.body(&env, h.ret, true)
                .prop_map(move |b| format!("{kw} {name}({HELPER_PARAMS}) {{\n{b}}}\n{wrapper}"))
                .boxed(),
        );
    }
    let m0 = material(&g, "m0", &order);
    let m1 = material(&g, "m1", &order[..3]);
    let tree_env = Env { helpers: order.to_vec(), ..Env::empty() };
    let tm_env = tree_env.with("s", T::F, false);
    let tm = map1(g.expr(&tm_env, T::F, 2), |t| {
        format!("material tm(material a, material b, float s = 1) = mix({t}, a, b);\n")
    });
    let tree0 = tree(&g, &tree_env, 2, &["m0", "m1", "mirror", "glass", "lambert"]);
    let tree1 = tree(&g, &tree_env, 1, &["m0", "tree0", "m1", "phong"]);
    (consts, g_arr, helpers, (m0, m1, tm), (tree0, tree1)).prop_map(|(k, ga, hs, (m0, m1, tm), (t0, t1))| {
        Source(format!("{k}{ga}{}{m0}{m1}{tm}material tree0 = {t0};\nmaterial tree1 = {t1};\n", hs.join("")))
    })
}
