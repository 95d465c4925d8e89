//! Run-time-bound instances (`Instance::bind`): one compiled shader, its
//! numeric, vector, color and bool parameters read from each instance's
//! parameter block. They agree with specialised instances (values folded
//! in) within float rounding, on both back ends, in RGB and a spectral
//! model; binding again after a value changed compiles nothing.

mod common;

use common::{Rng, args, shading_point};
use tsl::{Backend, ColorModel, Compiler, Material, ParamType, ParamValue, Program, Shader, ShadingGlobals, WordType};

/// A program of no templates of its own (an empty file is an error).
const HOST: &str = "material host = lambert;";

fn program(src: &str, model: ColorModel) -> Program {
    Compiler::new().color_model(model).source("host.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"))
}

/// A value other than the default: a `phong` for a material, the last
/// option for a string.
fn non_default(p: &tsl::ParamInfo, k: usize, program: &Program) -> Option<ParamValue> {
    if p.array_len.is_some() {
        return None;
    }
    let x = 0.15 + 0.1 * k as f32;
    Some(match p.ty {
        ParamType::Float => ParamValue::Float(x),
        ParamType::Int => ParamValue::Int(k as i32 + 2),
        ParamType::Bool => ParamValue::Bool(p.default != Some(ParamValue::Bool(true))),
        ParamType::Color => ParamValue::Triple([x, 0.5, 1.0 - x / 2.0]),
        ParamType::Vector | ParamType::Point | ParamType::Normal => ParamValue::Triple([x, -0.5, 0.25]),
        ParamType::Vec2 => ParamValue::Vec2([x, 0.5]),
        ParamType::String => ParamValue::String(p.options.last()?.clone()),
        ParamType::Material => program.shader("phong").ok()?.instance().set("ns", 12.0).ok()?.clone().into(),
        ParamType::Matrix | ParamType::BsdfSample => return None,
    })
}

/// Whether two result words agree: equal, or floats within rounding.
fn close(a: u32, b: u32, ty: WordType) -> bool {
    if a == b || ty != WordType::F32 {
        return a == b;
    }
    let (x, y) = (f32::from_bits(a), f32::from_bits(b));
    (x.is_nan() && y.is_nan()) || (x - y).abs() <= 1e-4 * x.abs().max(y.abs()) + 1e-5
}

/// Every interface method of both materials, on the same arguments at the
/// same points, on `backend`: results within rounding. Returns how many
/// words were compared.
fn assert_agree(bound: &Material, specialised: &Material, backend: Backend, what: &str) -> usize {
    let mut rng = Rng(0x5eed);
    let mut compared = 0;
    for _ in 0..4 {
        let mut g = shading_point(&mut rng);
        if bound.color_model() == ColorModel::Hero {
            // Hero lanes are at the wavelengths of the camera sample.
            g.wavelengths = [0; 4].map(|_| rng.range(380.0, 780.0));
        }
        for method in tsl::check::Method::ALL {
            let (fa, fb) = (bound.method(method).unwrap(), specialised.method(method).unwrap());
            let words = args(&mut rng, fa.params(), bound.color_model());
            let results = fa.result_types();
            let (mut oa, mut ob) = (vec![0u32; results.len()], vec![0u32; results.len()]);
            fa.call_words(backend, &g, &words, &mut oa).unwrap();
            fb.call_words(backend, &g, &words, &mut ob).unwrap();
            for (k, ((a, b), ty)) in oa.iter().zip(&ob).zip(&results).enumerate() {
                assert!(
                    close(*a, *b, *ty),
                    "{what} {backend:?}: `{}` word {k}: bound {} vs specialised {}",
                    method.name(),
                    f32::from_bits(*a),
                    f32::from_bits(*b)
                );
            }
            compared += results.len();
        }
    }
    compared
}

#[test]
fn bound_and_specialised_instances_agree_for_every_stdlib_material() {
    for model in [ColorModel::Rgb, ColorModel::Spectral { samples: 8 }, ColorModel::Hero] {
        let program = program(HOST, model);
        let shaders: Vec<Shader> = program.shaders().into_iter().filter(Shader::in_prelude).collect();
        assert!(shaders.len() >= 19, "{} shaders", shaders.len());
        for shader in &shaders {
            // At the defaults (required parameters set), then with every
            // parameter changed.
            let mut instance = shader.instance();
            for changed in [false, true] {
                for (k, p) in shader.params().iter().enumerate().filter(|(_, p)| changed || p.required()) {
                    if let Some(v) = non_default(p, k, &program) {
                        instance.set(&p.name, v).unwrap_or_else(|e| panic!("{}.{}: {e}", shader.name(), p.name));
                    }
                }
                let what = format!("{model:?} {}", instance.source());
                let bound = instance.bind().unwrap_or_else(|e| panic!("{what}: {e}"));
                let specialised = instance.specialise().unwrap_or_else(|e| panic!("{what}: {e}"));
                for backend in [Backend::Jit, Backend::Interpreter] {
                    assert!(assert_agree(&bound, &specialised, backend, &what) > 0);
                }
            }
        }
    }
}

#[test]
fn the_block_is_read_at_run_time_so_changing_a_value_compiles_nothing() {
    let program = program(HOST, ColorModel::Rgb);
    let mut metal = program.shader("rough_conductor").unwrap().instance();
    let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ..Default::default() };
    let (wi, wo) = ([0.6, 0.0, 0.8], [-0.6, 0.0, 0.8]);
    let white = program.rgb(1.0, 1.0, 1.0);
    let first = metal.set("alpha", 0.05).unwrap().bind().unwrap();
    let compiled = program.compiled_functions();
    assert!(compiled > 0);
    let mut peaks = vec![first.reflection(&g, wi, &white, wo).to_rgb()[0]];
    for alpha in [0.2, 0.6] {
        let m = metal.set("alpha", alpha).unwrap().bind().unwrap();
        peaks.push(m.reflection(&g, wi, &white, wo).to_rgb()[0]);
        // The same code, another block.
        assert!(m.method(tsl::check::Method::Reflection).unwrap().instance_words() > 0);
    }
    assert_eq!(program.compiled_functions(), compiled, "binding new values compiled code");
    assert!(peaks[0] > peaks[1] && peaks[1] > peaks[2], "rougher is a lower mirror peak: {peaks:?}");
    // The first material keeps its own block.
    assert_eq!(first.reflection(&g, wi, &white, wo).to_rgb()[0], peaks[0]);
    // A string option changes the code: one more compilation, then cached.
    metal.set("distribution", "ggx").unwrap();
    let ggx = metal.bind().unwrap();
    let after_ggx = program.compiled_functions();
    assert!(after_ggx > compiled);
    metal.set("alpha", 0.3).unwrap().bind().unwrap();
    assert_eq!(program.compiled_functions(), after_ggx);
    assert!(ggx.reflection(&g, wi, &white, wo).to_rgb()[0].is_finite());
}

#[test]
fn bound_instances_are_shared_across_threads() {
    let program = program(HOST, ColorModel::Spectral { samples: 8 });
    let shader = program.shader("phong").unwrap();
    let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ..Default::default() };
    let (wi, wo) = ([0.3, 0.0, 0.954], [-0.3, 0.0, 0.954]);
    let light = program.rgb(1.0, 1.0, 1.0);
    let shared = shader.instance().set("ns", 64.0).unwrap().bind().unwrap();
    let want = shared.reflection(&g, wi, &light, wo);
    let compiled = program.compiled_functions();
    let got: Vec<(tsl::Color, tsl::Color)> = std::thread::scope(|s| {
        let handles: Vec<_> = [4.0f32, 16.0, 128.0]
            .map(|ns| {
                let (shader, shared, light) = (&shader, &shared, &light);
                s.spawn(move || {
                    let own = shader.instance().set("ns", ns).unwrap().bind().unwrap();
                    (shared.reflection(&g, wi, light, wo), own.reflection(&g, wi, light, wo))
                })
            })
            .into_iter()
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert!(got.iter().all(|(s, _)| *s == want), "a shared bound material gave another result on a thread");
    let peaks: Vec<f32> = got.iter().map(|(_, own)| own.to_rgb()[0]).collect();
    assert!(peaks[0] < peaks[1] && peaks[1] < peaks[2], "higher exponents, higher peaks: {peaks:?}");
    assert_eq!(program.compiled_functions(), compiled, "threads binding values compiled code");
}

#[test]
fn a_user_template_binds_its_values_at_run_time() {
    let program = program(common::CAR_PAINT, ColorModel::Rgb);
    let mut paint = program.shader("car_paint").unwrap().instance();
    let mut under = program.shader("rough_conductor").unwrap().instance();
    under.set("alpha", 0.4).unwrap();
    paint.set("finish", "satin").unwrap().set("under", &under).unwrap();
    for base in [[0.1, 0.2, 0.7], [0.9, 0.1, 0.1]] {
        paint.set("base", base).unwrap();
        let (bound, specialised) = (paint.bind().unwrap(), paint.specialise().unwrap());
        for backend in [Backend::Jit, Backend::Interpreter] {
            assert_agree(&bound, &specialised, backend, &paint.source());
        }
    }
}

#[test]
fn a_required_parameter_without_a_value_is_an_error_when_bound() {
    let src = "material tinted(color c) = lambert(kd: c);";
    let program = program(src, ColorModel::Rgb);
    let err = program.shader("tinted").unwrap().instance().bind().unwrap_err();
    assert!(err.to_string().contains("needs a value for `c`"), "{err}");
    let mut tinted = program.shader("tinted").unwrap().instance();
    tinted.set("c", [0.2, 0.4, 0.6]).unwrap();
    let (bound, specialised) = (tinted.bind().unwrap(), tinted.specialise().unwrap());
    assert!(assert_agree(&bound, &specialised, Backend::Jit, "tinted") > 0);
}

/// A spectral host's colors: a `Color` of the program's model binds and
/// specialises to the same results, and one made by `Program::rgb` gives
/// what `rgb(...)` written in source gives (both convert as lowering
/// converts a constant `rgb`). A required color given so binds too (its
/// call is written with a stand-in the block replaces).
#[test]
fn a_spectral_color_binds_and_specialises_as_rgb_written_in_source() {
    for model in [ColorModel::Spectral { samples: 8 }, ColorModel::Smits { samples: 8 }] {
        let src = format!(
            "{}\nmaterial tinted(color c) = lambert(kd: c);\nmaterial written = car_paint(base: rgb(0.7, 0.25, 0.1));\nmaterial written_tint = tinted(c: rgb(0.7, 0.25, 0.1));",
            common::CAR_PAINT
        );
        let program = program(&src, model);
        let base = program.rgb(0.7, 0.25, 0.1);
        for (shader, param, written) in [("car_paint", "base", "written"), ("tinted", "c", "written_tint")] {
            let mut instance = program.shader(shader).unwrap().instance();
            instance.set(param, base).unwrap();
            let what = format!("{model:?} {shader}");
            let (bound, specialised) = (instance.bind().unwrap(), instance.specialise().unwrap());
            let written = program.material(written).unwrap();
            for backend in [Backend::Jit, Backend::Interpreter] {
                assert!(assert_agree(&bound, &specialised, backend, &what) > 0);
                assert!(assert_agree(&specialised, &written, backend, &what) > 0);
            }
            // Folded in, not read: the specialised code takes no block.
            let reflection = |m: &Material| m.method(tsl::check::Method::Reflection).unwrap().instance_words();
            assert_eq!(reflection(&specialised), 0, "{what}");
            assert!(reflection(&bound) >= model.lanes(), "{what}");
        }
    }
}

/// A spectrum that no RGB upsamples to is used lane by lane: Lambert's
/// reflection under a flat light is `kd / π` in every lane.
#[test]
fn a_spectrum_is_used_lane_by_lane() {
    let model = ColorModel::Spectral { samples: 8 };
    let program = program(HOST, model);
    let ramp: Vec<f32> = (1..=8).map(|i| 0.1 * i as f32).collect();
    let mut lambert = program.shader("lambert").unwrap().instance();
    lambert.set("kd", tsl::Color::from_lanes(model, &ramp)).unwrap();
    let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], ..Default::default() };
    let flat = tsl::Color::from_lanes(model, &[1.0; 8]);
    let up = [0.0, 0.0, 1.0];
    let (bound, specialised) = (lambert.bind().unwrap(), lambert.specialise().unwrap());
    for m in [&bound, &specialised] {
        let f = m.reflection(&g, up, &flat, up);
        for (got, kd) in f.lanes().iter().zip(&ramp) {
            let want = kd / std::f32::consts::PI;
            assert!((got - want).abs() <= 1e-5, "{:?}: {got} vs {want}", f.lanes());
        }
    }
    for backend in [Backend::Jit, Backend::Interpreter] {
        assert!(assert_agree(&bound, &specialised, backend, "ramp") > 0);
    }
}

#[test]
fn a_color_of_another_model_is_an_error() {
    let model = ColorModel::Spectral { samples: 8 };
    let program = program(common::CAR_PAINT, model);
    let mut lambert = program.shader("lambert").unwrap().instance();
    let others = [
        tsl::Color::black(ColorModel::Rgb),
        tsl::Color::from_lanes(ColorModel::Spectral { samples: 16 }, &[0.5; 16]),
        tsl::Color::from_lanes(ColorModel::Smits { samples: 8 }, &[0.5; 8]),
    ];
    for other in others {
        let err = lambert.set("kd", other).unwrap_err().to_string();
        let want = "`kd` of `lambert` takes a color of the program's model (Spectral { samples: 8 }, 8 lanes), not";
        assert!(err.contains(want), "{err}");
        assert!(err.contains("give RGB as `[f32; 3]`"), "{err}");
    }
    assert!(lambert.values().iter().all(Option::is_none), "failed sets change nothing");
    // A material value's own lanes have no text for the outer call.
    lambert.set("kd", program.rgb(0.2, 0.3, 0.4)).unwrap();
    let err = program.shader("car_paint").unwrap().instance().set("under", &lambert).unwrap_err().to_string();
    assert!(err.contains("`under` of `car_paint`: the instance's `kd` is a spectral color"), "{err}");
}

/// Hero sampling draws each lane's wavelength per camera sample: a bound
/// RGB color, set or a default, is upsampled at the hit's wavelengths, as
/// the specialised `rgb(...)` is, not at the default ones.
#[test]
fn a_hero_program_binds_rgb_at_the_hits_wavelengths() {
    let program = program(HOST, ColorModel::Hero);
    let mut set = program.shader("lambert").unwrap().instance();
    set.set("kd", [0.8, 0.2, 0.1]).unwrap();
    let mut metal = program.shader("rough_conductor").unwrap().instance();
    metal.set("alpha", 0.3).unwrap();
    let defaults = program.shader("lambert").unwrap().instance();
    let flat = tsl::Color::from_lanes(ColorModel::Hero, &[1.0; 4]);
    let up = [0.0, 0.0, 1.0];
    let wi = [0.6, 0.0, 0.8];
    for instance in [&set, &metal, &defaults] {
        let (bound, specialised) = (instance.bind().unwrap(), instance.specialise().unwrap());
        for wavelengths in [[430.0, 530.0, 630.0, 730.0], [400.0, 480.0, 560.0, 640.0]] {
            let g = ShadingGlobals { n: up, ng: up, wavelengths, ..Default::default() };
            let (b, s) = (bound.reflection(&g, wi, &flat, up), specialised.reflection(&g, wi, &flat, up));
            assert!(s.lanes().iter().any(|x| *x > 0.0));
            for (x, y) in b.lanes().iter().zip(s.lanes()) {
                assert!(
                    (x - y).abs() <= 1e-5 * x.abs().max(1.0),
                    "{} at {wavelengths:?}: bound {:?}, specialised {:?}",
                    instance.source(),
                    b.lanes(),
                    s.lanes()
                );
            }
        }
    }
}
