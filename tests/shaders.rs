//! Shaders and instances (`Program::shaders`, `Shader::instance`): every
//! stdlib template described and documented, its header table and its doc
//! comments in agreement, instance values checked once, and specialised
//! instances compiling to exactly what the same call in source gives.

mod common;

use common::{Rng, args, shading_point};
use tsl::{Backend, ColorModel, Compiler, Instance, Material, ParamType, ParamValue, Program, Shader};

/// A program of no templates of its own (an empty file is an error).
const HOST: &str = "material host = lambert;";

fn program(src: &str, model: ColorModel) -> Program {
    Compiler::new().color_model(model).source("host.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"))
}

fn prelude_shaders(program: &Program) -> Vec<Shader> {
    program.shaders().into_iter().filter(Shader::in_prelude).collect()
}

#[test]
fn shaders_and_instances_can_be_shared_across_threads() {
    fn shared<T: Send + Sync>() {}
    shared::<Shader>();
    shared::<Instance>();
    shared::<tsl::ParamInfo>();
    let program = program(HOST, ColorModel::Rgb);
    let shader = program.shader("phong").unwrap();
    let materials: Vec<Material> = std::thread::scope(|s| {
        let handles: Vec<_> = [8.0f32, 64.0]
            .map(|ns| {
                let shader = &shader;
                s.spawn(move || shader.instance().set("ns", ns).unwrap().specialise().unwrap())
            })
            .into_iter()
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let g = tsl::ShadingGlobals { n: [0.0, 0.0, 1.0], ..Default::default() };
    let (wi, wo) = ([0.3, 0.0, 0.954], [-0.3, 0.0, 0.954]);
    let light = program.rgb(1.0, 1.0, 1.0);
    let [soft, sharp] = [&materials[0], &materials[1]].map(|m| m.reflection(&g, wi, &light, wo).to_rgb()[0]);
    assert!(sharp > soft, "a higher exponent is a sharper, higher peak: {soft} {sharp}");
}

#[test]
fn every_stdlib_template_and_parameter_is_documented() {
    let program = program(HOST, ColorModel::Rgb);
    let shaders = prelude_shaders(&program);
    assert!(shaders.len() >= 19, "{} shaders", shaders.len());
    let mut missing = Vec::new();
    for s in &shaders {
        if s.doc().is_none_or(str::is_empty) {
            missing.push(s.name().to_string());
        }
        for p in s.params() {
            if p.doc.as_deref().is_none_or(str::is_empty) {
                missing.push(format!("{}.{}", s.name(), p.name));
            }
            // Every stdlib default is one constant, so it has a value.
            if p.default_source.is_some() && p.ty != ParamType::Material {
                assert!(p.default.is_some(), "{}.{} = {:?} has no value", s.name(), p.name, p.default_source);
            }
        }
    }
    assert!(missing.is_empty(), "undocumented: {missing:?}");
}

#[test]
fn rough_conductor_is_described_with_types_defaults_docs_and_options() {
    let program = program(HOST, ColorModel::Rgb);
    let shader = program.shader("rough_conductor").unwrap();
    assert_eq!(shader.doc(), Some("Rough metal (Mitsuba: roughconductor)."));
    let names: Vec<&str> = shader.params().iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["alpha", "alpha_u", "alpha_v", "distribution", "eta", "k", "specular_reflectance"]);
    let distribution = shader.param("distribution").unwrap();
    assert_eq!(distribution.ty, ParamType::String);
    assert_eq!(distribution.options, ["beckmann", "ggx"]);
    assert_eq!(distribution.default, Some(ParamValue::String("beckmann".into())));
    let k = shader.param("k").unwrap();
    assert_eq!((k.ty, k.default_source.as_deref()), (ParamType::Color, Some("gray(1)")));
    assert_eq!(k.default, Some(ParamValue::Color(program.rgb(1.0, 1.0, 1.0))));
    // Spectral defaults are lanes of the program's model.
    let spectral = self::program(HOST, ColorModel::Spectral { samples: 8 });
    let k = spectral.shader("rough_conductor").unwrap().param("k").unwrap().default.clone();
    let Some(ParamValue::Color(c)) = k else { panic!("{k:?}") };
    assert_eq!(c.lanes().len(), 8);
}

#[test]
fn user_templates_are_shaders_and_unknown_names_are_errors() {
    let src = r#"
/// A car paint.
material car_paint(
    /// The paint's colour.
    color base = rgb(0.5, 0.02, 0.02),
    string finish = "gloss" in ("gloss", "satin"),
) = rough_plastic(diffuse_reflectance: base, alpha: finish == "gloss" ? 0.05 : 0.3);
material plain = lambert;
"#;
    let program = program(src, ColorModel::Rgb);
    let own: Vec<String> = program.shaders().iter().filter(|s| !s.in_prelude()).map(|s| s.name().into()).collect();
    assert_eq!(own, ["car_paint"], "a tree without parameters is a material, not a template");
    let paint = program.shader("car_paint").unwrap();
    assert_eq!(paint.doc(), Some("A car paint."));
    assert_eq!(paint.param("base").unwrap().doc.as_deref(), Some("The paint's colour."));
    assert_eq!(paint.param("finish").unwrap().doc, None);
    assert_eq!(paint.param("finish").unwrap().options, ["gloss", "satin"]);
    let err = program.shader("car_pant").unwrap_err().to_string();
    assert!(err.contains("no material template named `car_pant` (did you mean `car_paint`?)"), "{err}");
    let err = program.shader("plain").unwrap_err().to_string();
    assert!(err.contains("`plain` is a material tree without parameters"), "{err}");
}

#[test]
fn instance_values_are_checked_once_with_clear_errors() {
    let src = "material layered(float[2] w = [0.5, 0.5], material top = mirror) = mix(w[0], top, lambert);";
    let program = program(src, ColorModel::Rgb);
    let metal = program.shader("rough_conductor").unwrap();
    let mut i = metal.instance();
    let message = |r: Result<&mut Instance, tsl::Error>| r.map(|_| ()).unwrap_err().to_string();
    let unknown = message(i.set("alpah", 0.2));
    assert!(unknown.contains("`rough_conductor` has no parameter named `alpah`"), "{unknown}");
    assert!(unknown.contains("did you mean `alpha`?"), "{unknown}");
    let wrong = message(i.set("alpha", true));
    assert!(wrong.contains("`alpha` of `rough_conductor` is a `float`, not a bool"), "{wrong}");
    assert!(wrong.contains("physical.tsl"), "located at the declaration: {wrong}");
    let option = message(i.set("distribution", "gxx"));
    assert!(option.contains("has no option \"gxx\" (the options are \"beckmann\", \"ggx\")"), "{option}");
    assert!(option.contains("did you mean \"ggx\"?"), "{option}");
    let nan = message(i.set("alpha", f32::NAN));
    assert!(nan.contains("must be finite"), "{nan}");
    let color = message(i.set("eta", 1.5));
    assert!(color.contains("is a `color`, not a float"), "{color}");
    assert!(i.values().iter().all(Option::is_none), "failed sets change nothing");
    // An int is a float, as in TSL source.
    i.set("alpha", 1).unwrap();
    assert_eq!(i.value("alpha"), Some(&ParamValue::Float(1.0)));

    let layered = program.shader("layered").unwrap();
    let array = message(layered.instance().set("w", 0.5));
    assert!(array.contains("`w` of `layered` is a `float[2]`: set it in TSL source"), "{array}");
    let other = self::program(HOST, ColorModel::Rgb).shader("lambert").unwrap().instance();
    let foreign = message(layered.instance().set("top", other));
    assert!(foreign.contains("takes an instance of a shader of the same program"), "{foreign}");
    let not_material = message(layered.instance().set("top", 0.5));
    assert!(not_material.contains("is a `material`, not a float"), "{not_material}");

    // A spectral program takes its own model's lanes (tests/runtime_params.rs);
    // a Hero program's lanes have no fixed wavelengths, so it takes RGB.
    let spectral = self::program(HOST, ColorModel::Spectral { samples: 8 });
    assert!(spectral.shader("lambert").unwrap().instance().set("kd", spectral.rgb(0.5, 0.5, 0.5)).is_ok());
    let hero = self::program(HOST, ColorModel::Hero);
    let lanes = message(hero.shader("lambert").unwrap().instance().set("kd", hero.rgb(0.5, 0.5, 0.5)));
    assert!(lanes.contains("takes a color's RGB ([f32; 3])"), "{lanes}");
    let mixed = message(metal.instance().set("eta", spectral.rgb(0.5, 0.5, 0.5)));
    assert!(mixed.contains("takes a color of the program's model"), "{mixed}");

    let cutout = program.shader("cutout").unwrap();
    let err = cutout.instance().specialise().unwrap_err().to_string();
    assert!(err.contains("`cutout` needs a value for `alpha`, `m` (no default)"), "{err}");
}

/// A value unlike the default for each settable parameter, and the same
/// value as TSL source text written by hand (shortest digits).
fn non_default(p: &tsl::ParamInfo, k: usize, program: &Program) -> Option<(ParamValue, String)> {
    if p.array_len.is_some() {
        return None;
    }
    let x = 0.15 + 0.1 * k as f32;
    Some(match p.ty {
        ParamType::Float => (ParamValue::Float(x), format!("{x}")),
        ParamType::Int => (ParamValue::Int(k as i32 + 2), format!("{}", k + 2)),
        ParamType::Bool => {
            let b = p.default != Some(ParamValue::Bool(true));
            (ParamValue::Bool(b), b.to_string())
        }
        ParamType::Color => {
            let rgb = [x, 0.5, 1.0 - x / 2.0];
            (ParamValue::Triple(rgb), format!("rgb({}, {}, {})", rgb[0], rgb[1], rgb[2]))
        }
        ParamType::Vector | ParamType::Point | ParamType::Normal => {
            let t = [x, -0.5, 0.25];
            (ParamValue::Triple(t), format!("{}({}, {}, {})", p.ty, t[0], t[1], t[2]))
        }
        ParamType::Vec2 => (ParamValue::Vec2([x, 0.5]), format!("vec2({x}, 0.5)")),
        ParamType::String => {
            let last = p.options.last()?.clone();
            (ParamValue::String(last.clone()), format!("\"{last}\""))
        }
        ParamType::Material => {
            let mut kd = program.shader("phong").ok()?.instance();
            kd.set("ns", 12.0).ok()?;
            (kd.into(), "phong(ns: 12)".into())
        }
        ParamType::Matrix | ParamType::BsdfSample => return None,
    })
}

/// Every interface method of both materials, on the same arguments at the
/// same points, gives the same bits.
fn assert_same_bits(a: &Material, b: &Material, what: &str) {
    let mut rng = Rng(0x5eed);
    for _ in 0..4 {
        let g = shading_point(&mut rng);
        for method in tsl::check::Method::ALL {
            let (fa, fb) = (a.method(method).unwrap(), b.method(method).unwrap());
            let words = args(&mut rng, fa.params(), a.color_model());
            let n = fa.result_types().len();
            let (mut oa, mut ob) = (vec![0u32; n], vec![0u32; n]);
            fa.call_words(Backend::Jit, &g, &words, &mut oa).unwrap();
            fb.call_words(Backend::Jit, &g, &words, &mut ob).unwrap();
            assert_eq!(oa, ob, "{what}: `{}` differs", method.name());
        }
    }
}

#[test]
fn specialised_instances_equal_the_same_call_in_source() {
    for model in [ColorModel::Rgb, ColorModel::Spectral { samples: 8 }] {
        let program = program(HOST, model);
        let mut calls = Vec::new();
        let mut instances = Vec::new();
        for shader in prelude_shaders(&program) {
            let mut instance = shader.instance();
            let mut args = Vec::new();
            for (k, p) in shader.params().iter().enumerate() {
                let Some((value, text)) = non_default(p, k, &program) else { continue };
                instance.set(&p.name, value).unwrap_or_else(|e| panic!("{}.{}: {e}", shader.name(), p.name));
                args.push(format!("{}: {text}", p.name));
            }
            calls.push(format!("material m_{} = {}({});", shader.name(), shader.name(), args.join(", ")));
            instances.push(instance);
        }
        let source = self::program(&calls.join("\n"), model);
        for instance in &instances {
            let name = instance.shader().name();
            let specialised = instance.specialise().unwrap_or_else(|e| panic!("{name}: {e}"));
            let written = source.material(&format!("m_{name}")).unwrap();
            assert_same_bits(&specialised, &written, &format!("{model:?} {}", instance.source()));
        }
    }
}

#[test]
fn user_templates_specialise_like_their_source_call() {
    let src = format!(
        "{}material written = car_paint(base: rgb(0.1, 0.2, 0.7), finish: \"satin\", under: rough_conductor(alpha: 0.4));",
        common::CAR_PAINT
    );
    let program = program(&src, ColorModel::Rgb);
    let mut under = program.shader("rough_conductor").unwrap().instance();
    under.set("alpha", 0.4).unwrap();
    let mut paint = program.shader("car_paint").unwrap().instance();
    paint.set("base", [0.1, 0.2, 0.7]).unwrap().set("finish", "satin").unwrap().set("under", &under).unwrap();
    assert_same_bits(&paint.specialise().unwrap(), &program.material("written").unwrap(), "car_paint");
    // A Color of an RGB program is written as its lanes.
    let mut by_color = program.shader("car_paint").unwrap().instance();
    by_color
        .set("base", program.rgb(0.1, 0.2, 0.7))
        .unwrap()
        .set("finish", "satin")
        .unwrap()
        .set("under", under)
        .unwrap();
    assert_same_bits(&by_color.specialise().unwrap(), &program.material("written").unwrap(), "car_paint by Color");
}

#[test]
fn stdlib_header_tables_agree_with_the_declarations() {
    let program = program(HOST, ColorModel::Rgb);
    let shaders = prelude_shaders(&program);
    let mut problems = Vec::new();
    for file in ["materials", "physical", "openpbr", "texturing"] {
        let text = std::fs::read_to_string(format!("stdlib/{file}.tsl")).unwrap();
        let header: Vec<&str> = text.lines().map_while(|l| l.strip_prefix("//")).collect();
        let names: Vec<&str> = shaders.iter().map(Shader::name).collect();
        for shader in &shaders {
            let Some(at) = header.iter().position(|l| introduces(l, shader.name())) else { continue };
            let table = table_rows(&header[at + 1..], &names);
            for p in shader.params() {
                let Some(row) = table.iter().find(|r| r.name == p.name) else {
                    problems.push(format!("{file}.tsl: {}.{} is not in its table", shader.name(), p.name));
                    continue;
                };
                let doc = p.doc.clone().unwrap_or_default().replace('\n', " ");
                if row.meaning != doc {
                    problems.push(format!("{}.{}: table {:?}, doc {doc:?}", shader.name(), p.name, row.meaning));
                }
                if row.ty != p.type_text() {
                    problems.push(format!(
                        "{}.{}: table type {}, declared {}",
                        shader.name(),
                        p.name,
                        row.ty,
                        p.type_text()
                    ));
                }
                let default = p.default_source.as_deref().unwrap_or("required");
                if !row.default.starts_with(default) {
                    problems.push(format!(
                        "{}.{}: table default {}, declared {default}",
                        shader.name(),
                        p.name,
                        row.default
                    ));
                }
            }
            if !shader.params().is_empty() && table.is_empty() {
                problems.push(format!("{file}.tsl: {} has no table", shader.name()));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Whether a header line introduces `name`: `name -- title` or `name(...)`.
fn introduces(line: &str, name: &str) -> bool {
    let t = line.trim();
    !t.contains('|') && t.strip_prefix(name).is_some_and(|rest| rest.starts_with('(') || rest.starts_with(" --"))
}

struct Row {
    name: String,
    ty: String,
    default: String,
    meaning: String,
}

/// The table rows after a template's introduction, up to the next
/// template's: `name | type | default | meaning`, continuation rows (an
/// empty first cell) joined to the meaning.
fn table_rows(lines: &[&str], templates: &[&str]) -> Vec<Row> {
    let mut rows: Vec<Row> = Vec::new();
    for line in lines {
        if templates.iter().any(|t| introduces(line, t)) {
            break;
        }
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let rule = !cells[0].is_empty() && cells[0].chars().all(|c| c == '-' || c == '+');
        if cells.len() != 4 || cells[0] == "Parameter" || rule {
            continue;
        }
        match rows.last_mut() {
            Some(last) if cells[0].is_empty() => {
                last.meaning = format!("{} {}", last.meaning, cells[3]);
            }
            _ => rows.push(Row {
                name: cells[0].into(),
                ty: cells[1].into(),
                default: cells[2].into(),
                meaning: cells[3].into(),
            }),
        }
    }
    rows
}
