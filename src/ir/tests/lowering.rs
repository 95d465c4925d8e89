//! What lowering promises, checked by running the code or by counting
//! operations across contexts: generators shared by several children of a
//! texture tree run once, `mix` at exactly 0 or 1 runs only one child,
//! reflection sums and delta lobes share one texture and agree with the
//! methods they combine, inlined noise is the native noise, and powers
//! computed by multiplication are exact to a few ulps.
//!
//! What a small program lowers to (folding, specialisation, defaults
//! without weights, string options, each tree node) is in the golden IR
//! of `tests/lower/` (`tests/lower_golden.rs`).

use crate::ir::{Function, Inst, Op};
use crate::{Compiler, Program, ShadingGlobals};

fn compile(src: &str) -> Program {
    Compiler::new().source("t.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"))
}

fn ir(p: &Program, name: &str) -> Function {
    p.function(name).unwrap_or_else(|| panic!("no entry {name}")).ir().clone()
}

/// Every operation in a body, depth first.
fn ops(body: &[Inst], out: &mut Vec<Op>) {
    for inst in body {
        match inst {
            Inst::Def(_, op) => out.push(op.clone()),
            Inst::If { then_body, else_body, .. } => {
                ops(then_body, out);
                ops(else_body, out);
            }
            Inst::Block { body, .. } | Inst::Loop { body, .. } => ops(body, out),
            _ => {}
        }
    }
}

fn all_ops(f: &Function) -> Vec<Op> {
    let mut out = Vec::new();
    ops(&f.body, &mut out);
    out
}

fn calls(f: &Function, native: &str) -> usize {
    all_ops(f).iter().filter(|op| matches!(op, Op::Call { native: n, .. } if *n == native)).count()
}

/// How many times `f` evaluates 3D noise: native calls, plus inlined
/// expansions, each of which reads the permutation table 14 times (2 + 4 + 8).
fn noise3_evaluations(f: &Function) -> usize {
    let perm = crate::runtime::PERM_WORDS.as_ptr();
    let lookups =
        all_ops(f).iter().filter(|op| matches!(op, Op::Table { table, .. } if table.as_ptr() == perm)).count();
    assert_eq!(lookups % 14, 0, "a partial noise expansion:\n{f}");
    calls(f, "tsl_noise3") + lookups / 14
}

#[test]
fn a_generator_shared_by_children_runs_once() {
    let p = compile(
        r#"
        float grain() { return noise(Pl * 7); }
        material m = mix(grain(), scale(gray(grain()), lambert), bump(grain(), 0.1, lambert));
        "#,
    );
    let f = ir(&p, "m.diffuse");
    // grain() at the shading point is shared by the mix and the scale node;
    // bump also evaluates it at two offset points (other contexts).
    assert_eq!(noise3_evaluations(&f), 1, "{f}");
    let refl = ir(&p, "m.reflection");
    assert_eq!(noise3_evaluations(&refl), 3, "the point plus bump's two offsets:\n{refl}");
}

#[test]
fn mix_runs_one_child_at_zero_and_one() {
    // `bad` reflects NaN; blending it with weight 0 would poison the result.
    let p = compile(
        r#"
        material bad() { color reflection(vector wi, color light, vector wo) { return light * (0.0 / 0.0); } }
        material at_zero = mix(u, lambert, bad);
        material at_one = mix(u, bad, lambert);
        "#,
    );
    let light = p.rgb(1.0, 1.0, 1.0);
    let n = [0.0, 0.0, 1.0];
    for (name, u) in [("at_zero", 0.0), ("at_one", 1.0)] {
        let g = ShadingGlobals { n, ng: n, u, ..Default::default() };
        let c = p.material(name).unwrap().reflection(&g, n, &light, n);
        assert!(c.lanes().iter().all(|x| x.is_finite() && *x > 0.0), "{name}: {c:?}");
        // Strictly between, both run (and the NaN shows).
        let g = ShadingGlobals { u: 0.5, ..g };
        let c = p.material(name).unwrap().reflection(&g, n, &light, n);
        assert!(c.lanes().iter().all(|x| x.is_nan()), "{name} at 0.5: {c:?}");
    }
}

#[test]
fn materials_compile_on_first_use() {
    let p = compile("material mine = lambert; material unused = mirror;");
    assert!(p.entries().is_empty(), "nothing is compiled before it is used");
    p.material("mine").unwrap();
    let before = p.entries().len();
    let methods = crate::check::INTERFACE.len();
    assert_eq!(before, methods, "only the material asked for");
    let glass = p.material("glass").expect("prelude materials are available by name");
    assert!(!glass.opaque(&ShadingGlobals::default()));
    assert_eq!(p.entries().len(), before + methods);
    assert!(p.material("glas").unwrap_err().to_string().contains("did you mean `glass`"));
}

#[test]
fn a_reflection_sum_evaluates_the_texture_once_for_all_lights() {
    let p = compile(
        r#"
        float veins() { return fract(noise(Pl * 3) * 4); }
        material marble = mix(veins(), lambert(kd: gray(0.9)), phong(kd: gray(0.2)));
        "#,
    );
    let one = ir(&p, "marble.reflection");
    let sums = p.reflection_sums(&["marble"], 3).unwrap();
    let three = sums[0].ir();
    assert_eq!(noise3_evaluations(&one), 1, "{one}");
    assert_eq!(noise3_evaluations(three), 1, "three lights, one texture:\n{three}");
    assert_eq!(three.params.len(), 3 * (3 + 3) + 3);
    // The sum equals three separate calls.
    let g = ShadingGlobals { n: [0.0, 0.0, 1.0], pl: [0.3, 0.1, 0.7], ..Default::default() };
    let wis = [[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, -0.6, 0.8]];
    let lights = [[1.0, 2.0, 3.0], [0.5, 0.5, 0.5], [2.0, 0.0, 1.0]];
    let wo = [0.0, 0.6, 0.8];
    let m = p.material("marble").unwrap();
    let mut expected = [0.0f32; 3];
    for k in 0..3 {
        let mut out = [0.0f32; 3];
        m.reflection_into(&g, wis[k], &lights[k], wo, &mut out);
        for c in 0..3 {
            expected[c] += out[c];
        }
    }
    let mut args = Vec::new();
    for k in 0..3 {
        args.extend(wis[k].map(f32::to_bits));
        args.extend(lights[k].map(f32::to_bits));
    }
    args.extend(wo.map(f32::to_bits));
    let mut out = [0u32; 3];
    sums[0].call_words(crate::Backend::Jit, &g, &args, &mut out).unwrap();
    for c in 0..3 {
        assert!((f32::from_bits(out[c]) - expected[c]).abs() <= 1e-5 * expected[c].abs().max(1.0));
    }
}

#[test]
fn methods_no_child_defines_skip_the_weights() {
    // Neither lambert nor phong refracts: the default, with no noise
    // (tests/lower/defaults.ir); glass does: the weights stay.
    let p = compile(
        r#"
        float veins() { return fract(noise(Pl * 3) * 4); }
        material marble = mix(veins(), lambert(kd: gray(0.9)), phong(kd: gray(0.2)));
        material half_glass = mix(veins(), lambert, glass);
        "#,
    );
    let f = ir(&p, "half_glass.refraction_dir");
    assert_eq!(noise3_evaluations(&f), 1, "{f}");
    let m = p.material("marble").unwrap();
    assert!(!m.facts().refracts && m.facts().always_opaque && !m.facts().may_emit);
}

#[test]
fn clear_glass_absorbs_nothing_and_its_index_is_a_constant() {
    let p = compile("material clear = glass(ior: gray(1.5)); material smoky = glass(transmittance: gray(0.5));");
    let clear = p.material("clear").unwrap();
    assert!(clear.facts().clear, "{}", ir(&p, "clear.absorption"));
    assert_eq!(clear.facts().constant_ior.clone(), Some(vec![1.5; 3]));
    let smoky = p.material("smoky").unwrap();
    assert!(!smoky.facts().clear);
}

#[test]
fn work_before_an_early_return_is_shared_after_it() {
    // The body has an early return, so it is lowered inside a block; the
    // normal computed before the return is shared by the second copy.
    let p = compile(
        r#"
        material bumpy(color kd = gray(0.5)) {
            normal normal() { return normalize(N + 0.5 * vector(noise(Pl * 4))); }
            color reflection(vector wi, color light, vector wo) {
                normal n = faceforward(normal(), -wo);
                float c = dot(n, wi);
                if c <= 0 { return black(); }
                return light * kd * c;
            }
        }
        material b = bumpy;
        "#,
    );
    let one = ir(&p, "b.reflection");
    let sums = p.reflection_sums(&["b"], 2).unwrap();
    assert_eq!(noise3_evaluations(&one), 1, "{one}");
    assert_eq!(noise3_evaluations(sums[0].ir()), 1, "{}", sums[0].ir());
}

#[test]
fn templates_and_spline_blends_are_seen_through() {
    // Without an emitter, emission is the constant black
    // (tests/lower/defaults.ir); with one inside the template, the weights
    // stay.
    let p = compile(
        r#"
        float veins() { return fract(noise(Pl * 3) * 4); }
        material framed(material inside, material frame) = mix(veins(), frame, inside);
        material smooth = blend(veins(), [lambert, phong, lambert], spline: true);
        material lit = select(face, [framed(lambert, emitter), smooth]);
        "#,
    );
    let f = ir(&p, "lit.emission");
    assert_eq!(noise3_evaluations(&f), 1, "{f}");
}

/// Runs a float entry with no arguments on both back ends; they agree.
fn float_at(p: &Program, name: &str, g: &ShadingGlobals) -> f32 {
    let f = p.function(name).unwrap();
    let (mut a, mut b) = ([0u32], [0u32]);
    f.call_words(crate::Backend::Jit, g, &[], &mut a).unwrap();
    f.call_words(crate::Backend::Interpreter, g, &[], &mut b).unwrap();
    assert_eq!(a, b, "{name}");
    f32::from_bits(a[0])
}

#[test]
fn inlined_noise_is_the_native_noise() {
    // Six sites: the first are expanded inline, the rest call the native.
    let p = compile(
        r#"
        float n1() { return noise(P.x); }
        float n2() { return noise(vec2(P.x, P.y)); }
        float n3() { return noise(P); }
        float many() {
            return noise(P) + noise(P + 1) + noise(P + 2) + noise(P + 3) + noise(P + 4) + noise(P + 5);
        }
        "#,
    );
    let f = ir(&p, "many");
    assert!(noise3_evaluations(&f) == 6 && calls(&f, "tsl_noise3") > 0 && calls(&f, "tsl_noise3") < 6, "{f}");
    assert_eq!(calls(&ir(&p, "n3"), "tsl_noise3"), 0, "a lone site is inlined");
    let mut state = 0x1234_5678_9abc_def1u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    // Up to 2^63, where the native's integer cell saturates.
    let special = [0.0, -0.0, 1e-30, 255.5, 256.0, -256.25, 16777215.5, 3e9, -7e12, 1e18];
    for k in 0..20_000 {
        let coord = |r: u64| -> f32 {
            if r.is_multiple_of(13) {
                special[(r / 13 % special.len() as u64) as usize]
            } else {
                (r >> 40) as f32 / 2e5 - 40.0
            }
        };
        let p3 = [coord(next()), coord(next()), coord(next())];
        let g = ShadingGlobals { p: p3, ..Default::default() };
        let native = [
            crate::runtime::tsl_noise1(p3[0]),
            crate::runtime::tsl_noise2(p3[0], p3[1]),
            crate::runtime::tsl_noise3(p3[0], p3[1], p3[2]),
        ];
        for (name, want) in ["n1", "n2", "n3"].iter().zip(native) {
            let got = float_at(&p, name, &g);
            assert!((got - want).abs() <= 2e-6, "{name}({p3:?}) at {k}: inline {got} vs native {want}");
        }
    }
    for bad in [f32::NAN, f32::INFINITY, -f32::INFINITY] {
        let g = ShadingGlobals { p: [0.5, bad, 0.25], ..Default::default() };
        assert_eq!(float_at(&p, "n3", &g), 0.0);
        assert_eq!(float_at(&p, "n2", &g), 0.0);
        let g = ShadingGlobals { p: [bad, 0.5, 0.25], ..Default::default() };
        assert_eq!(float_at(&p, "n1", &g), 0.0);
        assert_eq!(float_at(&p, "n3", &g), 0.0);
    }
}

#[test]
fn natives_of_constants_fold_to_their_own_value() {
    let p = compile(
        r#"
        float k() { return sin(0.349) + cos(0.349); }
        float w() { return sin(P.x); }
        "#,
    );
    let k = ir(&p, "k");
    assert!(!all_ops(&k).iter().any(|op| matches!(op, Op::Call { .. })), "{k}");
    let want = crate::runtime::tsl_sin(0.349) + crate::runtime::tsl_cos(0.349);
    assert_eq!(float_at(&p, "k", &ShadingGlobals::default()).to_bits(), want.to_bits());
    assert_eq!(calls(&ir(&p, "w"), "tsl_sin"), 1);
}

#[test]
fn powers_by_multiplication_are_pow() {
    let p = compile(
        r#"
        float p2() { return pow(P.x, 2); }
        float p5() { return pow(P.x, 5); }
        float p32() { return pow(P.x, 32); }
        float p64() { return pow(P.x, 64); }
        "#,
    );
    // Which powers are multiplications: tests/lower/folding.ir.
    for x in [0.0f32, -0.0, 0.3, -0.7, 0.999, 1.0, 1.5, -2.0, 10.0, f32::INFINITY, -f32::INFINITY, f32::NAN] {
        let g = ShadingGlobals { p: [x, 0.0, 0.0], ..Default::default() };
        for (name, e) in [("p2", 2), ("p5", 5), ("p32", 32), ("p64", 64)] {
            let (got, want) = (float_at(&p, name, &g), x.powi(e));
            let ok = if want.is_nan() {
                got.is_nan()
            } else {
                (got == want || (got - want).abs() <= 4.0 * f32::EPSILON * want.abs())
                    && got.is_sign_negative() == want.is_sign_negative()
            };
            assert!(ok, "pow({x}, {e}) = {got}, expected {want}");
        }
    }
}

#[test]
fn delta_lobes_agree_with_the_four_methods() {
    let p = compile(
        r#"
        float veins() { return fract(noise(Pl * 3) * 4); }
        material clear = glass(ior: gray(1.5));
        material tinted = glass(ior: rgb(1.4, 1.5, 1.6), kr: rgb(0.9, 0.8, 0.7), kt: gray(0.8));
        material chrome = mirror(kr: gray(0.9));
        material matte = lambert;
        material veined = mix(veins(), glass(ior: gray(1.33)), mirror);
        "#,
    );
    let names = ["clear", "tinted", "chrome", "matte", "veined"];
    let lobes = p.delta_lobes(&names).unwrap();
    // Outside, inside (wo against N) and grazing from inside (total
    // internal reflection: no refraction direction).
    let wos = [[0.0, 0.6, 0.8], [0.3, -0.2, -0.932_737_9], [0.0, 0.999, -0.044_710_2], [0.0, 0.0, 1.0]];
    let etas = [[1.5, 1.5, 1.5], [0.7, 0.65, 0.6]];
    let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], pl: [0.3, 0.1, 0.7], ..Default::default() };
    let one = p.rgb(1.0, 1.0, 1.0);
    let mut refracted = 0;
    for (name, f) in names.iter().zip(&lobes) {
        assert_eq!((f.ir().params.len(), f.ir().results.len()), (6, 12), "{name}");
        let m = p.material(name).unwrap();
        for wo in wos {
            for eta in etas {
                let mut args: Vec<u32> = wo.map(f32::to_bits).to_vec();
                args.extend(eta.map(f32::to_bits));
                let mut out = [0u32; 12];
                f.call_words(crate::Backend::Jit, &g, &args, &mut out).unwrap();
                let got: Vec<f32> = out.iter().map(|w| f32::from_bits(*w)).collect();
                let eta_c = crate::Color::from_lanes(p.color_model(), &eta);
                let dr = m.reflection_dir(&g, wo);
                let wr = m.reflection(&g, dr, &one, wo);
                let dt = m.refraction_dir(&g, wo, &eta_c);
                let wt = m.refraction(&g, dt, &one, &eta_c, wo);
                let want: Vec<f32> = [&dr[..], wr.lanes(), &dt[..], wt.lanes()].concat();
                assert_eq!(got, want, "{name}, wo {wo:?}, eta {eta:?}");
                refracted += usize::from(dt != [0.0; 3]);
            }
        }
    }
    assert!(refracted >= 8, "some glass refracts: {refracted}");
    // The four methods share the tree's texture.
    assert_eq!(noise3_evaluations(lobes[4].ir()), 1, "{}", lobes[4].ir());
}

#[test]
fn string_options_choose_their_branch() {
    let p = compile(
        "float pick(string axis = \"u\") { if axis == \"v\" { return v; } return u; }
        float picked_v() { return pick(\"v\"); }
        float picked_u() { return pick(); }",
    );
    // Each reads one global: tests/lower/folding.ir.
    let g = ShadingGlobals { u: 0.25, v: 0.75, ..Default::default() };
    assert_eq!(float_at(&p, "picked_v", &g), 0.75);
    assert_eq!(float_at(&p, "picked_u", &g), 0.25);
}

/// A bump runs its height at three points (the point and one step along
/// each tangent) however many methods of a hit group read the tilted
/// normal: the coordinate contexts of one bump lowered for `sample`,
/// `eval_pdf` and the delta lobes are one context, so the generator calls
/// under them share the memo.
#[test]
fn a_bump_evaluates_its_height_three_times_per_hit() {
    let p = compile(
        r#"
        material bumped = bump(cellnoise(Pl * 5), 0.1, phong(kd: gray(0.5), ks: gray(0.3)));
        "#,
    );
    let m = &p.hit_materials(&["bumped"], crate::PATH_METHODS).unwrap()[0];
    let prepare = m.prepare_function().ir();
    assert_eq!(calls(prepare, "tsl_cellnoise3"), 3, "{prepare}");
    // On its own, `sample` needs the tilted normal for its direction, its
    // weight and its pdf: still three heights.
    let sample = ir(&p, "bumped.sample");
    assert_eq!(calls(&sample, "tsl_cellnoise3"), 3, "{sample}");
}

/// Methods that do not read the normal compute no height: a bump's
/// finite differences are dead code there, loops included.
#[test]
fn methods_that_ignore_the_normal_run_no_generator() {
    let p = compile(
        r#"
        float dents() { return 1 - worley(Pl * 6); }
        material hammered = bump(dents(), 0.15, phong(kd: gray(0.5), ks: gray(0.3)));
        "#,
    );
    for method in ["refraction_index", "opaque", "emission", "absorption"] {
        let f = ir(&p, &format!("hammered.{method}"));
        assert_eq!(calls(&f, "tsl_cellnoise3"), 0, "{f}");
        assert!(!f.body.iter().any(|i| matches!(i, Inst::Loop { .. })), "a dead loop is left:\n{f}");
    }
    assert!(calls(&ir(&p, "hammered.normal"), "tsl_cellnoise3") > 0);
    // So the renderer sees what they are: opaque, and not refracting.
    let m = p.material("hammered").unwrap();
    assert!(m.facts().always_opaque && !m.facts().refracts);
}

/// The interpreter's counts (for `cargo bench --bench render -- split`):
/// native noise calls and inline expansions alike, each loop trip again.
#[test]
fn the_interpreter_counts_noise_evaluations() {
    let p = compile(
        r#"
        float three() { return noise(P) + cellnoise(P * 2) + noise(vec2(u, v)); }
        float octaves() { return fbm(P, octaves: 5); }
        "#,
    );
    let globals = ShadingGlobals { p: [0.3, 0.2, 0.1], u: 0.4, v: 0.7, ..Default::default() };
    let g = globals.words();
    for (name, expected) in [("three", 3.0), ("octaves", 5.0)] {
        let f = ir(&p, name);
        let mut out = [0u32; 1];
        let counts = crate::interp::run_counting(&f, &g, &[], &[], &mut out);
        assert_eq!(counts.noise, expected, "{f}");
        // What hosts call (`benches/render.rs` does) counts the same.
        let public = p.function(name).unwrap().count_ops(&globals, &[], &mut out).unwrap();
        assert_eq!(public, counts);
    }
}

#[test]
fn a_constant_rough_interface_is_a_table_and_a_variable_one_a_call() {
    let p = compile(
        "float constant(float c) { return rough_transmittance(c, 0.3, 1.5, true); }
         float variable(float c, float a) { return rough_transmittance(c, a, 1.5, true); }
         float reflectance() { return rough_internal_reflectance(0.3, 1.5, true); }",
    );
    let table = crate::runtime::rough_interface::constant_table(0.3, 1.5, true).unwrap();
    let reads = |f: &Function| {
        all_ops(f).iter().filter(|op| matches!(op, Op::Table { table: t, .. } if t.as_ptr() == table.as_ptr())).count()
    };
    let constant = ir(&p, "constant");
    assert_eq!((reads(&constant), calls(&constant, "tsl_rough_transmittance")), (2, 0), "{constant}");
    let variable = ir(&p, "variable");
    assert_eq!((reads(&variable), calls(&variable, "tsl_rough_transmittance")), (0, 1), "{variable}");
    // Constant arguments fold the internal reflectance into a literal.
    let reflectance = ir(&p, "reflectance");
    assert_eq!(calls(&reflectance, "tsl_rough_internal_reflectance"), 0, "{reflectance}");
    // Both paths and both back ends give the same bits.
    let g = ShadingGlobals::default();
    for c in [0.0f32, 0.11, 0.5, 0.93, 1.0] {
        let mut words = Vec::new();
        for backend in [crate::Backend::Jit, crate::Backend::Interpreter] {
            for (name, args) in [("constant", vec![c.to_bits()]), ("variable", vec![c.to_bits(), 0.3f32.to_bits()])] {
                let mut out = [0u32];
                p.function(name).unwrap().call_words(backend, &g, &args, &mut out).unwrap();
                words.push(out[0]);
            }
        }
        let want = crate::runtime::rough_interface::lerp_transmittance(|k| f32::from_bits(table[k]), c).to_bits();
        assert!(words.iter().all(|w| *w == want), "cos {c}: {words:?} against {want}");
    }
}
