//! Particle–collider contact: swept, then pushed off, then verified. See the
//! [module docs](super).

use super::ContactWorkspace;
use super::bodies::{ImpulseRecord, MovingCollider, entry_of};
use crate::math::{Real, Vector};
use crate::neighbors::NeighborGrid;
use crate::par::CHUNK;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::query::Ray;
use rapier3d::geometry::{ColliderHandle, ColliderSet};
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

/// `true` when the box `lo..hi` is farther than `margin` from `b` along some axis. Written as
/// "clearly apart" so NaN coordinates never count as apart (the queries then run as before).
#[inline(always)]
fn apart(b: &Aabb, lo: Vector, hi: Vector, margin: Real) -> bool {
    hi.x < b.mins.x - margin
        || hi.y < b.mins.y - margin
        || hi.z < b.mins.z - margin
        || lo.x > b.maxs.x + margin
        || lo.y > b.maxs.y + margin
        || lo.z > b.maxs.z + margin
}

/// Earliest hit of the segment `from → from + motion` among `candidates`: `(t ∈ [0,1], normal)`.
/// A candidate whose box (`boxes`, same order) is farther than `margin` from the segment's
/// box cannot be hit and is not queried.
fn sweep(
    colliders: &ColliderSet,
    candidates: &[ColliderHandle],
    boxes: &[Aabb],
    margin: Real,
    from: Vector,
    motion: Vector,
) -> Option<(Real, Vector)> {
    if motion.length_squared() == 0.0 {
        return None;
    }
    let ray = Ray::new(from, motion);
    let (lo, hi) = (from.min(from + motion), from.max(from + motion));
    let mut best: Option<(Real, Vector)> = None;
    for (&h, b) in candidates.iter().zip(boxes) {
        if apart(b, lo, hi, margin) {
            continue;
        }
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

/// `true` when the segment `from → to` crosses no candidate's surface (candidates whose box
/// is farther than `margin` from the segment's are not queried, as in [`sweep`]).
fn segment_is_free(
    colliders: &ColliderSet,
    candidates: &[ColliderHandle],
    boxes: &[Aabb],
    margin: Real,
    from: Vector,
    to: Vector,
) -> bool {
    let motion = to - from;
    if motion.length_squared() == 0.0 {
        return true;
    }
    let ray = Ray::new(from, motion);
    let (lo, hi) = (from.min(to), from.max(to));
    candidates.iter().zip(boxes).all(|(&h, b)| {
        apart(b, lo, hi, margin)
            || colliders.get(h).is_none_or(|co| {
                co.shape()
                    .cast_ray(co.position(), &ray, 1.0, false)
                    .is_none()
            })
    })
}

/// `true` when `p` is inside any solid candidate.
fn inside_any(colliders: &ColliderSet, candidates: &[ColliderHandle], p: Vector) -> bool {
    candidates.iter().any(|&h| {
        colliders
            .get(h)
            .is_some_and(|co| co.shape().contains_point(co.position(), p))
    })
}

/// The 26 directions of a cube's faces, edges and corners, for the depenetration search.
fn directions() -> impl Iterator<Item = Vector> {
    (-1i32..=1).flat_map(|x| {
        (-1i32..=1).flat_map(move |y| {
            (-1i32..=1)
                .filter(move |&z| (x, y, z) != (0, 0, 0))
                .map(move |z| Vector::new(x as Real, y as Real, z as Real).normalize())
        })
    })
}

/// From `start`, inside some solids, the nearest point found outside every candidate, one
/// `radius` off the surface it leaves through, with the outward normal there.
///
/// First the cheap answer: the nearest surface point of each solid containing the particle.
/// It fails where solids overlap (the nearest surface of one lies inside the other, which
/// also happens inside a compound), so then it marches along 26 directions, crossing solid
/// after solid with ray casts, and keeps the shortest way out.
fn depenetrate(
    colliders: &ColliderSet,
    candidates: &[ColliderHandle],
    start: Vector,
    radius: Real,
) -> Option<(Vector, Vector)> {
    if !inside_any(colliders, candidates, start) {
        return None;
    }
    for &h in candidates {
        let Some(co) = colliders.get(h) else { continue };
        if !co.shape().contains_point(co.position(), start) {
            continue;
        }
        let proj = co.shape().project_point(co.position(), start, false);
        let out = proj.point - start;
        if crate::math::is_finite(proj.point) && out.length() > Real::EPSILON * radius {
            let n = out.normalize();
            let p = proj.point + n * radius;
            if crate::math::is_finite(p) && !inside_any(colliders, candidates, p) {
                return Some((p, n));
            }
        }
    }
    let mut best: Option<(Real, Vector, Vector)> = None;
    for dir in directions() {
        let mut p = start;
        let mut travelled: Real = 0.0;
        let mut escaped = false;
        for _ in 0..16 {
            // Exit of every solid containing `p` along `dir`; step to the farthest one.
            let ray = Ray::new(p, dir);
            let mut exit: Real = 0.0;
            for &h in candidates {
                let Some(co) = colliders.get(h) else { continue };
                if co.shape().contains_point(co.position(), p)
                    && let Some(t) = co.shape().cast_ray(co.position(), &ray, Real::MAX, false)
                {
                    exit = exit.max(t);
                }
            }
            p += dir * (exit + radius);
            travelled += exit + radius;
            if !inside_any(colliders, candidates, p) {
                escaped = true;
                break;
            }
        }
        if escaped && crate::math::is_finite(p) && best.is_none_or(|b| travelled < b.0) {
            best = Some((travelled, p, dir));
        }
    }
    best.map(|(_, p, n)| (p, n))
}

/// Moving bodies near the fluid during a substep, for [`resolve`]: the coupling table, the
/// particle mass, and one impulse buffer per chunk of particles (reused across steps).
pub struct Movers<'a> {
    /// The table of the substep (sorted by collider handle).
    pub table: &'a [MovingCollider],
    /// Mass of one particle (kg).
    pub mass: Real,
    /// Per-chunk impulses on dynamic bodies, filled by [`resolve`] (chunk order is the
    /// summation order).
    pub records: &'a mut Vec<Vec<ImpulseRecord>>,
}

/// Resolves contact for every particle of a sorted fluid. `previous` holds the start-of-step
/// positions (outside every solid), `positions` and `velocities` the integrated ones. With
/// `movers`, colliders of non-fixed bodies are handled in their moving frames and impulses on
/// dynamic bodies are recorded (see [`super::bodies`]).
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
    movers: Option<Movers<'_>>,
) -> ContactCounts {
    match movers {
        Some(m) if !m.table.is_empty() => resolve_moving(
            grid,
            candidates,
            colliders,
            response,
            depenetrate_first,
            previous,
            positions,
            velocities,
            m,
        ),
        Some(m) => {
            m.records.iter_mut().for_each(Vec::clear);
            resolve_static(
                grid,
                candidates,
                colliders,
                response,
                depenetrate_first,
                previous,
                positions,
                velocities,
            )
        }
        None => resolve_static(
            grid,
            candidates,
            colliders,
            response,
            depenetrate_first,
            previous,
            positions,
            velocities,
        ),
    }
}

/// [`resolve`] when every candidate collider is at rest.
#[allow(clippy::too_many_arguments)]
fn resolve_static(
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
                let (cands, boxes) = candidates.of_cell_with_boxes(grid.cell_of(i));
                if cands.is_empty() {
                    continue;
                }
                let mut start = previous[i];
                // Far from every candidate's box (by more than r − slack, plus a few ulps of
                // the coordinates for round-off, around the motion's box), nothing below can
                // touch the particle: the sweep needs the segment to meet a shape, a push
                // needs the end point closer than r − slack to one (step 2's cull), a
                // depenetration needs the start inside one. Skipping is then exact, and most
                // particles of a cell next to a wall are not next to the wall themselves;
                // nor are those resting on it, one radius off (less than `slack` nearer).
                let scale = start.abs().max_element().max(xs[k].abs().max_element());
                let reach = Aabb::new(start.min(xs[k]), start.max(xs[k]))
                    .loosened(r - slack + 8.0 * Real::EPSILON * scale);
                if !boxes.iter().any(|b| b.intersects(&reach)) {
                    continue;
                }
                let mut v = vs[k];
                let motion = xs[k] - start;
                let mut touched = false;

                if depenetrate_first && let Some((p, n)) = depenetrate(colliders, cands, start, r) {
                    start = p;
                    v = reflect(v, n, 0.0, 0.0);
                    counts.depenetrated += 1;
                    touched = true;
                }

                // 1. Sweep the motion: the centre never crosses a surface.
                let mut target = start + motion;
                // Ray casts are skipped for candidates whose box the segment's box does not
                // reach within round-off (`tight`: 1 % of r plus a few ulps of the
                // coordinates), so particles gliding at distance r along a wall cast none.
                let scale = scale.max(start.abs().max_element());
                let tight = 0.01 * r + 8.0 * Real::EPSILON * scale;
                if let Some((t, normal)) = sweep(colliders, cands, boxes, tight, start, motion) {
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
                    for (&h, b) in cands.iter().zip(boxes) {
                        // Within `d` of a shape is within `d` of its box (the box holds
                        // the shape): a candidate whose box is farther than `r − slack`
                        // along some axis is farther than that from the shape, which is
                        // left alone below anyway. A few ulps of the coordinates on top
                        // absorb round-off (the projection's `d` then still reads at least
                        // `r − slack`: same results bit for bit). Particles resting one
                        // radius off a wall (between `r − slack` and `r`), the usual case,
                        // then query nothing (with the margin `r` used before, each cost a
                        // projection per wall per step: contact at 2,500 particles on one
                        // thread 187 µs, 127 with this cull, 112 with the same margin for
                        // the whole motion above; 201 with `2r` before that).
                        let cull =
                            r - slack + 8.0 * Real::EPSILON * scale.max(target.abs().max_element());
                        if apart(b, target, target, cull) {
                            continue;
                        }
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

                // 3. Verify: the corrected motion must still cross no surface, and a parry
                // query must not have produced a non-finite point.
                if touched {
                    counts.contacts += 1;
                    let finite = crate::math::is_finite(target) && crate::math::is_finite(v);
                    let scale = scale.max(target.abs().max_element());
                    let tight = 0.01 * r + 8.0 * Real::EPSILON * scale;
                    if !finite || !segment_is_free(colliders, cands, boxes, tight, start, target) {
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

/// `true` when the particle's motion `from → to` (over the substep) crosses no candidate's
/// surface, each collider seen in its own moving frame.
fn moving_segment_free(
    colliders: &ColliderSet,
    table: &[MovingCollider],
    candidates: &[ColliderHandle],
    from: Vector,
    to: Vector,
) -> Result<(), Option<u32>> {
    for &h in candidates {
        let Some(co) = colliders.get(h) else { continue };
        match entry_of(table, h) {
            Some((e, m)) if m.moving => {
                let a = m.start.inverse_transform_point(from);
                let b = m.stop.inverse_transform_point(to);
                if a == b {
                    if co.shape().contains_local_point(a) {
                        return Err(Some(e));
                    }
                    continue;
                }
                if co
                    .shape()
                    .cast_local_ray(&Ray::new(a, b - a), 1.0, false)
                    .is_some()
                {
                    return Err(Some(e));
                }
            }
            other => {
                let motion = to - from;
                if motion.length_squared() == 0.0 {
                    continue;
                }
                if co
                    .shape()
                    .cast_ray(co.position(), &Ray::new(from, motion), 1.0, false)
                    .is_some()
                {
                    return Err(other.map(|(e, _)| e));
                }
            }
        }
    }
    Ok(())
}

/// [`resolve`] with moving bodies near the fluid.
#[allow(clippy::too_many_arguments)]
fn resolve_moving(
    grid: &NeighborGrid,
    candidates: &ContactWorkspace,
    colliders: &ColliderSet,
    response: ContactResponse,
    depenetrate_first: bool,
    previous: &[Vector],
    positions: &mut [Vector],
    velocities: &mut [Vector],
    movers: Movers<'_>,
) -> ContactCounts {
    let Movers {
        table,
        mass,
        records,
    } = movers;
    let r = response.radius;
    let slack = r * 1e-3;
    records.resize_with(positions.len().div_ceil(CHUNK), Vec::new);
    // Surface velocity of an entry at a point (zero for bodies at rest and static colliders).
    let surface = |e: Option<u32>, p: Vector| match e {
        Some(e) => table[e as usize].velocity_at_stop(p),
        _ => Vector::ZERO,
    };
    let per_chunk = crate::par_chunks_mut!(positions, CHUNK)
        .zip(crate::par_chunks_mut!(velocities, CHUNK))
        .zip(crate::par_iter_mut!(records[..]))
        .enumerate()
        .map(|(c, ((xs, vs), recs))| {
            recs.clear();
            let base = c * CHUNK;
            let mut counts = ContactCounts::default();
            for k in 0..xs.len() {
                let i = base + k;
                let cands = candidates.of_cell(grid.cell_of(i));
                if cands.is_empty() {
                    continue;
                }
                let mut start = previous[i];
                let v_orig = vs[k];
                let mut v = v_orig;
                let motion = xs[k] - start;
                let mut touched = false;
                let first_record = recs.len();
                // Velocity change against entry `e` at `p` with normal `n`: recorded as an
                // impulse on a dynamic body (one record per particle and body: repeated
                // contacts add up, the last normal and point are kept).
                let kick = |recs: &mut Vec<ImpulseRecord>,
                            e: Option<u32>,
                            dv: Vector,
                            p: Vector,
                            n: Vector| {
                    if let Some(e) = e
                        && table[e as usize].dynamic
                        && dv != Vector::ZERO
                    {
                        if recs.len() > first_record
                            && let Some(last) = recs.last_mut()
                            && last.entry == e
                        {
                            last.impulse += dv * -mass;
                            last.point = p;
                            last.normal = n;
                        } else {
                            recs.push(ImpulseRecord {
                                entry: e,
                                particle: i as u32,
                                normal: n,
                                impulse: dv * -mass,
                                point: p,
                            });
                        }
                    }
                };

                if depenetrate_first && let Some((p, n)) = depenetrate(colliders, cands, start, r) {
                    start = p;
                    v = reflect(v, n, 0.0, 0.0);
                    counts.depenetrated += 1;
                    touched = true;
                }

                // 1. Sweep the motion, each collider in its own moving frame.
                let mut target = start + motion;
                let mut best: Option<(Real, Vector, Vector, Vector, Option<u32>)> = None;
                for &h in cands {
                    let Some(co) = colliders.get(h) else { continue };
                    let max_t = best.map_or(1.0, |b| b.0);
                    match entry_of(table, h) {
                        Some((e, m)) if m.moving => {
                            let a = m.start.inverse_transform_point(start);
                            let b = m.stop.inverse_transform_point(start + motion);
                            let d = b - a;
                            if d.length_squared() == 0.0 {
                                continue;
                            }
                            if let Some(hit) = co.shape().cast_local_ray_and_get_normal(
                                &Ray::new(a, d),
                                max_t,
                                false,
                            ) && hit.time_of_impact <= max_t
                            {
                                let t = hit.time_of_impact;
                                best = Some((
                                    t,
                                    m.stop.rotation * hit.normal,
                                    m.stop.transform_point(a + d * t),
                                    m.stop.rotation * d,
                                    Some(e),
                                ));
                            }
                        }
                        other => {
                            if motion.length_squared() == 0.0 {
                                continue;
                            }
                            if let Some(hit) = co.shape().cast_ray_and_get_normal(
                                co.position(),
                                &Ray::new(start, motion),
                                max_t,
                                false,
                            ) && hit.time_of_impact <= max_t
                            {
                                let t = hit.time_of_impact;
                                best = Some((
                                    t,
                                    hit.normal,
                                    start + motion * t,
                                    motion,
                                    other.map(|(e, _)| e),
                                ));
                            }
                        }
                    }
                }
                if let Some((_, normal, point, rel, e)) = best {
                    let mut n = if normal.dot(rel) > 0.0 {
                        -normal
                    } else {
                        normal
                    };
                    if n.length_squared() < 0.5 {
                        n = -rel.normalize_or_zero();
                    }
                    target = point + n * r;
                    let u = surface(e, point);
                    let nv = u + reflect(v - u, n, response.restitution, response.friction);
                    kick(recs, e, nv - v, point, n);
                    v = nv;
                    touched = true;
                }

                // 2. Keep one contact radius off every surface, at the substep's end poses.
                for _ in 0..4 {
                    let mut moved = false;
                    for &h in cands {
                        let Some(co) = colliders.get(h) else { continue };
                        let entry = entry_of(table, h);
                        let pose = match entry {
                            Some((_, m)) if m.moving => &m.stop,
                            _ => co.position(),
                        };
                        let Some(proj) = co
                            .shape()
                            .project_point_with_max_dist(pose, target, false, r)
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
                            let from = match entry {
                                Some((_, m)) if m.moving => m
                                    .stop
                                    .transform_point(m.start.inverse_transform_point(start)),
                                _ => start,
                            };
                            (from - proj.point).normalize_or_zero()
                        };
                        if n == Vector::ZERO {
                            continue;
                        }
                        target = proj.point + n * r;
                        let e = entry.map(|(e, _)| e);
                        let u = surface(e, proj.point);
                        let nv = u + reflect(v - u, n, response.restitution, response.friction);
                        kick(recs, e, nv - v, proj.point, n);
                        v = nv;
                        moved = true;
                    }
                    touched |= moved;
                    if !moved {
                        break;
                    }
                }

                // 3. Verify in the moving frames; on failure ride with the body that failed
                // it, unless riding crosses another solid (a particle caught between a
                // moving body and a wall), or stay put against a static one.
                if touched {
                    counts.contacts += 1;
                    let finite = crate::math::is_finite(target) && crate::math::is_finite(v);
                    let check = if finite {
                        moving_segment_free(colliders, table, cands, start, target)
                    } else {
                        Err(None)
                    };
                    if let Err(failed) = check {
                        recs.truncate(first_record);
                        let ride = |m: &MovingCollider| {
                            m.stop
                                .transform_point(m.start.inverse_transform_point(start))
                        };
                        match failed.map(|e| (e, &table[e as usize])) {
                            Some((e, m))
                                if m.moving
                                    && moving_segment_free(
                                        colliders,
                                        table,
                                        cands,
                                        start,
                                        ride(m),
                                    )
                                    .is_ok() =>
                            {
                                target = ride(m);
                                v = m.velocity_at_stop(target);
                                kick(recs, Some(e), v - v_orig, target, Vector::ZERO);
                            }
                            other => {
                                target = start;
                                v = Vector::ZERO;
                                kick(
                                    recs,
                                    other.map(|(e, _)| e),
                                    v - v_orig,
                                    target,
                                    Vector::ZERO,
                                );
                            }
                        }
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
