//! The parts of the emitters' stage ([`crate::Fluid::run_emitters`] in `run.rs` calls them in
//! this order): the emitter's clock opens the frame's window of due instants, an attached
//! nozzle takes its body's pose, the plan bounds the tries, the particles and colliders near
//! the nozzle are gathered, and the due particles are placed where they fit.

use super::{Attachment, Emitter, MAX_ATTEMPTS_PER_FRAME};
use crate::math::{Real, Rotation, Vector};
use crate::params::FluidParams;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::partitioning::{Bvh, BvhNode};
use parry3d::query::Ray;
use rapier3d::dynamics::{RigidBody, RigidBodySet};
use rapier3d::geometry::{ColliderHandle, ColliderSet};

/// What the emitters' stage reads of the rapier world.
#[derive(Copy, Clone)]
pub(crate) struct EmitWorld<'a> {
    /// Rapier's broad-phase tree (`None` without colliders).
    pub bvh: Option<&'a Bvh>,
    pub colliders: &'a ColliderSet,
    pub bodies: &'a RigidBodySet,
}

/// The emitter clock's times of this frame: due instant `k` is at `start + k/rate`.
#[derive(Copy, Clone)]
pub(super) struct Window {
    /// The clock at the frame's end.
    pub c1: f64,
    pub start: f64,
    pub rate: f64,
}

impl Window {
    /// Clock time of due instant `k`.
    pub fn at(&self, k: u64) -> f64 {
        self.start + k as f64 / self.rate
    }
}

/// Where the nozzle is this frame (world space), and the body whose velocity it adds.
pub(super) struct NozzlePose<'a> {
    pub position: Vector,
    /// The body's rotation, for an attached nozzle (its slots and jet turn with it).
    pub rotation: Option<Rotation>,
    /// The body whose velocity at the nozzle the particles take (a collider without a body:
    /// none).
    pub body: Option<&'a RigidBody>,
}

/// How many due particles the frame tries (see the module docs of [`crate::emitter`],
/// "Bounds"): every `stride`-th due instant up to instant `last`.
pub(super) struct Plan {
    pub last: f64,
    pub due_count: f64,
    pub attempts: f64,
    pub stride: u64,
}

impl Emitter {
    /// Advances the clock by `dt` and returns the frame's window, or `None` when nothing is
    /// due (switched off, not started, stopped). Instants before this frame that were not
    /// emitted (the emitter was off or paused) are skipped: a paused stream does not build up.
    pub(super) fn open_window(&mut self, dt: Real) -> Option<Window> {
        let c0 = self.clock;
        self.clock += dt as f64;
        let w = Window {
            c1: self.clock,
            start: self.start as f64,
            rate: self.rate as f64,
        };
        if w.at(self.due) < c0 {
            self.due = ((c0 - w.start) * w.rate).ceil().max(0.0) as u64;
        }
        if !self.enabled || w.at(self.due) > w.c1 || w.at(self.due) > self.stop as f64 {
            return None;
        }
        Some(w)
    }

    /// The nozzle's pose this frame: its own, or its attachment's pose applied to its
    /// position and direction given in the body's (or collider's) frame. `None` when the body
    /// or collider it is attached to no longer exists.
    pub(super) fn nozzle_pose<'a>(&self, world: &EmitWorld<'a>) -> Option<NozzlePose<'a>> {
        let (pose, body) = match self.attachment {
            None => {
                return Some(NozzlePose {
                    position: self.position,
                    rotation: None,
                    body: None,
                });
            }
            Some(Attachment::Body(h)) => {
                let b = world.bodies.get(h)?;
                (*b.position(), Some(b))
            }
            Some(Attachment::Collider(h)) => {
                let co = world.colliders.get(h)?;
                let body = co.parent().and_then(|b| world.bodies.get(b));
                (*co.position(), body)
            }
        };
        Some(NozzlePose {
            position: pose.transform_point(self.position),
            rotation: Some(pose.rotation),
            body,
        })
    }

    /// The slots in world space (offsets from the nozzle's position, jet directions).
    pub(super) fn world_slots(&self, s: Real, pose: &NozzlePose) -> Vec<(Vector, Vector)> {
        let mut slots = self.slot_offsets(s);
        if let Some(q) = pose.rotation {
            for (offset, dir) in &mut slots {
                *offset = q * *offset;
                *dir = q * *dir;
            }
        }
        slots
    }

    /// The frame's plan for `slots` slots at spacing `s`.
    pub(super) fn plan(&self, w: &Window, slots: usize, dt: Real, s: Real) -> Plan {
        let end = w.c1.min(self.stop as f64);
        let last = ((end - w.start) * w.rate).floor();
        let due_count = last - self.due as f64 + 1.0;
        let layers = (self.speed as f64 * dt as f64 / (0.9 * s as f64)).floor();
        let attempts = (4.0 * slots as f64 * (layers + 1.0))
            .min(MAX_ATTEMPTS_PER_FRAME as f64)
            .max(1.0);
        let stride = if due_count > attempts {
            (due_count / attempts).ceil().min(u64::MAX as f64) as u64
        } else {
            1
        };
        Plan {
            last,
            due_count,
            attempts,
            stride,
        }
    }
}

/// The velocity a particle leaving slot point `from` along `dir` takes: the jet's, plus the
/// attached body's velocity at that point (`v + ω × (x − c)`).
pub(super) fn jet_velocity(pose: &NozzlePose, from: Vector, dir: Vector, speed: Real) -> Vector {
    match pose.body {
        None => dir * speed,
        Some(b) => dir * speed + b.velocity_at_point(from),
    }
}

/// Decides whether a particle fits: at least `0.9·spacing` from every particle near the
/// nozzle (old or just emitted), outside every solid near it by the contact radius, and
/// reached from its slot without crossing a surface.
pub(super) struct Placer<'a> {
    pub near: NearGrid,
    solids: Vec<ColliderHandle>,
    colliders: &'a ColliderSet,
    min_d2: Real,
    radius: Real,
}

impl<'a> Placer<'a> {
    /// The particles of `positions` and the solid colliders (through rapier's broad-phase)
    /// within `reach` of `center`.
    pub fn new(
        positions: &[Vector],
        center: Vector,
        reach: Real,
        p: &FluidParams,
        world: &EmitWorld<'a>,
    ) -> Self {
        let s = p.particle_spacing;
        let mut near = NearGrid::new(s);
        for x in positions {
            if (*x - center).length_squared() <= reach * reach {
                near.insert(*x);
            }
        }
        let mut solids: Vec<ColliderHandle> = Vec::new();
        if let Some(bvh) = world.bvh {
            let aabb = Aabb::new(center - Vector::splat(reach), center + Vector::splat(reach));
            for leaf in bvh.leaves(|node: &BvhNode| node.aabb().intersects(&aabb)) {
                if let Some((co, h)) = world.colliders.get_unknown_gen(leaf)
                    && co.is_enabled()
                    && !co.is_sensor()
                    && p.collision_groups.test(co.collision_groups())
                {
                    solids.push(h);
                }
            }
        }
        Self {
            near,
            solids,
            colliders: world.colliders,
            min_d2: (0.9 * s) * (0.9 * s),
            radius: p.particle_radius,
        }
    }

    /// Whether a particle fits at `x`, coming from slot point `from`.
    pub fn placeable(&self, x: Vector, from: Vector) -> bool {
        if self.near.any_within(x, self.min_d2) {
            return false;
        }
        let motion = x - from;
        let ray = Ray::new(from, motion);
        self.solids.iter().all(|&h| {
            let co = &self.colliders[h];
            let (shape, pose) = (co.shape(), co.position());
            !shape.contains_point(pose, from)
                && shape
                    .project_point_with_max_dist(pose, x, true, self.radius)
                    .is_none()
                && (motion == Vector::ZERO || shape.cast_ray(pose, &ray, 1.0, true).is_none())
        })
    }
}

/// Points in cubic cells of one particle spacing, hashed: [`NearGrid::any_within`] scans the 27
/// cells around a point, which hold every point closer than a spacing (the emitter asks for
/// `0.9·spacing`), so it answers exactly as a scan of every point would.
pub(super) struct NearGrid {
    inv_cell: f64,
    cells: std::collections::HashMap<[i64; 3], Vec<Vector>>,
}

impl NearGrid {
    fn new(cell: Real) -> Self {
        Self {
            inv_cell: 1.0 / cell as f64,
            cells: std::collections::HashMap::new(),
        }
    }

    fn key(&self, x: Vector) -> [i64; 3] {
        let k = |v: Real| (v as f64 * self.inv_cell).floor() as i64;
        [k(x.x), k(x.y), k(x.z)]
    }

    pub fn insert(&mut self, x: Vector) {
        let key = self.key(x);
        self.cells.entry(key).or_default().push(x);
    }

    /// Whether a point lies closer to `x` than `sqrt(d2)` (at most a cell).
    fn any_within(&self, x: Vector, d2: Real) -> bool {
        let [i, j, k] = self.key(x);
        for a in i - 1..=i + 1 {
            for b in j - 1..=j + 1 {
                for c in k - 1..=k + 1 {
                    if let Some(points) = self.cells.get(&[a, b, c])
                        && points.iter().any(|q| (*q - x).length_squared() < d2)
                    {
                        return true;
                    }
                }
            }
        }
        false
    }
}
