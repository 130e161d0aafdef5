//! Particle–collider contact: swept, then pushed off, then verified. See the
//! [module docs](super).

use super::ContactWorkspace;
use super::bodies::{ImpulseRecord, MovingCollider, ParticleMass, entry_of};
use crate::math::{Pose, Real, Vector};
use crate::neighbors::NeighborGrid;
use crate::par::CHUNK;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::query::Ray;
use rapier3d::geometry::{Collider, ColliderHandle, ColliderSet};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Contact response constants.
#[derive(Copy, Clone, Debug)]
pub struct ContactResponse {
    /// Distance kept between particle centers and surfaces (m).
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
/// "clearly apart" so NaN coordinates never count as apart (the queries then run).
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

/// Where contact stands a candidate collider: its own pose for those at rest, the pose of the
/// substep's start for moving ones (the particles' start positions are there too).
type PoseOf<'a> = &'a dyn Fn(ColliderHandle, &Collider) -> Pose;

/// A collider's own pose.
fn own_pose(_: ColliderHandle, co: &Collider) -> Pose {
    *co.position()
}

/// `true` when `p` is inside any solid candidate (each at `pose_of`).
fn inside_any(
    colliders: &ColliderSet,
    candidates: &[ColliderHandle],
    pose_of: PoseOf<'_>,
    p: Vector,
) -> bool {
    candidates.iter().any(|&h| {
        colliders
            .get(h)
            .is_some_and(|co| co.shape().contains_point(&pose_of(h, co), p))
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
    pose_of: PoseOf<'_>,
    start: Vector,
    radius: Real,
) -> Option<(Vector, Vector)> {
    if !inside_any(colliders, candidates, pose_of, start) {
        return None;
    }
    for &h in candidates {
        let Some(co) = colliders.get(h) else { continue };
        let pose = pose_of(h, co);
        if !co.shape().contains_point(&pose, start) {
            continue;
        }
        let proj = co.shape().project_point(&pose, start, false);
        let out = proj.point - start;
        if crate::math::is_finite(proj.point) && out.length() > Real::EPSILON * radius {
            let n = out.normalize();
            let p = proj.point + n * radius;
            if crate::math::is_finite(p) && !inside_any(colliders, candidates, pose_of, p) {
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
                let pose = pose_of(h, co);
                if co.shape().contains_point(&pose, p)
                    && let Some(t) = co.shape().cast_ray(&pose, &ray, Real::MAX, false)
                {
                    exit = exit.max(t);
                }
            }
            p += dir * (exit + radius);
            travelled += exit + radius;
            if !inside_any(colliders, candidates, pose_of, p) {
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

/// What contact reads besides the particles.
pub struct ContactInput<'a> {
    /// The grid the particles are sorted by.
    pub grid: &'a NeighborGrid,
    /// The candidate colliders of each cell.
    pub candidates: &'a ContactWorkspace,
    /// The colliders.
    pub colliders: &'a ColliderSet,
    /// Contact radius, restitution and friction.
    pub response: ContactResponse,
    /// Push a particle that starts inside a solid out first (see [`depenetrate`]).
    pub depenetrate_first: bool,
    /// The positions at the substep's start (outside every solid).
    pub previous: &'a [Vector],
}

/// Moving bodies near the fluid during a substep, for [`resolve`]: the coupling table, the
/// particle mass, and one impulse buffer per chunk of particles (reused across steps).
pub struct Movers<'a> {
    /// The table of the substep (sorted by collider handle).
    pub table: &'a [MovingCollider],
    /// Each particle's mass.
    pub mass: ParticleMass<'a>,
    /// Per-chunk impulses on dynamic bodies, filled by [`resolve`] (chunk order is the
    /// summation order).
    pub records: &'a mut Vec<Vec<ImpulseRecord>>,
}

/// Resolves contact for every particle of a sorted fluid: `positions` and `velocities` hold
/// the integrated ones, `input.previous` the start-of-step positions. With `movers`,
/// colliders of non-fixed bodies are handled in their moving frames and impulses on dynamic
/// bodies are recorded (see [`super::bodies`]).
pub fn resolve(
    input: &ContactInput<'_>,
    positions: &mut [Vector],
    velocities: &mut [Vector],
    movers: Option<Movers<'_>>,
) -> ContactCounts {
    match movers {
        Some(m) if !m.table.is_empty() => resolve_moving(input, positions, velocities, m),
        Some(m) => {
            m.records.iter_mut().for_each(Vec::clear);
            resolve_static(input, positions, velocities)
        }
        None => resolve_static(input, positions, velocities),
    }
}

/// Below this fraction of the contact radius a particle counts as at the contact distance
/// (no push): avoids chasing round-off at every step for particles resting on a surface.
const SLACK: Real = 1e-3;

/// The per-chunk counts summed (integers: the same in any order).
#[cfg(feature = "parallel")]
fn total(per_chunk: impl ParallelIterator<Item = ContactCounts>) -> ContactCounts {
    per_chunk.reduce(ContactCounts::default, |a, b| a + b)
}

/// The per-chunk counts summed.
#[cfg(not(feature = "parallel"))]
fn total(per_chunk: impl Iterator<Item = ContactCounts>) -> ContactCounts {
    per_chunk.fold(ContactCounts::default(), |a, b| a + b)
}

/// One particle during contact: where it starts (out of the solid it started in, if it was
/// pushed out), its motion, where it goes, its velocity, and whether anything changed them.
struct Particle {
    start: Vector,
    motion: Vector,
    target: Vector,
    v: Vector,
    touched: bool,
    depenetrated: bool,
}

impl Particle {
    /// The particle moving from `start` to `end` with velocity `v`, first pushed out of the
    /// solid it starts in when `input.depenetrate_first` (see [`depenetrate`]).
    #[inline(always)]
    fn begin(
        input: &ContactInput<'_>,
        (cands, pose_of): (&[ColliderHandle], PoseOf<'_>),
        start: Vector,
        end: Vector,
        v: Vector,
    ) -> Self {
        let motion = end - start;
        let mut p = Particle {
            start,
            motion,
            target: end,
            v,
            touched: false,
            depenetrated: false,
        };
        if input.depenetrate_first
            && let Some((x, n)) = depenetrate(
                input.colliders,
                cands,
                pose_of,
                start,
                input.response.radius,
            )
        {
            p.start = x;
            p.v = reflect(v, n, 0.0, 0.0);
            p.depenetrated = true;
            p.touched = true;
        }
        p.target = p.start + motion;
        p
    }

    /// Step 2 of both paths: `pass` keeps `(target, v)` one contact radius off every
    /// candidate once and says whether it moved the particle; a corner takes a few passes.
    #[inline(always)]
    fn keep_off(&mut self, mut pass: impl FnMut(&mut Vector, &mut Vector) -> bool) {
        for _ in 0..4 {
            let moved = pass(&mut self.target, &mut self.v);
            self.touched |= moved;
            if !moved {
                break;
            }
        }
    }

    /// `true` when no parry query produced a non-finite point or velocity.
    #[inline(always)]
    fn finite(&self) -> bool {
        crate::math::is_finite(self.target) && crate::math::is_finite(self.v)
    }

    /// Counts the touched particle into `counts` (`fallback`: its corrected motion failed the
    /// final check) and writes its position and velocity.
    #[inline(always)]
    fn finish(&self, fallback: bool, counts: &mut ContactCounts, x: &mut Vector, v: &mut Vector) {
        counts.contacts += 1;
        counts.depenetrated += self.depenetrated as usize;
        counts.fallbacks += fallback as usize;
        *x = self.target;
        *v = self.v;
    }
}

/// The sweep's normal `normal` turned against the motion `motion` (a ray cast from inside a
/// sheet may return the far side's); without a normal, straight back along the motion.
#[inline(always)]
fn facing(normal: Vector, motion: Vector) -> Vector {
    let n = if normal.dot(motion) > 0.0 {
        -normal
    } else {
        normal
    };
    if n.length_squared() < 0.5 {
        -motion.normalize_or_zero()
    } else {
        n
    }
}

/// Where `target` must go to stay one contact radius `r` off collider `co` (at `pose`): the
/// closest point of its surface and the outward normal there, or `None` when `target` is
/// outside it and no nearer than `r − slack`. On the surface itself (a zero-thickness
/// sheet) the normal points back to `from()`, the side the particle came from.
#[inline(always)]
fn push_off(
    co: &Collider,
    pose: &Pose,
    target: Vector,
    r: Real,
    slack: Real,
    from: impl FnOnce() -> Vector,
) -> Option<(Vector, Vector)> {
    let proj = co
        .shape()
        .project_point_with_max_dist(pose, target, false, r)?;
    let delta = target - proj.point;
    let d = delta.length();
    if !proj.is_inside && d >= r - slack {
        return None;
    }
    let n = if proj.is_inside {
        -delta / d.max(Real::MIN_POSITIVE)
    } else if d > 1e-6 * r {
        delta / d
    } else {
        (from() - proj.point).normalize_or_zero()
    };
    (n != Vector::ZERO).then_some((proj.point, n))
}

/// [`resolve`] when every candidate collider is at rest.
fn resolve_static(
    input: &ContactInput<'_>,
    positions: &mut [Vector],
    velocities: &mut [Vector],
) -> ContactCounts {
    total(
        crate::par_chunks_mut!(positions, CHUNK)
            .zip(crate::par_chunks_mut!(velocities, CHUNK))
            .enumerate()
            .map(|(c, (xs, vs))| {
                let mut counts = ContactCounts::default();
                for (k, (x, v)) in xs.iter_mut().zip(vs.iter_mut()).enumerate() {
                    static_particle(input, c * CHUNK + k, x, v, &mut counts);
                }
                counts
            }),
    )
}

/// Contact of sorted particle `i` (integrated position `x`, velocity `v`) with colliders at
/// rest: swept, pushed off, verified.
#[inline(always)]
fn static_particle(
    input: &ContactInput<'_>,
    i: usize,
    x: &mut Vector,
    v: &mut Vector,
    counts: &mut ContactCounts,
) {
    let (cands, boxes) = input.candidates.of_cell_with_boxes(input.grid.cell_of(i));
    if cands.is_empty() {
        return;
    }
    let (colliders, response) = (input.colliders, input.response);
    let r = response.radius;
    let slack = r * SLACK;
    let start = input.previous[i];
    // Far from every candidate's box (by more than r − slack, plus a few ulps of the
    // coordinates for round-off, around the motion's box), nothing below can touch the
    // particle: the sweep needs the segment to meet a shape, a push needs the end point
    // closer than r − slack to one (step 2's cull), a depenetration needs the start inside
    // one. Skipping is then exact, and most particles of a cell next to a wall are not next
    // to the wall themselves; nor are those resting on it, one radius off (less than `slack`
    // nearer).
    let scale = start.abs().max_element().max(x.abs().max_element());
    let reach =
        Aabb::new(start.min(*x), start.max(*x)).loosened(r - slack + 8.0 * Real::EPSILON * scale);
    if !boxes.iter().any(|b| b.intersects(&reach)) {
        return;
    }
    let mut p = Particle::begin(input, (cands, &own_pose), start, *x, *v);

    // 1. Sweep the motion: the center never crosses a surface. Ray casts are skipped for
    // candidates whose box the segment's box does not reach within round-off (`tight`: 1 %
    // of r plus a few ulps of the coordinates), so particles gliding at distance r along a
    // wall cast none.
    let scale = scale.max(p.start.abs().max_element());
    let tight = 0.01 * r + 8.0 * Real::EPSILON * scale;
    if let Some((t, normal)) = sweep(colliders, cands, boxes, tight, p.start, p.motion) {
        let n = facing(normal, p.motion);
        p.target = p.start + p.motion * t + n * r;
        p.v = reflect(p.v, n, response.restitution, response.friction);
        p.touched = true;
    }

    // 2. Keep one contact radius off every surface (corners: a few passes).
    let from = p.start;
    p.keep_off(|target, v| static_pass(input, (cands, boxes), scale, from, target, v));
    if !p.touched {
        return;
    }

    // 3. Verify: the corrected motion must still cross no surface, and a parry query must
    // not have produced a non-finite point.
    let scale = scale.max(p.target.abs().max_element());
    let tight = 0.01 * r + 8.0 * Real::EPSILON * scale;
    let fallback =
        !p.finite() || !segment_is_free(colliders, cands, boxes, tight, p.start, p.target);
    if fallback {
        p.target = p.start;
        p.v = Vector::ZERO;
    }
    p.finish(fallback, counts, x, v);
}

/// One pass of step 2 on the static path: `(target, v)` kept one contact radius off every
/// candidate of `cands` (with their boxes), `from` the side the particle came from. Returns
/// whether it moved the particle.
///
/// Within `d` of a shape is within `d` of its box (the box holds the shape): a candidate
/// whose box is farther than `r − slack` along some axis is farther than that from the
/// shape, which [`push_off`] leaves alone anyway, and is not queried. A few ulps of the
/// coordinates (`scale`) on top absorb round-off (the projection's `d` then still reads at
/// least `r − slack`: the same results bit for bit). Particles resting one radius off a
/// wall (between `r − slack` and `r`), the usual case, then query nothing. Contact at 2,500
/// particles on one thread (`cargo run --release --example stage_medians -- 2500 1500 1`):
/// 187 µs with a margin of `r`, 127 with this cull, 112 with the same margin for the whole
/// motion (the `reach` test of [`static_particle`]), 201 with `2r`.
#[inline(always)]
fn static_pass(
    input: &ContactInput<'_>,
    (cands, boxes): (&[ColliderHandle], &[Aabb]),
    scale: Real,
    from: Vector,
    target: &mut Vector,
    v: &mut Vector,
) -> bool {
    let response = input.response;
    let r = response.radius;
    let slack = r * SLACK;
    let mut moved = false;
    for (&h, b) in cands.iter().zip(boxes) {
        let cull = r - slack + 8.0 * Real::EPSILON * scale.max(target.abs().max_element());
        if apart(b, *target, *target, cull) {
            continue;
        }
        let Some(co) = input.colliders.get(h) else {
            continue;
        };
        let Some((point, n)) = push_off(co, co.position(), *target, r, slack, || from) else {
            continue;
        };
        *target = point + n * r;
        *v = reflect(*v, n, response.restitution, response.friction);
        moved = true;
    }
    moved
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

/// Where a particle at `p` at the substep's start stands at its end riding with body `m`.
#[inline(always)]
fn ride(m: &MovingCollider, p: Vector) -> Vector {
    m.stop.transform_point(m.start.inverse_transform_point(p))
}

/// Earliest hit of the motion `start → start + motion` among `candidates`, each collider in
/// its own moving frame: `(t, normal, point, motion relative to the collider, entry)` (the
/// normal, point and relative motion at the substep's end pose).
fn moving_sweep(
    colliders: &ColliderSet,
    table: &[MovingCollider],
    candidates: &[ColliderHandle],
    start: Vector,
    motion: Vector,
) -> Option<(Real, Vector, Vector, Vector, Option<u32>)> {
    let mut best: Option<(Real, Vector, Vector, Vector, Option<u32>)> = None;
    for &h in candidates {
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
                if let Some(hit) =
                    co.shape()
                        .cast_local_ray_and_get_normal(&Ray::new(a, d), max_t, false)
                    && hit.time_of_impact <= max_t
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
                    let e = other.map(|(e, _)| e);
                    best = Some((t, hit.normal, start + motion * t, motion, e));
                }
            }
        }
    }
    best
}

/// What the moving path reads besides the particles.
struct Moving<'a> {
    input: &'a ContactInput<'a>,
    /// The coupling table of the substep.
    table: &'a [MovingCollider],
    /// Each particle's mass.
    mass: ParticleMass<'a>,
}

impl Moving<'_> {
    /// The velocity `v` reflected off the surface of entry `e` (none: a static collider) at
    /// `point` with normal `n`, relative to the surface's velocity there.
    #[inline(always)]
    fn respond(&self, e: Option<u32>, v: Vector, n: Vector, point: Vector) -> Vector {
        let response = self.input.response;
        let u = match e {
            Some(e) => self.table[e as usize].velocity_at_stop(point),
            _ => Vector::ZERO,
        };
        u + reflect(v - u, n, response.restitution, response.friction)
    }
}

/// The impulses one particle's contact gives dynamic bodies: a velocity change against an
/// entry is recorded as an impulse on its body (one record per particle and body: repeated
/// contacts add up, the last normal and point are kept).
struct Kicks<'a> {
    table: &'a [MovingCollider],
    /// The particle's mass (kg).
    mass: Real,
    records: &'a mut Vec<ImpulseRecord>,
    /// The particle's first record in `records`.
    first: usize,
    particle: u32,
}

impl Kicks<'_> {
    /// The velocity change `dv` against entry `e` at `p` with normal `n`.
    #[inline(always)]
    fn add(&mut self, e: Option<u32>, dv: Vector, p: Vector, n: Vector) {
        let Some(e) = e else { return };
        if !self.table[e as usize].dynamic || dv == Vector::ZERO {
            return;
        }
        if self.records.len() > self.first
            && let Some(last) = self.records.last_mut()
            && last.entry == e
        {
            last.impulse += dv * -self.mass;
            last.point = p;
            last.normal = n;
        } else {
            self.records.push(ImpulseRecord {
                entry: e,
                particle: self.particle,
                normal: n,
                impulse: dv * -self.mass,
                point: p,
                moment: Vector::ZERO,
                held: None,
            });
        }
    }
}

/// [`resolve`] with moving bodies near the fluid.
fn resolve_moving(
    input: &ContactInput<'_>,
    positions: &mut [Vector],
    velocities: &mut [Vector],
    movers: Movers<'_>,
) -> ContactCounts {
    let Movers {
        table,
        mass,
        records,
    } = movers;
    records.resize_with(positions.len().div_ceil(CHUNK), Vec::new);
    let moving = Moving { input, table, mass };
    total(
        crate::par_chunks_mut!(positions, CHUNK)
            .zip(crate::par_chunks_mut!(velocities, CHUNK))
            .zip(crate::par_iter_mut!(records[..]))
            .enumerate()
            .map(|(c, ((xs, vs), recs))| {
                recs.clear();
                let mut counts = ContactCounts::default();
                for (k, (x, v)) in xs.iter_mut().zip(vs.iter_mut()).enumerate() {
                    moving_particle(&moving, c * CHUNK + k, x, v, recs, &mut counts);
                }
                counts
            }),
    )
}

/// Contact of sorted particle `i` (integrated position `x`, velocity `v`) with colliders of
/// which some move: swept and pushed off in each collider's moving frame, its velocity
/// reflected relative to the surface's, the velocity changes recorded as impulses on dynamic
/// bodies (`records`), then verified.
#[inline(always)]
fn moving_particle(
    m: &Moving<'_>,
    i: usize,
    x: &mut Vector,
    v: &mut Vector,
    records: &mut Vec<ImpulseRecord>,
    counts: &mut ContactCounts,
) {
    let input = m.input;
    let (cands, boxes) = input.candidates.of_cell_with_boxes(input.grid.cell_of(i));
    if cands.is_empty() {
        return;
    }
    let (colliders, table) = (input.colliders, m.table);
    let r = input.response.radius;
    let slack = r * SLACK;
    if static_and_far(m, (cands, boxes), input.previous[i], *x) {
        return;
    }
    let v_orig = *v;
    let mut kicks = Kicks {
        table,
        mass: m.mass.of(i),
        first: records.len(),
        records,
        particle: i as u32,
    };
    // A moving collider is pushed out of at its pose of the substep's start: rapier has
    // already moved it to the frame's end, where particles just added to a spinning tank
    // would be inside its walls, and pushed out through them.
    let pose_of = |h: ColliderHandle, co: &Collider| match entry_of(table, h) {
        Some((_, mc)) if mc.moving => mc.start,
        _ => *co.position(),
    };
    let mut p = Particle::begin(input, (cands, &pose_of), input.previous[i], *x, v_orig);

    // 1. Sweep the motion, each collider in its own moving frame.
    if let Some((_, normal, point, rel, e)) =
        moving_sweep(colliders, table, cands, p.start, p.motion)
    {
        let n = facing(normal, rel);
        p.target = point + n * r;
        let nv = m.respond(e, p.v, n, point);
        kicks.add(e, nv - p.v, point, n);
        p.v = nv;
        p.touched = true;
    }

    // 2. Keep one contact radius off every surface, at the substep's end poses.
    let start = p.start;
    let mut press = Press::default();
    p.keep_off(|target, v| {
        let mut moved = false;
        for &h in cands {
            let Some(co) = colliders.get(h) else { continue };
            let entry = entry_of(table, h);
            let (pose, from) = match entry {
                Some((_, mc)) if mc.moving => (&mc.stop, Some(mc)),
                _ => (co.position(), None),
            };
            let came_from = || from.map_or(start, |mc| ride(mc, start));
            let Some((point, n)) = push_off(co, pose, *target, r, slack, came_from) else {
                continue;
            };
            *target = point + n * r;
            let e = entry.map(|(e, _)| e);
            press.record(table, e, n, point);
            let nv = m.respond(e, *v, n, point);
            kicks.add(e, nv - *v, point, n);
            *v = nv;
            moved = true;
        }
        moved
    });
    if !p.touched {
        return;
    }
    if let Some(c) = press.caught(table) {
        hold(m, &mut p, c, &mut kicks);
    }
    let fallback = verify_moving(m, &mut p, cands, v_orig, &mut kicks);
    let integrated = *x;
    p.finish(fallback, counts, x, v);
    settle_records(&mut kicks, integrated, *x, v_orig);
}

/// `true` when every candidate of `cands` is outside the coupling table (at rest, at its own
/// pose, its box the shape's there) and its box farther than the contact radius (less the
/// slack, plus a few ulps of the coordinates) from the box of the motion `start → end`: the
/// static path's `reach` test. No sweep can then hit, no push can reach the end point (and
/// without a push it never moves), no start is inside: the particle would come out of
/// `moving_particle` untouched, so skipping it is exact.
#[inline(always)]
fn static_and_far(
    m: &Moving<'_>,
    (cands, boxes): (&[ColliderHandle], &[Aabb]),
    start: Vector,
    end: Vector,
) -> bool {
    let r = m.input.response.radius;
    let scale = start.abs().max_element().max(end.abs().max_element());
    let margin = r - r * SLACK + 8.0 * Real::EPSILON * scale;
    let (lo, hi) = (start.min(end), start.max(end));
    cands
        .iter()
        .zip(boxes)
        .all(|(&h, b)| entry_of(m.table, h).is_none() && apart(b, lo, hi, margin))
}

/// The last pushes of step 2 on one particle, each as `(entry, outward normal, surface
/// point)` (no entry: a collider at rest): by a dynamic body, and by any other surface.
#[derive(Default)]
struct Press {
    body: Option<(u32, Vector, Vector)>,
    other: Option<(Option<u32>, Vector, Vector)>,
}

/// A particle caught between a dynamic body and another surface facing it (see [`hold`]).
#[derive(Copy, Clone)]
struct Caught {
    /// The body's entry, outward normal and surface point.
    body: (u32, Vector, Vector),
    /// The other surface's entry (none: at rest), outward normal and point.
    other: (Option<u32>, Vector, Vector),
}

impl Press {
    /// Records a push of normal `n` at `point` by entry `e` of `table` (none: a collider at
    /// rest). A push by another body than the one recorded becomes the other surface.
    #[inline(always)]
    fn record(&mut self, table: &[MovingCollider], e: Option<u32>, n: Vector, point: Vector) {
        match e {
            Some(e) if table[e as usize].dynamic => {
                if let Some((b, bn, bp)) = self.body
                    && table[b as usize].body != table[e as usize].body
                {
                    self.other = Some((Some(b), bn, bp));
                }
                self.body = Some((e, n, point));
            }
            _ => self.other = Some((e, n, point)),
        }
    }

    /// The particle is caught when a dynamic body and another surface that is not a dynamic
    /// body (a static collider, a kinematic body) both pushed it and their normals are more
    /// than 120° apart: it is within a contact radius of both, in a gap thinner than two. A
    /// dynamic other surface would take none of the momentum [`hold`] stops (the sloshing box
    /// of `tests/moving_bodies.rs`, Clavet without cohesion: 1.66 % of the momentum lost over
    /// 5 s; 0.10 % with this when Clavet counted dynamic bodies in its densities, 0.16 % now
    /// that it meets them by contact only), and its own contact with the body is rapier's.
    #[inline(always)]
    fn caught(&self, table: &[MovingCollider]) -> Option<Caught> {
        let body = self.body?;
        let other = self.other?;
        let dynamic = other.0.is_some_and(|o| table[o as usize].dynamic);
        (!dynamic && body.1.dot(other.1) < -0.5).then_some(Caught { body, other })
    }
}

/// A particle caught in a gap thinner than two contact radii between a dynamic body closing
/// in and another surface (a landing box and the floor, a box pushed against a wall) cannot
/// be kept a radius off both: step 2 leaves it nearer one, and once the gap is thinner than
/// one radius the fallback of [`verify_moving`] keeps it still while the body closes over it
/// (4–9 particles ended 1–2 mm inside 20,000 kg/m³ boxes landed on the floor,
/// `tests/light_bodies.rs`; the body took only that particle's `−m·Δv`, and rapier's floor
/// contact does not see particles).
///
/// Here the other surface holds the particle, so it is the body's spacer: its record is
/// marked held ([`ImpulseRecord::held`]) and the added-mass solve gives it
/// `HELD_MASS` (`bodies::exchange`) times the body's mass, moving at the other surface's
/// velocity: the body's approach there stops, as against a rigid contact (inelastic: the
/// body loses that velocity, the other surface takes the momentum). The particle moves with
/// the body along the normal (the solve then brings both to the other surface's velocity);
/// its position is step 2's. A gap thinner than two contact radii (the body reached it
/// within a substep, or rapier's gravity of the frame moved it on) is opened back to two by
/// moving the body (its drift, no velocity: no energy but the weight's lift over that
/// distance), so the particle can stay a radius off both: without it a 20,000 kg/m³ DFSPH
/// box crept down 0.25 mm a frame until the gap was one radius and the fallback let it fall
/// over the particles. Nothing changes for a body moving away, for a particle near one
/// surface only, between two dynamic bodies (see [`Press::caught`]), or for kinematic bodies.
fn hold(m: &Moving<'_>, p: &mut Particle, c: Caught, kicks: &mut Kicks<'_>) {
    let (e, n, point) = c.body;
    let u = m.table[e as usize].velocity_at_stop(point).dot(n);
    let w = match c.other.0 {
        Some(o) => m.table[o as usize].velocity_at_stop(c.other.2).dot(n),
        None => 0.0,
    };
    if !(u > w) {
        return;
    }
    let v = p.v;
    p.v = v + n * (u - v.dot(n));
    // The gap across, between the two surface points along the other surface's normal.
    let gap = (point - c.other.2).dot(c.other.1);
    let record = ImpulseRecord {
        entry: e,
        particle: kicks.particle,
        normal: n,
        impulse: n * (-(u - w) * kicks.mass),
        point,
        moment: Vector::ZERO,
        held: Some((2.0 * m.input.response.radius - gap).max(0.0)),
    };
    let first = kicks.first;
    match kicks.records[first..].iter_mut().find(|r| r.entry == e) {
        Some(r) => *r = record,
        None => kicks.records.push(record),
    }
}

/// The angular momentum bookkeeping of one particle's contact records: the particle's
/// momentum changed by `Δp` where it ended (`x`), so each impulse is taken on the body on
/// that line (see `bodies::on_line`); and moving it out of the body (from `integrated`, at
/// momentum `m·v`) gave it `(x − integrated) × m·v` of angular momentum with no impulse,
/// which the last body it touched gives up (`ImpulseRecord::moment`). With both, the water
/// and the bodies exchange angular momentum exactly.
#[inline(always)]
fn settle_records(kicks: &mut Kicks<'_>, integrated: Vector, x: Vector, v: Vector) {
    let first = kicks.first;
    if kicks.records.len() <= first {
        return;
    }
    for rec in &mut kicks.records[first..] {
        rec.point = super::bodies::on_line(x, rec.point, rec.impulse);
    }
    if let Some(last) = kicks.records.last_mut() {
        last.moment = (x - integrated).cross(v * kicks.mass);
    }
}

/// Step 3 of the moving path: the corrected motion must cross no surface in the moving
/// frames, and be finite. On failure the particle rides with the body that failed it, unless
/// riding crosses another solid (a particle caught between a moving body and a wall), or
/// stays put against a static one; its impulses are then only that change. Returns whether
/// it failed.
fn verify_moving(
    m: &Moving<'_>,
    p: &mut Particle,
    cands: &[ColliderHandle],
    v_orig: Vector,
    kicks: &mut Kicks<'_>,
) -> bool {
    let (colliders, table, start) = (m.input.colliders, m.table, p.start);
    let check = if p.finite() {
        moving_segment_free(colliders, table, cands, start, p.target)
    } else {
        Err(None)
    };
    let Err(failed) = check else { return false };
    kicks.records.truncate(kicks.first);
    match failed.map(|e| (e, &table[e as usize])) {
        Some((e, mc))
            if mc.moving
                && moving_segment_free(colliders, table, cands, start, ride(mc, start)).is_ok() =>
        {
            p.target = ride(mc, start);
            p.v = mc.velocity_at_stop(p.target);
            kicks.add(Some(e), p.v - v_orig, p.target, Vector::ZERO);
        }
        other => {
            p.target = start;
            p.v = Vector::ZERO;
            kicks.add(other.map(|(e, _)| e), p.v - v_orig, p.target, Vector::ZERO);
        }
    }
    true
}
