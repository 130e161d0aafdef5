//! Two-way coupling with rapier's dynamic and kinematic bodies.
//!
//! **Body → fluid.** rapier steps first, so when the fluid steps a frame every body already
//! stands at its pose at the frame's end. A body's pose at an earlier time of the frame is
//! found by running its motion backward along the path rapier's own substeps gave it: rapier
//! adds its velocity change `Δv` of the step (gravity, its contacts) in `n` equal parts, each
//! before moving the body, so `pose(T − τ)` is the end pose moved by
//! `−τ·v + Δv·(n − 1)/(2n)·τ²/dt` and rotated by `−τ·ω` about the center of mass (exact for
//! the translation, first order for the rotation; `Δv` is known from the velocity the
//! coupling left the body with at the end of the last frame, see [`Coupling::begin_frame`]).
//! Contact then sweeps each particle's motion of a substep *in the body's moving frame* (the
//! start of the segment mapped through the body's pose at the substep's start, its end
//! through the pose at its end), so a thin fast paddle cannot pass over a particle, and
//! reflects the particle's velocity *relative* to the body's surface velocity at the contact
//! point (linear and angular, `v + ω × (x − c)`).
//!
//! **Fluid → body.** Every velocity change contact makes on a particle next to a dynamic
//! body's collider is an impulse `−m·Δv` on that body at the contact point; with walls
//! counting in the density, each particle's wall pressure force from the body is one too.
//! Impulses are recorded per chunk of particles and summed in chunk order (no float atomics:
//! the parallel and serial builds sum in the same order). Each substep's impulses change the
//! body's linear and angular velocity together (the added-mass solve of
//! [`Coupling::exchange`]), and the body moves with those velocities from the next substep
//! on ([`Drift`]): the body follows the substeps the fluid takes. At the frame's end the
//! impulses go to rapier (`apply_impulse` and `apply_torque_impulse` about the center of
//! mass: the velocities rapier continues with are the ones the fluid saw last), and the body
//! is moved by the drift its velocity changes made over the frame (`set_position`; the
//! colliders follow at rapier's next step). Applying the whole frame's impulse once at its end
//! instead leaves the body moving along rapier's path for the whole frame while the stiff
//! weakly-compressible fluid pushes back: a floating box's corners are shaken at 0.55–1.06 g
//! RMS (see `tests/buoyancy.rs`).
//!
//! **Cost.** Only colliders of non-fixed bodies whose motion over the substep comes within a
//! kernel radius of the fluid's bounding box enter the table; a scene without dynamic or
//! kinematic bodies pays one pass over its bodies per frame, and a scene whose moving bodies
//! are far from the fluid pays one bounding box per collider per substep.

use crate::math::{Pose, Real, Rotation, Vector};
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::math::AngularInertia;
use rapier3d::dynamics::{RigidBodyHandle, RigidBodySet};
use rapier3d::geometry::{ColliderHandle, ColliderSet};

mod exchange;

pub use exchange::{ImpulseRecord, ParticleMass, on_line};

/// A collider of a non-fixed body near the fluid, with its poses over the current substep.
#[derive(Clone, Debug)]
pub struct MovingCollider {
    /// The collider.
    pub handle: ColliderHandle,
    /// Its body.
    pub body: RigidBodyHandle,
    /// `true` for a dynamic body (it receives the fluid's impulses).
    pub dynamic: bool,
    /// `true` when the body has a non-zero velocity (otherwise its poses are the end pose).
    pub moving: bool,
    /// Body velocity (m/s) at the frame's start: the poses of the frame follow it.
    pub linvel: Vector,
    /// Body velocity (m/s) the fluid sees: `linvel` plus the fluid's impulses of the
    /// frame's earlier substeps.
    pub vel: Vector,
    /// Rapier's own velocity change over the frame (gravity, its contacts, user forces) as
    /// rapier's substeps spread it, as an acceleration: the body's velocity `back` seconds
    /// before the frame's end is `vel − accel·back` (see [`Coupling::begin_frame`]).
    pub accel: Vector,
    /// Rapier's own velocity change over the frame (gravity, its contacts, user forces) divided
    /// by the frame's length: the rate [`Coupling::exchange`] adds to the added-mass solve of
    /// the walls' records (`with_rapier`).
    pub rapier_rate: Vector,
    /// Seconds from the current substep's start and end to the frame's end.
    pub backs: (Real, Real),
    /// Inverse mass per axis (0 along locked axes; 0 for kinematic bodies).
    pub inv_mass: Vector,
    /// Angular velocity (rad/s) the fluid sees: rapier's plus the fluid's angular impulses of
    /// the frame's earlier substeps.
    pub angvel: Vector,
    /// Rapier's angular velocity at the frame's start: the poses of the frame follow it.
    pub rapier_angvel: Vector,
    /// Effective world-space inverse inertia (0 for kinematic bodies and locked axes).
    pub inv_inertia: AngularInertia,
    /// How far the fluid's impulses of this frame have moved the body off rapier's path.
    pub drift: Drift,
    /// Collider pose at the frame's end (rapier's current pose).
    pub end: Pose,
    /// Body center of mass at the frame's end.
    pub com_end: Vector,
    /// Collider pose at the start of the current substep.
    pub start: Pose,
    /// Collider pose at the end of the current substep.
    pub stop: Pose,
    /// Center of mass at the start and end of the current substep.
    pub com_start: Vector,
    /// Center of mass at the end of the current substep.
    pub com_stop: Vector,
    /// Box swept by the collider over the substep.
    pub aabb: Aabb,
    /// Distance from the body's center of mass to the farthest corner of the collider's box
    /// (m): a point of the collider moves at most `|v| + |ω|·reach`.
    pub reach: Real,
}

impl MovingCollider {
    /// The surface velocity of the body at `point` (at the substep's end).
    #[inline]
    pub fn velocity_at_stop(&self, point: Vector) -> Vector {
        self.vel - self.accel * self.backs.1 + self.angvel.cross(point - self.com_stop)
    }

    /// The fastest any point of the collider moves (m/s) at the current velocities:
    /// `|v| + |a|·back + |ω|·reach` (0 when not finite: such a body is not followed).
    pub fn surface_speed(&self, back: Real) -> Real {
        let s = self.vel.length() + self.accel.length() * back + self.angvel.length() * self.reach;
        if s.is_finite() { s } else { 0.0 }
    }

    /// The surface velocity of the body at `point` (at the substep's start).
    #[inline]
    pub fn velocity_at_start(&self, point: Vector) -> Vector {
        self.vel - self.accel * self.backs.0 + self.angvel.cross(point - self.com_start)
    }
}

/// The motion the fluid's impulses added to a body during the current frame, on top of the
/// path rapier gave it: the body's center of mass is shifted by `shift + dv·τ` and the body
/// turned about it by `exp(dw·τ)·turn`, where `τ` is the time since `anchor` (seconds before
/// the frame's end) at which the velocity changes `dv`, `dw` started to act.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Drift {
    /// Seconds before the frame's end at which `dv` and `dw` started to act.
    pub anchor: Real,
    /// Shift of the center of mass at `anchor` (m).
    pub shift: Vector,
    /// Rotation about the center of mass at `anchor`.
    pub turn: Rotation,
    /// Linear velocity change moving the body since `anchor` (m/s).
    pub dv: Vector,
    /// Angular velocity change turning the body since `anchor` (rad/s).
    pub dw: Vector,
}

impl Drift {
    /// No drift, from `anchor` seconds before the frame's end.
    pub fn none(anchor: Real) -> Self {
        Self {
            anchor,
            shift: Vector::ZERO,
            turn: Rotation::IDENTITY,
            dv: Vector::ZERO,
            dw: Vector::ZERO,
        }
    }

    /// `true` when the body is on rapier's path and stays there.
    pub fn is_none(&self) -> bool {
        self.shift == Vector::ZERO
            && self.turn == Rotation::IDENTITY
            && self.dv == Vector::ZERO
            && self.dw == Vector::ZERO
    }

    /// Shift and turn at `back` seconds before the frame's end (`back ≤ anchor`).
    pub fn at(&self, back: Real) -> (Vector, Rotation) {
        let tau = self.anchor - back;
        let turn = if self.dw == Vector::ZERO {
            self.turn
        } else {
            (Rotation::from_scaled_axis(self.dw * tau) * self.turn).normalize()
        };
        (self.shift + self.dv * tau, turn)
    }

    /// Moves `pose` (whose body's center of mass is `com`) by the drift at `back`.
    fn apply(&self, pose: Pose, com: Vector, back: Real) -> (Pose, Vector) {
        if self.is_none() {
            return (pose, com);
        }
        let (shift, turn) = self.at(back);
        let c = com + shift;
        (
            Pose::from_parts(
                c + turn * (pose.translation - com),
                (turn * pose.rotation).normalize(),
            ),
            c,
        )
    }
}

/// The pose of a body's collider `back` seconds before the end pose `end`, for a body whose
/// velocity `back` seconds before the end was `v − a·back`.
pub fn pose_back(
    end: &Pose,
    com: Vector,
    v: Vector,
    w: Vector,
    a: Vector,
    back: Real,
) -> (Pose, Vector) {
    if back == 0.0 || (v == Vector::ZERO && w == Vector::ZERO && a == Vector::ZERO) {
        return (*end, com);
    }
    let q = Rotation::from_scaled_axis(w * -back);
    let com_b = com - v * back + a * (0.5 * back * back);
    (
        Pose::from_parts(
            com_b + q * (end.translation - com),
            (q * end.rotation).normalize(),
        ),
        com_b,
    )
}

/// The fastest surface speeds of the non-fixed bodies near a fluid.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct NearBodies {
    /// Of every non-fixed body near (m/s; 0 without one).
    pub fastest: Real,
    /// Of the kinematic ones (`None`: no kinematic body near).
    pub kinematic: Option<Real>,
}

impl NearBodies {
    fn add(&mut self, c: &MovingCollider, speed: Real) {
        self.fastest = self.fastest.max(speed);
        if !c.dynamic {
            self.kinematic = Some(self.kinematic.map_or(speed, |k| k.max(speed)));
        }
    }

    /// Both maxima of `self` and `other`.
    pub fn merge(self, other: NearBodies) -> NearBodies {
        NearBodies {
            fastest: self.fastest.max(other.fastest),
            kinematic: match (self.kinematic, other.kinematic) {
                (Some(a), Some(b)) => Some(a.max(b)),
                (a, b) => a.or(b),
            },
        }
    }
}

/// Accumulated impulse on one body: `(body, linear impulse, angular impulse about the
/// center of mass)`, summed in f64.
type BodyImpulse = (RigidBodyHandle, [f64; 3], [f64; 3]);

/// Coupling state of the pipeline: the non-fixed colliders of the frame, the table of those
/// near the fluid in the current substep, and the impulses gathered for the bodies.
#[derive(Clone, Debug, Default)]
pub struct Coupling {
    /// Colliders of non-fixed bodies (sorted by handle): `(handle, body, dynamic, linvel,
    /// angvel, end pose, end com)`.
    candidates: Vec<MovingCollider>,
    /// Sorted handles of every non-fixed collider (those far from the fluid too): contact
    /// takes them from the table only, never from the broad-phase.
    nonfixed: Vec<ColliderHandle>,
    /// Table of the current (fluid, substep).
    table: Vec<MovingCollider>,
    impulses: Vec<BodyImpulse>,
    /// Scratch of [`Coupling::exchange`]: bodies already settled.
    done: Vec<RigidBodyHandle>,
    /// The linear velocity each dynamic body was left with at the end of the last frame
    /// (sorted by handle): rapier's change of it over the next frame is known from it.
    left: Vec<(RigidBodyHandle, Vector)>,
    /// Bodies that jump (`set_position`, marked kinematic moves), see [`super::teleport`].
    pub teleports: super::teleport::Teleports,
}

impl Coupling {
    /// Collects the colliders of every non-fixed body, once per frame.
    /// `dt` is the frame's length: the fluid's impulses start moving bodies from its start.
    ///
    /// rapier steps first, with `rapier_substeps` substeps (its `num_solver_iterations`),
    /// each adding its share of the velocity change `Δv` (gravity, contacts) before moving
    /// the body; so a body's pose at the frame's start is not `end − v·dt` but
    /// `end − v·dt + Δv·dt·(n − 1)/(2n)`. The poses the fluid sees follow that path
    /// (velocity `v − Δv·(n − 1)/n·back/dt`, `back` seconds before the end), so a body does
    /// not jump at frame boundaries (a floating box would otherwise be seen to jump up by
    /// `3/8·g·dt²`, 1 mm at 60 Hz, every frame and sink through the frame). `Δv` is known
    /// for bodies the coupling saw at the end of the last frame; for the others it is 0.
    pub fn begin_frame(
        &mut self,
        dt: Real,
        rapier_substeps: usize,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) {
        let n = rapier_substeps.max(1) as Real; // 0 is refused by the pipeline
        let spread = (n - 1.0) / (n * dt);
        self.candidates.clear();
        self.nonfixed.clear();
        self.table.clear();
        self.impulses.clear();
        for (bh, body) in bodies.iter() {
            if body.is_fixed() {
                continue;
            }
            for &ch in body.colliders() {
                let Some(co) = colliders.get(ch) else {
                    continue;
                };
                self.nonfixed.push(ch);
                if !co.is_enabled() || co.is_sensor() {
                    continue;
                }
                let linvel = body.linvel();
                let angvel = body.angvel();
                let end = *co.position();
                let rapier_dv = match self.left.binary_search_by_key(&bh.0, |l| l.0.0) {
                    Ok(k) if body.is_dynamic() && !body.is_sleeping() => linvel - self.left[k].1,
                    _ => Vector::ZERO,
                };
                let (mut accel, mut rapier_rate) = (rapier_dv * spread, rapier_dv / dt);
                let (mut linvel, mut angvel) = (linvel, angvel);
                if self.teleports.holds_still(bh) {
                    // A marked move: the body jumped, it did not sweep through the water; nor
                    // does rapier's change of its velocity move it during the frame (the
                    // added-mass solve of PBF's walls would otherwise give the water rapier's
                    // share of a velocity the body never had here).
                    (linvel, angvel, accel) = (Vector::ZERO, Vector::ZERO, Vector::ZERO);
                    rapier_rate = Vector::ZERO;
                }
                let aabb = co.compute_aabb();
                let com = body.center_of_mass();
                let reach = (aabb.mins - com)
                    .abs()
                    .max((aabb.maxs - com).abs())
                    .length();
                self.candidates.push(MovingCollider {
                    handle: ch,
                    body: bh,
                    dynamic: body.is_dynamic(),
                    moving: linvel != Vector::ZERO
                        || angvel != Vector::ZERO
                        || accel != Vector::ZERO,
                    linvel,
                    vel: linvel,
                    accel,
                    rapier_rate,
                    backs: (0.0, 0.0),
                    inv_mass: if body.is_dynamic() {
                        body.mass_properties().effective_inv_mass
                    } else {
                        Vector::ZERO
                    },
                    angvel,
                    rapier_angvel: angvel,
                    inv_inertia: if body.is_dynamic() {
                        body.mass_properties().effective_world_inv_inertia
                    } else {
                        AngularInertia::zero()
                    },
                    drift: Drift::none(dt),
                    end,
                    com_end: body.center_of_mass(),
                    start: end,
                    stop: end,
                    com_start: body.center_of_mass(),
                    com_stop: body.center_of_mass(),
                    aabb,
                    reach,
                });
            }
        }
        self.candidates.sort_by_key(|c| c.handle.0);
        self.nonfixed.sort_by_key(|h| h.0);
    }

    /// The fastest surface speeds (m/s) of the non-fixed colliders that come within `margin`
    /// of `fluid_box` over the frame (each one's box at the frame's end swept back by its
    /// speed over `dt`): the fluid's substeps must follow them as they follow their fastest
    /// particle (a wall moving at `V` moves `V·dt` per substep into the particles ahead of
    /// it), see `pipeline::time_stepping`; the kinematic ones bound the speeds they can give
    /// the water (see `pipeline::substep`).
    pub fn surface_speeds_near(&self, fluid_box: &Aabb, margin: Real, dt: Real) -> NearBodies {
        let mut near = NearBodies::default();
        for c in &self.candidates {
            let s = c.surface_speed(dt);
            if c.aabb.loosened(margin + s * dt).intersects(fluid_box) {
                near.add(c, s);
            }
        }
        near
    }

    /// The non-fixed colliders whose boxes (at the frame's end) come within `margin` of
    /// `fluid_box`.
    pub fn near<'a>(
        &'a self,
        fluid_box: &'a Aabb,
        margin: Real,
    ) -> impl Iterator<Item = &'a MovingCollider> + 'a {
        self.candidates
            .iter()
            .filter(move |c| c.aabb.loosened(margin).intersects(fluid_box))
    }

    /// The fastest surface speeds (m/s) of the colliders of the current substep's table.
    pub fn table_surface_speeds(&self) -> NearBodies {
        let mut near = NearBodies::default();
        for c in &self.table {
            near.add(c, c.surface_speed(c.backs.0));
        }
        near
    }

    /// Finds the frame's teleports (see [`super::teleport`]) before [`Coupling::begin_frame`]:
    /// `dt` the frame, `rapier_substeps` as there, `tolerance` the pose mismatch (m) that
    /// counts as a jump.
    pub fn detect_teleports(
        &mut self,
        dt: Real,
        rapier_substeps: usize,
        tolerance: Real,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) {
        let n = rapier_substeps.max(1) as Real;
        let spread = (n - 1.0) / (n * dt);
        let left = &self.left;
        let accel = |bh: RigidBodyHandle| {
            let Some(body) = bodies.get(bh) else {
                return Vector::ZERO;
            };
            match left.binary_search_by_key(&bh.0, |l| l.0.0) {
                Ok(k) if body.is_dynamic() && !body.is_sleeping() => {
                    (body.linvel() - left[k].1) * spread
                }
                _ => Vector::ZERO,
            }
        };
        self.teleports
            .detect(dt, tolerance, bodies, colliders, accel);
    }

    /// `true` when the scene has no non-fixed collider at all (coupling is off).
    pub fn is_off(&self) -> bool {
        self.candidates.is_empty()
    }

    /// Builds the table of one fluid's substep: the non-fixed colliders whose motion over the
    /// substep (from `back_start` to `back_stop` seconds before the frame's end) comes within
    /// `margin` of `fluid_box`.
    pub fn begin_substep(
        &mut self,
        colliders: &ColliderSet,
        fluid_box: &Aabb,
        margin: Real,
        back_start: Real,
        back_stop: Real,
    ) {
        self.table.clear();
        for c in &mut self.candidates {
            let Some(co) = colliders.get(c.handle) else {
                continue;
            };
            // The velocity changes the fluid made so far move the body from this substep on
            // (the drift's motion up to here is kept).
            let (dv, dw) = (c.vel - c.linvel, c.angvel - c.rapier_angvel);
            if (dv, dw) != (c.drift.dv, c.drift.dw) {
                let (shift, turn) = c.drift.at(back_start);
                c.drift = Drift {
                    anchor: back_start,
                    shift,
                    turn,
                    dv,
                    dw,
                };
            }
            let mut m = c.clone();
            let (l, w) = (c.linvel, c.rapier_angvel);
            let a = c.accel;
            let (start, com_start) = pose_back(&c.end, c.com_end, l, w, a, back_start);
            let (stop, com_stop) = pose_back(&c.end, c.com_end, l, w, a, back_stop);
            m.backs = (back_start, back_stop);
            (m.start, m.com_start) = c.drift.apply(start, com_start, back_start);
            (m.stop, m.com_stop) = c.drift.apply(stop, com_stop, back_stop);
            m.moving |= !c.drift.is_none();
            let mut aabb = co.shape().compute_aabb(&m.stop);
            if m.moving {
                aabb.merge(&co.shape().compute_aabb(&m.start));
            }
            m.aabb = aabb;
            if aabb.loosened(margin).intersects(fluid_box) {
                self.table.push(m);
            }
        }
    }

    /// Drops the dynamic bodies' colliders from the current substep's table (the overlap
    /// relaxation's table: it moves no body, see `pipeline::substep`).
    pub fn keep_kinematic(&mut self) {
        self.table.retain(|m| !m.dynamic);
    }

    /// The table of the current substep (sorted by handle).
    pub fn table(&self) -> &[MovingCollider] {
        &self.table
    }

    /// `true` when `handle` is a collider of a non-fixed body.
    pub fn is_nonfixed(&self, handle: ColliderHandle) -> bool {
        !self.nonfixed.is_empty()
            && self
                .nonfixed
                .binary_search_by_key(&handle.0, |h| h.0)
                .is_ok()
    }

    /// Applies the gathered impulses to their bodies through rapier (waking them up), moves
    /// each body by the drift they made during the frame (its pose at the frame's end is
    /// rapier's plus the drift), and forgets them. Returns the number of bodies pushed.
    pub fn apply(&mut self, bodies: &mut RigidBodySet) -> usize {
        let n = self.impulses.len();
        let mut done = std::mem::take(&mut self.done);
        done.clear();
        for c in &self.candidates {
            if !c.dynamic || c.drift.is_none() || done.contains(&c.body) {
                continue;
            }
            done.push(c.body);
            if let Some(body) = bodies.get_mut(c.body) {
                let com = body.center_of_mass();
                let (pose, _) = c.drift.apply(*body.position(), com, 0.0);
                body.set_position(pose, true);
            }
        }
        self.done = done;
        self.teleports.record(bodies);
        for (h, j, t) in self.impulses.drain(..) {
            if let Some(body) = bodies.get_mut(h) {
                let j = Vector::new(j[0] as Real, j[1] as Real, j[2] as Real);
                let t = Vector::new(t[0] as Real, t[1] as Real, t[2] as Real);
                body.apply_impulse(j, true);
                body.apply_torque_impulse(t, true);
            }
        }
        // The velocity rapier starts its next step from, the fluid's impulses included: its
        // change over that step is then rapier's own (gravity, contacts, joints, user forces).
        self.left.clear();
        for c in &self.candidates {
            if c.dynamic
                && let Some(body) = bodies.get(c.body)
            {
                self.left.push((c.body, body.linvel()));
            }
        }
        self.left.sort_by_key(|l| l.0.0);
        self.left.dedup_by_key(|l| l.0);
        n
    }

    /// The linear velocity each dynamic body was left with at the end of the last frame
    /// (kept across frames; part of a snapshot).
    pub fn left_velocities(&self) -> &[(RigidBodyHandle, Vector)] {
        &self.left
    }

    /// Restores [`Coupling::left_velocities`] (from a snapshot).
    pub fn set_left_velocities(&mut self, mut left: Vec<(RigidBodyHandle, Vector)>) {
        left.sort_by_key(|l| l.0.0);
        self.left = left;
    }
}

/// The coupling-table entry of collider `h`, if any: `(index, entry)`.
#[inline]
pub fn entry_of(table: &[MovingCollider], h: ColliderHandle) -> Option<(u32, &MovingCollider)> {
    if table.is_empty() {
        return None;
    }
    table
        .binary_search_by_key(&h.0, |m| m.handle.0)
        .ok()
        .map(|k| (k as u32, &table[k]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rapier3d::dynamics::RigidBodyBuilder;
    use rapier3d::geometry::ColliderBuilder;
    use rapier3d::pipeline::PhysicsWorld;

    /// A ball in free fall whose frame ends with a fluid impulse `J` (`Coupling::apply`), then
    /// one more rapier step: the velocity change `begin_frame` reads for that step is rapier's
    /// own (gravity: `accel = g·(n − 1)/n`), not `g + J/(M·dt)`: the impulse changed the
    /// velocity rapier started from, before its substeps. (Recording the velocity before the
    /// impulses read 290.19 m/s² instead of −9.81 here, for `J = 5 m/s · M` at 60 Hz.)
    #[test]
    fn rapier_change_leaves_out_the_fluids_last_impulse() {
        let mut world = PhysicsWorld::new();
        world.gravity = Vector::new(0.0, -9.81, 0.0);
        let dt = world.integration_parameters.dt;
        let n = world.integration_parameters.num_solver_iterations;
        let body = world
            .bodies
            .insert(RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 10.0, 0.0)));
        let (bodies, colliders) = (&mut world.bodies, &mut world.colliders);
        colliders.insert_with_parent(ColliderBuilder::ball(0.5), body, bodies);
        world.step();
        let mut coupling = Coupling::default();
        coupling.begin_frame(dt, n, &world.bodies, &world.colliders);
        let mass = world.bodies[body].mass();
        // The fluid's impulse of the frame: 5 m/s up.
        coupling
            .impulses
            .push((body, [0.0, 5.0 * mass as f64, 0.0], [0.0; 3]));
        coupling.apply(&mut world.bodies);
        // The velocity recorded for the next frame is the one rapier continues from.
        assert_eq!(coupling.left_velocities()[0].1, world.bodies[body].linvel());
        world.step();
        coupling.begin_frame(dt, n, &world.bodies, &world.colliders);
        let c = &coupling.candidates[0];
        let g = -9.81;
        // f32 round-off of velocities near 5 m/s divided by dt: a few 1e-4 m/s².
        let tol = 64.0 * Real::EPSILON * 5.0 / dt;
        let spread = (n as Real - 1.0) / n as Real;
        assert!(
            (c.accel.y - g * spread).abs() < tol && c.accel.x == 0.0 && c.accel.z == 0.0,
            "accel {:?}, expected {}",
            c.accel,
            g * spread
        );
    }
}
