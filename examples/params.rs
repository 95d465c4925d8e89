//! A host asking what a material template takes and making instances of it:
//! `rough_conductor`'s parameters with their types, defaults and docs,
//! instances at alpha 0.05, 0.2 and 0.6 bound at run time to one compiled
//! shader shading one point (the compile count shows nothing compiled
//! after the first), a spectral host's own spectrum as a `color` value,
//! and the errors of a wrong name and a wrong type.
//!
//! `cargo run --example params`

use tsl::{ColorModel, Compiler, ShadingGlobals};

fn main() -> Result<(), tsl::Error> {
    let program =
        Compiler::new().color_model(ColorModel::Rgb).source("host.tsl", "material host = lambert;").compile()?;
    let shader = program.shader("rough_conductor")?;

    println!("material {}: {}", shader.name(), shader.doc().unwrap_or(""));
    for p in shader.params() {
        let default = p.default_source.as_deref().unwrap_or("(required)");
        let options = if p.options.is_empty() { String::new() } else { format!(" in {:?}", p.options) };
        println!("  {:<6} {:<21} = {default}{options}", p.type_text(), p.name);
        if let Some(doc) = &p.doc {
            println!("         {}", doc.replace('\n', " "));
        }
    }

    // One shading point: a flat surface facing +z, lit and seen at 30
    // degrees from the normal, half way round from each other.
    let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], dpdu: [1.0, 0.0, 0.0], ..Default::default() };
    let (s, c) = 30f32.to_radians().sin_cos();
    let (wi, wo) = ([-s, 0.0, c], [s, 0.0, c]);
    let light = program.rgb(1.0, 1.0, 1.0);
    println!("\nreflection of unit light, mirror configuration at 30 degrees (gold), one compiled shader:");
    let mut gold = shader.instance();
    gold.set("distribution", "ggx")?;
    gold.set("eta", [0.143, 0.374, 1.442])?.set("k", [3.983, 2.385, 1.603])?;
    let mut compiled_after_first = None;
    for alpha in [0.05f32, 0.2, 0.6] {
        // Binding writes the instance's parameter block; the shader's code
        // is compiled on the first bind only.
        let material = gold.set("alpha", alpha)?.bind()?;
        let compiled = *compiled_after_first.get_or_insert(program.compiled_functions());
        let [r, g_, b] = material.reflection(&g, wi, &light, wo).to_rgb();
        let new = program.compiled_functions() - compiled;
        println!("  alpha {alpha:<4}  rgb({r:.4}, {g_:.4}, {b:.4})  functions compiled since the first: {new}");
    }

    // What binding costs: writing the block and sharing the compiled code.
    let start = std::time::Instant::now();
    let binds = 1000;
    for k in 0..binds {
        gold.set("alpha", 0.05 + k as f32 * 1e-4)?.bind()?;
    }
    println!("  one bind: {:.1} us", start.elapsed().as_secs_f64() * 1e6 / f64::from(binds));

    // A spectral host gives a color as a spectrum of the program's model.
    let model = ColorModel::Spectral { samples: 8 };
    let spectral = Compiler::new().color_model(model).source("host.tsl", "material host = lambert;").compile()?;
    let ramp: Vec<f32> = (1..=8).map(|i| 0.1 * i as f32).collect();
    let lambert = spectral.shader("lambert")?.instance().set("kd", tsl::Color::from_lanes(model, &ramp))?.bind()?;
    let f = lambert.reflection(&g, wi, &tsl::Color::from_lanes(model, &[1.0; 8]), wo);
    println!("\nlambert, kd a ramp over 8 bins (spectral), reflection per bin: {:.4?}", f.lanes());

    println!("\nmistakes a host makes, caught when the value is set:");
    let mut instance = shader.instance();
    if let Err(e) = instance.set("roughness", 0.2) {
        print!("{e}");
    }
    if let Err(e) = instance.set("alpha", "rough") {
        print!("{e}");
    }
    Ok(())
}
