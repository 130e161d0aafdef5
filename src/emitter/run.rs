//! The emitters' and sinks' stages, and their storage on the fluid: a fluid's emitters add the
//! particles due in a frame (after its substeps), its sinks remove the particles inside them
//! (after every substep). See the module docs of [`crate::emitter`].

use super::emit::{EmitWorld, NozzlePose, Placer, Plan, Window, jet_velocity};
use super::{Attachment, Emitter, EmitterHandle, Region, Sink, SinkHandle};
use crate::error::{SphError, SphResult};
use crate::fluid::Fluid;
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use parry3d::bounding_volume::BoundingVolume;
use rapier3d::dynamics::RigidBodySet;
use rapier3d::geometry::ColliderSet;

/// The error for an emitter handle that names no emitter of the fluid.
fn unknown_emitter(handle: EmitterHandle) -> SphError {
    SphError::InvalidParameter {
        field: "emitter",
        value: handle.index as f64,
        reason: "names no emitter of this fluid (removed, or of another fluid)",
    }
}

/// What the emitters of one fluid did during one frame.
#[derive(Copy, Clone, Debug, Default)]
pub(crate) struct EmitCounts {
    pub emitted: usize,
    pub blocked: usize,
    pub capacity_reached: bool,
}

impl Fluid {
    /// Adds an emitter (validated) to this fluid. Its clock starts at 0 and advances with
    /// every step of the fluid.
    ///
    /// # Errors
    /// [`Emitter::validate`]'s errors, and [`crate::SphError::InvalidParameter`] naming the
    /// nozzle's size when it has more than [`super::MAX_NOZZLE_SLOTS`] slots at this fluid's
    /// spacing (a nozzle of 1 km at 5 cm spacing would have 1.6·10^9); nothing is added.
    ///
    /// # Examples
    ///
    /// ```
    /// use rapier_sph::{Emitter, Fluid, FluidParamsBuilder, Nozzle};
    /// use rapier_sph::math::Vector;
    ///
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.04).build()?)?;
    /// // A hose: 3 cm nozzle, 1 m up, shooting sideways at 2 m/s, 400 particles a second for
    /// // 5 s, 1,000 particles at most.
    /// let hose = Emitter::new(Nozzle::Disk { radius: 0.03 }, Vector::new(0.0, 1.0, 0.0),
    ///                         Vector::X, 2.0, 400.0)
    ///     .active_between(0.0, 5.0)
    ///     .budget(1_000);
    /// let handle = fluid.add_emitter(hose)?;
    /// fluid.emitter_mut(handle).unwrap().set_rate(200.0)?;
    /// // A negative speed is refused, naming the field.
    /// let bad = Emitter::new(Nozzle::Disk { radius: 0.03 }, Vector::ZERO, Vector::X, -1.0, 10.0);
    /// assert!(fluid.add_emitter(bad).is_err());
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn add_emitter(&mut self, emitter: Emitter) -> SphResult<EmitterHandle> {
        emitter.validate()?;
        emitter.check_slots(self.params().particle_spacing)?;
        let (index, generation) = self.sources.emitters.insert(emitter);
        Ok(EmitterHandle { index, generation })
    }

    /// Attaches an emitter to a rigid body or a collider, which then carries it: each frame
    /// the nozzle takes the body's (or collider's) pose, its position and direction being
    /// read in that frame, and the particles it emits add the body's velocity at the nozzle to
    /// the jet's (see [`Attachment`]). Place the nozzle outside the body's own colliders (a
    /// particle is never emitted inside a solid). If the body or collider is removed later,
    /// the emitter's due particles are counted as blocked ([`crate::StepReport::emitter_blocked`])
    /// until it is attached again or detached.
    ///
    /// # Errors
    /// [`crate::SphError::InvalidParameter`] naming `emitter` when the handle names no emitter
    /// of this fluid, `body` or `collider` when the attachment names nothing in `bodies` or
    /// `colliders`; nothing changes.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::prelude::*;
    /// use rapier_sph::rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};
    ///
    /// let mut world = FluidWorld::new();
    /// // A watering can carried at 1 m/s along x; its spout 20 cm in front, pointing down.
    /// let can = world.physics.insert_body(
    ///     RigidBodyBuilder::kinematic_velocity_based()
    ///         .translation(Vector::new(0.0, 1.0, 0.0))
    ///         .linvel(Vector::new(1.0, 0.0, 0.0)),
    /// );
    /// world.physics.insert_collider(ColliderBuilder::cuboid(0.1, 0.1, 0.1), Some(can));
    /// let mut water = Fluid::new(FluidParamsBuilder::water(0.04))?;
    /// let spout = water.add_emitter(Emitter::new(Nozzle::Disk { radius: 0.03 },
    ///     Vector::new(0.2, 0.0, 0.0), Vector::NEG_Y, 1.0, 300.0))?;
    /// water.attach_emitter(spout, Attachment::Body(can), &world.physics.bodies,
    ///                      &world.physics.colliders)?;
    /// let water = world.fluids.insert(water);
    /// for _ in 0..6 {
    ///     world.step()?;
    /// }
    /// let fluid = &world.fluids[water];
    /// assert!(fluid.len() > 0);
    /// // Every drop left the spout with the can's 1 m/s along x.
    /// assert!(fluid.velocities().iter().all(|v| v.x > 0.9));
    /// // A body that does not exist is refused, naming it.
    /// let mut other = rapier_sph::rapier3d::prelude::RigidBodySet::new();
    /// let gone = other.insert(RigidBodyBuilder::dynamic());
    /// let stale = rapier_sph::rapier3d::prelude::RigidBodySet::new();
    /// assert!(world.fluids[water].emitter(spout).is_some());
    /// let r = world.fluids[water].attach_emitter(spout, Attachment::Body(gone), &stale,
    ///                                            &world.physics.colliders);
    /// assert!(matches!(r, Err(SphError::InvalidParameter { field: "body", .. })));
    /// # Ok::<(), SphError>(())
    /// ```
    pub fn attach_emitter(
        &mut self,
        emitter: EmitterHandle,
        to: Attachment,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) -> SphResult<()> {
        match to {
            Attachment::Body(h) if bodies.get(h).is_none() => {
                return Err(SphError::InvalidParameter {
                    field: "body",
                    value: h.into_raw_parts().0 as f64,
                    reason: "names no rigid body of the set (removed, or from another set)",
                });
            }
            Attachment::Collider(h) if colliders.get(h).is_none() => {
                return Err(crate::fluid::unknown_collider(h));
            }
            _ => {}
        }
        let e = self.emitter_mut(emitter).ok_or(unknown_emitter(emitter))?;
        e.attachment = Some(to);
        Ok(())
    }

    /// Detaches an emitter ([`Fluid::attach_emitter`]): it stays where it is, its position and
    /// direction now in world space (taken from the body or collider's current pose, if it
    /// still exists in `bodies` or `colliders`, so the nozzle does not jump). Returns the
    /// attachment it had.
    ///
    /// # Errors
    /// [`crate::SphError::InvalidParameter`] naming `emitter` when the handle names no emitter
    /// of this fluid.
    pub fn detach_emitter(
        &mut self,
        emitter: EmitterHandle,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) -> SphResult<Option<Attachment>> {
        let e = self.emitter_mut(emitter).ok_or(unknown_emitter(emitter))?;
        let pose = match e.attachment {
            Some(Attachment::Body(h)) => bodies.get(h).map(|b| *b.position()),
            Some(Attachment::Collider(h)) => colliders.get(h).map(|c| *c.position()),
            None => None,
        };
        if let Some(pose) = pose {
            e.position = pose.transform_point(e.position);
            e.direction = pose.rotation * e.direction;
        }
        Ok(e.attachment.take())
    }

    /// Removes an emitter, returning it.
    pub fn remove_emitter(&mut self, handle: EmitterHandle) -> Option<Emitter> {
        self.sources
            .emitters
            .remove(handle.index, handle.generation)
    }

    /// The emitter named by `handle`.
    pub fn emitter(&self, handle: EmitterHandle) -> Option<&Emitter> {
        self.sources.emitters.get(handle.index, handle.generation)
    }

    /// The emitter named by `handle`, mutably (its setters validate).
    pub fn emitter_mut(&mut self, handle: EmitterHandle) -> Option<&mut Emitter> {
        self.sources
            .emitters
            .get_mut(handle.index, handle.generation)
    }

    /// Iterates over `(handle, emitter)`.
    pub fn emitters(&self) -> impl Iterator<Item = (EmitterHandle, &Emitter)> {
        self.sources
            .emitters
            .iter()
            .map(|((index, generation), e)| (EmitterHandle { index, generation }, e))
    }

    /// Adds a sink (validated) to this fluid: every substep, its particles inside the sink's
    /// region are removed (counted in [`crate::StepReport::drained`]).
    ///
    /// # Errors
    ///
    /// [`crate::SphError::InvalidParameter`] naming the region's bad field
    /// ([`Sink::validate`]); nothing is added.
    ///
    /// # Examples
    ///
    /// ```
    /// use rapier_sph::{Fluid, FluidParamsBuilder, Region, Sink};
    /// use rapier_sph::math::Vector;
    ///
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.04).build()?)?;
    /// // Whatever falls below y = −1 m is drained.
    /// fluid.add_sink(Sink::new(Region::Aabb {
    ///     min: Vector::splat(-100.0),
    ///     max: Vector::new(100.0, -1.0, 100.0),
    /// }))?;
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn add_sink(&mut self, sink: Sink) -> SphResult<SinkHandle> {
        sink.validate()?;
        self.sleep.wake(); // a sink in still water drains it
        let (index, generation) = self.sources.sinks.insert(sink);
        Ok(SinkHandle { index, generation })
    }

    /// Removes a sink, returning it.
    pub fn remove_sink(&mut self, handle: SinkHandle) -> Option<Sink> {
        self.sources.sinks.remove(handle.index, handle.generation)
    }

    /// The sink named by `handle`.
    pub fn sink(&self, handle: SinkHandle) -> Option<&Sink> {
        self.sources.sinks.get(handle.index, handle.generation)
    }

    /// Iterates over `(handle, sink)`.
    pub fn sinks(&self) -> impl Iterator<Item = (SinkHandle, &Sink)> {
        self.sources
            .sinks
            .iter()
            .map(|((index, generation), s)| (SinkHandle { index, generation }, s))
    }

    /// The sink named by `handle`, mutably.
    pub fn sink_mut(&mut self, handle: SinkHandle) -> Option<&mut Sink> {
        self.sleep.wake();
        self.sources.sinks.get_mut(handle.index, handle.generation)
    }

    /// Removes the particles inside the fluid's sinks. Returns how many.
    pub(crate) fn drain_sinks(&mut self, colliders: &ColliderSet) -> usize {
        if self.sources.sinks.is_empty() {
            return 0;
        }
        let spacing = self.params().particle_spacing;
        let mut sinks = std::mem::take(&mut self.sources.sinks);
        let mut total = 0;
        for sink in sinks.iter_mut() {
            if !sink.enabled {
                continue;
            }
            let removed = match sink.region {
                Region::Aabb { min, max } => {
                    self.remove_where(|x, _, _| x.cmpge(min).all() && x.cmple(max).all())
                }
                Region::Ball { center, radius } => {
                    let r2 = radius * radius;
                    self.remove_where(|x, _, _| (x - center).length_squared() <= r2)
                }
                Region::Collider(handle) => {
                    let Some(co) = colliders.get(handle) else {
                        continue;
                    };
                    let aabb = co.compute_aabb();
                    let (shape, pose) = (co.shape(), co.position());
                    self.remove_where(|x, _, _| {
                        aabb.contains_local_point(x) && shape.contains_point(pose, x)
                    })
                }
                Region::NearCollider { handle, reach } => {
                    let Some(co) = colliders.get(handle) else {
                        continue;
                    };
                    let reach = reach.unwrap_or(spacing);
                    let aabb = co.compute_aabb().loosened(reach);
                    let (shape, pose) = (co.shape(), co.position());
                    self.remove_where(|x, _, _| {
                        aabb.contains_local_point(x)
                            && shape
                                .project_point_with_max_dist(pose, x, true, reach)
                                .is_some()
                    })
                }
            };
            sink.drained += removed as u64;
            total += removed;
        }
        self.sources.sinks = sinks;
        self.drained += total;
        total
    }

    /// Runs the fluid's emitters over a frame of `dt` seconds that ends now: places the
    /// particles due during the frame where they are at its end (see the [module
    /// docs](crate::emitter)).
    pub(crate) fn run_emitters(&mut self, dt: Real, world: EmitWorld<'_>) -> EmitCounts {
        if self.sources.emitters.is_empty() {
            return EmitCounts::default();
        }
        let params = self.params().clone();
        let mut frame = EmitFrame {
            dt,
            params: &params,
            world,
            new_x: Vec::new(),
            new_v: Vec::new(),
            counts: EmitCounts::default(),
        };
        let mut emitters = std::mem::take(&mut self.sources.emitters);
        for e in emitters.iter_mut() {
            self.run_emitter(e, &mut frame);
        }
        self.sources.emitters = emitters;
        let EmitFrame {
            new_x,
            new_v,
            counts,
            ..
        } = frame;
        if !new_x.is_empty() {
            self.append_unchecked(&new_x, &new_v);
            self.emitted += new_x.len();
        }
        counts
    }

    /// One emitter's frame: its window of due instants, its nozzle's pose, the plan of tries,
    /// the memory check, then the placements.
    fn run_emitter(&self, e: &mut Emitter, f: &mut EmitFrame<'_>) {
        let Some(window) = e.open_window(f.dt) else {
            return;
        };
        let s = f.params.particle_spacing;
        if e.check_slots(s).is_err() {
            // Refused by `add_emitter` and `set_params`; a state restored from elsewhere
            // cannot make a frame build billions of slots.
            return;
        }
        let Some(pose) = e.nozzle_pose(&f.world) else {
            // Attached to a body or collider that no longer exists: its due particles are
            // blocked (and skipped at the next frame, as a paused emitter's).
            let plan = e.plan(&window, 1, f.dt, s);
            f.counts.blocked = (f.counts.blocked).saturating_add(plan.due_count as usize);
            return;
        };
        let slots = e.world_slots(s, &pose);
        let reach = e.reach() + e.speed * f.dt + s;
        let plan = e.plan(&window, slots.len(), f.dt, s);
        // The memory the fluid would need if every try were placed: when it cannot be
        // reserved, the emitter pauses for the frame as at the capacity.
        let most = plan.due_count.max(0.0).min(plan.attempts);
        if most >= 1.0
            && crate::fluid::check_particle_count(
                (self.positions.len() + f.new_x.len()) as f64 + most,
                crate::fluid::bytes_per_particle(f.params),
                "rate",
            )
            .is_err()
        {
            f.counts.capacity_reached = true;
            f.counts.blocked = f.counts.blocked.saturating_add(plan.due_count as usize);
            return;
        }
        let placer = Placer::new(&self.positions, pose.position, reach, f.params, &f.world);
        let mut jet = Jet {
            window,
            plan,
            slots,
            pose,
            placer,
        };
        self.place_due(e, &mut jet, f);
    }

    /// Tries the frame's due particles in turn over the slots (every `stride`-th due instant),
    /// placing those that fit; stops at the budget, the capacity or when the ids run out.
    fn place_due(&self, e: &mut Emitter, jet: &mut Jet<'_>, f: &mut EmitFrame<'_>) {
        let (w, stride) = (jet.window, jet.plan.stride);
        let first = e.due;
        let mut tried = 0u64;
        while w.at(e.due) <= w.c1 && w.at(e.due) <= e.stop as f64 {
            if e.budget.is_some_and(|b| e.emitted >= b) {
                break;
            }
            if self
                .capacity
                .is_some_and(|cap| self.positions.len() + f.new_x.len() >= cap)
                || f.new_x.len() >= self.ids_left()
            {
                f.counts.capacity_reached = true;
                break;
            }
            let age = (w.c1 - w.at(e.due)) as Real;
            let (offset, dir) = jet.slots[e.next_slot % jet.slots.len()];
            let from = jet.pose.position + offset;
            let x = from + dir * (e.speed * age);
            e.due = e.due.saturating_add(stride);
            tried += 1;
            e.next_slot = (e.next_slot + 1) % jet.slots.len();
            if jet.placer.placeable(x, from) {
                jet.placer.near.insert(x);
                f.new_x.push(x);
                f.new_v.push(jet_velocity(&jet.pose, from, dir, e.speed));
                e.emitted += 1;
                f.counts.emitted += 1;
            } else {
                f.counts.blocked += 1;
            }
        }
        if stride > 1 {
            // The instants skipped between the tried ones were due and not emitted.
            let next = e.due.min(jet.plan.last as u64 + 1);
            e.due = next;
            let skipped = next.saturating_sub(first).saturating_sub(tried);
            f.counts.blocked = f
                .counts
                .blocked
                .saturating_add(usize::try_from(skipped).unwrap_or(usize::MAX));
        }
    }
}

/// One frame of one fluid's emitters: its inputs, and the particles and counts it makes.
struct EmitFrame<'a> {
    dt: Real,
    params: &'a FluidParams,
    world: EmitWorld<'a>,
    new_x: Vec<Vector>,
    new_v: Vec<Vector>,
    counts: EmitCounts,
}

/// One emitter's frame once planned: its window, plan, slots (world space), nozzle pose and
/// what is near it.
struct Jet<'a> {
    window: Window,
    plan: Plan,
    slots: Vec<(Vector, Vector)>,
    pose: NozzlePose<'a>,
    placer: Placer<'a>,
}
