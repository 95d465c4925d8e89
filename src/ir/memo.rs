//! Lowering's memo: what a pure operation, an inlined call, a material
//! method, a noise site or a texture lookup already computed, in scopes
//! that follow the structured control flow being built (a value defined in
//! a branch is not visible after it).
//!
//! Every key is hashed once, when it is looked up or stored: a lookup then
//! probes each open scope with that hash, and a table that grows reuses its
//! entries' stored hashes. (A map per scope hashing the key at each level
//! was a tenth of the compile time of a deep texture tree.)

use super::Value;
use super::builder::MemoKey;
use hashbrown::HashTable;
use smallvec::SmallVec;
use std::hash::BuildHasher;

/// The values a key stands for: one for an operation, a few for a call.
type Values = SmallVec<[Value; 2]>;

struct Entry {
    hash: u64,
    key: MemoKey,
    values: Values,
}

/// One scope's entries.
#[derive(Default)]
pub(crate) struct Scope {
    table: HashTable<Entry>,
}

/// The open scopes, outermost first; there is always at least one.
pub(crate) struct Memo {
    scopes: Vec<Scope>,
}

fn hash(key: &MemoKey) -> u64 {
    rustc_hash::FxBuildHasher.hash_one(key)
}

impl Scope {
    fn get(&self, hash: u64, key: &MemoKey) -> Option<&[Value]> {
        self.table.find(hash, |e| e.hash == hash && e.key == *key).map(|e| &e.values[..])
    }

    fn insert(&mut self, entry: Entry) {
        let found = self.table.entry(entry.hash, |e| e.hash == entry.hash && e.key == entry.key, |e| e.hash);
        match found {
            hashbrown::hash_table::Entry::Occupied(mut o) => *o.get_mut() = entry,
            hashbrown::hash_table::Entry::Vacant(v) => {
                v.insert(entry);
            }
        }
    }
}

impl Memo {
    pub(crate) fn new() -> Memo {
        Memo { scopes: vec![Scope::default()] }
    }

    /// The values of `key` in the innermost scope that has it.
    pub(crate) fn get(&self, key: &MemoKey) -> Option<&[Value]> {
        let hash = hash(key);
        self.scopes.iter().rev().find_map(|s| s.get(hash, key))
    }

    /// The values of `key` in the outermost scope only (constants).
    pub(crate) fn get_outermost(&self, key: &MemoKey) -> Option<&[Value]> {
        self.scopes[0].get(hash(key), key)
    }

    /// Remembers `key` in the scope at `depth` (0 is the outermost).
    pub(crate) fn insert_at(&mut self, depth: usize, key: MemoKey, values: &[Value]) {
        let entry = Entry { hash: hash(&key), key, values: SmallVec::from_slice(values) };
        self.scopes[depth].insert(entry);
    }

    /// Remembers `key` in the innermost scope.
    pub(crate) fn insert(&mut self, key: MemoKey, values: &[Value]) {
        self.insert_at(self.scopes.len() - 1, key, values);
    }

    pub(crate) fn push(&mut self) {
        self.scopes.push(Scope::default());
    }

    /// Closes the innermost scope, forgetting what it remembered.
    pub(crate) fn pop(&mut self) {
        if self.scopes.len() > 1 {
            self.scopes.pop();
        }
    }

    /// Closes the innermost scope, moving into its parent the entries
    /// whose values all satisfy `keep`.
    pub(crate) fn pop_into_parent(&mut self, keep: impl Fn(&Value) -> bool) {
        if self.scopes.len() < 2 {
            return;
        }
        let scope = self.scopes.pop().unwrap_or_default();
        let parent = self.scopes.last_mut().expect("a parent scope");
        for entry in scope.table {
            if entry.values.iter().all(&keep) {
                parent.insert(entry);
            }
        }
    }

    /// Takes away the scopes from `depth` on (to work in an outer scope
    /// for a while); [`Memo::restore`] puts them back.
    pub(crate) fn split_off(&mut self, depth: usize) -> Vec<Scope> {
        self.scopes.split_off(depth.max(1))
    }

    pub(crate) fn restore(&mut self, scopes: Vec<Scope>) {
        self.scopes.extend(scopes);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(n: u32) -> MemoKey {
        MemoKey::Noise(vec![Value(n)])
    }

    #[test]
    fn inner_scopes_shadow_and_are_forgotten() {
        let mut m = Memo::new();
        m.insert(key(1), &[Value(10)]);
        m.push();
        assert_eq!(m.get(&key(1)), Some(&[Value(10)][..]));
        m.insert(key(1), &[Value(11)]);
        m.insert(key(2), &[Value(20), Value(21), Value(22)]);
        assert_eq!(m.get(&key(1)), Some(&[Value(11)][..]));
        assert_eq!(m.get_outermost(&key(1)), Some(&[Value(10)][..]));
        m.pop();
        assert_eq!(m.get(&key(1)), Some(&[Value(10)][..]));
        assert_eq!(m.get(&key(2)), None);
    }

    #[test]
    fn pop_into_parent_keeps_only_what_dominates() {
        let mut m = Memo::new();
        m.push();
        m.insert(key(1), &[Value(1)]);
        m.insert(key(2), &[Value(1), Value(2)]);
        m.pop_into_parent(|v| *v != Value(2));
        assert_eq!(m.get(&key(1)), Some(&[Value(1)][..]));
        assert_eq!(m.get(&key(2)), None);
    }

    #[test]
    fn split_off_hides_inner_scopes_until_restored() {
        let mut m = Memo::new();
        m.push();
        m.insert(key(1), &[Value(1)]);
        let inner = m.split_off(1);
        assert_eq!(m.get(&key(1)), None);
        m.insert(key(2), &[Value(2)]);
        m.restore(inner);
        assert_eq!(m.get(&key(1)), Some(&[Value(1)][..]));
        assert_eq!(m.get(&key(2)), Some(&[Value(2)][..]));
    }

    #[test]
    fn many_entries_survive_growth() {
        let mut m = Memo::new();
        for n in 0..1000 {
            m.insert(key(n), &[Value(n + 1)]);
        }
        assert!((0..1000).all(|n| m.get(&key(n)) == Some(&[Value(n + 1)][..])));
    }
}
