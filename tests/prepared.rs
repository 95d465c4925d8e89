//! The embedding API's prepared hits (`Program::hit_materials`): the JIT
//! and the interpreter agree, and agree with the materials' methods called
//! on their own; a method looked up once answers as by name. That the
//! split itself changes no result, and what it saves, is tested on the IR
//! in the crate (`src/ir/tests/prepared.rs`).

use tsl::check::SymbolKind;
use tsl::syntax::ast::Item;
use tsl::{ColorModel, Compiler, HitMethod};

mod common;
use common::Rng;

const MODELS: [ColorModel; 2] = [ColorModel::Rgb, ColorModel::Spectral { samples: 16 }];

/// Every material without parameters the program names (named materials
/// and trees of the root module and the prelude), as trees of the root.
fn material_trees(source: &str, name: &str) -> (tsl::Program, Vec<String>) {
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
