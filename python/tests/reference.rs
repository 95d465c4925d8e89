//! The Rust API's answers for python/tests/test_rust_agreement.py: a
//! material (or a shader instance bound at run time) shaded point by point
//! with `Material::at` and a `ShadingGlobals` filled as the Python
//! package fills unspecified globals. The test compares the bits.
//!
//! `reference FILE NAME [PARAM=VALUE ...] [--color MODEL] < points > results`:
//! with parameters, NAME is a shader instantiated and bound; without, a
//! material. Each point is 17 little-endian f32s (wi, wo, P, N, u, v, the
//! lobe number, the 2D sample); each result 12 (reflection of white light
//! as RGB, pdf of wi, then the sample's wi, RGB weight, pdf and delta).

use std::io::{Read, Write};
use tsl::render::sampling::Frame;
use tsl::{Color, ColorModel, ShadingGlobals, SurfaceRecord};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut model = ColorModel::Rgb;
    if let Some(k) = args.iter().position(|a| a == "--color") {
        model = ColorModel::parse(&args[k + 1]).ok_or("bad color model")?;
        args.drain(k..k + 2);
    }
    let [file, name, params @ ..] = &args[..] else {
        return Err("usage: reference FILE NAME [PARAM=VALUE ...]".into());
    };
    let program = tsl::Compiler::new().color_model(model).file(file).compile()?;
    let material = if params.is_empty() {
        program.material(name)?
    } else {
        let mut instance = program.shader(name)?.instance();
        for p in params {
            let (key, value) = p.split_once('=').ok_or("PARAM=VALUE")?;
            let numbers: Result<Vec<f32>, _> = value.split(',').map(str::parse::<f32>).collect();
            match numbers.as_deref() {
                Ok([x]) => instance.set(key, *x)?,
                Ok([x, y, z]) => instance.set(key, [*x, *y, *z])?,
                _ => instance.set(key, value)?,
            };
        }
        instance.bind()?
    };
    let mut input = Vec::new();
    std::io::stdin().read_to_end(&mut input)?;
    let floats: Vec<f32> = input.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
    let white = program.rgb(1.0, 1.0, 1.0);
    let eta = Color::from_lanes(model, &vec![1.0; model.lanes()]);
    let mut out = Vec::new();
    let mut record = SurfaceRecord::new();
    for p in floats.chunks_exact(17) {
        let v = |k: usize| [p[k], p[k + 1], p[k + 2]];
        let (wi, wo, n) = (v(0), v(3), v(9));
        let frame = Frame::new(tsl::render::Vec3::from(n));
        let g = ShadingGlobals {
            p: v(6),
            pl: v(6),
            n,
            ng: n,
            u: p[12],
            v: p[13],
            dpdu: frame.s.to_array(),
            dpdv: frame.t.to_array(),
            ..Default::default()
        };
        let mut surface = material.at(&g, wo, &eta, &mut record);
        let reflection = surface.reflection(wi, &white);
        let pdf = surface.pdf(wi);
        let s = surface.sample(p[14], [p[15], p[16]]);
        out.extend(reflection.to_rgb());
        out.push(pdf);
        out.extend(s.wi);
        out.extend(s.weight.to_rgb());
        out.push(s.pdf);
        out.push(if s.delta { 1.0 } else { 0.0 });
    }
    let bytes: Vec<u8> = out.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::io::stdout().write_all(&bytes)?;
    Ok(())
}
