//! The word layouts of the results a host decodes: a `bsdf_sample`, an
//! `eval_pdf` and the `delta_lobes`. Lowering writes these results only
//! through [`SampleLayout::assemble`], [`EvalPdfLayout::assemble`] and
//! [`DeltaLobesLayout::assemble`], and the embedding API reads them only
//! through the same layouts' ranges (`api::outputs`), so the two cannot
//! disagree: a layout is defined here once, for a color model of `lanes`
//! lanes.

use std::ops::Range;

/// A `bsdf_sample`: `[wi (3) | weight (lanes) | pdf | delta (0 or 1)]`,
/// the order of `check::SAMPLE_FIELDS`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SampleLayout {
    pub lanes: usize,
}

impl SampleLayout {
    pub const WI: Range<usize> = 0..3;

    pub fn weight(self) -> Range<usize> {
        3..3 + self.lanes
    }

    pub fn pdf(self) -> usize {
        3 + self.lanes
    }

    /// 1.0 for a delta lobe, else 0.0.
    pub fn delta(self) -> usize {
        4 + self.lanes
    }

    pub fn words(self) -> usize {
        5 + self.lanes
    }

    /// The words of the field `name` of `check::SAMPLE_FIELDS`.
    pub fn field(self, name: &str) -> Option<Range<usize>> {
        match name {
            "wi" => Some(Self::WI),
            "weight" => Some(self.weight()),
            "pdf" => Some(self.pdf()..self.pdf() + 1),
            "delta" => Some(self.delta()..self.delta() + 1),
            _ => None,
        }
    }

    /// The words of a sample in this layout: the one place they are ordered.
    pub fn assemble<T: Copy>(self, wi: &[T], weight: &[T], pdf: T, delta: T) -> Vec<T> {
        debug_assert!(wi.len() == 3 && weight.len() == self.lanes);
        let mut out = Vec::with_capacity(self.words());
        out.extend_from_slice(wi);
        out.extend_from_slice(weight);
        out.push(pdf);
        out.push(delta);
        out
    }
}

/// `eval_pdf`'s result: `[f · cos for unit light (lanes) | pdf]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EvalPdfLayout {
    pub lanes: usize,
}

impl EvalPdfLayout {
    pub fn value(self) -> Range<usize> {
        0..self.lanes
    }

    pub fn pdf(self) -> usize {
        self.lanes
    }

    pub fn words(self) -> usize {
        self.lanes + 1
    }

    pub fn assemble<T: Copy>(self, value: &[T], pdf: T) -> Vec<T> {
        debug_assert_eq!(value.len(), self.lanes);
        let mut out = Vec::with_capacity(self.words());
        out.extend_from_slice(value);
        out.push(pdf);
        out
    }
}

/// `delta_lobes`' result: the mirror direction and its response to unit
/// light, then the refracted direction and its response:
/// `[reflect dir (3) | weight (lanes) | refract dir (3) | weight (lanes)]`.
/// A zero direction means there is no such lobe.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DeltaLobesLayout {
    pub lanes: usize,
}

impl DeltaLobesLayout {
    pub const REFLECT_DIR: Range<usize> = 0..3;

    pub fn reflect_weight(self) -> Range<usize> {
        3..3 + self.lanes
    }

    pub fn refract_dir(self) -> Range<usize> {
        3 + self.lanes..6 + self.lanes
    }

    pub fn refract_weight(self) -> Range<usize> {
        6 + self.lanes..6 + 2 * self.lanes
    }

    pub fn words(self) -> usize {
        6 + 2 * self.lanes
    }

    pub fn assemble<T: Copy>(self, reflect_dir: &[T], reflect: &[T], refract_dir: &[T], refract: &[T]) -> Vec<T> {
        debug_assert!(reflect_dir.len() == 3 && refract_dir.len() == 3);
        debug_assert!(reflect.len() == self.lanes && refract.len() == self.lanes);
        [reflect_dir, reflect, refract_dir, refract].concat()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{SAMPLE_FIELDS, Ty};

    /// Each layout's ranges tile its words in the order `assemble` writes
    /// them, for RGB and a spectral model.
    #[test]
    fn ranges_are_where_assemble_writes() {
        for lanes in [3, 8] {
            let words: Vec<usize> = (0..lanes + 5).collect();
            let s = SampleLayout { lanes };
            let assembled = s.assemble(&words[..3], &words[3..3 + lanes], words[3 + lanes], words[4 + lanes]);
            assert_eq!(assembled, words);
            assert_eq!(&assembled[SampleLayout::WI], &words[..3]);
            assert_eq!(&assembled[s.weight()], &words[3..3 + lanes]);
            assert_eq!((assembled[s.pdf()], assembled[s.delta()], s.words()), (3 + lanes, 4 + lanes, 5 + lanes));

            let e = EvalPdfLayout { lanes };
            let assembled = e.assemble(&words[..lanes], 99);
            assert_eq!((&assembled[e.value()], assembled[e.pdf()], e.words()), (&words[..lanes], 99, lanes + 1));

            let d = DeltaLobesLayout { lanes };
            let (dr, wr, dt, wt) = (vec![1; 3], vec![2; lanes], vec![3; 3], vec![4; lanes]);
            let assembled = d.assemble(&dr, &wr, &dt, &wt);
            assert_eq!(assembled.len(), d.words());
            assert_eq!(&assembled[DeltaLobesLayout::REFLECT_DIR], &dr[..]);
            assert_eq!(&assembled[d.reflect_weight()], &wr[..]);
            assert_eq!(&assembled[d.refract_dir()], &dt[..]);
            assert_eq!(&assembled[d.refract_weight()], &wt[..]);
        }
    }

    /// The checker's field order (`s.pdf` in TSL) is the layout's.
    #[test]
    fn sample_fields_follow_the_layout() {
        let layout = SampleLayout { lanes: 16 };
        let mut start = 0;
        for (name, ty) in SAMPLE_FIELDS {
            let n = match ty {
                Ty::Vector => 3,
                Ty::Color => 16,
                _ => 1,
            };
            assert_eq!(layout.field(name), Some(start..start + n), "field {name}");
            start += n;
        }
        assert_eq!(start, layout.words());
    }
}
