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

/// The neighbour search of one fluid: the grid, the lists, and the scratch the re-sort swaps
/// arrays through (so a warm search allocates nothing).
#[derive(Clone, Debug, Default)]
pub(crate) struct NeighbourSearch {
    /// Cells and the particles' sort order.
    pub grid: NeighborGrid,
    /// Neighbour lists of the current positions.
    pub lists: NeighborLists,
    reals: Vec<Real>,
    ids: Vec<u32>,
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
            let perm = self.grid.permutation();
            // The accelerations are rewritten by the stages after the search before they are
            // read, so their buffer is the vectors' scratch (12 bytes per particle saved).
            let scratch = &mut *particles.accelerations;
            crate::par::permute(particles.positions, scratch, perm);
            crate::par::permute(particles.velocities, scratch, perm);
            crate::par::permute(particles.ids, &mut self.ids, perm);
            for values in particles.attributes.values_mut() {
                crate::par::permute(values, &mut self.reals, perm);
            }
            if let Some(previous) = previous {
                crate::par::permute(previous, scratch, perm);
            }
        }
        self.grid.build_cells();
        self.build_lists(particles.positions, h, domain);
    }

    /// The neighbour lists over the current cells.
    pub fn build_lists(&mut self, positions: &[Vector], h: Real, domain: Option<MinimumImage>) {
        match domain {
            None => self.lists.build(&self.grid, positions, h),
            Some(d) => self.lists.build_periodic(&self.grid, positions, h, d),
        }
    }

    /// Reserves the re-sort's scratch for `capacity` particles (a fluid with a capacity then
    /// never reallocates it while it fills up). A failed reservation is left to the arrays'
    /// own growth.
    pub fn reserve(&mut self, capacity: usize) {
        let _ = self
            .reals
            .try_reserve_exact(capacity.saturating_sub(self.reals.len()));
        let _ = self
            .ids
            .try_reserve_exact(capacity.saturating_sub(self.ids.len()));
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.grid.heap_bytes()
            + self.lists.heap_bytes()
            + (self.reals.capacity() + self.ids.capacity()) * 4
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
