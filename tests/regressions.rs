//! Minimal programs for bugs found by `tests/random_programs.rs` and
//! `tests/safety.rs`, kept as guards now that they are fixed.

use std::sync::mpsc;
use std::time::Duration;
use tsl::{Backend, ColorModel, Compiler, Program, ShadingGlobals};

fn compile(src: &str) -> Program {
    Compiler::new()
        .color_model(ColorModel::Rgb)
        .eager(true)
        .source("regression.tsl", src)
        .compile()
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Calls `name` on both back ends; they must agree. Returns the first word.
fn call(p: &Program, name: &str, args: &[u32]) -> u32 {
    let f = p.function(name).unwrap();
    let (mut jit, mut int) = ([0u32; 4], [0u32; 4]);
    f.call_words(Backend::Jit, &ShadingGlobals::default(), args, &mut jit).unwrap();
    f.call_words(Backend::Interpreter, &ShadingGlobals::default(), args, &mut int).unwrap();
    assert_eq!(jit, int, "{name}({args:?}): jit vs interpreter");
    jit[0]
}

// Found by random_programs at b7494fa; fixed in 55df2cd. `mod` and `clamp`
// of ints were typed `int` by the checker but lowered to float operations,
// so integer code using the result failed the Cranelift verifier
// ("v20 = sdiv.f32 v11, v19: invalid controlling type f32"), and
// `mod(7, 3)` returned the bits of 1.0f32 as an int.
#[test]
fn integer_mod_and_clamp_stay_integers() {
    let p = compile(
        r#"
        int mod_div(int a, int b) { return mod(a, b) / 2; }
        int clamp_div(int a, int b) { return clamp(a, 0, b) / 2; }
        int clamp_index(int a, int b) { int[3] x = [10, 20, 30]; return x[clamp(a, 0, b)]; }
        int plain_mod(int a, int b) { return mod(a, b); }
        "#,
    );
    assert_eq!(call(&p, "mod_div", &[7, 3]), 0);
    assert_eq!(call(&p, "plain_mod", &[7, 3]), 1);
    assert_eq!(call(&p, "plain_mod", &[(-7i32) as u32, 3]), 2);
    assert_eq!(call(&p, "clamp_div", &[7, 5]), 2);
    assert_eq!(call(&p, "clamp_index", &[7, 1]), 20);
}

// Found by the random_programs work (a hand-written spot check); fixed.
// `blend` rejects an array of ints ("`blend` cannot interpolate `int`"),
// although `int` is accepted wherever `float` is expected, `mix(t, 2, 4)`
// is accepted, and the typing rule in src/check/builtins.rs already maps an
// `int` element type to `float` after the (too strict) check.
#[test]
fn blend_of_ints_is_a_float_blend() {
    let checked =
        tsl::check_source("blend.tsl", "float f() { return blend(0.25, [0, 10, 20]); }", &tsl::LoadOptions::default());
    assert!(checked.is_ok(), "{}", checked.render_diagnostics());
    let p = compile("float f() { return blend(0.25, [0, 10, 20]); }");
    assert_eq!(f32::from_bits(call(&p, "f", &[])), 5.0);
}

// Found by the safety tests; fixed.
// Every `for` loop was capped at 1,000,000 iterations on its own, so nested
// loops multiply the caps: three nested `0..2000000000` loops run 10^18
// iterations (the JIT does about 10^9 a second here; the interpreter about
// 10^7), so a three-line shader hangs its host, against "a shader must not
// be able to hang its host". A budget per call (or per loop nest) would
// bound it.
#[test]
fn nested_loops_cannot_hang_the_host() {
    let p = compile(
        r#"
        int spin() {
            int n = 0;
            for i in 0..2000000000 { for j in 0..2000000000 { for k in 0..2000000000 { n += 1; } } }
            return n;
        }
        "#,
    );
    let f = p.function("spin").unwrap();
    let (done, finished) = mpsc::channel();
    // Detached on purpose: if the call never returns, the test still ends
    // (the thread dies with the process).
    std::thread::spawn(move || {
        let mut out = [0u32; 1];
        f.call_words(Backend::Jit, &ShadingGlobals::default(), &[], &mut out).unwrap();
        let _ = done.send(out[0]);
    });
    match finished.recv_timeout(Duration::from_secs(10)) {
        Ok(_) => {}
        Err(_) => panic!("a shader with three nested capped loops was still running after 10 s"),
    }
}

// Found by the safety tests; fixed.
// Looking up a name that is not an entry but starts with a prelude name
// (`lambert.no_such_method`, or a prelude constant such as `PI`) compiles
// that prelude item again on every call and keeps the new JIT part: here
// the entry list grows by 11 methods per lookup (1,156 entries after 100
// lookups of `cook_torrance.nope`, 22 ms each in a debug build), and the
// memory is only freed with the Program.
#[test]
fn failed_prelude_lookups_do_not_recompile() {
    let p = compile("float f() { return 1; }");
    let start = p.functions().len();
    for _ in 0..10 {
        assert!(p.function("lambert.no_such_method").is_none());
        assert!(p.function("PI").is_none());
    }
    let after = p.functions().len();
    let methods = tsl::check::INTERFACE.len();
    assert!(after <= start + methods, "{start} entries before 10 failed lookups, {after} after");
    // The real methods are still found.
    assert!(p.function("lambert.reflection").is_some());
}

// Found by the random-program work; fixed. A bool argument word other than
// 0 or 1 (say 2) was true for the JIT but compared unequal to `true` in the
// interpreter. Both now read any non-zero word as true.
#[test]
fn bool_argument_words_are_true_when_non_zero() {
    let p = compile("bool f(bool b) { return b == true; }");
    assert_eq!(call(&p, "f", &[2]), 1);
    assert_eq!(call(&p, "f", &[0]), 0);
}

// Found by random_programs while work before an early return was first
// shared past its block (this session, before it was committed in this
// form): a block whose result nobody used was removed as dead code, taking
// with it the definition of a value a later copy reused ("IR value used
// before its definition" in the JIT). Work before a block's first exit now
// goes before the block. The program is proptest's shrunk input.
#[test]
fn work_shared_out_of_a_dead_block_keeps_its_definition() {
    let src = std::fs::read_to_string("tests/data/regressions/shared_block_work.tsl").unwrap();
    let p = compile(&src);
    let g = ShadingGlobals::default();
    for entry in p.functions() {
        let f = p.function(entry.name()).unwrap();
        let args = vec![0u32; f.arg_words()];
        let (mut jit, mut int) = (vec![0u32; f.result_types().len()], vec![0u32; f.result_types().len()]);
        f.call_words(Backend::Jit, &g, &args, &mut jit).unwrap();
        f.call_words(Backend::Interpreter, &g, &args, &mut int).unwrap();
        let same =
            jit.iter().zip(&int).all(|(a, b)| a == b || (f32::from_bits(*a).is_nan() && f32::from_bits(*b).is_nan()));
        assert!(same, "{}: {jit:?} vs {int:?}", entry.name());
    }
}

// Found while marking the states lowering assumes the checker rules out
// (`ruled_out!` in src/ir/lower); fixed. A `?:` between two arrays always
// gave the first (the choice selected lanes, and kept its `then` side for
// anything else), and a method that assigned one of its material's
// parameters (`kd = kd * 2`) lost the assignment (parameters were bound as
// values, so the store found no variable and did nothing). Each method
// assigns its own copy: the other methods still see the parameter's value.
#[test]
fn array_choices_and_assigned_material_parameters() {
    let p = compile(
        r#"
        float pick() { float[2] a = u > 0.5 ? [1.0, 2.0] : [3.0, 4.0]; return a[0] + a[1]; }
        int ipick(int k) { int[2] a = k > 0 ? [1, 2] : [3, 4]; return a[k]; }
        material q(color kd = gray(0.5), float[2] w = [1.0, 2.0]) {
            color diffuse() { kd = kd * 2; w[0] = 3; return kd * w[0]; }
            color emission(vector wo) { return kd * w[0]; }
        }
        "#,
    );
    assert_eq!(f32::from_bits(call(&p, "pick", &[])), 7.0);
    assert_eq!(call(&p, "ipick", &[1]), 2);
    assert_eq!(call(&p, "ipick", &[0]), 3);
    let q = p.material("q").unwrap();
    let g = ShadingGlobals::default();
    assert_eq!(q.diffuse(&g).lanes(), [3.0; 3]);
    assert_eq!(q.emission(&g, [0.0, 0.0, 1.0]).lanes(), [0.5; 3]);
}

/// `material[N]` template parameters: an element (`ms[i]`, clamped like
/// `select`), the whole array given to `blend` or `select`, an array passed
/// on to another template, and a default array. They were once accepted by
/// the checker and lowered as the zero material (black, not opaque).
#[test]
fn material_array_parameters() {
    let p = compile(
        r#"
        material pair(material[2] ms) = mix(0.25, ms[0], ms[1]);
        material picked(material[2] ms, int i) = select(i, ms);
        material element(material[3] ms, int i) = ms[i];
        material blended(material[2] ms) = blend(0.5, ms);
        material passed(material[2] ms) = pair(ms);
        material defaulted(material[2] ms = [lambert(kd: gray(0.6)), lambert(kd: gray(0.8))]) = ms[1];
        material a = pair([lambert(kd: gray(0.2)), lambert(kd: gray(0.4))]);
        material b0 = picked([lambert(kd: gray(0.2)), lambert(kd: gray(0.4))], 0);
        material b1 = picked([lambert(kd: gray(0.2)), lambert(kd: gray(0.4))], 7);
        material c = element([lambert(kd: gray(0.1)), lambert(kd: gray(0.3)), lambert(kd: gray(0.5))], 1);
        material c_low = element([lambert(kd: gray(0.1)), lambert(kd: gray(0.3)), lambert(kd: gray(0.5))], -4);
        material d = blended([lambert(kd: gray(0.2)), lambert(kd: gray(0.4))]);
        material e = passed([lambert(kd: gray(0.2)), lambert(kd: gray(0.4))]);
        material f = defaulted();
        material varying = element([lambert(kd: gray(0.1)), lambert(kd: gray(0.3)), lambert(kd: gray(0.5))], face);
        "#,
    );
    let expected =
        [("a", 0.25), ("b0", 0.2), ("b1", 0.4), ("c", 0.3), ("c_low", 0.1), ("d", 0.3), ("e", 0.25), ("f", 0.8)];
    // The method's result words through either back end.
    let call = |name: &str, method: &str, backend: Backend, g: &ShadingGlobals| {
        let m = p.material(name).unwrap();
        let mut out = [0u32; 3];
        m.method(tsl::check::Method::from_name(method).unwrap())
            .unwrap()
            .call_words(backend, g, &[], &mut out)
            .unwrap();
        out
    };
    for backend in [Backend::Jit, Backend::Interpreter] {
        let g = ShadingGlobals::default();
        for (name, kd) in expected {
            let diffuse = call(name, "diffuse", backend, &g).map(f32::from_bits);
            assert!(diffuse.iter().all(|x| (x - kd).abs() < 1e-6), "{name} ({backend:?}): {diffuse:?}, not {kd}");
            assert_ne!(call(name, "opaque", backend, &g)[0], 0, "{name} ({backend:?}): lambert is opaque");
        }
        // The index may vary over the surface (here the face).
        for (face, kd) in [(0, 0.1), (1, 0.3), (2, 0.5), (9, 0.5)] {
            let g = ShadingGlobals { face, ..Default::default() };
            assert_eq!(call("varying", "diffuse", backend, &g).map(f32::from_bits), [kd; 3], "face {face}");
        }
    }
}

/// A mix whose weight is read at run time (a bound instance's parameter)
/// left out its first child's `opaque` only when that child needed code:
/// `mix(w, hole, lambert)` at w = 1 said "not opaque", because `hole`'s
/// constant false was taken for the child left out. Bound and specialised
/// instances must agree at every weight.
#[test]
fn a_mix_at_a_run_time_weight_of_one_is_as_opaque_as_its_second_child() {
    let p = compile(
        "material cut(float w = 1) = mix(w, hole, lambert);\n\
         material picked(float w = 0) = blend(w, [hole, lambert]);\n",
    );
    for (name, weights) in [("cut", [0.0, 0.5, 1.0]), ("picked", [0.0, 0.5, 1.0])] {
        for w in weights {
            let mut instance = p.shader(name).unwrap().instance();
            instance.set("w", w).unwrap();
            let (bound, specialised) = (instance.bind().unwrap(), instance.specialise().unwrap());
            let method = tsl::check::Method::from_name("opaque").unwrap();
            for backend in [Backend::Jit, Backend::Interpreter] {
                let opaque = |m: &tsl::Material| {
                    let mut out = [0u32; 1];
                    m.method(method).unwrap().call_words(backend, &ShadingGlobals::default(), &[], &mut out).unwrap();
                    out[0] != 0
                };
                let want = w == 1.0;
                assert_eq!(opaque(&bound), want, "{name} bound at w = {w} ({backend:?})");
                assert_eq!(opaque(&specialised), want, "{name} specialised at w = {w} ({backend:?})");
            }
        }
    }
}
