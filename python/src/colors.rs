//! Colors across the boundary: Python gives and gets linear RGB; a
//! spectral program's inputs are upsampled as the program upsamples RGB
//! (`Program::rgb`), and its results converted back point by point
//! (`Color::to_rgb`).

use crate::arrays::Input;
use tsl::{Color, ColorModel};

/// The lanes of the RGB inputs `rgb` (three [`Input`]s) upsampled into
/// `program`'s model, point by point when `points` says so (`None`: one
/// color for all). Empty for an RGB program, which reads `rgb` as it is.
pub fn upsample(program: &tsl::Program, rgb: &[Input<'_>], points: Option<usize>) -> Vec<f32> {
    if program.color_model() == ColorModel::Rgb {
        return Vec::new();
    }
    let color = |i: usize| program.rgb(rgb[0].get(i), rgb[1].get(i), rgb[2].get(i)).lanes().to_vec();
    (0..points.unwrap_or(1)).flat_map(color).collect()
}

/// One [`Input`] per lane of the model: `rgb` itself for an RGB program,
/// else the lanes [`upsample`] made.
pub fn lanes<'a>(model: ColorModel, rgb: &[Input<'a>], points: Option<usize>, upsampled: &'a [f32]) -> Vec<Input<'a>> {
    let lanes = model.lanes();
    match (model, points) {
        (ColorModel::Rgb, _) => rgb.to_vec(),
        (_, Some(_)) => (0..lanes).map(|k| Input::Strided { values: upsampled, first: k, stride: lanes }).collect(),
        (_, None) => upsampled.iter().map(|&x| Input::Same(x)).collect(),
    }
}

/// Colors of `model` stored point by point (`lanes` floats each) as RGB,
/// three floats a point.
pub fn to_rgb(model: ColorModel, lanes: usize, values: &[f32]) -> Vec<f32> {
    if model == ColorModel::Rgb {
        return values.to_vec();
    }
    values.chunks_exact(lanes.max(1)).flat_map(|c| Color::from_lanes(model, c).to_rgb()).collect()
}
