//! The per-hit split (`ir::split`) changes no result: for every material of
//! `stdlib/`, the examples and `tests/check/ok/`, each method of a hit
//! group, run after its `prepare`, gives what the method lowered on its own
//! gives, at random shading points, in the RGB and a spectral model, on the
//! interpreter. And the split does what it is for: the per-direction
//! methods of textured materials call no generator. Moved from
//! tests/prepared.rs (the IR is crate-private); the tests of the public
//! prepared hits (both back ends) stay there.

use super::{Rng, close, shading_point};
use crate::check::{SymbolKind, Ty};
use crate::ir::lower::{
    HitEntry, HitGroup, HitMethod, lower_entries, lower_eval_pdf, lower_hit_groups, lower_hit_groups_with,
};
use crate::ir::{Function, Inst, Op, Scalar};
use crate::syntax::ast::{Expr, Item};
use crate::{ColorModel, Compiler, Program};
use std::path::Path;

/// Shading points per material: many for the stdlib, fewer for the
/// examples, whose trees are large for the interpreter.
const POINTS: usize = 200;
const EXAMPLE_POINTS: usize = 40;

const METHODS: [HitMethod; 8] = [
    HitMethod::Interface(crate::check::Method::Reflection),
    HitMethod::Interface(crate::check::Method::Refraction),
    HitMethod::Interface(crate::check::Method::Emission),
    HitMethod::Interface(crate::check::Method::Sample),
    HitMethod::Interface(crate::check::Method::Pdf),
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
        HitMethod::Interface(crate::check::Method::Reflection) => [own, wo].concat(),
        HitMethod::Interface(crate::check::Method::Refraction) => [own, eta, wo].concat(),
        HitMethod::Interface(crate::check::Method::Emission) => wo.to_vec(),
        HitMethod::Interface(crate::check::Method::Sample) => [wo, eta, own].concat(),
        HitMethod::Interface(crate::check::Method::Pdf) | HitMethod::EvalPdf => [own, wo, eta].concat(),
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
fn near(a: u32, b: u32, ty: Scalar) -> bool {
    if close(a, b, ty) {
        return true;
    }
    let (x, y) = (f32::from_bits(a), f32::from_bits(b));
    ty == Scalar::F32 && (x - y).abs() <= 1e-3 * x.abs().max(y.abs()).max(1.0)
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
    let bodies: Vec<(String, &crate::syntax::ast::Expr)> = trees
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
    let (delta, _, _) = crate::ir::lower::lower_delta_lobes(checked, model, &bodies);
    let (sums, _, _) = crate::ir::lower::lower_reflection_sums(checked, model, &bodies, 2);
    let lanes = model.lanes();
    let mut rng = Rng(seed);
    for ((name, _), group) in bodies.iter().zip(&groups) {
        let HitGroup { split, entries, combined } = group;
        for point in 0..points {
            let g = shading_point(&mut rng).words();
            let wo = args(&mut rng, &[("wo".into(), Ty::Vector)], model);
            let eta = args(&mut rng, &[("eta".into(), Ty::Color)], model);
            // Not zeroed: renderers reuse one buffer, so a method must read
            // only the slots `prepare` wrote at this hit.
            let mut record = vec![UNWRITTEN; split.record_words()];
            crate::interp::run(&split.prepare, &g, &[wo.clone(), eta.clone()].concat(), &mut record);
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
                crate::interp::run(reference, &g, &alone_args(*method, &wo, &eta, &own), &mut want);
                let mut got = vec![0u32; f.results.len()];
                crate::interp::run(f, &g, &[record.clone(), own.clone()].concat(), &mut got);
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
                crate::interp::run(combined, &g, &all_args, &mut whole);
                for (k, ty) in f.results.iter().enumerate() {
                    assert!(
                        close(got[k], whole[first_result + k], *ty),
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
fn probe_of<'c>(checked: &'c crate::check::Program, trees: &[String], material: &str) -> (String, &'c Expr) {
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
            matches!(&b.kind, crate::syntax::ast::ExprKind::Name(n) if n == material).then(|| (t.clone(), b))
        })
        .unwrap_or_else(|| panic!("the probe of `{material}`"))
}

/// A noise evaluation or a noise table lookup.
fn is_noise(op: &Op) -> bool {
    matches!(op, Op::Call { native, .. } if native.contains("noise")) || matches!(op, Op::Table { .. })
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
    let noise_calls = |f: &Function| {
        let mut n = 0;
        crate::ir::for_each_op(&f.body, &mut |op| n += usize::from(is_noise(op)));
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
    fn unconditional(body: &[Inst]) -> usize {
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
    crate::ir::for_each_op(&prepare.body, &mut |op| all += usize::from(is_noise(op)));
    assert!(all > 0, "prepare evaluates the noise:\n{prepare}");
    assert_eq!(unconditional(&prepare.body), 0, "the noise runs at every hit:\n{prepare}");
    // Without the cases (a preview's scene build), the noise runs at every
    // hit, as before them: the choice is what keeps it conditional.
    let (plain, _) = lower_hit_groups_with(checked, ColorModel::Rgb, &[(name, body)], &METHODS, false);
    let plain = &plain[0].split.prepare;
    assert!(unconditional(&plain.body) > 0, "without the cases:\n{plain}");
}
