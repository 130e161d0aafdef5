//! Stage 7: symplectic Euler (the Unity paper's eqs. 7–8): velocity first, then position with
//! the new velocity. The positions at the start of the step are kept for collider contact,
//! which sweeps every particle's motion.

use crate::math::{Real, Vector, is_finite};
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// `v += a·dt`, `previous = x`, `x += v·dt`. Returns the number of particles whose new state
/// is not finite, and the largest speed.
pub fn symplectic_euler(
    dt: Real,
    accelerations: &[Vector],
    velocities: &mut [Vector],
    positions: &mut [Vector],
    previous: &mut [Vector],
) -> (usize, Real) {
    let chunks = crate::par_chunks_mut!(positions, CHUNK)
        .zip(crate::par_chunks_mut!(velocities, CHUNK))
        .zip(crate::par_chunks_mut!(previous, CHUNK))
        .enumerate()
        .map(|(c, ((x, v), prev))| {
            let base = c * CHUNK;
            let mut bad = 0usize;
            let mut vmax2: Real = 0.0;
            for k in 0..x.len() {
                prev[k] = x[k];
                v[k] += accelerations[base + k] * dt;
                x[k] += v[k] * dt;
                let v2 = v[k].length_squared();
                if !is_finite(x[k]) || !v2.is_finite() {
                    bad += 1;
                } else {
                    vmax2 = vmax2.max(v2);
                }
            }
            (bad, vmax2)
        });
    let (bad, vmax2) = chunks.reduce_with_identity();
    (bad, vmax2.sqrt())
}

/// `previous = x`, `x += v·dt` (solvers that have already set the end-of-step velocity).
/// Returns the number of particles whose new state is not finite, and the largest speed.
pub fn advance_positions(
    dt: Real,
    velocities: &[Vector],
    positions: &mut [Vector],
    previous: &mut [Vector],
) -> (usize, Real) {
    let chunks = crate::par_chunks_mut!(positions, CHUNK)
        .zip(crate::par_chunks_mut!(previous, CHUNK))
        .enumerate()
        .map(|(c, (x, prev))| {
            let base = c * CHUNK;
            let mut bad = 0usize;
            let mut vmax2: Real = 0.0;
            for k in 0..x.len() {
                let v = velocities[base + k];
                prev[k] = x[k];
                x[k] += v * dt;
                let v2 = v.length_squared();
                if !is_finite(x[k]) || !v2.is_finite() {
                    bad += 1;
                } else {
                    vmax2 = vmax2.max(v2);
                }
            }
            (bad, vmax2)
        });
    let (bad, vmax2) = chunks.reduce_with_identity();
    (bad, vmax2.sqrt())
}

/// `v = (x − previous)/dt`: the velocity of position-based solvers after their position
/// solve. Returns the number of particles whose state is not finite, and the largest speed.
pub fn velocities_from_positions(
    dt: Real,
    positions: &[Vector],
    previous: &[Vector],
    velocities: &mut [Vector],
) -> (usize, Real) {
    let inv_dt = 1.0 / dt;
    let chunks = crate::par_chunks_mut!(velocities, CHUNK)
        .enumerate()
        .map(|(c, v)| {
            let base = c * CHUNK;
            let mut bad = 0usize;
            let mut vmax2: Real = 0.0;
            for (k, v) in v.iter_mut().enumerate() {
                let x = positions[base + k];
                *v = (x - previous[base + k]) * inv_dt;
                let v2 = v.length_squared();
                if !is_finite(x) || !v2.is_finite() {
                    bad += 1;
                } else {
                    vmax2 = vmax2.max(v2);
                }
            }
            (bad, vmax2)
        });
    let (bad, vmax2) = chunks.reduce_with_identity();
    (bad, vmax2.sqrt())
}

/// `previous = x`, `x += v·dt` without any check (the prediction of position-based solvers).
pub fn predict_positions(
    dt: Real,
    velocities: &[Vector],
    positions: &mut [Vector],
    previous: &mut [Vector],
) {
    crate::par_chunks_mut!(positions, CHUNK)
        .zip(crate::par_chunks_mut!(previous, CHUNK))
        .enumerate()
        .for_each(|(c, (x, prev))| {
            let base = c * CHUNK;
            prev.copy_from_slice(x);
            for (k, x) in x.iter_mut().enumerate() {
                *x += velocities[base + k] * dt;
            }
        });
}

/// `v += a·dt` only (the prediction step of the DFSPH solver).
pub fn add_accelerations(dt: Real, accelerations: &[Vector], velocities: &mut [Vector]) {
    crate::par_chunks_mut!(velocities, CHUNK)
        .enumerate()
        .for_each(|(c, v)| {
            let base = c * CHUNK;
            for (k, v) in v.iter_mut().enumerate() {
                *v += accelerations[base + k] * dt;
            }
        });
}

/// Largest speed, and the number of particles whose position or velocity is not finite (a speed
/// whose square overflows counts as not finite: [`crate::math::is_finite_velocity`]).
pub fn scan(positions: &[Vector], velocities: &[Vector]) -> (usize, Real) {
    let chunks = crate::par_chunks!(positions, CHUNK)
        .enumerate()
        .map(|(c, x)| {
            let base = c * CHUNK;
            let mut bad = 0usize;
            let mut vmax2: Real = 0.0;
            for k in 0..x.len() {
                let v = velocities[base + k];
                let v2 = v.length_squared();
                if !is_finite(x[k]) || !v2.is_finite() {
                    bad += 1;
                } else {
                    vmax2 = vmax2.max(v2);
                }
            }
            (bad, vmax2)
        });
    let (bad, vmax2) = chunks.reduce_with_identity();
    (bad, vmax2.sqrt())
}

/// Limits every particle's speed to `cap` (direction kept); returns how many were limited.
/// See `pipeline::substep` for the bound it enforces near moving bodies.
pub fn limit_speeds(velocities: &mut [Vector], cap: Real) -> usize {
    let cap2 = cap * cap;
    crate::par_chunks_mut!(velocities, CHUNK)
        .map(|vs| {
            let mut n = 0usize;
            for v in vs.iter_mut() {
                let s2 = v.length_squared();
                if s2 > cap2 {
                    *v *= cap / s2.sqrt();
                    n += 1;
                }
            }
            n
        })
        .sum::<usize>()
}

/// Reduces `(count, max)` pairs; both operations are exact, so the result does not depend on
/// the order of reduction.
trait ReduceCountMax {
    fn reduce_with_identity(self) -> (usize, Real);
}

#[cfg(feature = "parallel")]
impl<I: rayon::iter::ParallelIterator<Item = (usize, Real)>> ReduceCountMax for I {
    fn reduce_with_identity(self) -> (usize, Real) {
        self.reduce(|| (0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)))
    }
}

#[cfg(not(feature = "parallel"))]
impl<I: Iterator<Item = (usize, Real)>> ReduceCountMax for I {
    fn reduce_with_identity(self) -> (usize, Real) {
        self.fold((0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)))
    }
}

/// Bounding box `(min, max)` of the finite positions (min/max are exact, so the result does
/// not depend on the order of reduction). An empty slice gives an inverted box.
pub fn bounds(positions: &[Vector]) -> (Vector, Vector) {
    let chunks = crate::par_chunks!(positions, CHUNK).map(|x| {
        let mut lo = Vector::splat(Real::MAX);
        let mut hi = Vector::splat(Real::MIN);
        for p in x.iter().filter(|p| is_finite(**p)) {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        (lo, hi)
    });
    let id = || (Vector::splat(Real::MAX), Vector::splat(Real::MIN));
    let merge = |a: (Vector, Vector), b: (Vector, Vector)| (a.0.min(b.0), a.1.max(b.1));
    #[cfg(feature = "parallel")]
    return rayon::iter::ParallelIterator::reduce(chunks, id, merge);
    #[cfg(not(feature = "parallel"))]
    chunks.fold(id(), merge)
}

/// Wraps every position into the periodic box `domain` (a particle that left through one face
/// re-enters through the opposite one; none is added or lost). Non-finite positions are left
/// as they are, for the quarantine to remove.
pub fn wrap_positions(domain: &crate::domain::MinimumImage, positions: &mut [Vector]) {
    crate::par_chunks_mut!(positions, CHUNK).for_each(|chunk| {
        for x in chunk {
            if is_finite(*x) {
                *x = domain.wrap(*x);
            }
        }
    });
}
