//! A host asking what a material template takes and making instances of it:
//! `rough_conductor`'s parameters with their types, defaults and docs,
//! three instances at alpha 0.05, 0.2 and 0.6 shading one point, and the
//! errors of a wrong name and a wrong type.
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
    println!("\nreflection of unit light, mirror configuration at 30 degrees (gold):");
    for alpha in [0.05f32, 0.2, 0.6] {
        let mut gold = shader.instance();
        gold.set("alpha", alpha)?.set("distribution", "ggx")?;
        gold.set("eta", [0.143, 0.374, 1.442])?.set("k", [3.983, 2.385, 1.603])?;
        let material = gold.specialise()?;
        let [r, g_, b] = material.reflection(&g, wi, &light, wo).to_rgb();
        println!("  alpha {alpha:<4}  rgb({r:.4}, {g_:.4}, {b:.4})");
    }

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
