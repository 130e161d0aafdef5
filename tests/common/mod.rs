//! Shared helpers of the integration tests: a small harness that throws particles at rapier
//! colliders and checks, after every step, that none went through.
//!
//! Only the public API of `rapier_sph`, rapier and parry is used.

#![allow(dead_code)]

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rapier_sph::rapier3d::prelude::*;
use rapier_sph::{Fluid, FluidHandle, FluidParams, FluidParamsBuilder, FluidWorld, StepReport};

/// Unit round-off of `f32` (half an ulp of 1): every correctly rounded operation has a
/// relative error of at most this.
pub const U32: f64 = f32::EPSILON as f64 * 0.5;

pub fn rng(seed: u64) -> Pcg64 {
    Pcg64::seed_from_u64(seed)
}

/// A uniformly distributed unit vector.
pub fn random_unit(rng: &mut Pcg64) -> Vector {
    loop {
        let v = Vector::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    }
}

/// Water at `spacing` (radius spacing/2, h = 2·spacing, c = 30 m/s).
pub fn water(spacing: Real) -> FluidParams {
    FluidParamsBuilder::water(spacing).build().unwrap()
}

/// A fluid world with one fixed body holding `colliders`, and one empty fluid. The rapier
/// world is stepped once so that its broad-phase holds the colliders.
pub fn world_with(
    params: FluidParams,
    colliders: Vec<ColliderBuilder>,
) -> (FluidWorld, FluidHandle, Vec<ColliderHandle>) {
    let mut world = FluidWorld::new();
    let body = world.physics.insert_body(RigidBodyBuilder::fixed());
    let handles = colliders
        .into_iter()
        .map(|c| world.physics.insert_collider(c, Some(body)))
        .collect();
    world.physics.step();
    let fluid = world.fluids.insert(Fluid::new(params).unwrap());
    (world, fluid, handles)
}

/// Steps only the fluid (rapier's fixed colliders do not move) with the given gravity and dt.
pub fn step_fluid(world: &mut FluidWorld, gravity: Vector, dt: Real) -> StepReport {
    let p = &mut world.physics;
    world
        .pipeline
        .step(
            gravity,
            dt,
            &mut world.fluids,
            &mut p.bodies,
            &p.colliders,
            &p.broad_phase,
        )
        .expect("step")
        .clone()
}

/// How "inside the solid" is decided for a collider.
#[derive(Clone, Debug)]
pub enum Region {
    /// parry's `contains_point` on the collider (every solid parry shape).
    Solid(ColliderHandle),
    /// A closed triangle mesh of a box: inside is decided analytically, in the box's frame
    /// (parry's `contains_point` is always false on a trimesh without pseudo-normals).
    LocalBox { pose: Pose, half: Vector },
    /// A zero-thickness rectangle `|x| ≤ hx, |z| ≤ hz` in the plane `y = 0` of `pose`, or a
    /// plate of that footprint whose mid-plane is there. "Inside" is crossing it: a particle's
    /// straight move between two steps may not cross the rectangle, and a particle that has
    /// stayed over the rectangle since it was spawned keeps the side it started on.
    Sheet { pose: Pose, hx: Real, hz: Real },
    /// A heightfield collider whose footprint in its frame is `|x| ≤ hx, |z| ≤ hz` and whose
    /// frame's y is the world's y: a particle that has stayed over the footprint is never
    /// below the surface under it (found by a vertical ray cast).
    Height {
        collider: ColliderHandle,
        hx: Real,
        hz: Real,
    },
}

/// Per-particle state the checks need, indexed by particle id.
#[derive(Clone, Debug, Default)]
pub struct Tracker {
    /// Position after the previous step (or at spawn).
    prev: Vec<Vector>,
    /// Side of the sheet a particle started on (+1/−1), 0 once it left the footprint.
    side: Vec<i8>,
    /// Worst (smallest) signed distance to a collider surface seen after a step.
    pub min_clearance: Real,
    /// Number of (particle, step) pairs closer to a surface than `radius − tolerance`.
    pub clearance_violations: usize,
    /// First clearance violation, for the failure message.
    pub first_violation: Option<String>,
    pub steps: usize,
    pub contacts: usize,
    pub fallbacks: usize,
    pub depenetrated: usize,
}

/// Largest coordinate magnitude of the scene (m), for round-off tolerances.
pub const SCENE_SCALE: f64 = 4.0;

/// The contact code promises centers at least `radius` off every surface, minus its own
/// `slack = 1e-3·radius` (below which it does not push), minus f32 round-off: the pushed
/// position `proj + n·r` and our check's re-projection each go through a pose transform and
/// a projection, about 16 correctly rounded operations on coordinates of magnitude up to
/// `SCENE_SCALE`, hence `2 · 16 · u · SCENE_SCALE`.
pub fn clearance_tolerance(radius: Real) -> Real {
    (1e-3 * radius as f64 + 2.0 * 16.0 * U32 * SCENE_SCALE) as Real
}

fn in_footprint(local: Vector, hx: Real, hz: Real) -> bool {
    local.x.abs() <= hx && local.z.abs() <= hz
}

/// Height of the heightfield surface under `p` (world), by a downward ray cast.
pub fn surface_height(co: &Collider, p: Vector) -> Option<Real> {
    let top = 100.0;
    let ray = Ray::new(Vector::new(p.x, top, p.z), Vector::NEG_Y);
    co.shape()
        .cast_ray(co.position(), &ray, 1000.0, false)
        .map(|t| top - t)
}

/// Signed distance from `p` to the collider's surface (negative inside, when parry can tell).
pub fn signed_distance(co: &Collider, p: Vector) -> Real {
    let proj = co.shape().project_point(co.position(), p, false);
    let d = (p - proj.point).length();
    if proj.is_inside { -d } else { d }
}

impl Tracker {
    pub fn new() -> Self {
        Self {
            min_clearance: Real::MAX,
            ..Default::default()
        }
    }

    /// Registers particles just added (ids `ids`, positions `pos`).
    pub fn spawn(&mut self, ids: std::ops::Range<u32>, pos: &[Vector], regions: &[Region]) {
        assert_eq!(ids.len(), pos.len());
        let end = ids.end as usize;
        if self.prev.len() < end {
            self.prev.resize(end, Vector::ZERO);
            self.side.resize(end, 0);
        }
        for (id, &p) in ids.zip(pos) {
            self.prev[id as usize] = p;
            self.side[id as usize] = 0;
            for r in regions {
                if let Region::Sheet { pose, hx, hz } = r {
                    let l = pose.inverse_transform_point(p);
                    if in_footprint(l, *hx, *hz) {
                        self.side[id as usize] = if l.y > 0.0 { 1 } else { -1 };
                    }
                }
            }
        }
    }

    /// Checks the fluid after a step. Panics on a penetration, a lost particle or a NaN;
    /// records clearance violations (closer than `radius − tolerance` to any of `surfaces`).
    #[allow(clippy::too_many_arguments)]
    pub fn check(
        &mut self,
        label: &str,
        world: &FluidWorld,
        fluid: FluidHandle,
        expected_len: usize,
        regions: &[Region],
        surfaces: &[ColliderHandle],
        report: &StepReport,
    ) {
        self.steps += 1;
        self.contacts += report.contacts;
        self.fallbacks += report.contact_fallbacks;
        self.depenetrated += report.depenetrated;
        let f = &world.fluids[fluid];
        let colliders = &world.physics.colliders;
        assert_eq!(
            f.len(),
            expected_len,
            "{label}: particle count changed at step {}",
            self.steps
        );
        assert_eq!(report.non_finite, 0, "{label}: non-finite particles");
        let radius = f.params().particle_radius;
        let tol = clearance_tolerance(radius);
        for ((&p, &v), &id) in f.positions().iter().zip(f.velocities()).zip(f.ids()) {
            let id = id as usize;
            assert!(
                p.is_finite() && v.is_finite(),
                "{label}: particle {id} not finite at step {}: {p} {v} \
                 (the step reported {} non-finite particles)",
                self.steps,
                report.non_finite
            );
            let prev = self.prev[id];
            for r in regions {
                match r {
                    Region::Solid(h) => {
                        let co = &colliders[*h];
                        assert!(
                            !co.shape().contains_point(co.position(), p),
                            "{label}: particle {id} inside the solid at step {}: {p} (was {prev}), \
                             signed distance {}",
                            self.steps,
                            signed_distance(co, p)
                        );
                    }
                    Region::LocalBox { pose, half } => {
                        let l = pose.inverse_transform_point(p);
                        assert!(
                            !(l.abs().cmplt(*half).all()),
                            "{label}: particle {id} inside the box mesh at step {}: {p} (local {l}, was {prev})",
                            self.steps
                        );
                    }
                    Region::Sheet { pose, hx, hz } => {
                        let a = pose.inverse_transform_point(prev);
                        let b = pose.inverse_transform_point(p);
                        // The straight move of the step may not cross the rectangle.
                        if b.y == 0.0 {
                            assert!(
                                !in_footprint(b, *hx, *hz),
                                "{label}: particle {id} on the sheet at step {}: local {b}",
                                self.steps
                            );
                        } else if (a.y > 0.0) != (b.y > 0.0) && a.y != 0.0 {
                            let t = a.y / (a.y - b.y);
                            let c = a + (b - a) * t;
                            assert!(
                                !in_footprint(c, *hx, *hz),
                                "{label}: particle {id} crossed the sheet at step {}: local {a} -> {b} \
                                 (crossing at {c})",
                                self.steps
                            );
                        }
                        // Over the footprint since spawn: same side as at spawn.
                        let s = &mut self.side[id];
                        if *s != 0 {
                            if in_footprint(b, *hx, *hz) {
                                assert!(
                                    (b.y > 0.0) == (*s > 0),
                                    "{label}: particle {id} changed side of the sheet at step {} \
                                     without leaving its footprint: local {b}",
                                    self.steps
                                );
                            } else {
                                *s = 0;
                            }
                        }
                    }
                    Region::Height {
                        collider: h,
                        hx,
                        hz,
                    } => {
                        let co = &colliders[*h];
                        let l = co.position().inverse_transform_point(p);
                        let s = &mut self.side[id];
                        if in_footprint(l, *hx, *hz) {
                            if *s >= 0 {
                                let surf = surface_height(co, p).unwrap_or(Real::NEG_INFINITY);
                                assert!(
                                    p.y >= surf,
                                    "{label}: particle {id} below the heightfield at step {}: {p}, \
                                     surface at {surf} (was {prev})",
                                    self.steps
                                );
                            }
                        } else {
                            // Left the footprint: it may go under the terrain from the side.
                            *s = -1;
                        }
                    }
                }
            }
            for &h in surfaces {
                let d = signed_distance(&colliders[h], p);
                self.min_clearance = self.min_clearance.min(d);
                if d < radius - tol {
                    self.clearance_violations += 1;
                    if self.first_violation.is_none() {
                        self.first_violation = Some(format!(
                            "{label}: particle {id} at {p} is {d} from a surface at step {} \
                             (radius {radius}, tolerance {tol}; was at {prev})",
                            self.steps
                        ));
                    }
                }
            }
            self.prev[id] = p;
        }
    }

    /// Fails if any clearance violation was recorded.
    pub fn assert_clearance(&self, label: &str) {
        assert_eq!(
            self.clearance_violations,
            0,
            "{label}: {} particle-steps closer to a surface than the contact radius allows \
             (min clearance {}); first: {}",
            self.clearance_violations,
            self.min_clearance,
            self.first_violation.as_deref().unwrap_or("")
        );
    }
}

/// Particles (positions, velocities) thrown at `target` along direction `dir` at `speed`:
/// a stream (a line of `stream_len` particles two spacings apart) and a cloud (a 4×4×4
/// lattice at 1.2 spacings jittered by ±0.1 spacing, so neighbours interact, with velocities
/// spread by up to 20 %). Both start just outside the
/// surface point the ray `target − dir·∞ → target` reaches first (or before `target` if the
/// ray misses), leaving a gap travelled in about 10 ms.
#[allow(clippy::too_many_arguments)]
pub fn emission(
    rng: &mut Pcg64,
    colliders: &ColliderSet,
    handles: &[ColliderHandle],
    target: Vector,
    dir: Vector,
    speed: Real,
    spacing: Real,
    radius: Real,
    stream_len: usize,
    with_cloud: bool,
) -> (Vec<Vector>, Vec<Vector>) {
    let far = 20.0;
    let ray = Ray::new(target - dir * far, dir);
    let toi = handles
        .iter()
        .filter_map(|&h| {
            let co = &colliders[h];
            co.shape().cast_ray(co.position(), &ray, 2.0 * far, true)
        })
        .fold(Real::MAX, Real::min);
    let hit = if toi < Real::MAX {
        ray.origin + dir * toi
    } else {
        target
    };
    let gap = radius + 0.01 + 0.01 * speed;
    let mut pos = Vec::new();
    let mut vel = Vec::new();
    for k in 0..stream_len {
        pos.push(hit - dir * (gap + 2.0 * spacing * k as Real));
        vel.push(dir * speed);
    }
    if with_cloud {
        let a = 1.2 * spacing;
        let center = hit - dir * (gap + 2.5 * a);
        for i in 0..4 {
            for j in 0..4 {
                for k in 0..4 {
                    let jitter = Vector::new(
                        rng.random_range(-0.1..0.1),
                        rng.random_range(-0.1..0.1),
                        rng.random_range(-0.1..0.1),
                    ) * spacing;
                    let lattice = Vector::new(i as Real, j as Real, k as Real) - Vector::splat(1.5);
                    pos.push(center + lattice * a + jitter);
                    vel.push((dir + random_unit(rng) * rng.random_range(0.0..0.2)) * speed);
                }
            }
        }
    }
    (pos, vel)
}

/// Keeps the particles that start clear of every collider (at least `2·radius` off every
/// surface and outside every region) and at least `0.9·spacing` from every kept particle.
#[allow(clippy::too_many_arguments)]
pub fn filter_spawn(
    colliders: &ColliderSet,
    handles: &[ColliderHandle],
    regions: &[Region],
    existing: &[Vector],
    pos: Vec<Vector>,
    vel: Vec<Vector>,
    spacing: Real,
    radius: Real,
) -> (Vec<Vector>, Vec<Vector>) {
    let mut kept_p: Vec<Vector> = Vec::new();
    let mut kept_v = Vec::new();
    'outer: for (p, v) in pos.into_iter().zip(vel) {
        for &h in handles {
            let co = &colliders[h];
            if co.shape().contains_point(co.position(), p) || signed_distance(co, p) < 2.0 * radius
            {
                continue 'outer;
            }
        }
        for r in regions {
            match r {
                Region::LocalBox { pose, half } => {
                    let l = pose.inverse_transform_point(p);
                    if l.abs().cmplt(*half + Vector::splat(2.0 * radius)).all() {
                        continue 'outer;
                    }
                }
                Region::Height {
                    collider: h,
                    hx: _,
                    hz: _,
                } => {
                    if let Some(s) = surface_height(&colliders[*h], p)
                        && p.y < s + 2.0 * radius
                    {
                        continue 'outer;
                    }
                }
                _ => {}
            }
        }
        for q in existing.iter().chain(kept_p.iter()) {
            if (*q - p).length() < 0.9 * spacing {
                continue 'outer;
            }
        }
        kept_p.push(p);
        kept_v.push(v);
    }
    (kept_p, kept_v)
}

/// One shot: particles thrown along `dir` at `target`, a stream and optionally a cloud.
#[derive(Copy, Clone, Debug)]
pub struct Shot {
    pub dir: Vector,
    pub target: Vector,
    pub cloud: bool,
}

/// One throw of a shape test: all `shots` at `speed` under `gravity`, for `duration` seconds
/// at the acoustic time step.
pub struct Throw {
    pub label: String,
    pub speed: Real,
    pub gravity: Vector,
    pub shots: Vec<Shot>,
    pub duration: Real,
    pub stream_len: usize,
}

/// Runs one throw against a fresh world holding `colliders`; `regions` decides what
/// "inside" is. Returns the tracker (contacts, clearance figures).
pub fn run_throw(
    params: &FluidParams,
    colliders: Vec<ColliderBuilder>,
    regions_of: impl Fn(&FluidWorld, &[ColliderHandle]) -> Vec<Region>,
    throw: &Throw,
    seed: u64,
) -> Tracker {
    let (mut world, fluid, handles) = world_with(params.clone(), colliders);
    let regions = regions_of(&world, &handles);
    let mut rng = rng(seed);
    let s = params.particle_spacing;
    let r = params.particle_radius;
    let mut all_p = Vec::new();
    let mut all_v = Vec::new();
    for shot in &throw.shots {
        {
            let (p, v) = emission(
                &mut rng,
                &world.physics.colliders,
                &handles,
                shot.target,
                shot.dir,
                throw.speed,
                s,
                r,
                throw.stream_len,
                shot.cloud,
            );
            let (p, v) = filter_spawn(
                &world.physics.colliders,
                &handles,
                &regions,
                &all_p,
                p,
                v,
                s,
                r,
            );
            all_p.extend(p);
            all_v.extend(v);
        }
    }
    assert!(
        all_p.len() >= 10,
        "{}: only {} particles could be placed",
        throw.label,
        all_p.len()
    );
    let ids = world.fluids[fluid]
        .add_particles_with_velocities(&all_p, Some(&all_v))
        .unwrap();
    let mut tracker = Tracker::new();
    tracker.spawn(ids, &all_p, &regions);
    let dt = params.acoustic_time_step();
    let steps = (throw.duration / dt).ceil() as usize;
    for _ in 0..steps {
        let report = step_fluid(&mut world, throw.gravity, dt);
        tracker.check(
            &throw.label,
            &world,
            fluid,
            all_p.len(),
            &regions,
            &handles,
            &report,
        );
    }
    tracker
}

/// A closed box mesh of half extents `h`, triangles wound counter-clockwise seen from
/// outside (outward normals).
pub fn box_mesh(h: Vector) -> (Vec<Vector>, Vec<[u32; 3]>) {
    let v = (0..8)
        .map(|i| {
            Vector::new(
                if i & 1 != 0 { h.x } else { -h.x },
                if i & 2 != 0 { h.y } else { -h.y },
                if i & 4 != 0 { h.z } else { -h.z },
            )
        })
        .collect();
    let idx = vec![
        [0, 2, 3],
        [0, 3, 1], // -z
        [4, 5, 7],
        [4, 7, 6], // +z
        [0, 4, 6],
        [0, 6, 2], // -x
        [1, 3, 7],
        [1, 7, 5], // +x
        [0, 1, 5],
        [0, 5, 4], // -y
        [2, 6, 7],
        [2, 7, 3], // +y
    ];
    (v, idx)
}

/// `run` on a rayon pool of `threads` worker threads, for the thread-parity tests: the crate
/// promises bitwise identical results whatever the thread count, so they compare what this
/// returns for several counts.
pub fn on_threads<T: Send>(threads: usize, run: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a rayon thread pool")
        .install(run)
}

/// `run` once on a pool of each of `threads` worker threads, in that order: its results.
pub fn on_each<T: Send>(threads: &[usize], run: impl Fn() -> T + Sync) -> Vec<T> {
    threads.iter().map(|&n| on_threads(n, &run)).collect()
}
