//! A map from spans to values kept as a vector in span order, searched by
//! bisection: the checker's expression types ([`super::ExprTypes`]) and
//! name resolutions. A generated scene of a million objects has a million
//! resolutions (one per `material` name), and a hash table of them was
//! twice their size (half its buckets empty).
//! Entries arrive in span order when every expression is checked once, in
//! source order; otherwise the vector is sorted once when checking ends.

use crate::diag::Span;
use std::cmp::Reverse;

/// The order of the entries: by file and start, an enclosing expression
/// before the ones it contains.
fn key(span: &Span) -> (u32, u32, Reverse<u32>) {
    (span.file.0, span.start, Reverse(span.end))
}

#[derive(Debug, Clone)]
pub struct SpanMap<T> {
    entries: Vec<(Span, T)>,
    /// Whether `entries` is in span order with no span twice.
    ordered: bool,
}

impl<T> Default for SpanMap<T> {
    fn default() -> Self {
        SpanMap { entries: Vec::new(), ordered: true }
    }
}

impl<T> SpanMap<T> {
    /// The value of `span`.
    pub fn get(&self, span: &Span) -> Option<&T> {
        debug_assert!(self.ordered, "SpanMap searched before finish");
        let k = key(span);
        let at = self.entries.binary_search_by(|(s, _)| key(s).cmp(&k)).ok()?;
        Some(&self.entries[at].1)
    }

    /// Every span and its value, in span order.
    pub fn iter(&self) -> impl Iterator<Item = (&Span, &T)> {
        self.entries.iter().map(|(span, value)| (span, value))
    }

    /// Whether no entry has come out of span order (so `finish` sorts nothing).
    #[cfg(test)]
    pub(super) fn is_ordered(&self) -> bool {
        self.ordered
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Gives `span` its value; a span given values twice keeps the last.
    /// Returns the entry's slot, whose value [`SpanMap::set`] may replace
    /// until [`SpanMap::finish`].
    pub(super) fn insert(&mut self, span: Span, value: T) -> usize {
        if let Some((last, _)) = self.entries.last()
            && key(last) >= key(&span)
        {
            self.ordered = false;
        }
        self.entries.push((span, value));
        self.entries.len() - 1
    }

    /// Replaces the value of the entry `insert` returned `slot` for.
    pub(super) fn set(&mut self, slot: usize, value: T) {
        self.entries[slot].1 = value;
    }

    /// Keeps the entries whose span `keep` accepts, and gives the memory
    /// of the others back.
    pub(super) fn retain(&mut self, mut keep: impl FnMut(&Span) -> bool) {
        self.entries.retain(|(span, _)| keep(span));
        self.entries.shrink_to_fit();
    }

    /// Puts the entries in span order, once checking is done.
    pub(super) fn finish(&mut self) {
        if !self.ordered {
            // Stable: of equal spans the last given stays last.
            self.entries.sort_by_key(|(s, _)| key(s));
            self.entries.dedup_by(|later, kept| {
                let same = later.0 == kept.0;
                if same {
                    std::mem::swap(&mut kept.1, &mut later.1);
                }
                same
            });
            self.ordered = true;
        }
        self.entries.shrink_to_fit();
    }
}

impl<'a, T> IntoIterator for &'a SpanMap<T> {
    type Item = (&'a Span, &'a T);
    type IntoIter = std::iter::Map<std::slice::Iter<'a, (Span, T)>, fn(&'a (Span, T)) -> (&'a Span, &'a T)>;

    fn into_iter(self) -> Self::IntoIter {
        self.entries.iter().map(|(span, value)| (span, value))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diag::FileId;

    fn span(start: u32, end: u32) -> Span {
        Span { file: FileId(0), start, end }
    }

    #[test]
    fn finds_values_inserted_in_any_order_and_keeps_the_last() {
        let mut map = SpanMap::default();
        map.insert(span(0, 10), 'a');
        map.insert(span(0, 4), 'b');
        map.insert(span(20, 25), 'c');
        map.insert(span(5, 8), 'd');
        map.insert(span(0, 4), 'e');
        map.finish();
        assert_eq!(map.len(), 4);
        assert_eq!(map.get(&span(0, 10)), Some(&'a'));
        assert_eq!(map.get(&span(0, 4)), Some(&'e'));
        assert_eq!(map.get(&span(5, 8)), Some(&'d'));
        assert_eq!(map.get(&span(20, 25)), Some(&'c'));
        assert_eq!(map.get(&span(1, 4)), None);
        let order: Vec<char> = map.iter().map(|(_, v)| *v).collect();
        assert_eq!(order, ['a', 'e', 'd', 'c']);
    }
}
