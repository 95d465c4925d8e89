//! The typed results of material calls (`BsdfSample`, `EvalPdf`,
//! `DeltaLobes`), decoded from result words through the layouts that
//! lowering writes them with (`ir::lower::{SampleLayout, EvalPdfLayout,
//! DeltaLobesLayout}`): no position is written here.
//!
//! Results are generic over where a color's lanes live ([`Lanes`]): a
//! [`Color`] for hosts, or a renderer's own fixed-size type, so a hot loop
//! copies no more lanes than its color model has.

use super::Color;
use crate::color::ColorModel;
use crate::ir::lower::{DeltaLobesLayout, EvalPdfLayout, SampleLayout};

/// Storage for a color's lanes that material calls read and write: a
/// [`Color`], or a host's own type (the renderer's `Spectrum<N>`). Lanes
/// past the color model's count are zero in what a call returns.
pub trait Lanes: Copy {
    /// Every lane zero, for a color of `model`.
    fn zero(model: ColorModel) -> Self;
    /// All lanes held (at least the model's count for a call to accept it).
    fn lanes(&self) -> &[f32];
    fn lanes_mut(&mut self) -> &mut [f32];
    /// A color of `model` whose lanes are the first of `words`, as bits.
    /// A type of a fixed lane count overrides it with a fixed-size copy: a
    /// copy of a count known only at run time is a `memmove` call per
    /// result, which renderers pay at every call.
    fn from_words(model: ColorModel, words: &[u32]) -> Self {
        let mut c = Self::zero(model);
        for (x, w) in c.lanes_mut().iter_mut().zip(words) {
            *x = f32::from_bits(*w);
        }
        c
    }
    /// Appends the first `lanes` lanes to `words`, as bits: the argument
    /// words of a call. A type of a fixed lane count overrides it as
    /// [`Lanes::from_words`], for the same reason.
    ///
    /// # Panics
    /// When the color holds fewer than `lanes` lanes.
    fn push_lanes(&self, lanes: usize, words: &mut Vec<u32>) {
        words.extend_from_slice(bytemuck::cast_slice(&self.lanes()[..lanes]));
    }
}

impl Lanes for Color {
    fn zero(model: ColorModel) -> Self {
        Color::black(model)
    }
    fn lanes(&self) -> &[f32] {
        &self.lanes
    }
    fn lanes_mut(&mut self) -> &mut [f32] {
        &mut self.lanes
    }
}

/// A direction drawn by a material's `sample`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfSample<C = Color> {
    /// The incident direction, unit, pointing away from the surface; the
    /// zero vector when the material drew nothing (the path ends).
    pub wi: [f32; 3],
    /// `f · cos / pdf` for a smooth lobe; for a delta lobe, the response to
    /// unit light along `wi` over the probability of choosing that lobe.
    pub weight: C,
    /// The solid-angle density of `wi` (0 for a delta lobe).
    pub pdf: f32,
    /// Whether `wi` is a perfect (delta) direction: no light sample can
    /// find it, so multiple importance sampling gives it weight 1.
    pub delta: bool,
}

/// What next-event estimation needs of a light direction `wi`, from one
/// call (Mitsuba's `eval_pdf`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalPdf<C = Color> {
    /// `f · cos` for unit light from `wi`: reflection on the viewer's side
    /// of the geometric normal, refraction across it.
    pub value: C,
    /// The density with which `sample` draws `wi`.
    pub pdf: f32,
}

/// One perfect direction and the material's response to unit light along it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeltaLobe<C = Color> {
    /// Unit (as the material gave it; renderers normalise).
    pub dir: [f32; 3],
    pub weight: C,
}

/// Both perfect directions of a surface point, each absent when the
/// material has none there (a zero or non-finite direction).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeltaLobes<C = Color> {
    pub reflect: Option<DeltaLobe<C>>,
    pub refract: Option<DeltaLobe<C>>,
}

impl<C> DeltaLobes<C> {
    pub const NONE: DeltaLobes<C> = DeltaLobes { reflect: None, refract: None };
}

fn float(w: u32) -> f32 {
    f32::from_bits(w)
}

fn vector(words: &[u32]) -> [f32; 3] {
    [float(words[0]), float(words[1]), float(words[2])]
}

/// A color of `model` from result words.
fn color<C: Lanes>(model: ColorModel, words: &[u32]) -> C {
    C::from_words(model, words)
}

/// Whether a direction is the interface's "none".
fn is_none(v: [f32; 3]) -> bool {
    v == [0.0; 3] || !v.iter().all(|x| x.is_finite())
}

impl<C: Lanes> BsdfSample<C> {
    /// Decodes `sample`'s result words.
    #[inline]
    pub(crate) fn from_words(model: ColorModel, out: &[u32]) -> Self {
        let layout = SampleLayout { lanes: model.lanes() };
        BsdfSample {
            wi: vector(&out[SampleLayout::WI]),
            weight: color(model, &out[layout.weight()]),
            pdf: float(out[layout.pdf()]),
            delta: float(out[layout.delta()]) > 0.0,
        }
    }
}

impl<C: Lanes> EvalPdf<C> {
    /// Decodes `eval_pdf`'s result words.
    #[inline]
    pub(crate) fn from_words(model: ColorModel, out: &[u32]) -> Self {
        let layout = EvalPdfLayout { lanes: model.lanes() };
        EvalPdf { value: color(model, &out[layout.value()]), pdf: float(out[layout.pdf()]) }
    }
}

impl<C: Lanes> DeltaLobes<C> {
    /// Decodes `delta_lobes`' result words.
    #[inline]
    pub(crate) fn from_words(model: ColorModel, out: &[u32]) -> Self {
        let layout = DeltaLobesLayout { lanes: model.lanes() };
        let lobe =
            |dir: [f32; 3], weight: &[u32]| (!is_none(dir)).then(|| DeltaLobe { dir, weight: color(model, weight) });
        DeltaLobes {
            reflect: lobe(vector(&out[DeltaLobesLayout::REFLECT_DIR]), &out[layout.reflect_weight()]),
            refract: lobe(vector(&out[layout.refract_dir()]), &out[layout.refract_weight()]),
        }
    }
}

/// The most result words any material call gives: the delta lobes of the
/// widest color model.
pub(crate) const MAX_RESULT_WORDS: usize = 6 + 2 * crate::color::MAX_SAMPLES;

const _: () = assert!(MAX_RESULT_WORDS >= 5 + crate::color::MAX_SAMPLES, "room for a bsdf_sample");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Backend, ColorModel, Compiler, ShadingGlobals};

    /// The combined entries decoded through the layouts give what the
    /// interface methods give one by one: were a layout and its lowering
    /// to disagree, a weight would read a direction or a pdf a lane.
    #[test]
    fn combined_results_decode_as_the_methods_give_them() {
        let src = "material glassy = glass; material plastic = phong(kd: rgb(0.6, 0.3, 0.1));";
        for model in [ColorModel::Rgb, ColorModel::Spectral { samples: 8 }] {
            let program = Compiler::new().color_model(model).source("m.tsl", src).compile().unwrap();
            let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], ..Default::default() };
            let wo = [0.3f32, 0.0, 0.954];
            let eta = program.rgb(1.5, 1.5, 1.5);
            let ones = program.rgb(1.0, 1.0, 1.0);
            let bits = |xs: &[&[f32]]| xs.concat().iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
            let mut out = [0u32; MAX_RESULT_WORDS];

            let glassy = program.material("glassy").unwrap();
            let lobes_fn = &program.delta_lobes(&["glassy"]).unwrap()[0];
            lobes_fn.call_words(Backend::Jit, &g, &bits(&[&wo, eta.lanes()]), &mut out).unwrap();
            let lobes: DeltaLobes = DeltaLobes::from_words(model, &out);
            let (reflect, refract) = (lobes.reflect.unwrap(), lobes.refract.unwrap());
            assert_eq!(reflect.dir, glassy.reflection_dir(&g, wo));
            assert_eq!(reflect.weight, glassy.reflection(&g, reflect.dir, &ones, wo));
            assert_eq!(refract.dir, glassy.refraction_dir(&g, wo, &eta));
            assert_eq!(refract.weight, glassy.refraction(&g, refract.dir, &ones, &eta, wo));

            let plastic = program.material("plastic").unwrap();
            let eval_fn = &program.eval_pdf(&["plastic"]).unwrap()[0];
            let wi = [0.0f32, 0.6, 0.8];
            eval_fn.call_words(Backend::Jit, &g, &bits(&[&wi, &wo, eta.lanes()]), &mut out).unwrap();
            let e: EvalPdf = EvalPdf::from_words(model, &out);
            let f = plastic.reflection(&g, wi, &ones, wo);
            for (a, b) in e.value.lanes().iter().zip(f.lanes()) {
                assert!((a - b).abs() <= 1e-6 * b.abs().max(1.0), "{a} vs {b}");
            }
            assert_eq!(e.pdf, plastic.pdf(&g, wi, wo, &eta));
            assert!(e.pdf > 0.0 && e.value.lanes().iter().all(|x| *x > 0.0));

            let s = plastic.sample(&g, wo, &eta, 0.3, [0.2, 0.7]);
            assert!(!s.delta && s.pdf > 0.0, "{s:?}");
            assert!((s.pdf - plastic.pdf(&g, s.wi, wo, &eta)).abs() <= 1e-4 * s.pdf);
        }
    }
}
