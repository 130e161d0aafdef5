//! Per-particle data for drawing the liquid, computed on request only: nothing here runs
//! inside [`crate::FluidPipeline::step`], so a game that does not call it pays nothing.
//!
//! - [`Anisotropy`]: the ellipsoid of each particle's neighbourhood and its smoothed center
//!   (Yu & Turk 2013, "Reconstructing surfaces of particle-based fluids using anisotropic
//!   kernels", ACM TOG 32(1)), so a thin sheet is drawn as a sheet and a flat surface as a
//!   flat surface instead of a layer of beads.
//! - [`Interpolation`]: positions between the last two physics steps, followed by particle
//!   id (particles are re-sorted every step), for a game drawing at another rate than it
//!   steps.
//! - [`DiffuseParticles`]: spray, foam and bubbles (Ihmsen, Akinci, Akinci & Teschner 2012,
//!   "Unified spray, foam and air bubbles for particle-based fluids", The Visual Computer
//!   28), generated from the liquid's trapped air and wave crests, advected by class, never
//!   fed back into the liquid; opt-in, with a cap on their number.
//!
//! All three read a [`crate::Fluid`] through its public accessors (positions, velocities,
//! densities, ids) after the step, and hold their own buffers (no allocation once warm).
//! Their cost per particle is measured by `examples/visual_cost.rs`
//! (see `docs/outputs.md`).

pub mod anisotropy;
pub mod diffuse;
pub mod interpolate;

pub use anisotropy::{Anisotropy, AnisotropySettings, Ellipsoid};
pub use diffuse::{DiffuseKind, DiffuseParticles, DiffuseReport, DiffuseSettings};
pub use interpolate::Interpolation;

use crate::math::{Real, Vector};
use crate::neighbors::{NeighborGrid, NeighborLists};

/// A neighbour search over any point set: the points are copied in the grid's cell order
/// (the crate's [`NeighborGrid`] wants sorted positions), their lists built over that copy.
#[derive(Clone, Debug, Default)]
struct Search {
    grid: NeighborGrid,
    lists: NeighborLists,
    /// The points in sorted order.
    sorted: Vec<Vector>,
    /// `order[k]`: the index in the caller's array of sorted point `k`.
    order: Vec<u32>,
}

impl Search {
    /// Sorts `points` into cells of size `radius` and builds every point's list of the
    /// others closer than `radius`.
    fn build(&mut self, points: &[Vector], radius: Real) {
        self.grid.sort(points, radius);
        let perm = self.grid.permutation();
        self.sorted.clear();
        self.sorted
            .extend(perm.iter().map(|&(_, i)| points[i as usize]));
        self.order.clear();
        self.order.extend(perm.iter().map(|&(_, i)| i));
        self.grid.build_cells();
        self.lists.build(&self.grid, &self.sorted, radius);
    }

    fn heap_bytes(&self) -> usize {
        self.grid.heap_bytes()
            + self.lists.heap_bytes()
            + self.sorted.capacity() * std::mem::size_of::<Vector>()
            + self.order.capacity() * 4
    }
}

/// `SphError::InvalidParameter` unless `v` is finite and positive.
fn positive(field: &'static str, v: Real) -> crate::SphResult<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(crate::SphError::InvalidParameter {
            field,
            value: v as f64,
            reason: "must be a positive finite number",
        })
    }
}
