//! Pair loops shared by the solvers: a particle's neighbours are visited [`LANES`] at a time in
//! lane arrays (so square roots and kernel polynomials run as packed SIMD), then the remainder
//! one by one. The lane results equal [`Kernel::gradient`] pair by pair, coincident pairs
//! included.

use crate::domain::Separation;
use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::neighbors::Pairs;
use crate::par::{CHUNK, LANES, lane_sum};
use rapier3d::glamx::Vec3A;

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
    for d in &mut d {
        *d = d.sqrt();
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

/// A particle's kernel sums over its neighbours: `Σ_j W_ij`, `Σ_j ∇W_ij` and `Σ_j |∇W_ij|²`
/// (the density and the DFSPH factor's or PBF's constraint gradient need all three).
pub(crate) struct KernelSums {
    pub w: Real,
    pub g: Vector,
    pub g2: Real,
}

/// Where [`kernel_sums`] hands the pair values it computes (DFSPH's density pass stores them;
/// `()` drops them).
pub(crate) trait PairSink {
    /// The block of pairs `o..o + LANES`, before it is summed.
    fn block(&mut self, o: usize, b: &Block);
    /// Remaining pair `t`: its gradient and distance.
    fn one(&mut self, t: usize, gradient: Vector, d: Real);
}

impl PairSink for () {
    #[inline(always)]
    fn block(&mut self, _: usize, _: &Block) {}
    #[inline(always)]
    fn one(&mut self, _: usize, _: Vector, _: Real) {}
}

/// [`KernelSums`] of particle `i` over its neighbours `nb`: [`LANES`] at a time through
/// [`gradient_block`] (lane accumulators summed by [`lane_sum`]), then the rest one by one,
/// every pair's values handed to `sink` on the way.
#[inline(always)]
pub(crate) fn kernel_sums<K: Kernel, S: Separation>(
    pairs: &Pairs<'_, S>,
    kernel: &K,
    i: usize,
    nb: &[u32],
    sink: &mut impl PairSink,
) -> KernelSums {
    let (positions, sep) = (pairs.positions, &pairs.sep);
    let xi = positions[i];
    let (mut w, mut sx, mut sy, mut sz, mut s2) = (
        [0.0; LANES],
        [0.0; LANES],
        [0.0; LANES],
        [0.0; LANES],
        [0.0; LANES],
    );
    let full = nb.len() / LANES * LANES;
    for (t, bl) in nb[..full].chunks_exact(LANES).enumerate() {
        let b = gradient_block(sep, kernel, i, xi, positions, bl);
        sink.block(t * LANES, &b);
        // A separate loop: mixed with the sink's stores it did not vectorise.
        for l in 0..LANES {
            w[l] += kernel.w(b.d[l]);
            sx[l] += b.gx[l];
            sy[l] += b.gy[l];
            sz[l] += b.gz[l];
            s2[l] += b.gx[l] * b.gx[l] + b.gy[l] * b.gy[l] + b.gz[l] * b.gz[l];
        }
    }
    let mut sums = KernelSums {
        w: lane_sum(w),
        g: Vector::new(lane_sum(sx), lane_sum(sy), lane_sum(sz)),
        g2: lane_sum(s2),
    };
    for (t, &j) in nb.iter().enumerate().skip(full) {
        let (gr, d) = gradient_one(sep, kernel, i, xi, positions, j);
        sink.one(t, gr, d);
        sums.w += kernel.w(d);
        sums.g += gr;
        sums.g2 += gr.length_squared();
    }
    sums
}

/// Sum of per-chunk `(f64 sum, max)` partials in a fixed order.
pub(crate) fn reduce_partials(partials: &[(f64, Real)]) -> (f64, Real) {
    partials
        .iter()
        .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)))
}

/// Kernel gradients `∇W(x_i − x_j)` of every neighbour pair, stored in the neighbour lists'
/// own layout (per chunk of [`CHUNK`] particles, the pair at `indices[t]` of a chunk has its
/// gradient at `grad.at(t)`), 12 bytes per pair ([`PackedGradients`]); and, when the fluid is
/// viscous, the viscosity kernel's Laplacian `∇²W_v(|x_i − x_j|)` of every pair at
/// `laplacian[t]`.
///
/// An iterative solver visits every pair twice per iteration (density rate, then pressure
/// push) with the positions unchanged: computing each gradient once per step (distance,
/// square root, kernel polynomial) and streaming it afterwards makes every later pass a plain
/// gather-and-multiply. Each gradient loads as one 16-byte SIMD load (its `w` lane is the next
/// pair's `x`, which the passes never use), combined with a neighbour's velocity (held 16
/// bytes wide during the solves) in three packed operations.
#[derive(Clone, Debug, Default)]
pub(crate) struct PairGradients {
    chunks: Vec<PairChunk>,
}

/// The pair values of one chunk of particles (see [`PairGradients`]).
#[derive(Clone, Debug, Default)]
pub(crate) struct PairChunk {
    /// `∇W_ij`.
    pub grad: PackedGradients,
    /// `∇²W_v(|x_i − x_j|)`; empty when the fluid is not viscous.
    pub laplacian: Vec<Real>,
    /// Hydrostatic walls: each pair's weight `max(0, ∇W_ij·û_i)` in the wall's pressure value
    /// (DFSPH's wall pressure value `π̂_i`), constant over a substep, so the solves' iterations read
    /// it instead of recomputing it; empty without hydrostatic walls. 4 bytes per pair.
    pub wall_weight: Vec<Real>,
    /// Hydrostatic walls: each particle's sum of its pairs' `wall_weight` (0 where the wall
    /// takes no pressure from the neighbours); empty without hydrostatic walls.
    pub wall_weight_sum: Vec<Real>,
}

/// Vectors packed as `x, y, z` (12 bytes each), with one float of padding after the last, so
/// that vector `t` loads as one unaligned 16-byte load of floats `3t..3t + 4` ([`Self::at`];
/// its `w` lane holds the next vector's `x` or the padding, and is never to be used).
///
/// Why not [`Vec3A`] (16 bytes): the solves' passes stream the pair gradients from memory
/// every iteration; 12 bytes instead of 16 is a fifth less of what a pass reads per pair
/// (gradient and neighbour index, 16 bytes instead of 20), the same values bit for bit.
#[derive(Clone, Debug, Default)]
pub(crate) struct PackedGradients {
    data: Vec<Real>,
}

impl PackedGradients {
    /// Holds `len` vectors (new ones zero).
    pub(crate) fn resize(&mut self, len: usize) {
        self.data.resize(3 * len + 1, 0.0);
    }

    /// The vectors `s..e`, for reading.
    #[inline(always)]
    pub(crate) fn range(&self, s: usize, e: usize) -> GradientSlice<'_> {
        GradientSlice {
            data: &self.data[3 * s..3 * e + 1],
            len: e - s,
        }
    }

    /// The vectors `s..e`, for writing.
    #[inline(always)]
    pub(crate) fn range_mut(&mut self, s: usize, e: usize) -> &mut [Real] {
        &mut self.data[3 * s..3 * e]
    }

    /// Heap bytes held.
    fn heap_bytes(&self) -> usize {
        self.data.capacity() * std::mem::size_of::<Real>()
    }
}

/// Some consecutive vectors of a [`PackedGradients`] (with the float after the last).
#[derive(Copy, Clone)]
pub(crate) struct GradientSlice<'a> {
    /// `3·len + 1` floats.
    data: &'a [Real],
    len: usize,
}

impl GradientSlice<'_> {
    /// Number of vectors.
    #[inline(always)]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Vector `t` (`t < len`); the `w` lane is not part of it (see [`PackedGradients`]).
    #[inline(always)]
    pub(crate) fn at(&self, t: usize) -> Vec3A {
        assert!(t < self.len);
        // SAFETY: checked just above.
        unsafe { self.at_unchecked(t) }
    }

    /// [`Self::at`] without the check.
    ///
    /// # Safety
    /// `t < self.len()`.
    #[inline(always)]
    pub(crate) unsafe fn at_unchecked(&self, t: usize) -> Vec3A {
        debug_assert!(t < self.len);
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::_mm_loadu_ps;
            // SAFETY: `data` holds `3·len + 1` floats and `t < len`, so floats
            // `3t..3t + 4` are inside it; SSE is part of every x86-64 CPU.
            Vec3A::from(unsafe { _mm_loadu_ps(self.data.as_ptr().add(3 * t)) })
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            // SAFETY: as above, floats `3t..3t + 3` are inside `data`.
            let d = unsafe { self.data.get_unchecked(3 * t..3 * t + 3) };
            Vec3A::new(d[0], d[1], d[2])
        }
    }
}

impl PairGradients {
    /// One chunk per neighbour-list chunk, for `n` particles.
    pub(crate) fn chunks_mut(&mut self, n: usize) -> &mut [PairChunk] {
        self.chunks
            .resize_with(n.div_ceil(CHUNK), PairChunk::default);
        &mut self.chunks
    }

    /// The pair values of chunk `c`.
    #[inline(always)]
    pub(crate) fn chunk(&self, c: usize) -> &PairChunk {
        &self.chunks[c]
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.chunks
            .iter()
            .map(|c| {
                c.grad.heap_bytes()
                    + (c.laplacian.capacity()
                        + c.wall_weight.capacity()
                        + c.wall_weight_sum.capacity())
                        * 4
            })
            .sum::<usize>()
            + self.chunks.capacity() * std::mem::size_of::<PairChunk>()
    }
}
