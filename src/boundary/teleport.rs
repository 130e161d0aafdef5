//! Bodies that jump: a `set_position` (a teleport rapier's velocities know nothing of), or a
//! kinematic move the game marks as one ([`crate::FluidPipeline::mark_teleport`]).
//!
//! Seen as motion, a body that jumps 1 m in a 1/60 s frame is a 60 m/s wall: it throws the
//! water in its way at up to 120 m/s and leaves the water it held behind. A game that
//! teleports a bucket wants the water in it to come along, so a teleport is resolved as a
//! rigid carry: every particle inside the box of one of the body's colliders (in the body's
//! frame, grown by the fluid's smoothing length: the water in a container and the layers
//! resting on a plate) is moved with the body, from its pose before the jump to its pose
//! after, its velocity turned with it; the body is seen at rest during the frame of a marked
//! move. A body can leave the water behind instead ([`crate::FluidPipeline::set_teleport_carry`]).
//! Either way the particles the body lands on are pushed out of it by the next substep's
//! depenetration, and the carried ones relaxed where they overlap. A rigid carry (all the
//! jumping bodies' water carried, none of the water that stayed near where they land) makes
//! no overlap: the particles are then only pushed out of the solids they may land in, and
//! relaxed only if any was (relaxing the carried water anyway moved every particle of a
//! settled bucket of Clavet's water, whose hydrostatic compression exceeds the relaxation's
//! 1 % tolerance, and gave it 0.069 J; `tests/kinematic_jumps.rs`).
//!
//! A `set_position` is found by comparing each body's pose at the frame's start, as its
//! velocities place it (`bodies::pose_back`), with its pose at the end of the fluid's last
//! frame: a mismatch of more than half a particle radius at the collider's farthest corner is
//! a teleport from the pose it had to the pose its velocities start from (for a dynamic
//! body, more than rapier's position correction can move it in a frame: 5 cm at 60 Hz).

use crate::math::{Pose, Real, Vector};
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use rapier3d::dynamics::{RigidBodyHandle, RigidBodySet};
use rapier3d::geometry::ColliderSet;

/// How fast rapier may move a dynamic body to resolve a penetration without the velocity it
/// keeps showing it (m/s): its `max_corrective_velocity`, 3 m/s by default. A dynamic body's
/// pose may then differ from where its velocities place it by this times the frame without
/// a jump (a box pushed out of another), so a smaller mismatch is not taken for one.
const RAPIER_CORRECTION_SPEED: Real = 3.0;

/// One body's jump during the current frame.
#[derive(Clone, Debug)]
pub struct Teleport {
    /// The body.
    pub body: RigidBodyHandle,
    /// Its pose before the jump.
    pub from: Pose,
    /// Its pose after the jump.
    pub to: Pose,
    /// Its colliders' box in the body's frame (`None`: no solid collider).
    pub boxes: Option<Aabb>,
    /// `true`: the water in and on it goes with it.
    pub carry: bool,
    /// `true` for a kinematic move the game marked: the body is seen at rest this frame.
    pub marked: bool,
}

/// The teleports of a frame, the poses they are found from and the game's choices.
#[derive(Clone, Debug, Default)]
pub struct Teleports {
    /// Pose of every non-fixed body at the end of the fluid's last frame (sorted by handle).
    poses: Vec<(RigidBodyHandle, Pose)>,
    /// Bodies whose next move is a teleport (the game's marks, for the next step).
    marked: Vec<RigidBodyHandle>,
    /// Bodies that leave the water behind when they jump.
    left_behind: Vec<RigidBodyHandle>,
    /// This frame's teleports.
    frame: Vec<Teleport>,
}

impl Teleports {
    /// Marks `body`'s move of the next step as a teleport.
    pub fn mark(&mut self, body: RigidBodyHandle) {
        if !self.marked.contains(&body) {
            self.marked.push(body);
        }
    }

    /// Whether `body` carries the water in and on it when it jumps (default: it does).
    pub fn set_carry(&mut self, body: RigidBodyHandle, carry: bool) {
        self.left_behind.retain(|b| *b != body);
        if !carry {
            self.left_behind.push(body);
        }
    }

    /// This frame's teleports.
    pub fn frame(&self) -> &[Teleport] {
        &self.frame
    }

    /// `true` when `body` made a marked move this frame (the fluid sees it at rest).
    pub fn holds_still(&self, body: RigidBodyHandle) -> bool {
        self.frame.iter().any(|t| t.marked && t.body == body)
    }

    /// Finds this frame's teleports (`dt`: the frame; `rapier_dv`: rapier's velocity change
    /// of a body over the frame as the coupling knows it; `tolerance`: the mismatch, in m at
    /// a collider's farthest corner, above which a body jumped). Forgets the game's marks.
    pub fn detect(
        &mut self,
        dt: Real,
        tolerance: Real,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        rapier_accel: impl Fn(RigidBodyHandle) -> Vector,
    ) {
        self.frame.clear();
        for (bh, body) in bodies.iter() {
            if body.is_fixed() {
                continue;
            }
            let marked = self.marked.contains(&bh);
            let last = self
                .poses
                .binary_search_by_key(&bh.0, |p| p.0.0)
                .ok()
                .map(|k| self.poses[k].1);
            let end = *body.position();
            let boxes = local_boxes(body, colliders);
            let (from, to) = if marked {
                let start = last.unwrap_or_else(|| start_pose(body, dt, Vector::ZERO));
                (start, end)
            } else {
                let Some(last) = last else { continue };
                let start = start_pose(body, dt, rapier_accel(bh));
                let tolerance = if body.is_dynamic() {
                    tolerance.max(RAPIER_CORRECTION_SPEED * dt)
                } else {
                    tolerance
                };
                if mismatch(&last, &start, &boxes) <= tolerance {
                    continue;
                }
                (last, start)
            };
            if !(crate::math::is_finite(from.translation) && crate::math::is_finite(to.translation))
            {
                continue;
            }
            self.frame.push(Teleport {
                body: bh,
                from,
                to,
                boxes,
                carry: !self.left_behind.contains(&bh),
                marked,
            });
        }
        self.marked.clear();
    }

    /// Records the pose of every non-fixed body at the end of the frame.
    pub fn record(&mut self, bodies: &RigidBodySet) {
        self.poses.clear();
        for (bh, body) in bodies.iter() {
            if !body.is_fixed() {
                self.poses.push((bh, *body.position()));
            }
        }
        self.poses.sort_by_key(|p| p.0.0);
    }

    /// Carries the particles in and on the bodies that jumped this frame with them (see the
    /// module docs; `margin`: how far from a collider's box a particle still goes along).
    /// Returns how many were carried, and whether the frame's jumps were *rigid* for these
    /// particles: every jumping body carried its water (none left behind) and no particle
    /// that stayed lies within twice `margin` of a carrying body's box at its new pose. The
    /// carried water then keeps its own arrangement (a rigid motion, velocities turned with
    /// it) and meets no other water: the carry made no overlap between particles, and only a
    /// solid it landed in can need pushing out.
    pub fn carry(
        &self,
        positions: &mut [Vector],
        velocities: &mut [Vector],
        margin: Real,
    ) -> (usize, bool) {
        let mut carried = 0;
        let mut rigid = true;
        for t in &self.frame {
            if !t.carry {
                rigid = false;
                continue;
            }
            let turn = (t.to.rotation * t.from.rotation.inverse()).normalize();
            let Some(b) = t.boxes else {
                continue;
            };
            let (grown, around) = (b.loosened(margin), b.loosened(2.0 * margin));
            for (x, v) in positions.iter_mut().zip(velocities.iter_mut()) {
                let local = t.from.inverse_transform_point(*x);
                if grown.contains_local_point(local) {
                    *x = t.to.transform_point(local);
                    *v = turn * *v;
                    carried += 1;
                } else if rigid && around.contains_local_point(t.to.inverse_transform_point(*x)) {
                    rigid = false;
                }
            }
        }
        (carried, rigid)
    }
}

/// The body's pose at the frame's start as its velocities place it (rapier's velocity
/// change over the frame spread as an acceleration `accel`).
fn start_pose(body: &rapier3d::dynamics::RigidBody, dt: Real, accel: Vector) -> Pose {
    let end = *body.position();
    let com = body.center_of_mass();
    super::bodies::pose_back(&end, com, body.linvel(), body.angvel(), accel, dt).0
}

/// The box of `body`'s solid colliders in the body's frame.
fn local_boxes(body: &rapier3d::dynamics::RigidBody, colliders: &ColliderSet) -> Option<Aabb> {
    body.colliders()
        .iter()
        .filter_map(|&h| colliders.get(h))
        .filter(|co| co.is_enabled() && !co.is_sensor())
        .map(|co| {
            let rel = co.position_wrt_parent().copied().unwrap_or(Pose::IDENTITY);
            co.shape().compute_aabb(&rel)
        })
        .reduce(|a, b| a.merged(&b))
}

/// How far the corners of the box `boxes` (body frame) move between poses `a` and `b` (m).
fn mismatch(a: &Pose, b: &Pose, boxes: &Option<Aabb>) -> Real {
    let mut worst: Real = 0.0;
    if let Some(bx) = boxes {
        for p in bx.vertices() {
            worst = worst.max((a.transform_point(p) - b.transform_point(p)).length());
        }
    }
    if boxes.is_none() {
        worst = (a.translation - b.translation).length();
    }
    if worst.is_nan() {
        Real::INFINITY
    } else {
        worst
    }
}
