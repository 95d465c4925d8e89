//! The per-hit split (`ir::split`) changes no result: for every material of
//! `stdlib/`, the examples and `tests/check/ok/`, each method of a hit
//! group, run after its `prepare`, gives what the method lowered on its own
//! gives, at random shading points, in the RGB and a spectral model, on the
//! interpreter and the JIT. And the split does what it is for: the
//! per-direction methods of textured materials call no generator.

use std::path::Path;
use tsl::check::{SymbolKind, Ty};
use tsl::ir::lower::{
    HitEntry, HitGroup, HitMethod, lower_entries, lower_eval_pdf, lower_hit_groups, lower_hit_groups_with,
};
use tsl::syntax::ast::{Expr, Item};
use tsl::{ColorModel, Compiler, Program};

mod common;
use common::{Rng, close};

/// Shading points per material: many for the stdlib, fewer for the
/// examples, whose trees are large for the interpreter.
const POINTS: usize = 200;
const EXAMPLE_POINTS: usize = 40;

const METHODS: [HitMethod; 8] = [
    HitMethod::Interface(tsl::check::Method::Reflection),
    HitMethod::Interface(tsl::check::Method::Refraction),
    HitMethod::Interface(tsl::check::Method::Emission),
    HitMethod::Interface(tsl::check::Method::Sample),
    HitMethod::Interface(tsl::check::Method::Pdf),
    HitMethod::EvalPdf,
    HitMethod::DeltaLobes,
    HitMethod::ReflectionSum(2),
];

/// Every material without parameters the program names (named materials
/// and trees of the root module and the prelude), as trees of the root.
fn material_trees(source: &str, name: &str) -> (Program, Vec<String>) {
    let probe = Compiler::new().source(name, source).compile().unwrap();
    let mut names: Vec<String> = probe
        .checked()
        .symbols
        .iter()
        .filter(|(_, s)| matches!(s.kind, SymbolKind::Material | SymbolKind::MaterialTree))
        .filter(|(_, s)| match &probe.checked().loaded.modules[s.module].ast.items[s.item] {
            Item::Material(d) => d.params.iter().all(|p| p.default.is_some()),
            Item::MaterialTree(t) => t.params.is_none(),
            _ => false,
        })
        .map(|(n, _)| n.clone())
        .collect();
    names.sort();
    let mut text = source.to_string();
    for (k, n) in names.iter().enumerate() {
        text.push_str(&format!("\nmaterial hit_probe_{k} = {n};"));
    }
    let program = Compiler::new().source(name, &text).compile().unwrap();
    (program, (0..names.len()).map(|k| format!("hit_probe_{k}")).collect())
}

fn args(rng: &mut Rng, params: &[(String, Ty)], model: ColorModel) -> Vec<u32> {
    let mut words = Vec::new();
    for (name, ty) in params {
        match ty {
            Ty::Float => words.push(rng.range(0.0, 1.0).to_bits()),
            Ty::Vec2 => words.extend([rng.range(0.0, 1.0).to_bits(), rng.range(0.0, 1.0).to_bits()]),
            Ty::Vector => words.extend(rng.unit().map(f32::to_bits)),
            Ty::Color if name == "eta" => words.extend((0..model.lanes()).map(|_| rng.range(1.0, 2.0).to_bits())),
            Ty::Color => words.extend((0..model.lanes()).map(|_| rng.range(0.0, 1.0).to_bits())),
            other => panic!("no random {other:?}"),
        }
    }
    words
}

/// The argument list a method takes on its own, given the hit inputs and
/// its own arguments (the order of the interface, or of the fused entries).
fn alone_args(method: HitMethod, wo: &[u32], eta: &[u32], own: &[u32]) -> Vec<u32> {
    match method {
        HitMethod::Interface(tsl::check::Method::Reflection) => [own, wo].concat(),
        HitMethod::Interface(tsl::check::Method::Refraction) => [own, eta, wo].concat(),
        HitMethod::Interface(tsl::check::Method::Emission) => wo.to_vec(),
        HitMethod::Interface(tsl::check::Method::Sample) => [wo, eta, own].concat(),
        HitMethod::Interface(tsl::check::Method::Pdf) | HitMethod::EvalPdf => [own, wo, eta].concat(),
        HitMethod::DeltaLobes => [wo, eta].concat(),
        HitMethod::ReflectionSum(_) => [own, wo].concat(),
        other => panic!("{other:?}"),
    }
}

/// Agreement of a method in a group with the method lowered alone. Not
/// bit for bit: lowering expands `noise` inline at the first sites of each
/// function and calls the native after (they differ by about 1e-7), and
/// in one function for the whole group the sites fall elsewhere; `bump`'s
/// finite differences magnify that to about 1e-4 in a normal.
fn near(a: u32, b: u32, ty: tsl::ir::Scalar) -> bool {
    if close(a, b, ty.into()) {
        return true;
    }
    let (x, y) = (f32::from_bits(a), f32::from_bits(b));
    ty == tsl::ir::Scalar::F32 && (x - y).abs() <= 1e-3 * x.abs().max(y.abs()).max(1.0)
}

/// Where a method's results start among the combined function's.
fn result_offset(entries: &[HitEntry], method: &HitMethod, model: ColorModel) -> usize {
    let words = |t: &Ty| match t {
        Ty::Color => model.lanes(),
        Ty::Array(_, n) => *n as usize,
        Ty::BsdfSample => 5 + model.lanes(),
        Ty::Float => 1,
        other => panic!("{other:?}"),
    };
    entries.iter().take_while(|e| e.method != *method).map(|e| words(&e.ret)).sum()
}

/// A NaN with a payload: what a record slot holds before `prepare` writes it.
const UNWRITTEN: u32 = 0x7fc0_dead;

fn check_program(program: &Program, trees: &[String], model: ColorModel, seed: u64, points: usize) -> usize {
    let checked = program.checked();
    let bodies: Vec<(String, &tsl::syntax::ast::Expr)> = trees
        .iter()
        .map(|n| {
            let s = &checked.symbols[n];
            let Item::MaterialTree(t) = &checked.loaded.modules[s.module].ast.items[s.item] else { unreachable!() };
            (n.clone(), &t.body)
        })
        .collect();
    let (groups, diags) = lower_hit_groups(checked, model, &bodies, &METHODS);
    assert!(diags.is_empty(), "{diags:?}");
    // The methods lowered on their own.
    let (alone, _, _) = lower_entries(checked, model, |n, _| trees.iter().any(|t| t == n));
    let (eval_pdf, _, _) = lower_eval_pdf(checked, model, &bodies);
    let (delta, _, _) = tsl::ir::lower::lower_delta_lobes(checked, model, &bodies);
    let (sums, _, _) = tsl::ir::lower::lower_reflection_sums(checked, model, &bodies, 2);
    let lanes = model.lanes();
    let mut rng = Rng(seed);
    for ((name, _), group) in bodies.iter().zip(&groups) {
        let HitGroup { split, entries, combined } = group;
        for point in 0..points {
            let g = common::shading_point(&mut rng).words();
            let wo = args(&mut rng, &[("wo".into(), Ty::Vector)], model);
            let eta = args(&mut rng, &[("eta".into(), Ty::Color)], model);
            // Not zeroed: renderers reuse one buffer, so a method must read
            // only the slots `prepare` wrote at this hit.
            let mut record = vec![UNWRITTEN; split.record_words()];
            tsl::interp::run(&split.prepare, &g, &[wo.clone(), eta.clone()].concat(), &mut record);
            for (HitEntry { method, params, .. }, f) in entries.iter().zip(&split.methods) {
                let own = args(&mut rng, params, model);
                let reference = match method {
                    HitMethod::Interface(m) => alone.function(&format!("{name}.{}", m.name())),
                    HitMethod::EvalPdf => eval_pdf.function(&format!("{name}.eval_pdf")),
                    HitMethod::DeltaLobes => delta.function(&format!("{name}.delta_lobes")),
                    HitMethod::ReflectionSum(_) => sums.function(&format!("{name}.reflection_sum2")),
                }
                .unwrap_or_else(|| panic!("{name}: {method:?} lowered alone"));
                let mut want = vec![0u32; reference.results.len()];
                tsl::interp::run(reference, &g, &alone_args(*method, &wo, &eta, &own), &mut want);
                let mut got = vec![0u32; f.results.len()];
                tsl::interp::run(f, &g, &[record.clone(), own.clone()].concat(), &mut got);
                // The split changes nothing of the combined function.
                let mut all_args = [wo.clone(), eta.clone()].concat();
                let mut first_result = 0;
                for e in entries {
                    let words = if e.method == *method {
                        own.clone()
                    } else {
                        args(&mut Rng(point as u64 + 1), &e.params, model)
                    };
                    if e.method == *method {
                        first_result = result_offset(entries, method, model);
                    }
                    all_args.extend(words);
                }
                let mut whole = vec![0u32; combined.results.len()];
                tsl::interp::run(combined, &g, &all_args, &mut whole);
                for (k, ty) in f.results.iter().enumerate() {
                    assert!(
                        close(got[k], whole[first_result + k], (*ty).into()),
                        "{name} {method:?} word {k} at point {point}: prepared {:?}, combined {:?}",
                        f32::from_bits(got[k]),
                        f32::from_bits(whole[first_result + k]),
                    );
                }
                for (k, ty) in f.results.iter().enumerate() {
                    assert!(
                        near(got[k], want[k], *ty),
                        "{name} {method:?} ({} lanes) word {k} at point {point}: prepared {:?}, alone {:?}",
                        lanes,
                        f32::from_bits(got[k]),
                        f32::from_bits(want[k]),
                    );
                }
            }
        }
    }
    groups.len()
}

const MODELS: [ColorModel; 2] = [ColorModel::Rgb, ColorModel::Spectral { samples: 16 }];

#[test]
fn prepared_methods_agree_with_methods_alone_on_the_stdlib() {
    for model in MODELS {
        let (program, trees) = material_trees("const float UNUSED = 0;", "empty.tsl");
        assert!(trees.len() >= 12, "{} stdlib materials", trees.len());
        check_program(&program, &trees, model, 7, POINTS);
    }
}

#[test]
fn prepared_methods_agree_with_methods_alone_on_examples_and_fixtures() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for dir in ["examples", "examples/techniques", "tests/check/ok"] {
        for entry in std::fs::read_dir(root.join(dir)).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "tsl") {
                files.push(path);
            }
        }
    }
    files.sort();
    let mut groups = 0;
    for (k, path) in files.iter().enumerate() {
        // Its mesh is generated (`tslc make-mesh heavy`), not stored.
        if path.ends_with("examples/heavy.tsl") {
            continue;
        }
        let text = std::fs::read_to_string(path).unwrap();
        // Compiled from its own path, so imports and images resolve.
        let name = path.to_string_lossy().to_string();
        let (program, trees) = material_trees(&text, &name);
        println!("{name}");
        groups += check_program(&program, &trees, MODELS[k % 2], 1 + k as u64, EXAMPLE_POINTS);
    }
    assert!(groups > 50, "{groups} materials");
}

/// The probe tree [`material_trees`] made for the material `material`:
/// its name and body.
fn probe_of<'c>(checked: &'c tsl::check::Program, trees: &[String], material: &str) -> (String, &'c Expr) {
    let body = |t: &String| {
        let s = &checked.symbols[t];
        match &checked.loaded.modules[s.module].ast.items[s.item] {
            Item::MaterialTree(m) => Some(&m.body),
            _ => None,
        }
    };
    trees
        .iter()
        .find_map(|t| {
            let b = body(t)?;
            matches!(&b.kind, tsl::syntax::ast::ExprKind::Name(n) if n == material).then(|| (t.clone(), b))
        })
        .unwrap_or_else(|| panic!("the probe of `{material}`"))
}

/// A noise evaluation or a noise table lookup.
fn is_noise(op: &tsl::ir::Op) -> bool {
    matches!(op, tsl::ir::Op::Call { native, .. } if native.contains("noise"))
        || matches!(op, tsl::ir::Op::Table { .. })
}

/// What the split is for: in a bumped, noise-textured material, the
/// per-direction methods call no generator; `prepare` does, once.
#[test]
fn per_direction_methods_of_a_bumped_texture_call_no_noise() {
    let source = "
        float height() { return fbm(P * 4, 4); }
        material bumpy = bump(height(), 0.05, mix(noise(P * 3) * 0.5 + 0.5, lambert, phong));
    ";
    let (program, trees) = material_trees(source, "bumpy.tsl");
    let checked = program.checked();
    let (name, body) = probe_of(checked, &trees, "bumpy");
    let (groups, _) = lower_hit_groups(checked, ColorModel::Rgb, &[(name.clone(), body)], &METHODS);
    let noise_calls = |f: &tsl::ir::Function| {
        let mut n = 0;
        tsl::ir::for_each_op(&f.body, &mut |op| n += usize::from(is_noise(op)));
        n
    };
    let split = &groups[0].split;
    assert!(noise_calls(&split.prepare) > 0, "prepare evaluates the noise:\n{}", split.prepare);
    for f in &split.methods {
        assert_eq!(noise_calls(f), 0, "{} evaluates noise again:\n{f}", f.name);
    }
}

/// A checker of a plain and a textured material: `prepare` evaluates the
/// texture's noise only where the checker picks the textured one (every
/// method, `sample` included, lowered under the choice at t = 0 and 1),
/// never unconditionally.
#[test]
fn a_checker_of_two_materials_prepares_only_the_chosen_ones_noise() {
    let source = "
        color grain() { return gray(noise(P * 3) * 0.5 + 0.5); }
        material checks = mix(checker2(4), lambert, scale(grain(), phong));
    ";
    let (program, trees) = material_trees(source, "checks.tsl");
    let checked = program.checked();
    let (name, body) = probe_of(checked, &trees, "checks");
    let (groups, _) = lower_hit_groups(checked, ColorModel::Rgb, &[(name.clone(), body)], &METHODS);
    // Noise operations run whatever the branches decide (`If` bodies left out).
    fn unconditional(body: &[tsl::ir::Inst]) -> usize {
        use tsl::ir::Inst;
        body.iter()
            .map(|inst| match inst {
                Inst::Def(_, op) if is_noise(op) => 1,
                Inst::Block { body, .. } | Inst::Loop { body, .. } => unconditional(body),
                _ => 0,
            })
            .sum()
    }
    let prepare = &groups[0].split.prepare;
    let mut all = 0;
    tsl::ir::for_each_op(&prepare.body, &mut |op| all += usize::from(is_noise(op)));
    assert!(all > 0, "prepare evaluates the noise:\n{prepare}");
    assert_eq!(unconditional(&prepare.body), 0, "the noise runs at every hit:\n{prepare}");
    // Without the cases (a preview's scene build), the noise runs at every
    // hit, as before them: the choice is what keeps it conditional.
    let (plain, _) = lower_hit_groups_with(checked, ColorModel::Rgb, &[(name, body)], &METHODS, false);
    let plain = &plain[0].split.prepare;
    assert!(unconditional(&plain.body) > 0, "without the cases:\n{plain}");
}

/// The embedding API's prepared hits agree between the JIT and the
/// interpreter (both run the same split), and with the methods alone.
#[test]
fn prepared_hits_agree_on_both_back_ends() {
    for model in MODELS {
        let (program, trees) = material_trees("const float UNUSED = 0;", "empty.tsl");
        let names: Vec<&str> = trees.iter().map(String::as_str).collect();
        let hits = program.hit_materials(&names, tsl::PATH_METHODS).unwrap();
        let mut rng = Rng(11);
        for (name, hit) in names.iter().zip(&hits) {
            let material = program.material(name).unwrap();
            for _ in 0..100 {
                let g = common::shading_point(&mut rng);
                let wo = rng.unit();
                let eta = program.rgb(1.0, 1.0, 1.0);
                let eta = tsl::Color::from_lanes(model, &vec![eta.lanes()[0]; model.lanes()]);
                let (u1, u2) = (rng.range(0.0, 1.0), [rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
                let wi = rng.unit();
                let mut jit = hit.prepare(tsl::Backend::Jit, &g, wo, &eta);
                let mut int = hit.prepare(tsl::Backend::Interpreter, &g, wo, &eta);
                let (sj, si) = (jit.sample(u1, u2).unwrap(), int.sample(u1, u2).unwrap());
                let alone = material.sample(&g, wo, &eta, u1, u2);
                for (k, (a, b)) in sj.wi.iter().zip(&si.wi).enumerate() {
                    assert!((a - b).abs() <= 1e-5, "{name}: sample wi[{k}] jit {a} vs interpreter {b}");
                    assert!((a - alone.wi[k]).abs() <= 1e-3, "{name}: sample wi[{k}] {a} vs alone {}", alone.wi[k]);
                }
                let ((fj, pj), (fi, pi)) = (jit.eval_pdf(wi).unwrap(), int.eval_pdf(wi).unwrap());
                assert!((pj - pi).abs() <= 1e-5 * pj.abs().max(1.0), "{name}: pdf jit {pj} vs interpreter {pi}");
                let pdf_alone = material.pdf(&g, wi, wo, &eta);
                assert!((pj - pdf_alone).abs() <= 1e-3 * pj.abs().max(1.0), "{name}: pdf {pj} vs alone {pdf_alone}");
                for (a, b) in fj.lanes().iter().zip(fi.lanes()) {
                    assert!((a - b).abs() <= 1e-5 * a.abs().max(1.0), "{name}: f jit {a} vs interpreter {b}");
                }
            }
        }
    }
}

#[test]
fn a_method_looked_up_once_answers_as_by_name() {
    let program = Compiler::new()
        .source("m.tsl", "material m = mix(noise(P * 3) * 0.5 + 0.5, lambert, phong(ns: 20));")
        .compile()
        .unwrap();
    let hit = &program.hit_materials(&["m"], tsl::PATH_METHODS).unwrap()[0];
    assert_eq!(hit.method_index(HitMethod::Interface(tsl::check::Method::Reflection)), None, "not in the path group");
    let index = hit.method_index(HitMethod::EvalPdf).expect("eval_pdf is in the path group");
    let mut rng = Rng(5);
    for _ in 0..20 {
        let g = common::shading_point(&mut rng);
        // Both directions above the surface, where the pdf is positive.
        let above = |v: [f32; 3]| {
            let s = if v.iter().zip(&g.n).map(|(a, b)| a * b).sum::<f32>() < 0.0 { -1.0 } else { 1.0 };
            v.map(|x| x * s)
        };
        let inputs: Vec<u32> = above(rng.unit()).iter().chain(&[1.0; 3]).map(|x| x.to_bits()).collect();
        let wi = above(rng.unit()).map(f32::to_bits);
        let mut words = Vec::new();
        hit.prepare_words(tsl::Backend::Jit, &g, &inputs, &mut words);
        let (mut by_name, mut by_index) = ([0u32; 4], [0u32; 4]);
        hit.call_words(tsl::Backend::Jit, HitMethod::EvalPdf, &g, &mut words, &wi, &mut by_name).unwrap();
        // `call_words` left the record with `wi` after it: what `call_at` takes.
        hit.call_at(tsl::Backend::Jit, index, &g, &words, &mut by_index).unwrap();
        assert_eq!(by_name, by_index);
        assert!(by_name[3] != 0, "a pdf was computed");
    }
    let words = vec![0u32; hit.record_words() + 3];
    let err = hit.call_at(tsl::Backend::Jit, 99, &Default::default(), &words, &mut [0u32; 4]).unwrap_err();
    assert!(err.contains("no method 99"), "{err}");
}
