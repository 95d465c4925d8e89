//! The type of every expression of a checked program, by the expression's
//! span. A generated scene of a million objects has six million
//! expressions, so an entry is 16 bytes (the span and a code: an index into
//! the types that are not arrays, or into the array types met, few and
//! shared), kept in a [`SpanMap`] in the order the checker meets
//! expressions, outermost first: that is the spans' order (file, start,
//! longest first) when every expression is checked once, in source order.

use super::Ty;
use super::span_map::{SpanMap, SpanSlice};
use crate::diag::Span;

/// The types without parameters, in code order.
static PLAIN: [Ty; 14] = [
    Ty::Float,
    Ty::Int,
    Ty::Bool,
    Ty::Color,
    Ty::Vector,
    Ty::Point,
    Ty::Normal,
    Ty::Vec2,
    Ty::Matrix,
    Ty::BsdfSample,
    Ty::String,
    Ty::Material,
    Ty::Void,
    Ty::Error,
];

/// The code of a slot opened but not yet given its type.
const OPEN: u32 = u32::MAX;

/// An expression's span to its type; an expression checked twice has the
/// type it was given last.
#[derive(Debug, Clone, Default)]
pub struct ExprTypes {
    /// Each expression's type code.
    codes: SpanMap<u32>,
    /// The array types met, by code minus `PLAIN.len()`.
    arrays: Vec<Ty>,
}

impl ExprTypes {
    /// The type of the expression written at `span`.
    pub fn get(&self, span: &Span) -> Option<&Ty> {
        self.codes.get(span).map(|code| self.ty(*code))
    }

    /// The types of the expression written at `outer` and of the
    /// expressions inside it, found without searching the whole program.
    pub fn within(&self, outer: &Span) -> ExprTypesWithin<'_> {
        ExprTypesWithin { codes: self.codes.within(outer), types: self }
    }

    pub fn contains_key(&self, span: &Span) -> bool {
        self.codes.get(span).is_some()
    }

    /// Every expression's span and type, in span order.
    pub fn iter(&self) -> impl Iterator<Item = (&Span, &Ty)> {
        self.codes.iter().map(|(span, code)| (span, self.ty(*code)))
    }

    pub fn len(&self) -> usize {
        self.codes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.codes.is_empty()
    }

    /// Opens the entry of an expression about to be checked, before the
    /// expressions inside it, so entries arrive in span order; the
    /// returned slot is given its type by [`ExprTypes::set`].
    pub(super) fn open(&mut self, span: Span) -> usize {
        self.codes.insert(span, OPEN)
    }

    pub(super) fn set(&mut self, slot: usize, ty: &Ty) {
        let code = match PLAIN.iter().position(|t| t == ty) {
            Some(k) => k,
            None => match self.arrays.iter().position(|t| t == ty) {
                Some(k) => PLAIN.len() + k,
                None => {
                    self.arrays.push(ty.clone());
                    PLAIN.len() + self.arrays.len() - 1
                }
            },
        };
        self.codes.set(slot, code as u32);
    }

    pub(super) fn insert(&mut self, span: Span, ty: &Ty) {
        let slot = self.open(span);
        self.set(slot, ty);
    }

    /// Puts the entries in span order, keeping the last type given to a
    /// span checked twice, once checking is done.
    pub(super) fn finish(&mut self) {
        self.codes.finish();
    }

    pub(super) fn retain(&mut self, keep: impl FnMut(&Span) -> bool) {
        self.codes.retain(keep);
    }

    fn ty(&self, code: u32) -> &Ty {
        let code = code as usize;
        PLAIN.get(code).unwrap_or_else(|| &self.arrays[code - PLAIN.len()])
    }
}

/// The types of one expression and of those inside it
/// ([`ExprTypes::within`]).
#[derive(Debug, Clone, Copy)]
pub struct ExprTypesWithin<'a> {
    codes: SpanSlice<'a, u32>,
    types: &'a ExprTypes,
}

impl<'a> ExprTypesWithin<'a> {
    /// The type of the expression written at `span` if it lies inside;
    /// `None` for one outside (ask the whole [`ExprTypes`]).
    pub fn get(&self, span: &Span) -> Option<&'a Ty> {
        self.codes.get(span).map(|code| self.types.ty(*code))
    }
}

impl<'a> IntoIterator for &'a ExprTypes {
    type Item = (&'a Span, &'a Ty);
    type IntoIter = Box<dyn Iterator<Item = (&'a Span, &'a Ty)> + 'a>;

    fn into_iter(self) -> Self::IntoIter {
        Box::new(self.iter())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diag::FileId;

    #[test]
    fn every_type_comes_back_and_the_last_insert_wins() {
        let mut types = ExprTypes::default();
        let at = |k: u32| Span { file: FileId(k % 3), start: k, end: k + 1 };
        let mut all: Vec<Ty> = PLAIN.to_vec();
        all.push(Ty::Array(Box::new(Ty::Float), 4));
        all.push(Ty::Array(Box::new(Ty::Color), 0));
        all.push(Ty::Array(Box::new(Ty::Float), 4));
        for (k, ty) in all.iter().enumerate() {
            types.insert(at(k as u32), ty);
        }
        types.insert(at(0), &Ty::Int);
        types.finish();
        for (k, ty) in all.iter().enumerate().skip(1) {
            assert_eq!(types.get(&at(k as u32)), Some(ty));
        }
        assert_eq!(types.arrays.len(), 2, "array types are shared");
        assert_eq!(types.get(&at(0)), Some(&Ty::Int));
        assert_eq!(types.get(&at(99)), None);
        assert_eq!(types.iter().count(), all.len());
    }

    #[test]
    fn nested_spans_opened_outermost_first_stay_in_order() {
        let mut types = ExprTypes::default();
        let span = |start, end| Span { file: FileId(1), start, end };
        // `(a + b, c)`: the tuple, the sum, its operands, then `c`.
        let outer = types.open(span(0, 10));
        let sum = types.open(span(1, 6));
        types.insert(span(1, 2), &Ty::Float);
        types.insert(span(5, 6), &Ty::Int);
        types.set(sum, &Ty::Float);
        types.insert(span(8, 9), &Ty::Color);
        types.set(outer, &Ty::Point);
        assert!(types.codes.is_ordered());
        types.finish();
        assert_eq!(types.get(&span(0, 10)), Some(&Ty::Point));
        assert_eq!(types.get(&span(1, 6)), Some(&Ty::Float));
        assert_eq!(types.get(&span(1, 2)), Some(&Ty::Float));
        assert_eq!(types.get(&span(5, 6)), Some(&Ty::Int));
        assert_eq!(types.get(&span(8, 9)), Some(&Ty::Color));
        assert_eq!(types.get(&span(1, 5)), None);
    }
}
