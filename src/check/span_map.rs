//! A map from spans to values kept as a vector in span order, searched by
//! bisection: the checker's expression types ([`super::ExprTypes`]) and
//! name resolutions. A generated scene of a million objects has a million
//! resolutions (one per `material` name), and a hash table of them was
//! twice their size (half its buckets empty).
//! Entries arrive in span order when every expression is checked once, in
//! source order; otherwise the vector is sorted once when checking ends.

use crate::diag::Span;

/// The order of the entries: by file and start, an enclosing expression
/// (the longer span) before the ones it contains. Packed into one integer,
/// so a step of a bisection is one comparison.
fn key(span: &Span) -> Key {
    (u128::from(span.file.0) << 64) | (u128::from(span.start) << 32) | u128::from(u32::MAX - span.end)
}

type Key = u128;

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

    /// The entries of `outer` and of every span that starts inside it, to
    /// look up many spans of one expression by bisecting only its own
    /// entries (a constant's value among a million expressions).
    pub fn within(&self, outer: &Span) -> SpanSlice<'_, T> {
        debug_assert!(self.ordered, "SpanMap searched before finish");
        let lo = key(outer);
        // The first key of a span starting at `outer.end` (the longest).
        let hi = key(&Span { start: outer.end, end: u32::MAX, ..*outer });
        let first = self.entries.partition_point(|(s, _)| key(s) < lo);
        // The entries inside are the expression's own: walking them costs
        // what using them does.
        let count = self.entries[first..].iter().take_while(|(s, _)| key(s) < hi).count();
        SpanSlice { entries: &self.entries[first..first + count], lo, hi }
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

/// The part of a [`SpanMap`] that [`SpanMap::within`] returns: the
/// entries whose keys lie in `lo..hi`.
#[derive(Debug)]
pub struct SpanSlice<'a, T> {
    entries: &'a [(Span, T)],
    lo: Key,
    hi: Key,
}

// Not derived: a slice is `Copy` whatever `T` is.
impl<T> Clone for SpanSlice<'_, T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for SpanSlice<'_, T> {}

impl<'a, T> SpanSlice<'a, T> {
    /// The value of `span` if it lies in this part of the map; `None` when
    /// it lies outside (the whole map may still have it) or has no entry.
    pub fn get(&self, span: &Span) -> Option<&'a T> {
        let k = key(span);
        if k < self.lo || k >= self.hi {
            return None;
        }
        let at = self.entries.binary_search_by(|(s, _)| key(s).cmp(&k)).ok()?;
        Some(&self.entries[at].1)
    }

    /// How many entries this part holds.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
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

    #[test]
    fn a_slice_within_a_span_finds_what_the_map_finds_inside_it_and_nothing_outside() {
        let mut map = SpanMap::default();
        // An expression `0..10` holding `0..4` (holding `1..3`) and `5..10`;
        // then `10..12`, which starts where it ends, and one in another file.
        for (k, (start, end)) in [(0, 10), (0, 4), (1, 3), (5, 10), (10, 12), (12, 20)].into_iter().enumerate() {
            map.insert(span(start, end), k);
        }
        map.insert(Span { file: FileId(1), start: 2, end: 3 }, 6);
        map.finish();
        let whole = map.within(&span(0, 10));
        assert_eq!(whole.len(), 4);
        for (start, end) in [(0, 10), (0, 4), (1, 3), (5, 10)] {
            assert_eq!(whole.get(&span(start, end)), map.get(&span(start, end)));
            assert!(whole.get(&span(start, end)).is_some());
        }
        for outside in [span(10, 12), span(12, 20), Span { file: FileId(1), start: 2, end: 3 }, span(0, 11)] {
            assert_eq!(whole.get(&outside), None, "{outside:?}");
        }
        let inner = map.within(&span(0, 4));
        assert_eq!(inner.len(), 2);
        assert_eq!(inner.get(&span(1, 3)), Some(&2));
        assert_eq!(inner.get(&span(0, 10)), None);
        assert_eq!(inner.get(&span(5, 10)), None);
        assert!(map.within(&span(30, 40)).is_empty());
    }
}
