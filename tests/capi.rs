//! The C ABI called from Rust as a C host would call it, for what the C
//! programs of tests/c_host.rs do not reach: bad arguments (null handles,
//! strings that are not UTF-8, colours of the wrong lanes, columns that
//! overflow), errors read field by field, and parameter descriptions.

use std::ffi::c_char;
use std::ptr::{null, null_mut};
use tsl::capi::*;

fn text(s: TslStr) -> String {
    if s.ptr.is_null() {
        return String::new();
    }
    // SAFETY: a TslStr from the library: `len` bytes of UTF-8 at `ptr`,
    // alive while its handle is.
    let bytes = unsafe { std::slice::from_raw_parts(s.ptr.cast::<u8>(), s.len) };
    String::from_utf8(bytes.to_vec()).expect("UTF-8")
}

fn c(s: &str) -> *const c_char {
    s.as_ptr().cast()
}

/// The status and message of a call given an error slot.
fn failure(call: impl FnOnce(*mut *mut TslError) -> TslStatus) -> (TslStatus, String) {
    let mut error = null_mut();
    let status = call(&mut error);
    assert_ne!(status, TslStatus::TSL_OK, "the call succeeded");
    assert!(!error.is_null(), "a failed call leaves an error");
    // SAFETY: a live error handle, freed once below.
    let message = unsafe { text(tsl_error_message(error)) };
    assert_eq!(unsafe { tsl_error_status(error) }, status);
    unsafe { tsl_error_free(error) };
    (status, message)
}

fn compile(source: &str) -> *mut TslProgram {
    let compiler = tsl_compiler_new();
    let mut program = null_mut();
    // SAFETY: live handles and buffers of the lengths given.
    unsafe {
        assert_eq!(
            tsl_compiler_source(compiler, c("m.tsl"), 5, c(source), source.len(), null_mut()),
            TslStatus::TSL_OK
        );
        assert_eq!(tsl_compiler_compile(compiler, &mut program, null_mut()), TslStatus::TSL_OK);
        tsl_compiler_free(compiler);
    }
    program
}

#[test]
fn compile_errors_read_field_by_field_and_as_rustc_text() {
    let src = "material m = lambert;\nfloat f() { return nope; }\n";
    let compiler = tsl_compiler_new();
    let mut program = null_mut();
    let mut error = null_mut();
    unsafe {
        tsl_compiler_source(compiler, c("dir/bad.tsl"), 11, c(src), src.len(), null_mut());
        assert_eq!(tsl_compiler_compile(compiler, &mut program, &mut error), TslStatus::TSL_ERROR);
        assert!(program.is_null());
        let want = tsl::Compiler::new().source("dir/bad.tsl", src).compile().expect_err("errors").to_string();
        assert_eq!(text(tsl_error_message(error)), want);
        // NUL-terminated too, for C's printf("%s").
        let m = tsl_error_message(error);
        assert_eq!(*m.ptr.add(m.len), 0);
        assert_eq!(tsl_error_diagnostic_count(error), 1);
        let mut d = std::mem::zeroed::<TslDiagnostic>();
        assert!(tsl_error_diagnostic(error, 0, &mut d));
        assert_eq!((text(d.file), d.line, d.column, d.is_error), ("dir/bad.tsl".to_string(), 2, 20, true));
        assert_eq!(text(d.message), "cannot find value `nope` in this scope");
        assert!(!tsl_error_diagnostic(error, 1, &mut d), "past the end");
        tsl_error_free(error);
        tsl_compiler_free(compiler);
    }
}

#[test]
fn bad_arguments_are_errors_not_crashes() {
    unsafe {
        let (status, m) = failure(|e| tsl_compiler_compile(null(), &mut null_mut(), e));
        assert_eq!((status, m.as_str()), (TslStatus::TSL_INVALID_ARGUMENT, "error: `compiler` is null\n"));
        let compiler = tsl_compiler_new();
        let (status, m) = failure(|e| tsl_compiler_source(compiler, c("m.tsl"), 5, [0xffu8].as_ptr().cast(), 1, e));
        assert_eq!(status, TslStatus::TSL_INVALID_ARGUMENT);
        assert!(m.contains("`text` is not UTF-8"), "{m}");
        let (status, m) = failure(|e| tsl_compiler_source(compiler, null(), 3, c("x"), 1, e));
        assert!(status == TslStatus::TSL_INVALID_ARGUMENT && m.contains("`name` is null with a length of 3"), "{m}");
        let (status, m) = failure(|e| tsl_compiler_color_model(compiler, c("spectral99"), 10, e));
        assert!(status == TslStatus::TSL_INVALID_ARGUMENT && m.contains("not a color model"), "{m}");
        // No source yet: the compiler's own error. A null error slot is allowed.
        assert_eq!(tsl_compiler_compile(compiler, &mut null_mut(), null_mut()), TslStatus::TSL_ERROR);
        tsl_compiler_free(compiler);
        tsl_compiler_free(null_mut());
        tsl_program_free(null_mut());
        tsl_error_free(null_mut());
        assert_eq!(tsl_program_lanes(null()), 0);
        assert!(tsl_program_shader_name(null(), 0).ptr.is_null());

        let program = compile("material m = lambert(kd: gray(0.5));");
        // Names need no NUL: the first 15 bytes of a longer buffer.
        let mut shader = null_mut();
        let name = "rough_conductor and more";
        assert_eq!(tsl_program_shader(program, c(name), 15, &mut shader, null_mut()), TslStatus::TSL_OK);
        let (status, m) = failure(|e| tsl_program_shader(program, c("rough_conductr"), 14, &mut null_mut(), e));
        assert!(status == TslStatus::TSL_ERROR && m.contains("did you mean `rough_conductor`?"), "{m}");
        let (status, _) = failure(|e| tsl_program_shader(program, c(name), 15, null_mut(), e));
        assert_eq!(status, TslStatus::TSL_INVALID_ARGUMENT, "a null out-parameter");

        let mut instance = null_mut();
        assert_eq!(tsl_shader_instance(shader, &mut instance, null_mut()), TslStatus::TSL_OK);
        let (status, m) = failure(|e| tsl_instance_set_float(instance, c("distribution"), 12, 0.5, e));
        assert!(status == TslStatus::TSL_ERROR && m.contains("distribution"), "{m}");
        let (status, m) = failure(|e| tsl_instance_set_string(instance, c("distribution"), 12, c("phong"), 5, e));
        assert!(status == TslStatus::TSL_ERROR && m.contains("ggx"), "{m}");
        let (status, _) = failure(|e| tsl_instance_set_color(instance, c("eta"), 3, [1.0f32; 4].as_ptr(), 4, e));
        assert_eq!(status, TslStatus::TSL_INVALID_ARGUMENT, "4 lanes in rgb");

        // Colours of the wrong lanes, and batches that cannot be read.
        let mut m_ = null_mut();
        assert_eq!(tsl_program_material(program, c("m"), 1, &mut m_, null_mut()), TslStatus::TSL_OK);
        let g = tsl_globals_default();
        let (v3, mut out) = ([0.0f32, 0.0, 1.0], [0.0f32; 4]);
        let (status, m) = failure(|e| tsl_material_emission(m_, &g, v3.as_ptr(), v3.as_ptr(), 4, out.as_mut_ptr(), e));
        assert!(status == TslStatus::TSL_INVALID_ARGUMENT && m.contains("has 3 lanes, not 4"), "{m}");
        let (status, _) =
            failure(|e| tsl_material_emission(m_, null(), v3.as_ptr(), v3.as_ptr(), 3, out.as_mut_ptr(), e));
        assert_eq!(status, TslStatus::TSL_INVALID_ARGUMENT, "null globals");
        let mut batch = null_mut();
        assert_eq!(tsl_batch_new(3, null(), &mut batch, null_mut()), TslStatus::TSL_OK);
        let xs = [0.0f32; 9];
        let column = |stride| TslColumn { values: xs.as_ptr(), stride, uniform: 0.0 };
        let (status, m) = failure(|e| tsl_batch_set(batch, c("Q"), 1, [column(1)].as_ptr(), 1, e));
        assert!(status == TslStatus::TSL_ERROR && m.contains("no global `Q`"), "{m}");
        let (status, m) = failure(|e| tsl_batch_set(batch, c("P"), 1, [column(1)].as_ptr(), 1, e));
        assert!(status == TslStatus::TSL_ERROR && m.contains("3 columns, not 1"), "{m}");
        let (status, m) = failure(|e| tsl_batch_set(batch, c("u"), 1, [column(usize::MAX)].as_ptr(), 1, e));
        assert!(status == TslStatus::TSL_INVALID_ARGUMENT && m.contains("overflows"), "{m}");
        assert_eq!(tsl_batch_set(batch, c("P"), 1, [column(3); 3].as_ptr(), 3, null_mut()), TslStatus::TSL_OK);
        let eta = [TslColumn { values: null(), stride: 0, uniform: 1.0 }; 3];
        let mut values = [0.0f32; 9];
        let (status, _) = failure(|e| {
            tsl_material_batch_emission(m_, batch, eta.as_ptr(), eta.as_ptr(), 2, 3, values.as_mut_ptr(), e)
        });
        assert_eq!(status, TslStatus::TSL_INVALID_ARGUMENT, "2 lanes in rgb");
        let (status, m) = failure(|e| {
            tsl_material_batch_emission(m_, batch, eta.as_ptr(), eta.as_ptr(), 3, 2, values.as_mut_ptr(), e)
        });
        assert!(status == TslStatus::TSL_INVALID_ARGUMENT && m.contains("the batch has 3 points, not 2"), "{m}");
        assert_eq!(
            tsl_material_batch_emission(m_, batch, eta.as_ptr(), eta.as_ptr(), 3, 3, values.as_mut_ptr(), null_mut()),
            TslStatus::TSL_OK
        );

        // A program without a scene has nothing to render.
        let (status, m) = failure(|e| tsl_scene_new(program, null(), &mut null_mut(), e));
        assert!(status == TslStatus::TSL_ERROR && m.contains("no `scene { }` block"), "{m}");

        tsl_batch_free(batch);
        tsl_material_free(m_);
        tsl_instance_free(instance);
        tsl_shader_free(shader);
        tsl_program_free(program);
    }
}

#[test]
fn shader_parameters_list_types_defaults_docs_and_options() {
    let program = compile(
        "/// A tinted plastic.\nmaterial tinted(color c = rgb(0.5, 0.25, 1), int n = 3, bool b = true, vector v = vector(1, 2, 3)) = lambert(kd: c);",
    );
    unsafe {
        let count = tsl_program_shader_count(program);
        let names: Vec<String> = (0..count).map(|i| text(tsl_program_shader_name(program, i))).collect();
        let ours: Vec<&String> = names
            .iter()
            .enumerate()
            .filter(|(i, _)| !tsl_program_shader_in_prelude(program, *i))
            .map(|(_, n)| n)
            .collect();
        assert_eq!(ours, ["tinted"]);
        assert!(names.iter().any(|n| n == "rough_conductor"));
        let mut shader = null_mut();
        assert_eq!(tsl_program_shader(program, c("tinted"), 6, &mut shader, null_mut()), TslStatus::TSL_OK);
        assert_eq!(text(tsl_shader_name(shader)), "tinted");
        assert_eq!(text(tsl_shader_doc(shader)), "A tinted plastic.");
        assert_eq!(tsl_shader_param_count(shader), 4);
        let mut p = std::mem::zeroed::<TslParam>();
        assert_eq!(tsl_shader_param(shader, 0, &mut p, null_mut()), TslStatus::TSL_OK);
        assert_eq!(
            (text(p.name), p.ty, text(p.default_source), text(p.doc)),
            ("c".into(), TslParamType::TSL_TYPE_COLOR, "rgb(0.5, 0.25, 1)".into(), "".into())
        );
        assert_eq!(p.default_value.kind, TslValueKind::TSL_VALUE_COLOR);
        let rgb = &p.default_value.floats[..3];
        assert!((rgb[0] - 0.5).abs() < 1e-6 && (rgb[1] - 0.25).abs() < 1e-6 && (rgb[2] - 1.0).abs() < 1e-6, "{rgb:?}");
        tsl_shader_param(shader, 1, &mut p, null_mut());
        assert_eq!(
            (p.ty, p.default_value.kind, p.default_value.int_value),
            (TslParamType::TSL_TYPE_INT, TslValueKind::TSL_VALUE_INT, 3)
        );
        tsl_shader_param(shader, 2, &mut p, null_mut());
        assert_eq!(
            (p.ty, p.default_value.kind, p.default_value.int_value),
            (TslParamType::TSL_TYPE_BOOL, TslValueKind::TSL_VALUE_BOOL, 1)
        );
        tsl_shader_param(shader, 3, &mut p, null_mut());
        assert_eq!(
            (p.ty, p.default_value.kind, &p.default_value.floats[..3]),
            (TslParamType::TSL_TYPE_VECTOR, TslValueKind::TSL_VALUE_VECTOR, &[1.0, 2.0, 3.0][..])
        );
        let (status, _) = failure(|e| tsl_shader_param(shader, 4, &mut p, e));
        assert_eq!(status, TslStatus::TSL_INVALID_ARGUMENT);

        let mut metal = null_mut();
        tsl_program_shader(program, c("rough_conductor"), 15, &mut metal, null_mut());
        let index = (0..tsl_shader_param_count(metal))
            .find(|&i| {
                tsl_shader_param(metal, i, &mut p, null_mut());
                text(p.name) == "distribution"
            })
            .expect("a distribution parameter");
        assert_eq!(
            (p.ty, p.default_value.kind, text(p.default_value.string)),
            (TslParamType::TSL_TYPE_STRING, TslValueKind::TSL_VALUE_STRING, "beckmann".into())
        );
        let options: Vec<String> =
            (0..p.option_count).map(|k| text(tsl_shader_param_option(metal, index, k))).collect();
        assert_eq!(options, ["beckmann", "ggx"]);
        assert!(tsl_shader_param_option(metal, index, 2).ptr.is_null());
        tsl_shader_free(metal);
        tsl_shader_free(shader);
        tsl_program_free(program);
    }
}

#[test]
fn spectral_colors_have_the_models_lanes_and_the_rust_apis_bits() {
    let src = "material m = mix(0.3, lambert(kd: rgb(0.6, 0.4, 0.2)), rough_conductor(alpha: 0.2));";
    let compiler = tsl_compiler_new();
    let mut program = null_mut();
    unsafe {
        assert_eq!(tsl_compiler_color_model(compiler, c("spectral16"), 10, null_mut()), TslStatus::TSL_OK);
        tsl_compiler_source(compiler, c("m.tsl"), 5, c(src), src.len(), null_mut());
        assert_eq!(tsl_compiler_compile(compiler, &mut program, null_mut()), TslStatus::TSL_OK);
        tsl_compiler_free(compiler);
        assert_eq!(tsl_program_lanes(program), 16);
        let mut eta = [0.0f32; 16];
        assert_eq!(tsl_program_rgb(program, 1.0, 1.0, 1.0, eta.as_mut_ptr(), 16, null_mut()), TslStatus::TSL_OK);
        let mut material = null_mut();
        tsl_program_material(program, c("m"), 1, &mut material, null_mut());
        let mut g = tsl_globals_default();
        g.u = 0.25;
        let (wo, wi) = ([0.0f32, 0.6, 0.8], [0.6f32, 0.0, 0.8]);
        let mut out = [0.0f32; 16];
        let status = tsl_material_reflection(
            material,
            &g,
            wo.as_ptr(),
            eta.as_ptr(),
            wi.as_ptr(),
            eta.as_ptr(),
            16,
            out.as_mut_ptr(),
            null_mut(),
        );
        assert_eq!(status, TslStatus::TSL_OK);
        let mut rgb = [0.0f32; 3];
        tsl_program_to_rgb(program, out.as_ptr(), 16, rgb.as_mut_ptr(), null_mut());

        let rust = tsl::Compiler::new()
            .color_model(tsl::ColorModel::Spectral { samples: 16 })
            .source("m.tsl", src)
            .compile()
            .expect("compiles");
        let want_eta = rust.rgb(1.0, 1.0, 1.0);
        assert_eq!(eta.map(f32::to_bits), <[f32; 16]>::try_from(want_eta.lanes()).unwrap().map(f32::to_bits));
        let rg = tsl::ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], u: 0.25, ..Default::default() };
        let mut record = tsl::SurfaceRecord::new();
        let want = rust.material("m").unwrap().at(&rg, wo, &want_eta, &mut record).reflection(wi, &want_eta);
        assert_eq!(out.map(f32::to_bits), <[f32; 16]>::try_from(want.lanes()).unwrap().map(f32::to_bits));
        assert_eq!(rgb, want.to_rgb());
        assert!(rgb.iter().all(|c| *c > 0.0), "{rgb:?}");
        tsl_material_free(material);
        tsl_program_free(program);
    }
}

/// `n` columns, each one value for every point.
fn uniforms(values: &[f32]) -> Vec<TslColumn> {
    values.iter().map(|&v| TslColumn { values: null(), stride: 0, uniform: v }).collect()
}

#[test]
fn every_batch_call_gives_the_bits_of_its_point_call() {
    let src = "material m = mix(rings(), emitter(radiance: rgb(0.2, 0.3, 0.4), kd: gray(0.5)), rough_conductor(alpha: 0.3));\n\
               float rings() { return fract(length(vec2(P.x, P.z)) * 8); }";
    const N: usize = 16;
    let program = compile(src);
    let p: Vec<[f32; 3]> = (0..N).map(|i| [0.03 * i as f32, 0.0, 0.011 * i as f32]).collect();
    let wi: Vec<[f32; 3]> = (0..N).map(|i| [0.05 * i as f32 - 0.4, 0.3, 0.8]).collect();
    let us: Vec<f32> = (0..N).map(|i| (i as f32 + 0.5) / N as f32).collect();
    let (wo, eta) = ([0.0f32, 0.6, 0.8], [1.0f32; 3]);
    let field = |a: &[[f32; 3]], k: usize| TslColumn { values: a[0][k..].as_ptr(), stride: 3, uniform: 0.0 };
    let plain = |a: &[f32]| TslColumn { values: a.as_ptr(), stride: 1, uniform: 0.0 };
    unsafe {
        let mut m = null_mut();
        assert_eq!(tsl_program_material(program, c("m"), 1, &mut m, null_mut()), TslStatus::TSL_OK);
        let mut batch = null_mut();
        tsl_batch_new(N, null(), &mut batch, null_mut());
        let p_columns = [field(&p, 0), field(&p, 1), field(&p, 2)];
        assert_eq!(tsl_batch_set(batch, c("P"), 1, p_columns.as_ptr(), 3, null_mut()), TslStatus::TSL_OK);
        assert_eq!(tsl_batch_len(batch), N);
        let (wo_c, eta_c) = (uniforms(&wo), uniforms(&eta));
        let wi_c = [field(&wi, 0), field(&wi, 1), field(&wi, 2)];
        let ok = |s: TslStatus| assert_eq!(s, TslStatus::TSL_OK);

        let mut emission = vec![0.0f32; N * 3];
        ok(tsl_material_batch_emission(
            m,
            batch,
            wo_c.as_ptr(),
            eta_c.as_ptr(),
            3,
            N,
            emission.as_mut_ptr(),
            null_mut(),
        ));
        let mut reflection = vec![0.0f32; N * 3];
        ok(tsl_material_batch_reflection(
            m,
            batch,
            wo_c.as_ptr(),
            eta_c.as_ptr(),
            wi_c.as_ptr(),
            eta_c.as_ptr(),
            3,
            N,
            reflection.as_mut_ptr(),
            null_mut(),
        ));
        let (mut value, mut pdf_e, mut pdf) = (vec![0.0f32; N * 3], vec![0.0f32; N], vec![0.0f32; N]);
        ok(tsl_material_batch_eval_pdf(
            m,
            batch,
            wo_c.as_ptr(),
            eta_c.as_ptr(),
            3,
            wi_c.as_ptr(),
            N,
            value.as_mut_ptr(),
            pdf_e.as_mut_ptr(),
            null_mut(),
        ));
        ok(tsl_material_batch_pdf(
            m,
            batch,
            wo_c.as_ptr(),
            eta_c.as_ptr(),
            3,
            wi_c.as_ptr(),
            N,
            pdf.as_mut_ptr(),
            null_mut(),
        ));
        let (mut s_wi, mut s_weight, mut s_pdf, mut s_delta) =
            (vec![0.0f32; N * 3], vec![0.0f32; N * 3], vec![0.0f32; N], vec![false; N]);
        let half = TslColumn { values: null(), stride: 0, uniform: 0.5 };
        ok(tsl_material_batch_sample(
            m,
            batch,
            wo_c.as_ptr(),
            eta_c.as_ptr(),
            3,
            plain(&us),
            plain(&us),
            half,
            N,
            s_wi.as_mut_ptr(),
            s_weight.as_mut_ptr(),
            s_pdf.as_mut_ptr(),
            s_delta.as_mut_ptr(),
            null_mut(),
        ));

        let bits = |xs: &[f32]| xs.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
        let mut emitted = 0;
        for i in 0..N {
            let mut g = tsl_globals_default();
            g.p = p[i];
            let mut out = [0.0f32; 3];
            ok(tsl_material_emission(m, &g, wo.as_ptr(), eta.as_ptr(), 3, out.as_mut_ptr(), null_mut()));
            assert_eq!(bits(&out), bits(&emission[3 * i..3 * i + 3]), "emission at {i}");
            emitted += usize::from(out[0] > 0.0);
            ok(tsl_material_reflection(
                m,
                &g,
                wo.as_ptr(),
                eta.as_ptr(),
                wi[i].as_ptr(),
                eta.as_ptr(),
                3,
                out.as_mut_ptr(),
                null_mut(),
            ));
            assert_eq!(bits(&out), bits(&reflection[3 * i..3 * i + 3]), "reflection at {i}");
            let mut e = 0.0;
            ok(tsl_material_eval_pdf(
                m,
                &g,
                wo.as_ptr(),
                eta.as_ptr(),
                3,
                wi[i].as_ptr(),
                out.as_mut_ptr(),
                &mut e,
                null_mut(),
            ));
            assert_eq!(
                (bits(&out), e.to_bits()),
                (bits(&value[3 * i..3 * i + 3]), pdf_e[i].to_bits()),
                "eval_pdf at {i}"
            );
            let mut q = 0.0;
            ok(tsl_material_pdf(m, &g, wo.as_ptr(), eta.as_ptr(), 3, wi[i].as_ptr(), &mut q, null_mut()));
            assert_eq!(q.to_bits(), pdf[i].to_bits(), "pdf at {i}");
            let mut s = std::mem::zeroed::<TslSample>();
            ok(tsl_material_sample(
                m,
                &g,
                wo.as_ptr(),
                eta.as_ptr(),
                3,
                us[i],
                us[i],
                0.5,
                &mut s,
                out.as_mut_ptr(),
                null_mut(),
            ));
            assert_eq!(bits(&s.wi), bits(&s_wi[3 * i..3 * i + 3]), "sampled direction at {i}");
            assert_eq!(bits(&out), bits(&s_weight[3 * i..3 * i + 3]), "sample weight at {i}");
            assert_eq!((s.pdf.to_bits(), s.delta), (s_pdf[i].to_bits(), s_delta[i]), "sample pdf at {i}");
        }
        // The mixture's weight varies over the points, and so does what they emit.
        let mut distinct = bits(&emission);
        distinct.sort_unstable();
        distinct.dedup();
        assert!(emitted == N && distinct.len() > N, "{emitted} of {N} points emit {} values", distinct.len());
        tsl_batch_free(batch);
        tsl_material_free(m);
        tsl_program_free(program);
    }
}
