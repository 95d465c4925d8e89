//! The surface at a hit: the same typed answers whether the compiler split
//! the material into a per-hit stage, compiled combined entries, or left
//! the methods one by one; shared across threads.

use tsl::{Color, ColorModel, Compiler, HitCalls, MaterialSource, ShadingGlobals, SurfaceOptions, SurfaceRecord};

const SRC: &str = r#"
    material wood = mix(noise(P * 4) * 0.5 + 0.5, lambert(kd: rgb(0.6, 0.4, 0.2)), phong(kd: rgb(0.3, 0.2, 0.1)));
    material clear_glass = glass;
    material plain = phong(kd: rgb(0.5, 0.5, 0.2));
"#;

fn globals(k: usize) -> ShadingGlobals {
    let x = k as f32 * 0.137;
    ShadingGlobals {
        p: [x.sin(), 0.3 * x, x.cos()],
        pl: [x.sin(), 0.3 * x, x.cos()],
        n: [0.0, 0.0, 1.0],
        ng: [0.0, 0.0, 1.0],
        ..Default::default()
    }
}

fn close(a: &Color, b: &Color) -> bool {
    a.lanes().iter().zip(b.lanes()).all(|(x, y)| (x - y).abs() <= 1e-4 * (1.0 + y.abs()))
}

#[test]
fn prepared_combined_and_single_method_surfaces_agree() {
    for model in [ColorModel::Rgb, ColorModel::Spectral { samples: 8 }] {
        let program = Compiler::new().color_model(model).source("s.tsl", SRC).compile().unwrap();
        let names = ["wood", "clear_glass", "plain"];
        let sources: Vec<MaterialSource> = names.iter().map(|n| MaterialSource::Named(n.to_string())).collect();
        let options = SurfaceOptions { hit_calls: Some(HitCalls::Path), ..Default::default() };
        let compiled = program.compile_surfaces(&sources, &options).unwrap();
        assert!(compiled[0].is_prepared(), "a noise texture is worth a per-hit stage");
        assert!(!compiled[1].is_prepared() && !compiled[2].is_prepared(), "plain materials are not");
        let eta = program.rgb(1.0, 1.0, 1.0);
        let (mut a, mut b) = (SurfaceRecord::new(), SurfaceRecord::new());
        for (name, split) in names.iter().zip(&compiled) {
            let alone = program.material(name).unwrap();
            assert!(!alone.is_prepared());
            for k in 0..16 {
                let g = globals(k);
                let wo = [0.3, -0.2, 0.93];
                let mut s = split.at(&g, wo, &eta, &mut a);
                let mut t = alone.at(&g, wo, &eta, &mut b);
                let (x, y) = (s.sample(0.3, [0.6, 0.2]), t.sample(0.3, [0.6, 0.2]));
                assert!(close(&x.weight, &y.weight) && x.delta == y.delta, "{name}: {x:?} vs {y:?}");
                assert!((x.pdf - y.pdf).abs() <= 1e-4 * (1.0 + y.pdf), "{name}");
                if x.wi != [0.0; 3] {
                    let (e, f) = (s.eval_pdf(x.wi), t.eval_pdf(x.wi));
                    assert!(close(&e.value, &f.value) && (e.pdf - f.pdf).abs() <= 1e-4 * (1.0 + f.pdf), "{name}");
                }
                let (l, m) = (s.delta_lobes(), t.delta_lobes());
                assert_eq!(l.reflect.is_some(), m.reflect.is_some(), "{name}");
                assert_eq!(l.refract.is_some(), m.refract.is_some(), "{name}");
                if let (Some(l), Some(m)) = (l.refract, m.refract) {
                    assert!(close(&l.weight, &m.weight), "{name}");
                }
                assert_eq!(s.opaque(), t.opaque());
                assert!(close(&s.diffuse(), &t.diffuse()) && close(&s.emission(), &t.emission()));
            }
        }
        // glass has both perfect lobes; wood neither.
        let g = globals(0);
        let mut r = SurfaceRecord::new();
        let lobes = compiled[1].at(&g, [0.0, 0.6, 0.8], &eta, &mut r).delta_lobes();
        assert!(lobes.reflect.is_some() && lobes.refract.is_some());
        assert!(compiled[0].at(&g, [0.0, 0.6, 0.8], &eta, &mut r).delta_lobes().reflect.is_none());
    }
}

#[test]
fn one_material_serves_several_threads_at_once() {
    let program = Compiler::new().source("s.tsl", SRC).compile().unwrap();
    let options = SurfaceOptions { hit_calls: Some(HitCalls::Path), ..Default::default() };
    let wood = program.compile_surfaces(&[MaterialSource::Named("wood".into())], &options).unwrap().remove(0);
    assert!(wood.is_prepared());
    let eta = program.rgb(1.0, 1.0, 1.0);
    let run = || {
        let mut record = SurfaceRecord::new();
        (0..200)
            .map(|k| {
                let g = globals(k);
                let mut s = wood.at(&g, [0.1, 0.2, 0.97], &eta, &mut record);
                let x = s.sample(0.4, [0.3, 0.8]);
                (x.wi.map(f32::to_bits), x.pdf.to_bits(), s.eval_pdf([0.0, 0.6, 0.8]).pdf.to_bits())
            })
            .collect::<Vec<_>>()
    };
    let expected = run();
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..4).map(|_| scope.spawn(run)).collect();
        for h in handles {
            assert_eq!(h.join().unwrap(), expected);
        }
    });
}
