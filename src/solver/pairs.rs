//! Pair loops shared by the solvers: a particle's neighbours are visited [`LANES`] at a time in
//! lane arrays (so square roots and kernel polynomials run as packed SIMD), then the remainder
//! one by one. The lane results equal [`Kernel::gradient`] pair by pair, coincident pairs
//! included.

use crate::domain::Separation;
use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::par::{CHUNK, LANES};

/// A block of [`LANES`] neighbours of one particle: separations, distances, gradients.
pub(crate) struct Block {
    /// `∇W(x_i − x_j)` components.
    pub gx: [Real; LANES],
    pub gy: [Real; LANES],
    pub gz: [Real; LANES],
    /// Distances `|x_i − x_j|`.
    pub d: [Real; LANES],
}

/// Kernel gradients of particle `i` (at `xi`) against the neighbours of `block`.
#[inline(always)]
pub(crate) fn gradient_block<K: Kernel, S: Separation>(
    sep: &S,
    kernel: &K,
    i: usize,
    xi: Vector,
    positions: &[Vector],
    block: &[u32],
) -> Block {
    debug_assert_eq!(block.len(), LANES);
    let coincident = K::COINCIDENT_FRACTION * kernel.support();
    let (mut rx, mut ry, mut rz, mut d) = ([0.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
    for l in 0..LANES {
        let r = sep.sep(xi, positions[block[l] as usize]);
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
    Block { gx, gy, gz, d }
}

/// `∇W(x_i − x_j)` and `|x_i − x_j|` for one pair (the remainder loop).
#[inline(always)]
pub(crate) fn gradient_one<K: Kernel, S: Separation>(
    sep: &S,
    kernel: &K,
    i: usize,
    xi: Vector,
    positions: &[Vector],
    j: u32,
) -> (Vector, Real) {
    let r = sep.sep(xi, positions[j as usize]);
    let d = r.length();
    (kernel.gradient(r, d, i as u32, j), d)
}

/// Sum of per-chunk `(f64 sum, max)` partials in a fixed order.
pub(crate) fn reduce_partials(partials: &[(f64, Real)]) -> (f64, Real) {
    partials
        .iter()
        .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)))
}

/// Kernel gradients `∇W(x_i − x_j)` of every neighbour pair, stored in the neighbour lists'
/// own layout (per chunk of [`CHUNK`] particles, the pair at `indices[t]` of a chunk has its
/// gradient at `x[t], y[t], z[t]`), three flat arrays (structure of arrays).
///
/// An iterative solver visits every pair twice per iteration (density rate, then pressure
/// push) with the positions unchanged: computing each gradient once per step (distance,
/// square root, kernel polynomial) and streaming it afterwards makes every later pass a plain
/// gather-and-multiply.
#[derive(Clone, Debug, Default)]
pub struct PairGradients {
    chunks: Vec<GradientChunk>,
}

#[derive(Clone, Debug, Default)]
pub(crate) struct GradientChunk {
    pub x: Vec<Real>,
    pub y: Vec<Real>,
    pub z: Vec<Real>,
}

impl GradientChunk {
    /// Sizes the arrays for `pairs` pairs (no allocation once warm).
    pub fn resize(&mut self, pairs: usize) {
        self.x.resize(pairs, 0.0);
        self.y.resize(pairs, 0.0);
        self.z.resize(pairs, 0.0);
    }
}

impl PairGradients {
    /// One chunk per neighbour-list chunk, for `n` particles.
    pub(crate) fn chunks_mut(&mut self, n: usize) -> &mut [GradientChunk] {
        self.chunks
            .resize_with(n.div_ceil(CHUNK), GradientChunk::default);
        &mut self.chunks
    }

    /// The gradients of chunk `c`.
    #[inline(always)]
    pub(crate) fn chunk(&self, c: usize) -> &GradientChunk {
        &self.chunks[c]
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.chunks
            .iter()
            .map(|c| (c.x.capacity() + c.y.capacity() + c.z.capacity()) * 4)
            .sum::<usize>()
            + self.chunks.capacity() * std::mem::size_of::<GradientChunk>()
    }
}
