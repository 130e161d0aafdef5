//! Sleeping fluids (see [`crate::sleep`]): the checks that wake a sleeping fluid before a
//! frame, and the test that puts a fluid at rest to sleep after it.

use super::workspace::FluidRuntime;
use crate::boundary::Coupling;
use crate::boundary::forces::Watch;
use crate::fluid::Fluid;
use crate::math::{Real, Vector};
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::partitioning::{Bvh, BvhNode};
use rapier3d::dynamics::RigidBodySet;
use rapier3d::geometry::ColliderSet;

/// What the wake checks and the sleep test read of the frame.
#[derive(Copy, Clone)]
pub(super) struct Surroundings<'a> {
    pub gravity: Vector,
    pub dt: Real,
    /// rapier's broad-phase tree (`None` without colliders).
    pub bvh: Option<&'a Bvh>,
    pub colliders: &'a ColliderSet,
    pub coupling: &'a Coupling,
    pub watch: &'a Watch,
}

/// How far from a sleeping fluid's particles a collider or body counts as near (m): a kernel
/// support and a particle radius, plus how far gravity would move a particle in a frame
/// (what an awake fluid's coupling table reaches, see `Frame::quarantine`).
fn margin(fluid: &Fluid, s: &Surroundings<'_>) -> Real {
    let p = fluid.params();
    p.smoothing_length + p.particle_radius + s.gravity.length() * s.dt * s.dt
}

/// The attributes holding each particle's position at the start of the sleep test's window
/// (they follow the particles through re-sorts and removals).
const ANCHOR: [&str; 3] = ["sleep.anchor.x", "sleep.anchor.y", "sleep.anchor.z"];

/// Whether something disturbs a sleeping `fluid` this frame (see [`crate::sleep`] for the
/// list). Costs a few comparisons, a pass over the non-fixed bodies' boxes and a query of
/// rapier's tree around the fluid.
pub(super) fn disturbed(fluid: &Fluid, rt: &FluidRuntime, s: &Surroundings<'_>) -> bool {
    let st = &fluid.sleep;
    if fluid.params().sleep.is_none()
        || st.gravity != s.gravity
        || st.dt != s.dt
        || st.watched != watched(s.watch)
        || rt.ws.forces.slots() != s.watch.list.len()
        || !s.coupling.teleports.frame().is_empty()
    {
        return true;
    }
    let (lo, hi) = st.bounds;
    let fluid_box = Aabb::new(lo, hi);
    let m = margin(fluid, s);
    if s.coupling.surface_speeds_near(&fluid_box, m, s.dt).fastest > 0.0 {
        return true;
    }
    colliders_near(&fluid_box, m, s) != st.colliders
}

/// Puts `fluid` to sleep if it has been at rest for long enough; returns the box in which
/// dynamic bodies join it in sleep. `changed`: particles came or went during the frame.
pub(super) fn test(
    fluid: &mut Fluid,
    rt: &mut FluidRuntime,
    s: &Surroundings<'_>,
    changed: bool,
) -> Option<Aabb> {
    let sleep = fluid.params().sleep?;
    let calm = !changed && !fluid.is_empty() && rt.ws.frame_error <= sleep.density_error;
    let fresh = fluid.sleep.info.quiet_time == 0.0;
    let (lo, hi) = crate::integrate::bounds(fluid.positions());
    let near = Aabb::new(lo, hi).loosened(margin(fluid, s));
    if !calm
        || fresh
        || !within_drift(fluid, &mut rt.ws.sleep_cells, &sleep)
        || !bodies_within(fluid, s, &near, &sleep)
    {
        // A new window starts here.
        anchor(fluid);
        anchor_bodies(fluid, s, &near);
        fluid.sleep.info.quiet_time = if calm { s.dt } else { 0.0 };
        return None;
    }
    fluid.sleep.info.quiet_time += s.dt;
    (fluid.sleep.info.quiet_time >= sleep.time).then(|| fall_asleep(fluid, rt, s))
}

/// Whether every non-fixed body near the fluid (in `near`) stayed within the largest drift
/// of its pose at the window's start; a body that came near since does not.
fn bodies_within(
    fluid: &Fluid,
    s: &Surroundings<'_>,
    near: &Aabb,
    sleep: &crate::sleep::Sleep,
) -> bool {
    let limit = sleep.max_drift * fluid.params().particle_spacing;
    let anchors = &fluid.sleep.bodies;
    s.coupling.near(near, 0.0).all(|c| {
        anchors.iter().find(|a| a.0 == c.body).is_some_and(|a| {
            let turn = a.2.angle_between(c.end.rotation);
            (c.com_end - a.1).length() + turn * c.reach <= limit
        })
    })
}

/// Starts the window of the bodies near the fluid (in `near`): their poses now.
fn anchor_bodies(fluid: &mut Fluid, s: &Surroundings<'_>, near: &Aabb) {
    let anchors = &mut fluid.sleep.bodies;
    anchors.clear();
    for c in s.coupling.near(near, 0.0) {
        if !anchors.iter().any(|a| a.0 == c.body) {
            anchors.push((c.body, c.com_end, c.end.rotation));
        }
    }
}

/// The sleep test's scratch: the particles' mean displacement over cubic cells of one
/// kernel support (see [`within_drift`]), kept between frames so that a warm test does not
/// allocate.
#[derive(Clone, Debug, Default)]
pub(crate) struct DriftCells {
    /// Each cell's index in `sums`, by its integer coordinates.
    index: std::collections::HashMap<[i32; 3], u32>,
    /// Each cell's summed displacement and particle count.
    sums: Vec<(Vector, u32)>,
    /// Each particle's cell.
    of: Vec<u32>,
}

impl DriftCells {
    /// Heap bytes held (roughly, for the map).
    pub fn heap_bytes(&self) -> usize {
        self.index.capacity() * (std::mem::size_of::<([i32; 3], u32)>() + 1)
            + self.sums.capacity() * std::mem::size_of::<(Vector, u32)>()
            + self.of.capacity() * 4
    }
}

/// Whether the particles stayed within the drift thresholds of their window's start: no
/// particle moved more than [`crate::sleep::Sleep::max_drift`] spacings, and the water's
/// displacement, the particles' displacements averaged over cubic cells of one kernel
/// support `h` (the cell a particle's window-start position lies in), has a
/// root-mean-square (over the particles) of at most [`crate::sleep::Sleep::mean_drift`]
/// spacings.
///
/// Why cells: SPH water at rest jitters below the kernel's resolution, its particles
/// moving past each other (the solver's per-substep corrections) while the water they make
/// up, the field SPH resolves at the kernel's support, stays where it is. The game preset's
/// still 10,368-particle pool from 12 to 20 s (`cargo run --release --example pool_energy
/// -- --preset game --particles 10000 --hull none --where`, with `--every 30` and `--every
/// 120`; docs/performance.md): its particles' rms drift 0.11–0.17 spacings per 0.5 s and
/// 0.16–0.25 per 2 s, spread through the pool (the interior holds 40–47 % of the squared
/// drift); their cells' (of `h`) 0.06–0.11 per 0.5 s and 0.08–0.14 per 2 s. Over a window
/// four times as long a current's drift grows 4×, a random walk's 2×; the cells' grew
/// about 1.2×: an oscillation in place. A current, a slosh or a body's wake moves every
/// particle of a cell together and is not averaged away; one particle flying off is
/// `max_drift`'s.
fn within_drift(fluid: &mut Fluid, cells: &mut DriftCells, sleep: &crate::sleep::Sleep) -> bool {
    let spacing = fluid.params().particle_spacing;
    let edge = fluid.params().smoothing_length;
    let n = fluid.len();
    let (_, particles) = fluid.split_mut();
    let ks = ANCHOR.map(|name| particles.attributes.ensure(name, n));
    let [ax, ay, az] = ks.map(|k| particles.attributes.get(k));
    cells.index.clear();
    cells.sums.clear();
    cells.of.clear();
    let mut max2 = 0.0 as Real;
    for (i, x) in particles.positions.iter().enumerate() {
        let a = Vector::new(ax[i], ay[i], az[i]);
        let d = *x - a;
        max2 = max2.max(d.length_squared());
        let c = (a / edge).floor();
        let key = [c.x as i32, c.y as i32, c.z as i32];
        let next = cells.sums.len() as u32;
        let k = *cells.index.entry(key).or_insert(next);
        if k == next {
            cells.sums.push((Vector::ZERO, 0));
        }
        let cell = &mut cells.sums[k as usize];
        cell.0 += d;
        cell.1 += 1;
        cells.of.push(k);
    }
    // Summed in particle order (not the map's): the same bits on every run.
    let mut sum = 0.0f64;
    for &k in &cells.of {
        let (d, count) = cells.sums[k as usize];
        sum += (d / count as Real).length_squared() as f64;
    }
    let rms = (sum / n.max(1) as f64).sqrt() as Real;
    rms <= sleep.mean_drift * spacing && max2.sqrt() <= sleep.max_drift * spacing
}

/// Starts the sleep test's window: every particle's anchor at its position.
fn anchor(fluid: &mut Fluid) {
    let n = fluid.len();
    let (_, particles) = fluid.split_mut();
    for (c, name) in ANCHOR.iter().enumerate() {
        let k = particles.attributes.ensure(name, n);
        let a = particles.attributes.get_mut(k);
        for (a, x) in a.iter_mut().zip(particles.positions.iter()) {
            *a = x[c];
        }
    }
}

/// Stops the particles (recording what that dropped) and marks the fluid asleep; returns
/// the box in which dynamic bodies join it in sleep.
fn fall_asleep(fluid: &mut Fluid, rt: &FluidRuntime, s: &Surroundings<'_>) -> Aabb {
    let (lo, hi) = crate::integrate::bounds(fluid.positions());
    let fluid_box = Aabb::new(lo, hi);
    let m = margin(fluid, s);
    let fingerprint = colliders_near(&fluid_box, m, s);
    let mass = fluid.params().particle_mass as f64;
    let (_, particles) = fluid.split_mut();
    let (mut energy, mut fastest) = (0.0f64, 0.0 as Real);
    for v in particles.velocities.iter_mut() {
        energy += 0.5 * mass * v.length_squared() as f64;
        fastest = fastest.max(v.length());
        *v = Vector::ZERO;
    }
    let st = &mut fluid.sleep;
    st.info.asleep = true;
    st.info.quiet_time = 0.0;
    st.info.dropped_kinetic_energy = energy;
    st.info.dropped_max_speed = fastest;
    st.info.density_error_at_sleep = rt.ws.frame_error;
    st.info.times_asleep += 1;
    st.gravity = s.gravity;
    st.dt = s.dt;
    st.bounds = (lo, hi);
    st.colliders = fingerprint;
    st.watched = watched(s.watch);
    fluid_box.loosened(m)
}

/// Puts the dynamic bodies whose colliders reach into `near` to sleep in rapier
/// (`RigidBody::sleep`, which rapier keeps until something wakes the body): they rest in the
/// sleeping water as one island with it, and a floating body stays where its buoyancy held
/// it instead of sinking through water that no longer pushes.
pub(super) fn sleep_bodies(near: &Aabb, coupling: &Coupling, bodies: &mut RigidBodySet) {
    for c in coupling.near(near, 0.0) {
        if let Some(b) = bodies.get_mut(c.body)
            && b.is_dynamic()
            && !b.is_sleeping()
        {
            b.sleep();
        }
    }
}

/// An order-independent fingerprint of the colliders whose boxes come within `margin` of
/// `fluid_box`: their handles, poses and boxes (a collider appearing, leaving, moving or
/// changing shape near the fluid changes it).
fn colliders_near(fluid_box: &Aabb, margin: Real, s: &Surroundings<'_>) -> u64 {
    let Some(bvh) = s.bvh else {
        return 0;
    };
    let area = fluid_box.loosened(margin);
    let mut sum = 0u64;
    for leaf in bvh.leaves(|node: &BvhNode| node.aabb().intersects(&area)) {
        let Some((co, h)) = s.colliders.get_unknown_gen(leaf) else {
            continue;
        };
        if s.coupling.is_nonfixed(h) {
            // Moving bodies are followed by their motion (and teleports), not their poses:
            // the coupling moves a floating body after the fluid's sleep test.
            continue;
        }
        let (index, generation) = h.into_raw_parts();
        let mut x = mix(((index as u64) << 32) | generation as u64);
        let pose = co.position();
        let aabb = co.compute_aabb();
        let words = [
            pose.translation.to_array(),
            aabb.mins.to_array(),
            aabb.maxs.to_array(),
        ];
        for w in words.iter().flatten() {
            x = mix(x ^ w.to_bits() as u64);
        }
        for r in pose.rotation.to_array() {
            x = mix(x ^ r.to_bits() as u64);
        }
        x = mix(x ^ (co.is_enabled() as u64) ^ ((co.is_sensor() as u64) << 1));
        sum = sum.wrapping_add(x);
    }
    sum
}

/// A fingerprint of the watched colliders (their handles and flags).
fn watched(watch: &Watch) -> u64 {
    let mut x = mix(watch.list.len() as u64);
    for w in &watch.list {
        let (index, generation) = w.handle.into_raw_parts();
        let flags = (w.forces as u64) | ((w.events as u64) << 1);
        x = mix(x ^ ((index as u64) << 32) ^ generation as u64 ^ (flags << 62));
    }
    x
}

/// splitmix64's finaliser.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
