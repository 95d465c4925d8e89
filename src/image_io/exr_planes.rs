//! The layers of a [`RenderedImage`](super::RenderedImage) as sample
//! storage the exr crate writes from, read in place: one lane of the
//! interleaved color (or albedo, normal) triples, the depth floats, or the
//! object indices as floats. Writing an image copies no layer into planes
//! first, so it takes no more memory than the image (a merged frame of
//! 2^27 pixels with every AOV layer is 5.5 GiB).

use exr::block::lines::LineRefMut;
use exr::image::write::samples::{SamplesWriter, WritableSamples};
use exr::math::RoundingMode;
use exr::meta::attribute::{LevelMode, SampleType};
use exr::meta::header::Header;

/// One channel, as 32-bit floats, row by row over the layer.
#[derive(Debug, Clone, Copy)]
pub(super) enum Plane<'a> {
    /// Lane `k` of each triple.
    Lane(&'a [[f32; 3]], usize),
    Floats(&'a [f32]),
    /// Whole numbers, stored as floats so any EXR reader takes them.
    Indices(&'a [i32]),
}

impl<'s, 'a> WritableSamples<'s> for Plane<'a> {
    type Writer = PlaneWriter<'a>;

    fn sample_type(&self) -> SampleType {
        SampleType::F32
    }

    fn infer_level_modes(&self) -> (LevelMode, RoundingMode) {
        (LevelMode::Singular, RoundingMode::Down)
    }

    fn create_samples_writer(&'s self, header: &Header) -> PlaneWriter<'a> {
        PlaneWriter { width: header.layer_size.0, plane: *self }
    }
}

/// Lines of a [`Plane`] for the crate's block writer.
#[derive(Debug, Clone, Copy)]
pub(super) struct PlaneWriter<'a> {
    width: usize,
    plane: Plane<'a>,
}

impl SamplesWriter for PlaneWriter<'_> {
    fn extract_line(&self, line: LineRefMut<'_>) {
        let start = line.location.position.1 * self.width + line.location.position.0;
        let range = start..start + line.location.sample_count;
        // Whole lines through the crate's slice writer (a sample at a time
        // would be compiled unoptimised in debug builds: 3x slower).
        let written = match self.plane {
            Plane::Floats(values) => line.write_samples_from_slice(&values[range]),
            Plane::Lane(triples, lane) => {
                let lane: Vec<f32> = triples[range].iter().map(|t| t[lane]).collect();
                line.write_samples_from_slice(&lane)
            }
            Plane::Indices(values) => {
                let floats: Vec<f32> = values[range].iter().map(|&k| k as f32).collect();
                line.write_samples_from_slice(&floats)
            }
        };
        // The crate sizes the line's bytes for its samples: this cannot fail.
        debug_assert!(written.is_ok(), "a line of an EXR block could not be written");
    }
}
