//! Named per-particle values that follow the particles: every re-sort permutes them, every
//! removal compacts them and every append extends them with zeros, together with the
//! positions. A stage that must keep a value per particle from one step to the next (DFSPH's
//! warm starts) stores it here under its own name, so the fluid moves it with its particles
//! without knowing what it is.

use crate::math::Real;

/// The attributes of one fluid: `(name, values)` pairs, each `values` as long as the fluid.
#[derive(Clone, Debug, Default)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct Attributes {
    entries: Vec<(String, Vec<Real>)>,
}

impl Attributes {
    /// The index of attribute `name`, created (zeros) if it does not exist yet; every
    /// attribute is sized to `n` particles, new entries zero.
    pub fn ensure(&mut self, name: &str, n: usize) -> usize {
        let k = match self.entries.iter().position(|(a, _)| a == name) {
            Some(k) => k,
            None => {
                self.entries.push((name.to_owned(), Vec::new()));
                self.entries.len() - 1
            }
        };
        self.entries[k].1.resize(n, 0.0);
        k
    }

    /// Two attributes at once, mutably (`a != b`).
    pub fn pair_mut(&mut self, a: usize, b: usize) -> (&mut [Real], &mut [Real]) {
        assert_ne!(a, b, "two distinct attributes");
        let (lo, hi) = (a.min(b), a.max(b));
        let (left, right) = self.entries.split_at_mut(hi);
        let (x, y) = (&mut left[lo].1, &mut right[0].1);
        if a < b { (x, y) } else { (y, x) }
    }

    /// The values of attribute `name`, if it exists and has one value per particle (`n`).
    pub fn find(&self, name: &str, n: usize) -> Option<&[Real]> {
        self.entries
            .iter()
            .find(|(a, v)| a == name && v.len() == n)
            .map(|(_, v)| &v[..])
    }

    /// The values of attribute `k` (an index from [`Attributes::ensure`]).
    pub fn get(&self, k: usize) -> &[Real] {
        &self.entries[k].1
    }

    /// The index of the attribute named `prefix` followed by `name`, if it exists (no
    /// allocation: the step looks its scalars up every substep).
    pub fn index_of(&self, prefix: &str, name: &str) -> Option<usize> {
        self.entries
            .iter()
            .position(|(a, _)| a.strip_prefix(prefix) == Some(name))
    }

    /// The values of attribute `k`, writable.
    pub fn get_mut(&mut self, k: usize) -> &mut [Real] {
        &mut self.entries[k].1
    }

    /// The values of attribute `k` as their vector (a stage that swaps in new values).
    pub fn vec_mut(&mut self, k: usize) -> &mut Vec<Real> {
        &mut self.entries[k].1
    }

    /// Every attribute's name and values.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &[Real])> {
        self.entries.iter().map(|(a, v)| (a.as_str(), &v[..]))
    }

    /// Every attribute's values.
    pub fn values_mut(&mut self) -> impl Iterator<Item = &mut Vec<Real>> {
        self.entries.iter_mut().map(|(_, v)| v)
    }

    /// Every attribute resized to `n` particles (new entries zero).
    pub fn resize(&mut self, n: usize) {
        for v in self.values_mut() {
            v.resize(n, 0.0);
        }
    }

    #[cfg_attr(not(feature = "snapshot"), allow(dead_code))]
    /// `false` when an attribute's length differs from `n` (a malformed snapshot).
    pub fn is_consistent(&self, n: usize) -> bool {
        self.entries.iter().all(|(_, v)| v.len() == n)
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.entries
            .iter()
            .map(|(name, v)| name.capacity() + v.capacity() * std::mem::size_of::<Real>())
            .sum()
    }
}
