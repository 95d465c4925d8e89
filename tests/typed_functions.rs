//! Generators as typed functions: the signature is checked once, when the
//! host asks for the function, and calls take and return Rust values that
//! equal the raw-word calls on both back ends.

use tsl::{Backend, Color, ColorModel, Compiler, ShadingGlobals, TypedFunction};

const SRC: &str = r#"
    float rings(float scale) { return fract(length(vec2(Pl.x, Pl.z)) * scale); }
    color tint(color c, float k, int n, bool flip, vec2 st, vector d) {
        float s = flip ? -k : k;
        return c * (s + float(n) + st.x * st.y + d.z);
    }
    vector bent(point p) { return normalize(p + N); }
    int count(float x) { return int(floor(x * 10)); }
    bool above(float h) { return P.y > h; }
    material m = lambert;
"#;

fn program(model: ColorModel) -> tsl::Program {
    Compiler::new().color_model(model).source("gen.tsl", SRC).compile().unwrap()
}

fn globals() -> ShadingGlobals {
    ShadingGlobals { p: [0.2, 0.7, -0.1], pl: [0.31, 0.5, 0.12], n: [0.0, 0.0, 1.0], ..Default::default() }
}

fn words(xs: &[f32]) -> Vec<u32> {
    xs.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn typed_calls_equal_raw_word_calls_on_both_back_ends() {
    for model in [ColorModel::Rgb, ColorModel::Spectral { samples: 16 }] {
        let program = program(model);
        let g = globals();
        let lanes = model.lanes();
        let rings = program.typed_function::<(f32,), f32>("rings").unwrap();
        let tint = program.typed_function::<(Color, f32, i32, bool, [f32; 2], [f32; 3]), Color>("tint").unwrap();
        let bent = program.typed_function::<([f32; 3],), [f32; 3]>("bent").unwrap();
        let count = program.typed_function::<(f32,), i32>("count").unwrap();
        let above = program.typed_function::<(f32,), bool>("above").unwrap();
        let c = program.rgb(0.2, 0.5, 0.9);
        for backend in [Backend::Jit, Backend::Interpreter] {
            let mut out = vec![0u32; lanes];
            rings.function().call_words(backend, &g, &words(&[8.0]), &mut out).unwrap();
            assert_eq!(rings.call_on(backend, &g, (8.0,)).to_bits(), out[0]);

            let mut args = words(c.lanes());
            args.extend(words(&[0.25]));
            args.push(3);
            args.push(1);
            args.extend(words(&[0.5, 0.5, 0.0, 0.0, 2.0]));
            tint.function().call_words(backend, &g, &args, &mut out).unwrap();
            let typed = tint.call_on(backend, &g, (c, 0.25, 3, true, [0.5, 0.5], [0.0, 0.0, 2.0]));
            assert_eq!(typed.lanes(), &words_to_floats(&out)[..lanes]);
            // -0.25 + 3 + 0.25 + 2 = 5 times the color.
            assert!((typed.lanes()[0] - 5.0 * c.lanes()[0]).abs() < 1e-5);

            let v = bent.call_on(backend, &g, ([0.0, 3.0, 0.0],));
            assert!((v[1] - 3.0 / 10f32.sqrt()).abs() < 1e-6 && (v[2] - 1.0 / 10f32.sqrt()).abs() < 1e-6, "{v:?}");
            assert_eq!(count.call_on(backend, &g, (0.47,)), 4);
            assert!(above.call_on(backend, &g, (0.5,)) && !above.call_on(backend, &g, (0.8,)));
        }
    }
}

fn words_to_floats(ws: &[u32]) -> Vec<f32> {
    ws.iter().map(|w| f32::from_bits(*w)).collect()
}

#[test]
fn a_wrong_signature_is_an_error_when_asked() {
    let program = program(ColorModel::Rgb);
    let message = |r: Result<(), tsl::Error>| r.unwrap_err().to_string();
    let wrong_param = message(program.typed_function::<(i32,), f32>("rings").map(drop));
    assert!(wrong_param.contains("`rings` takes (float) and returns float, not (int) -> float"), "{wrong_param}");
    let too_many = message(program.typed_function::<(f32, f32), f32>("rings").map(drop));
    assert!(too_many.contains("not (float, float) -> float"), "{too_many}");
    let too_few = message(program.typed_function::<(), f32>("rings").map(drop));
    assert!(too_few.contains("not () -> float"), "{too_few}");
    let wrong_result = message(program.typed_function::<(f32,), Color>("rings").map(drop));
    assert!(wrong_result.contains("not (float) -> color"), "{wrong_result}");
    // A vector is not a point's Rust type's only reading: point and normal
    // are [f32; 3] too, but a vec2 is not.
    let vec2 = message(program.typed_function::<([f32; 2],), [f32; 3]>("bent").map(drop));
    assert!(vec2.contains("`bent` takes (point)"), "{vec2}");
    let missing = message(program.typed_function::<(f32,), f32>("ringz").map(drop));
    assert!(missing.contains("no generator named `ringz`"), "{missing}");
    // A material method has an entry, but is not a generator.
    let method = message(program.typed_function::<(), bool>("m.opaque").map(drop));
    assert!(method.contains("`m.opaque` takes () and returns bool"), "{method}");
}

#[test]
fn typed_functions_are_shared_across_threads() {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<TypedFunction<(f32,), f32>>();
    let program = program(ColorModel::Rgb);
    let rings = program.typed_function::<(f32,), f32>("rings").unwrap();
    let g = globals();
    let expected: Vec<u32> = (0..64).map(|k| rings.call(&g, (k as f32,)).to_bits()).collect();
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..4)
            .map(|_| s.spawn(|| (0..64).map(|k| rings.call(&g, (k as f32,)).to_bits()).collect::<Vec<u32>>()))
            .collect();
        for h in handles {
            assert_eq!(h.join().unwrap(), expected);
        }
    });
}
