//! Shaders can never crash or hang the host: every operation is total
//! (integer division by zero, `INT_MIN / -1`, out-of-range indices,
//! conversions of NaN and infinities), loops are capped, deep trees compile,
//! JIT memory is freed, programs are shared across threads, and the API
//! refuses bad argument slices. Every case runs on both back ends, which
//! must agree, with the value the IR's semantics promise.

use std::process::Command;
use tsl::{Backend, ColorModel, Compiler, Program, ShadingGlobals};

const MODELS: [ColorModel; 2] = [ColorModel::Rgb, ColorModel::Spectral { samples: 16 }];

fn compile(src: &str) -> Program {
    compile_in(ColorModel::Rgb, src)
}

fn compile_in(model: ColorModel, src: &str) -> Program {
    Compiler::new().color_model(model).source("safety.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"))
}

fn f(x: f32) -> u32 {
    x.to_bits()
}

fn i(x: i32) -> u32 {
    x as u32
}

/// Same bits, or both NaN.
fn same(a: u32, b: u32) -> bool {
    a == b || (f32::from_bits(a).is_nan() && f32::from_bits(b).is_nan())
}

/// Calls `name` on both back ends at the given globals; they must agree.
/// Returns the result words.
fn call_at(p: &Program, name: &str, g: &ShadingGlobals, args: &[u32]) -> Vec<u32> {
    let func = p.function(name).unwrap_or_else(|| panic!("no entry `{name}`"));
    let n = func.result_types().len();
    let mut jit = vec![0u32; n];
    let mut int = vec![0u32; n];
    func.call_words(Backend::Jit, g, args, &mut jit).unwrap();
    func.call_words(Backend::Interpreter, g, args, &mut int).unwrap();
    for k in 0..n {
        assert!(
            same(jit[k], int[k]),
            "{name}({args:?}) word {k}: jit {:#x} ({}) vs interpreter {:#x} ({})",
            jit[k],
            f32::from_bits(jit[k]),
            int[k],
            f32::from_bits(int[k])
        );
    }
    jit
}

fn call(p: &Program, name: &str, args: &[u32]) -> Vec<u32> {
    call_at(p, name, &ShadingGlobals::default(), args)
}

fn call_i(p: &Program, name: &str, args: &[u32]) -> i32 {
    call(p, name, args)[0] as i32
}

fn call_f(p: &Program, name: &str, args: &[u32]) -> f32 {
    f32::from_bits(call(p, name, args)[0])
}

// ---------------------------------------------------------------- total arithmetic

#[test]
fn integer_division_and_remainder_never_trap() {
    let p = compile(
        r#"
        int div(int a, int b) { return a / b; }
        int rem(int a, int b) { return a % b; }
        int imod(int a, int b) { return mod(a, b); }
        int div_assign(int a, int b) { int x = a; x /= b; return x; }
        int div_by_zero_const() { return 7 / 0; }
        int rem_by_zero_const() { return 7 % 0; }
        int min_div_const() { return (-2147483647 - 1) / (-1); }
        int min_rem_const() { return (-2147483647 - 1) % (-1); }
        int div_by_dynamic_zero() { return 7 / (face - face); }
        "#,
    );
    const MIN: i32 = i32::MIN;
    const MAX: i32 = i32::MAX;
    let cases = [
        // a, b, a / b, a % b
        (7, 0, 0, 0),
        (0, 0, 0, 0),
        (MIN, 0, 0, 0),
        (MIN, -1, MIN, 0),
        (MAX, -1, -MAX, 0),
        (-7, 2, -3, -1),
        (7, -2, -3, 1),
        (MIN, 1, MIN, 0),
        (MIN, MAX, -1, -1),
    ];
    for (a, b, q, r) in cases {
        assert_eq!(call_i(&p, "div", &[i(a), i(b)]), q, "{a} / {b}");
        assert_eq!(call_i(&p, "div_assign", &[i(a), i(b)]), q, "{a} /= {b}");
        assert_eq!(call_i(&p, "rem", &[i(a), i(b)]), r, "{a} % {b}");
        // mod() has no promised value for a zero divisor: it must only not trap,
        // and both back ends must agree (checked by `call`).
        call(&p, "imod", &[i(a), i(b)]);
    }
    assert_eq!(call_i(&p, "imod", &[i(-7), i(2)]), 1, "mod(-7, 2) is never negative");
    assert_eq!(call_i(&p, "div_by_zero_const", &[]), 0);
    assert_eq!(call_i(&p, "rem_by_zero_const", &[]), 0);
    assert_eq!(call_i(&p, "min_div_const", &[]), MIN);
    assert_eq!(call_i(&p, "min_rem_const", &[]), 0);
    assert_eq!(call_i(&p, "div_by_dynamic_zero", &[]), 0);
}

#[test]
fn float_division_by_zero_is_ieee() {
    let p = compile(
        r#"
        float fdiv(float a, float b) { return a / b; }
        float frem(float a, float b) { return a % b; }
        float one_over_zero() { return 1.0 / 0.0; }
        float zero_over_zero() { return 0.0 / 0.0; }
        vector vdiv(vector a, float b) { return a / b; }
        "#,
    );
    assert_eq!(call_f(&p, "fdiv", &[f(1.0), f(0.0)]), f32::INFINITY);
    assert_eq!(call_f(&p, "fdiv", &[f(-1.0), f(0.0)]), f32::NEG_INFINITY);
    assert_eq!(call_f(&p, "fdiv", &[f(1.0), f(-0.0)]), f32::NEG_INFINITY);
    assert!(call_f(&p, "fdiv", &[f(0.0), f(0.0)]).is_nan());
    assert!(call_f(&p, "fdiv", &[f(f32::INFINITY), f(f32::INFINITY)]).is_nan());
    assert!(call_f(&p, "frem", &[f(1.0), f(0.0)]).is_nan());
    assert!(call_f(&p, "frem", &[f(f32::INFINITY), f(1.0)]).is_nan());
    assert_eq!(call_f(&p, "frem", &[f(-7.5), f(2.0)]), -1.5, "float % truncates like fmod");
    assert_eq!(call_f(&p, "one_over_zero", &[]), f32::INFINITY);
    assert!(call_f(&p, "zero_over_zero", &[]).is_nan());
    let v = call(&p, "vdiv", &[f(1.0), f(-1.0), f(0.0), f(0.0)]);
    assert_eq!(f32::from_bits(v[0]), f32::INFINITY);
    assert_eq!(f32::from_bits(v[1]), f32::NEG_INFINITY);
    assert!(f32::from_bits(v[2]).is_nan());
}

#[test]
fn float_to_int_saturates() {
    let p = compile(
        r#"
        int to_int(float x) { return int(x); }
        int nan_const() { return int(sqrt(-1.0)); }
        int inf_const() { return int(1.0 / 0.0); }
        int huge_const() { return int(1e30); }
        int neg_huge_const() { return int(-1e30); }
        int loop_to_nan(float x) { int n = 0; for i in 0..int(x) { n += 1; } return n; }
        "#,
    );
    let cases = [
        (f32::NAN, 0),
        (-f32::NAN, 0),
        (f32::INFINITY, i32::MAX),
        (f32::NEG_INFINITY, i32::MIN),
        (1e10, i32::MAX),
        (-1e10, i32::MIN),
        (3e9, i32::MAX),
        (2147483520.0, 2147483520),
        (-2147483648.0, i32::MIN),
        (2.9, 2),
        (-2.9, -2),
        (-0.0, 0),
        (f32::MIN_POSITIVE, 0),
    ];
    for (x, want) in cases {
        assert_eq!(call_i(&p, "to_int", &[f(x)]), want, "int({x})");
    }
    assert_eq!(call_i(&p, "nan_const", &[]), 0);
    assert_eq!(call_i(&p, "inf_const", &[]), i32::MAX);
    assert_eq!(call_i(&p, "huge_const", &[]), i32::MAX);
    assert_eq!(call_i(&p, "neg_huge_const", &[]), i32::MIN);
    assert_eq!(call_i(&p, "loop_to_nan", &[f(f32::NAN)]), 0);
    assert_eq!(call_i(&p, "loop_to_nan", &[f(5.5)]), 5);
}

#[test]
fn dynamic_indices_are_clamped() {
    let p = compile(
        r#"
        float pick(int i) { float[3] a = [1, 2, 3]; return a[i]; }
        float store(int i) { float[3] a; a[i] = 5; return a[0] + 10 * a[1] + 100 * a[2]; }
        int bump_int(int i) { int[4] a = [10, 20, 30, 40]; a[i] += 1; return a[i]; }
        bool pick_bool(int i) { bool[2] b = [true, false]; return b[i]; }
        float pick_vector(int i) { vector p = vector(1, 2, 3); return p[i]; }
        float pick_vec2(int i) { vec2 p = vec2(1, 2); return p[i]; }
        float pick_param(float[4] xs, int i) { return xs[i]; }
        float pass_array(int i) { return pick_param([1, 2, 3, 4], i); }
        float pick_face() { float[6] a = [0, 1, 2, 3, 4, 5]; return a[face * 1000]; }
        "#,
    );
    const MIN: i32 = i32::MIN;
    const MAX: i32 = i32::MAX;
    let cases = [
        // index, of [1, 2, 3], of [1, 2, 3, 4]
        (MIN, 1.0, 1.0),
        (-5, 1.0, 1.0),
        (-1, 1.0, 1.0),
        (0, 1.0, 1.0),
        (1, 2.0, 2.0),
        (2, 3.0, 3.0),
        (3, 3.0, 4.0),
        (100, 3.0, 4.0),
        (MAX, 3.0, 4.0),
    ];
    for (k, of3, of4) in cases {
        assert_eq!(call_f(&p, "pick", &[i(k)]), of3, "a[{k}]");
        assert_eq!(call_f(&p, "pick_vector", &[i(k)]), of3, "p[{k}]");
        assert_eq!(call_f(&p, "pass_array", &[i(k)]), of4, "xs[{k}]");
    }
    assert_eq!(call_f(&p, "store", &[i(-1)]), 5.0);
    assert_eq!(call_f(&p, "store", &[i(1)]), 50.0);
    assert_eq!(call_f(&p, "store", &[i(7)]), 500.0);
    assert_eq!(call_f(&p, "store", &[i(MAX)]), 500.0);
    assert_eq!(call_i(&p, "bump_int", &[i(MIN)]), 11);
    assert_eq!(call_i(&p, "bump_int", &[i(9)]), 41);
    assert_eq!(call(&p, "pick_bool", &[i(-3)]), [1]);
    assert_eq!(call(&p, "pick_bool", &[i(3)]), [0]);
    assert_eq!(call_f(&p, "pick_vec2", &[i(-1)]), 1.0);
    assert_eq!(call_f(&p, "pick_vec2", &[i(5)]), 2.0);
    for face in [-7, 0, 1, 3, 1_000_000] {
        let g = ShadingGlobals { face, ..Default::default() };
        let want = if face > 0 { 5.0 } else { 0.0 };
        assert_eq!(f32::from_bits(call_at(&p, "pick_face", &g, &[])[0]), want, "face {face}");
    }
}

#[test]
fn math_of_bad_arguments_gives_nan_or_infinity() {
    let p = compile(
        r#"
        float fsqrt(float x) { return sqrt(x); }
        float flog(float x) { return log(x); }
        float fpow(float x, float e) { return pow(x, e); }
        float fasin(float x) { return asin(x); }
        float facos(float x) { return acos(x); }
        float fexp(float x) { return exp(x); }
        vector fnormalize(vector v) { return normalize(v); }
        float flength(vector v) { return length(v); }
        float sqrt_const() { return sqrt(-1.0); }
        float log_const() { return log(-1.0); }
        float log_zero_const() { return log(0.0); }
        float fnoise(float x) { return noise(vector(x, 0.5, 0.25)) + cellnoise(vector(x, x, x)); }
        "#,
    );
    assert!(call_f(&p, "fsqrt", &[f(-1.0)]).is_nan());
    assert_eq!(call(&p, "fsqrt", &[f(-0.0)]), [f(-0.0)]);
    assert!(call_f(&p, "flog", &[f(-1.0)]).is_nan());
    assert_eq!(call_f(&p, "flog", &[f(0.0)]), f32::NEG_INFINITY);
    assert!(call_f(&p, "fpow", &[f(-8.0), f(1.0 / 3.0)]).is_nan());
    assert!(call_f(&p, "fasin", &[f(2.0)]).is_nan());
    assert!(call_f(&p, "facos", &[f(-2.0)]).is_nan());
    assert_eq!(call_f(&p, "fexp", &[f(1000.0)]), f32::INFINITY);
    assert!(call_f(&p, "sqrt_const", &[]).is_nan());
    assert!(call_f(&p, "log_const", &[]).is_nan());
    assert_eq!(call_f(&p, "log_zero_const", &[]), f32::NEG_INFINITY);
    // Whatever these give, both back ends agree and nothing traps.
    call(&p, "fnormalize", &[f(0.0), f(0.0), f(0.0)]);
    call(&p, "fnormalize", &[f(f32::NAN), f(f32::INFINITY), f(0.0)]);
    assert_eq!(call_f(&p, "flength", &[f(f32::INFINITY), f(0.0), f(0.0)]), f32::INFINITY);
    for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -1e30] {
        let n = call_f(&p, "fnoise", &[f(x)]);
        assert!(n.is_finite(), "noise of {x} is {n}");
    }
}

// ---------------------------------------------------------------- loops

#[test]
fn loops_are_capped_at_65536_iterations() {
    let p = compile(
        r#"
        int count() { int n = 0; for i in 0..2000000000 { n += 1; } return n; }
        int count_range(int lo, int hi) { int n = 0; for i in lo..hi { n += 1; } return n; }
        int last_index(int lo, int hi) { int last = -1; for i in lo..hi { last = i; } return last; }
        int nested(int a, int b) { int n = 0; for i in 0..a { for j in 0..b { n += 1; } } return n; }
        int with_continue() { int n = 0; for i in 0..2000000000 { if i % 2 == 0 { continue; } n += 1; } return n; }
        int spin() {
            int n = 0;
            for i in 0..2000000000 { for j in 0..2000000000 { for k in 0..2000000000 { n += 1; } } }
            return n;
        }
        int after_budget() {
            int n = 0;
            for i in 0..2000000000 { for j in 0..2000000000 { n += 0; } }
            for k in 0..10 { n += 1; }
            return n;
        }
        int two_loops() { int n = 0; for i in 0..100000 { n += 1; } for i in 0..100000 { n += 1; } return n; }
        "#,
    );
    let start = std::time::Instant::now();
    assert_eq!(call_i(&p, "count", &[]), 65_536);
    assert_eq!(call_i(&p, "with_continue", &[]), 32_768);
    assert_eq!(call_i(&p, "count_range", &[i(i32::MIN), i(i32::MAX)]), 65_536);
    assert_eq!(call_i(&p, "count_range", &[i(i32::MAX), i(i32::MIN)]), 0);
    assert_eq!(call_i(&p, "count_range", &[i(5), i(-5)]), 0);
    assert_eq!(call_i(&p, "count_range", &[i(i32::MAX - 10), i(i32::MAX)]), 10);
    assert_eq!(call_i(&p, "last_index", &[i(i32::MAX - 3), i(i32::MAX)]), i32::MAX - 1);
    assert_eq!(call_i(&p, "last_index", &[i(i32::MIN), i(i32::MAX)]), i32::MIN + 65_535);
    assert_eq!(call_i(&p, "last_index", &[i(3), i(3)]), -1);
    assert_eq!(call_i(&p, "nested", &[i(300), i(300)]), 90_000);
    // Each loop is capped separately: 2 outer iterations of a capped inner loop.
    assert_eq!(call_i(&p, "nested", &[i(2), i(i32::MAX)]), 131_072);
    // A call has a budget of 2^18 iterations over all its loops, so nested
    // capped loops cannot multiply the cap; once it is spent, every loop ends.
    let spun = call_i(&p, "spin", &[]);
    assert!(spun <= 1 << 18 && spun > (1 << 18) - 100, "{spun}");
    assert_eq!(call_i(&p, "after_budget", &[]), 0);
    assert_eq!(call_i(&p, "two_loops", &[]), 131_072);
    eprintln!("capped loops on both back ends: {:?}", start.elapsed());
}

// ---------------------------------------------------------------- deep trees

/// Both back ends agree on every method of `name` at `points` shading points.
fn compare_material(p: &Program, name: &str, points: usize) {
    let lanes = p.color_model().lanes();
    p.material(name).unwrap_or_else(|e| panic!("{name}: {e}"));
    let entries: Vec<_> = p.functions().into_iter().filter(|e| e.name().starts_with(&format!("{name}."))).collect();
    assert_eq!(entries.len(), tsl::check::INTERFACE.len(), "the methods of `{name}`");
    for entry in &entries {
        for k in 0..points {
            let s = k as f32 / points as f32;
            let g = ShadingGlobals {
                p: [s * 3.0 - 1.0, 0.5 - s, s * s],
                pl: [s, 1.0 - s, 0.25],
                n: [0.0, 0.0, 1.0],
                ng: [0.0, 0.0, 1.0],
                u: s,
                v: 1.0 - s,
                dpdu: [1.0, 0.0, 0.0],
                dpdv: [0.0, 1.0, 0.0],
                face: k as i32 % 4,
                t: 1.0 + s,
                ..Default::default()
            };
            let mut args = Vec::new();
            for (pname, ty) in entry.params() {
                match ty {
                    tsl::check::Ty::Float => args.push(f(1.5)),
                    tsl::check::Ty::Color if pname == "eta" => args.extend((0..lanes).map(|_| f(1.5))),
                    tsl::check::Ty::Color => args.extend((0..lanes).map(|_| f(0.8))),
                    _ => args.extend([f(0.6), f(0.0), f(0.8)]),
                }
            }
            call_at(p, entry.name(), &g, &args);
        }
    }
}

#[test]
fn deep_texture_trees_compile_and_agree() {
    const DEPTH: usize = 60;
    // Every named tree is an entry point that inlines its whole subtree, so
    // a chain of named trees costs quadratic time to compile: 10 deep here.
    const CHAIN: usize = 10;
    // One expression nested 60 deep, and a chain of 10 named trees.
    let mut nested = "lambert(kd: rgb(0.5, 0.2, 0.1))".to_string();
    for k in 1..=DEPTH {
        nested = format!("mix(fract(noise(P * {k}) + u), {nested}, phong(kd: gray({})))", k as f32 / DEPTH as f32);
    }
    let mut chain = String::from("material t0 = lambert(kd: rgb(0.5, 0.2, 0.1));\n");
    for k in 1..=CHAIN {
        chain += &format!(
            "material t{k} = mix(0.5 + 0.5 * noise(Pl * {k}), t{}, phong(kd: gray({}), ns: {k}));\n",
            k - 1,
            k as f32 / CHAIN as f32
        );
    }
    let src = format!("material deep = {nested};\n{chain}");
    for model in MODELS {
        let p = compile_in(model, &src);
        compare_material(&p, "deep", 8);
        compare_material(&p, &format!("t{CHAIN}"), 8);
        // The tree is usable through the material API too.
        let m = p.material("deep").unwrap();
        let c = m.reflection(
            &ShadingGlobals { n: [0.0, 0.0, 1.0], ..Default::default() },
            [0.0, 0.0, 1.0],
            &p.rgb(1.0, 1.0, 1.0),
            [0.0, 0.0, 1.0],
        );
        assert!(c.lanes().iter().all(|x| x.is_finite()), "{c:?}");
    }
}

// ---------------------------------------------------------------- memory

/// Resident set size in bytes, from /proc/self/statm (Linux only).
fn rss() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096)
}

/// Runs in a child process of its own (this test binary, filtered to this
/// test), so that other tests running in parallel do not disturb the RSS.
#[test]
fn compiling_and_dropping_300_programs_frees_memory() {
    in_child("compiling_and_dropping_300_programs_frees_memory", || compile_and_drop_programs(300, 40));
}

/// The long soak (`cargo test --release --test safety -- --ignored soak`):
/// 10,000 programs, resident memory flat within 40 MB.
#[test]
#[ignore = "the JIT memory soak: minutes"]
fn soak_compiling_and_dropping_10000_programs_frees_memory() {
    in_child("soak_compiling_and_dropping_10000_programs_frees_memory", || compile_and_drop_programs(10_000, 40));
}

fn in_child(test: &str, body: impl FnOnce()) {
    const CHILD: &str = "TSL_SAFETY_MEMORY_CHILD";
    if std::env::var_os(CHILD).is_some() {
        body();
        return;
    }
    let out = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", test, "--nocapture", "--test-threads", "1", "--include-ignored"])
        .env(CHILD, "1")
        .output()
        .unwrap();
    let log = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success() && log.contains("1 passed"), "{log}");
    eprintln!("{}", log.lines().filter(|l| l.contains("RSS")).collect::<Vec<_>>().join("\n"));
}

fn compile_and_drop_programs(count: usize, allowed_mb: u64) {
    let source = |k: usize| {
        format!(
            "float g{k}(float x) {{ float s = 0; for i in 0..{n} {{ s += sin(x * float(i)) * {k}; }} return s; }}\n\
             material m{k} = mix(noise(P * {k}), phong(kd: gray(0.{k})), lambert);\n",
            n = k % 7 + 1
        )
    };
    // Warm up allocator pools and lazily built tables first.
    for k in 0..20 {
        drop(compile(&source(k)));
    }
    let before = rss();
    for k in 0..count {
        let p = compile(&source(k));
        assert_eq!(call(&p, &format!("g{k}"), &[f(0.0)]), [f(0.0)]);
        let m = p.material(&format!("m{k}")).unwrap();
        drop(m);
        drop(p);
    }
    if let (Some(before), Some(after)) = (before, rss()) {
        let growth = after.saturating_sub(before);
        eprintln!("RSS {} MB -> {} MB after {count} programs", before >> 20, after >> 20);
        // Leaking every program (std::mem::forget) grows RSS by about 125 MB
        // per 300 programs here; freeing them keeps it flat.
        assert!(
            growth < allowed_mb << 20,
            "RSS grew by {} MB over {count} compiled and dropped programs",
            growth >> 20
        );
    }
}

// ---------------------------------------------------------------- threads

fn assert_send_sync<T: Send + Sync>() {}

#[test]
fn programs_are_send_and_sync() {
    assert_send_sync::<Program>();
    assert_send_sync::<tsl::Material>();
    assert_send_sync::<tsl::Function>();
    assert_send_sync::<tsl::Color>();
}

#[test]
fn a_material_gives_the_same_results_from_8_threads() {
    let p = compile_in(
        ColorModel::Spectral { samples: 16 },
        r#"
        float rings() { float s = 0; for i in 1..6 { s += noise(Pl * float(i)) / float(i); } return fract(s * 4); }
        material wood = bump(rings(), 0.02, mix(rings(), phong(kd: rgb(0.6, 0.4, 0.2)), phong(kd: rgb(0.35, 0.2, 0.08))));
        "#,
    );
    let points: Vec<ShadingGlobals> = (0..500)
        .map(|k| {
            let s = k as f32 * 0.013;
            ShadingGlobals {
                p: [s, s.sin(), s.cos()],
                pl: [s.cos(), s, s.sin()],
                n: [0.0, 0.0, 1.0],
                ng: [0.0, 0.0, 1.0],
                u: s.fract(),
                v: (s * 3.0).fract(),
                dpdu: [1.0, 0.0, 0.0],
                dpdv: [0.0, 1.0, 0.0],
                ..Default::default()
            }
        })
        .collect();
    let shade = |p: &Program| -> Vec<Vec<u32>> {
        let m = p.material("wood").unwrap();
        let light = p.rgb(1.0, 0.9, 0.8);
        points
            .iter()
            .map(|g| {
                let c = m.reflection(g, [0.3, 0.4, 0.866], &light, [0.0, 0.6, 0.8]);
                let n = m.normal(g);
                c.lanes().iter().chain(&n).map(|x| x.to_bits()).collect()
            })
            .collect()
    };
    let single = shade(&p);
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..8)
            .map(|_| {
                let p = p.clone();
                s.spawn(move || (0..4).map(|_| shade(&p)).collect::<Vec<_>>())
            })
            .collect();
        for h in handles {
            for run in h.join().unwrap() {
                assert!(run == single, "a thread got different results");
            }
        }
    });
    // Shared by reference, not cloned, too.
    std::thread::scope(|s| {
        for _ in 0..8 {
            s.spawn(|| assert!(shade(&p) == single));
        }
    });
}

/// Prelude materials are compiled on first use; 8 threads asking for the
/// same one at once get it compiled once, and the same results.
#[test]
fn prelude_compiled_on_first_use_from_8_threads_at_once() {
    let src = "float own() { return u; }";
    let reference = {
        let p = compile(src);
        let m = p.material("cook_torrance").unwrap();
        let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ..Default::default() };
        m.reflection(&g, [0.3, 0.4, 0.866], &p.rgb(1.0, 1.0, 1.0), [0.0, 0.6, 0.8])
    };
    let p = compile(src);
    let own = p.functions().len();
    let barrier = std::sync::Barrier::new(8);
    std::thread::scope(|s| {
        for _ in 0..8 {
            s.spawn(|| {
                barrier.wait();
                let m = p.material("cook_torrance").unwrap();
                let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ..Default::default() };
                let c = m.reflection(&g, [0.3, 0.4, 0.866], &p.rgb(1.0, 1.0, 1.0), [0.0, 0.6, 0.8]);
                assert_eq!(c, reference);
            });
        }
    });
    assert_eq!(p.functions().len(), own + tsl::check::INTERFACE.len(), "cook_torrance was compiled more than once");
}

// ---------------------------------------------------------------- API misuse

#[test]
fn short_argument_or_result_slices_are_errors() {
    let p = compile("color tint(float a, vector d, color c) { return c * a * d.x; }");
    let func = p.function("tint").unwrap();
    let g = ShadingGlobals::default();
    let want_args = 1 + 3 + 3;
    for backend in [Backend::Jit, Backend::Interpreter] {
        let mut out = [0u32; 3];
        for short in 0..want_args {
            let args = vec![f(1.0); short];
            assert!(func.call_words(backend, &g, &args, &mut out).is_err(), "{backend:?} with {short} argument words");
        }
        let args = vec![f(1.0); want_args];
        for short in 0..3 {
            let mut out = vec![0u32; short];
            assert!(func.call_words(backend, &g, &args, &mut out).is_err(), "{backend:?} with {short} result words");
        }
        // Longer slices are fine; extra result words are left alone.
        let mut out = [7u32; 5];
        func.call_words(backend, &g, &vec![f(1.0); want_args + 2], &mut out).unwrap();
        assert_eq!(out, [f(1.0), f(1.0), f(1.0), 7, 7]);
    }
    let none = p.function("no_such_function");
    assert!(none.is_none());
    assert!(p.material("no_such_material").is_err());
}

// ---------------------------------------------------------------- tslc emit

fn tslc(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tslc")).args(args).output().expect("tslc runs")
}

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn tslc_emit_ir_clif_and_ast() {
    for kind in ["ir", "clif"] {
        let o = tslc(&["emit", "--emit", kind, "examples/wood.tsl"]);
        assert!(o.status.success(), "--emit {kind}: {}", stderr(&o));
        let text = stdout(&o);
        assert!(text.contains("wood.reflection"), "--emit {kind}:\n{text}");
        assert!(text.contains("rings"), "--emit {kind}:\n{text}");
    }
    let o = tslc(&["emit", "--emit", "ast", "examples/wood.tsl"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("rings"), "{}", stdout(&o));
}

#[test]
fn tslc_emit_only_one_function() {
    let o = tslc(&["emit", "--emit", "clif", "--only", "wood.reflection", "examples/wood.tsl"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    // `--only` selects by prefix (documented: "functions whose name starts
    // with this"), so `wood.reflection_dir` comes along; nothing else may.
    let names: Vec<&str> = text.lines().filter_map(|l| l.strip_prefix("; ")).collect();
    assert!(names.contains(&"wood.reflection"), "{text}");
    assert!(names.iter().all(|n| n.starts_with("wood.reflection")), "{names:?}");
    let all = tslc(&["emit", "--emit", "clif", "examples/wood.tsl"]);
    assert!(stdout(&all).len() > text.len());
}

#[test]
fn tslc_emit_spectral() {
    let o = tslc(&[
        "emit",
        "--emit",
        "ir",
        "--color-model",
        "spectral16",
        "--only",
        "wood.reflection",
        "examples/wood.tsl",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    // reflection(vector wi, color light, vector wo) -> color: 3 + 16 + 3 words in, 16 out.
    let header = text.lines().find(|l| l.starts_with("fn wood.reflection(")).unwrap_or_else(|| panic!("{text}"));
    assert_eq!(header.matches("f32").count(), 22 + 16, "{header}");
    let bad = tslc(&["emit", "--color-model", "spectral0", "examples/wood.tsl"]);
    assert_eq!(bad.status.code(), Some(2), "a bad color model is a usage error: {}", stderr(&bad));
}

#[test]
fn tslc_emit_reports_errors() {
    let dir = std::env::temp_dir().join(format!("tsl-safety-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("broken.tsl");
    std::fs::write(&file, "float f() { return x; }\ncolor g() { return rgb(1, 0, 0) - 1; }\n").unwrap();
    let path = file.to_str().unwrap();
    for kind in ["ir", "clif", "ast"] {
        let o = tslc(&["emit", "--emit", kind, path]);
        assert_eq!(o.status.code(), Some(1), "--emit {kind}");
        let err = stderr(&o);
        assert!(err.contains("error"), "--emit {kind}: {err}");
        assert!(err.contains("cannot find value `x`"), "--emit {kind}: {err}");
        assert!(err.contains("broken.tsl:1:"), "--emit {kind}: {err}");
        assert!(err.contains("broken.tsl:2:"), "every error is reported: {err}");
        assert!(stdout(&o).is_empty(), "--emit {kind} printed {}", stdout(&o));
    }
    let missing = tslc(&["emit", dir.join("missing.tsl").to_str().unwrap()]);
    assert_eq!(missing.status.code(), Some(1));
    assert!(!stderr(&missing).is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}
