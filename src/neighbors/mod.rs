//! Neighbour search: an unbounded hashed grid of cells of size `h`, particles re-sorted by
//! cell every step, and flat per-particle neighbour lists.
//!
//! 1. [`NeighborGrid::sort`] computes each particle's cell key and sorts particles by it
//!    (cells in z, y, x order, so the three cells of an x-row are adjacent in memory). The
//!    caller then permutes every per-particle array with the same permutation.
//! 2. [`NeighborGrid::build_cells`] finds each occupied cell's particle range and indexes the
//!    cells in a hash table. Cell coordinates wrap at 2²¹ per axis, so the grid needs no
//!    preset box: particles may be anywhere, at negative or far coordinates. Cells that
//!    alias after wrapping share a key, which only adds candidates that the distance test
//!    rejects.
//! 3. [`NeighborLists::build`] visits the 27 cells around each particle (merged into at most
//!    27, usually 9, contiguous index ranges) and keeps the particles closer than `h`.
//!
//! [`oracle`] holds the brute-force O(n²) search the tests compare against.

mod grid;
mod lists;
pub mod oracle;

pub use grid::NeighborGrid;
pub use lists::NeighborLists;

use crate::domain::MinimumImage;
use crate::fluid::ParticlesMut;
use crate::math::{Real, Vector};

/// The neighbour search of one fluid: the grid and the lists. The re-sort swaps arrays
/// through buffers that are idle at that moment and rewritten after it (so it holds no
/// scratch of its own, and a warm search allocates nothing).
#[derive(Clone, Debug, Default)]
pub(crate) struct NeighbourSearch {
    /// Cells and the particles' sort order.
    pub grid: NeighborGrid,
    /// Neighbour lists of the current positions.
    pub lists: NeighborLists,
}

impl NeighbourSearch {
    /// Sorts the particles by cell — positions, velocities, ids and every attribute follow
    /// the permutation, and `previous` (the positions at the substep's start) when given; the
    /// other arrays are rewritten by the stages before they are read — then builds the cells
    /// and the lists (minimum-image distances in a periodic box).
    pub fn search(
        &mut self,
        particles: &mut ParticlesMut<'_>,
        previous: Option<&mut Vec<Vector>>,
        h: Real,
        domain: Option<MinimumImage>,
    ) {
        let reordered = match &domain {
            None => self.grid.sort(particles.positions, h),
            Some(d) => self.grid.sort_periodic(particles.positions, h, d),
        };
        if reordered {
            // Each array is gathered into a scratch buffer that is then swapped with it (or
            // copied back). The scratch buffers are ones rewritten before they are read
            // again: the accelerations (by the stages after the search) for the vectors,
            // the grid's cell of each particle (by `build_cells`) for the ids and the
            // attributes: 12 + 4 bytes per particle that no scratch of its own holds.
            let (perm, cells) = self.grid.permutation_and_cells();
            let scratch = &mut *particles.accelerations;
            crate::par::permute(particles.positions, scratch, perm);
            crate::par::permute(particles.velocities, scratch, perm);
            crate::par::permute(particles.ids, cells, perm);
            for values in particles.attributes.values_mut() {
                permute_bits(values, cells, perm);
            }
            if let Some(previous) = previous {
                crate::par::permute(previous, scratch, perm);
            }
        }
        self.grid.build_cells();
        self.build_lists(particles.positions, h, domain);
    }

    /// The neighbour lists over the current cells (built first if need be), their flat
    /// coordinates written to the idle sort keys ([`NeighborGrid::take_idle_keys`]).
    pub fn build_lists(&mut self, positions: &[Vector], h: Real, domain: Option<MinimumImage>) {
        self.grid.build_cells();
        // The lists read the grid's cells, not its keys: the keys are lent beside them.
        let mut keys = self.grid.take_idle_keys();
        let scratch = grid::keys_as_reals(&mut keys);
        self.lists
            .build_in(&self.grid, positions, (h, domain), scratch);
        self.grid.put_back_keys(keys);
    }

    /// Reserves the buffers the re-sort swaps the ids and attributes through for `capacity`
    /// particles (they take the place of the fluid's own arrays, whose capacity they then
    /// give it: a fluid with a capacity then never reallocates while it fills up). A failed
    /// reservation is left to the arrays' own growth.
    pub fn reserve(&mut self, capacity: usize) {
        self.grid.reserve(capacity);
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.grid.heap_bytes() + self.lists.heap_bytes()
    }
}

/// `data[k] = data[perm[k].1]` for every `k` (all read before any is written), gathered
/// as bits into `scratch` and copied back.
fn permute_bits(data: &mut [Real], scratch: &mut Vec<u32>, perm: &[(u64, u32)]) {
    scratch.clear();
    scratch.extend(perm.iter().map(|&(_, i)| data[i as usize].to_bits()));
    for (d, &b) in data.iter_mut().zip(scratch.iter()) {
        *d = Real::from_bits(b);
    }
}

/// What a pass over every particle's neighbours reads: the sorted positions, their neighbour
/// lists, the particle mass, the support radius `h`, and how separations are formed (open
/// or periodic domain, see [`crate::domain`]).
#[derive(Copy, Clone)]
pub(crate) struct Pairs<'a, S> {
    /// Sorted positions.
    pub positions: &'a [Vector],
    /// Their neighbour lists.
    pub neighbors: &'a NeighborLists,
    /// Particle mass (kg).
    pub mass: Real,
    /// Support radius (m).
    pub h: Real,
    /// Forms the separations `x_i − x_j`.
    pub sep: S,
}
