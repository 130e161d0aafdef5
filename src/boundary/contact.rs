//! Particle–collider contact: swept, then pushed off, then verified. See the
//! [module docs](super).

use super::ContactWorkspace;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborGrid;
use crate::par::CHUNK;
use parry3d::query::Ray;
use rapier3d::geometry::{Collider, ColliderHandle, ColliderSet};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Contact response constants.
#[derive(Copy, Clone, Debug)]
pub struct ContactResponse {
    /// Distance kept between particle centres and surfaces (m).
    pub radius: Real,
    /// Restitution `e ∈ [0, 1]`.
    pub restitution: Real,
    /// Coulomb friction `μ ≥ 0`.
    pub friction: Real,
}

/// Counts of what contact did during one step.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct ContactCounts {
    /// Particles whose motion was changed by a collider.
    pub contacts: usize,
    /// Particles whose corrected position failed the final check and were kept at their
    /// start-of-step position instead.
    pub fallbacks: usize,
    /// Particles that started the step inside a solid and were pushed out.
    pub depenetrated: usize,
}

impl std::ops::Add for ContactCounts {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            contacts: self.contacts + o.contacts,
            fallbacks: self.fallbacks + o.fallbacks,
            depenetrated: self.depenetrated + o.depenetrated,
        }
    }
}

/// Reflects the velocity `v` off a surface of outward normal `n`: `v_n → −e·v_n`, and the
/// tangential part loses `μ` times the normal speed change (Coulomb), never reversing.
#[inline]
pub fn reflect(v: Vector, n: Vector, restitution: Real, friction: Real) -> Vector {
    let vn = v.dot(n);
    if vn >= 0.0 {
        return v;
    }
    let vt = v - n * vn;
    let dvn = -(1.0 + restitution) * vn;
    let vt_len = vt.length();
    let keep = if vt_len > 0.0 {
        (1.0 - friction * dvn / vt_len).max(0.0)
    } else {
        0.0
    };
    vt * keep - n * (restitution * vn)
}

/// Earliest hit of the segment `from → from + motion` among `candidates`: `(t ∈ [0,1], normal)`.
fn sweep(
    colliders: &ColliderSet,
    candidates: &[ColliderHandle],
    from: Vector,
    motion: Vector,
) -> Option<(Real, Vector)> {
    if motion.length_squared() == 0.0 {
        return None;
    }
    let ray = Ray::new(from, motion);
    let mut best: Option<(Real, Vector)> = None;
    for &h in candidates {
        let Some(co) = colliders.get(h) else { continue };
        let max_t = best.map_or(1.0, |b| b.0);
        if let Some(hit) = co
            .shape()
            .cast_ray_and_get_normal(co.position(), &ray, max_t, false)
            && hit.time_of_impact <= max_t
        {
            best = Some((hit.time_of_impact, hit.normal));
        }
    }
    best
}

/// `true` when the segment `from → to` crosses no candidate's surface.
fn segment_is_free(
    colliders: &ColliderSet,
    candidates: &[ColliderHandle],
    from: Vector,
    to: Vector,
) -> bool {
    let motion = to - from;
    if motion.length_squared() == 0.0 {
        return true;
    }
    let ray = Ray::new(from, motion);
    candidates.iter().all(|&h| {
        colliders.get(h).is_none_or(|co| {
            co.shape()
                .cast_ray(co.position(), &ray, 1.0, false)
                .is_none()
        })
    })
}

/// Moves `start` out of `co` if it is inside: to the nearest surface point plus `radius` along
/// the outward direction. Returns the outward normal when it did.
fn depenetrate(co: &Collider, start: Vector, radius: Real) -> Option<(Vector, Vector)> {
    if !co.shape().contains_point(co.position(), start) {
        return None;
    }
    let proj = co.shape().project_point(co.position(), start, false);
    let n = (proj.point - start).normalize_or(Vector::Y);
    Some((proj.point + n * radius, n))
}

/// Resolves contact for every particle of a sorted fluid. `previous` holds the start-of-step
/// positions (outside every solid), `positions` and `velocities` the integrated ones.
#[allow(clippy::too_many_arguments)]
pub fn resolve(
    grid: &NeighborGrid,
    candidates: &ContactWorkspace,
    colliders: &ColliderSet,
    response: ContactResponse,
    depenetrate_first: bool,
    previous: &[Vector],
    positions: &mut [Vector],
    velocities: &mut [Vector],
) -> ContactCounts {
    let r = response.radius;
    // Below this the particle counts as at the contact distance (no push): avoids chasing
    // round-off at every step for particles resting on a surface.
    let slack = r * 1e-3;
    let per_chunk = crate::par_chunks_mut!(positions, CHUNK)
        .zip(crate::par_chunks_mut!(velocities, CHUNK))
        .enumerate()
        .map(|(c, (xs, vs))| {
            let base = c * CHUNK;
            let mut counts = ContactCounts::default();
            for k in 0..xs.len() {
                let i = base + k;
                let cands = candidates.of_cell(grid.cell_of(i));
                if cands.is_empty() {
                    continue;
                }
                let mut start = previous[i];
                let mut v = vs[k];
                let motion = xs[k] - start;
                let mut touched = false;

                if depenetrate_first {
                    for &h in cands {
                        if let Some(co) = colliders.get(h)
                            && let Some((p, n)) = depenetrate(co, start, r)
                        {
                            start = p;
                            v = reflect(v, n, 0.0, 0.0);
                            counts.depenetrated += 1;
                            touched = true;
                        }
                    }
                }

                // 1. Sweep the motion: the centre never crosses a surface.
                let mut target = start + motion;
                if let Some((t, normal)) = sweep(colliders, cands, start, motion) {
                    let mut n = if normal.dot(motion) > 0.0 {
                        -normal
                    } else {
                        normal
                    };
                    if n.length_squared() < 0.5 {
                        n = -motion.normalize_or_zero();
                    }
                    target = start + motion * t + n * r;
                    v = reflect(v, n, response.restitution, response.friction);
                    touched = true;
                }

                // 2. Keep one contact radius off every surface (corners: a few passes).
                for _ in 0..4 {
                    let mut moved = false;
                    for &h in cands {
                        let Some(co) = colliders.get(h) else { continue };
                        let Some(proj) =
                            co.shape()
                                .project_point_with_max_dist(co.position(), target, false, r)
                        else {
                            continue;
                        };
                        let delta = target - proj.point;
                        let d = delta.length();
                        if !proj.is_inside && d >= r - slack {
                            continue;
                        }
                        let n = if proj.is_inside {
                            -delta / d.max(Real::MIN_POSITIVE)
                        } else if d > 1e-6 * r {
                            delta / d
                        } else {
                            // On the surface itself (a zero-thickness sheet): go back to the
                            // side the particle came from.
                            (start - proj.point).normalize_or_zero()
                        };
                        if n == Vector::ZERO {
                            continue;
                        }
                        target = proj.point + n * r;
                        v = reflect(v, n, response.restitution, response.friction);
                        moved = true;
                    }
                    touched |= moved;
                    if !moved {
                        break;
                    }
                }

                // 3. Verify: the corrected motion must still cross no surface.
                if touched {
                    counts.contacts += 1;
                    if !segment_is_free(colliders, cands, start, target) {
                        target = start;
                        v = Vector::ZERO;
                        counts.fallbacks += 1;
                    }
                    xs[k] = target;
                    vs[k] = v;
                }
            }
            counts
        });
    #[cfg(feature = "parallel")]
    return rayon::iter::ParallelIterator::reduce(per_chunk, ContactCounts::default, |a, b| a + b);
    #[cfg(not(feature = "parallel"))]
    per_chunk.fold(ContactCounts::default(), |a, b| a + b)
}
