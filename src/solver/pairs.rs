//! Pair loops shared by the solvers: a particle's neighbours are visited [`LANES`] at a time in
//! lane arrays (so square roots and kernel polynomials run as packed SIMD), then the remainder
//! one by one. The lane results equal [`Kernel::gradient`] pair by pair, coincident pairs
//! included.

use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::par::LANES;

/// A block of [`LANES`] neighbours of one particle: separations, distances, gradients.
pub(crate) struct Block {
    /// Neighbour indices.
    pub j: [usize; LANES],
    /// `∇W(x_i − x_j)` components.
    pub gx: [Real; LANES],
    pub gy: [Real; LANES],
    pub gz: [Real; LANES],
    /// Distances `|x_i − x_j|`.
    pub d: [Real; LANES],
}

/// Kernel gradients of particle `i` (at `xi`) against the neighbours of `block`.
#[inline(always)]
pub(crate) fn gradient_block<K: Kernel>(
    kernel: &K,
    i: usize,
    xi: Vector,
    positions: &[Vector],
    block: &[u32],
) -> Block {
    debug_assert_eq!(block.len(), LANES);
    let coincident = K::COINCIDENT_FRACTION * kernel.support();
    let mut j = [0usize; LANES];
    let (mut rx, mut ry, mut rz, mut d) = ([0.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
    for l in 0..LANES {
        j[l] = block[l] as usize;
        let r = xi - positions[j[l]];
        (rx[l], ry[l], rz[l]) = (r.x, r.y, r.z);
        d[l] = r.length_squared();
    }
    for l in 0..LANES {
        d[l] = d[l].sqrt();
    }
    let mut c = [0.0; LANES];
    for l in 0..LANES {
        let far = (d[l] > coincident) as u32 as Real;
        c[l] = kernel.dw(d[l]) * (far / d[l].max(coincident));
    }
    let (mut gx, mut gy, mut gz) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
    for l in 0..LANES {
        gx[l] = rx[l] * c[l];
        gy[l] = ry[l] * c[l];
        gz[l] = rz[l] * c[l];
    }
    if d.iter().any(|&dl| dl <= coincident) {
        for l in 0..LANES {
            if d[l] <= coincident {
                let g = kernel.gradient(Vector::ZERO, d[l], i as u32, block[l]);
                (gx[l], gy[l], gz[l]) = (g.x, g.y, g.z);
            }
        }
    }
    Block { j, gx, gy, gz, d }
}

/// `∇W(x_i − x_j)` and `|x_i − x_j|` for one pair (the remainder loop).
#[inline(always)]
pub(crate) fn gradient_one<K: Kernel>(
    kernel: &K,
    i: usize,
    xi: Vector,
    positions: &[Vector],
    j: u32,
) -> (Vector, Real) {
    let r = xi - positions[j as usize];
    let d = r.length();
    (kernel.gradient(r, d, i as u32, j), d)
}

/// Sum of per-chunk `(f64 sum, max)` partials in a fixed order.
pub(crate) fn reduce_partials(partials: &[(f64, Real)]) -> (f64, Real) {
    partials
        .iter()
        .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)))
}
