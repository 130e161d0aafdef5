//! The emitters' and sinks' stages, and their storage on the fluid: a fluid's emitters add the
//! particles due in a frame (after its substeps), its sinks remove the particles inside them
//! (after every substep). See the module docs of [`crate::emitter`].

use super::{Emitter, EmitterHandle, MAX_ATTEMPTS_PER_FRAME, Sink, SinkHandle, SinkRegion};
use crate::error::SphResult;
use crate::fluid::Fluid;
use crate::math::{Real, Vector};
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::partitioning::{Bvh, BvhNode};
use parry3d::query::Ray;
use rapier3d::geometry::{ColliderHandle, ColliderSet};

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
    /// use rapier_sph::{Fluid, FluidParamsBuilder, Sink, SinkRegion};
    /// use rapier_sph::math::Vector;
    ///
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.04).build()?)?;
    /// // Whatever falls below y = −1 m is drained.
    /// fluid.add_sink(Sink::new(SinkRegion::Aabb {
    ///     min: Vector::splat(-100.0),
    ///     max: Vector::new(100.0, -1.0, 100.0),
    /// }))?;
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn add_sink(&mut self, sink: Sink) -> SphResult<SinkHandle> {
        sink.validate()?;
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
                SinkRegion::Aabb { min, max } => {
                    self.remove_particles_where(|x, _, _| x.cmpge(min).all() && x.cmple(max).all())
                }
                SinkRegion::Ball { centre, radius } => {
                    let r2 = radius * radius;
                    self.remove_particles_where(|x, _, _| (x - centre).length_squared() <= r2)
                }
                SinkRegion::Collider { handle, reach } => {
                    let Some(co) = colliders.get(handle) else {
                        continue;
                    };
                    let reach = reach.unwrap_or(spacing);
                    let aabb = co.compute_aabb().loosened(reach);
                    let (shape, pose) = (co.shape(), co.position());
                    self.remove_particles_where(|x, _, _| {
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
    pub(crate) fn run_emitters(
        &mut self,
        dt: Real,
        bvh: Option<&Bvh>,
        colliders: &ColliderSet,
    ) -> EmitCounts {
        let mut counts = EmitCounts::default();
        if self.sources.emitters.is_empty() {
            return counts;
        }
        let p = self.params().clone();
        let (s, r) = (p.particle_spacing, p.particle_radius);
        let min_d2 = (0.9 * s) * (0.9 * s);
        let mut emitters = std::mem::take(&mut self.sources.emitters);
        let mut new_x: Vec<Vector> = Vec::new();
        let mut new_v: Vec<Vector> = Vec::new();
        for e in emitters.iter_mut() {
            let c0 = e.clock;
            e.clock += dt as f64;
            let c1 = e.clock;
            let (start, rate) = (e.start as f64, e.rate as f64);
            let at = |k: u64| start + k as f64 / rate;
            // Instants before this frame that were not emitted (the emitter was off or
            // paused) are skipped: a paused stream does not build up.
            if at(e.due) < c0 {
                e.due = ((c0 - start) * rate).ceil().max(0.0) as u64;
            }
            if !e.enabled {
                continue;
            }
            if at(e.due) > c1 || at(e.due) > e.stop as f64 {
                continue;
            }
            if e.check_slots(s).is_err() {
                // Refused by `add_emitter` and `set_params`; a state restored from elsewhere
                // cannot make a frame build billions of slots.
                continue;
            }
            let slots = e.slot_offsets(s);
            let travel = e.speed * dt;
            let reach = e.reach() + travel + s;
            // Particles near the nozzle (old ones; new ones are added to `near` as placed).
            let mut near = NearGrid::new(s);
            for x in &self.positions {
                if (*x - e.position).length_squared() <= reach * reach {
                    near.insert(*x);
                }
            }
            // At most `attempts` due instants are tried this frame (see the module docs,
            // "Bounds"): beyond it every `stride`-th is tried and the rest count as blocked.
            let end = c1.min(e.stop as f64);
            let last = ((end - start) * rate).floor();
            let due_count = last - e.due as f64 + 1.0;
            let layers = (e.speed as f64 * dt as f64 / (0.9 * s as f64)).floor();
            let attempts = (4.0 * slots.len() as f64 * (layers + 1.0))
                .min(MAX_ATTEMPTS_PER_FRAME as f64)
                .max(1.0);
            let stride = if due_count > attempts {
                (due_count / attempts).ceil().min(u64::MAX as f64) as u64
            } else {
                1
            };
            // The memory the fluid would need if every try were placed: when it cannot be
            // reserved, the emitter pauses for the frame as at the capacity.
            let most = due_count.max(0.0).min(attempts);
            if most >= 1.0
                && crate::fluid::check_particle_count(
                    (self.positions.len() + new_x.len()) as f64 + most,
                    crate::fluid::bytes_per_particle(&p),
                    "rate",
                )
                .is_err()
            {
                counts.capacity_reached = true;
                counts.blocked = counts.blocked.saturating_add(due_count as usize);
                continue;
            }
            let first = e.due;
            let mut tried = 0u64;
            // Colliders near the nozzle, from rapier's broad-phase.
            let mut solids: Vec<ColliderHandle> = Vec::new();
            if let Some(bvh) = bvh {
                let aabb = Aabb::new(
                    e.position - Vector::splat(reach),
                    e.position + Vector::splat(reach),
                );
                for leaf in bvh.leaves(|node: &BvhNode| node.aabb().intersects(&aabb)) {
                    if let Some((co, h)) = colliders.get_unknown_gen(leaf)
                        && co.is_enabled()
                        && !co.is_sensor()
                        && p.collision_groups.test(co.collision_groups())
                    {
                        solids.push(h);
                    }
                }
            }
            let placeable = |x: Vector, from: Vector, near: &NearGrid| -> bool {
                if near.any_within(x, min_d2) {
                    return false;
                }
                let motion = x - from;
                let ray = Ray::new(from, motion);
                solids.iter().all(|&h| {
                    let co = &colliders[h];
                    let (shape, pose) = (co.shape(), co.position());
                    !shape.contains_point(pose, from)
                        && shape
                            .project_point_with_max_dist(pose, x, true, r)
                            .is_none()
                        && (motion == Vector::ZERO
                            || shape.cast_ray(pose, &ray, 1.0, true).is_none())
                })
            };
            while at(e.due) <= c1 && at(e.due) <= e.stop as f64 {
                if e.budget.is_some_and(|b| e.emitted >= b) {
                    break;
                }
                if self
                    .capacity
                    .is_some_and(|cap| self.positions.len() + new_x.len() >= cap)
                    || new_x.len() >= self.ids_left()
                {
                    counts.capacity_reached = true;
                    break;
                }
                let age = (c1 - at(e.due)) as Real;
                let (offset, dir) = slots[e.next_slot % slots.len()];
                let from = e.position + offset;
                let x = from + dir * (e.speed * age);
                e.due = e.due.saturating_add(stride);
                tried += 1;
                e.next_slot = (e.next_slot + 1) % slots.len();
                if placeable(x, from, &near) {
                    near.insert(x);
                    new_x.push(x);
                    new_v.push(dir * e.speed);
                    e.emitted += 1;
                    counts.emitted += 1;
                } else {
                    counts.blocked += 1;
                }
            }
            if stride > 1 {
                // The instants skipped between the tried ones were due and not emitted.
                let next = e.due.min(last as u64 + 1);
                e.due = next;
                let skipped = next.saturating_sub(first).saturating_sub(tried);
                counts.blocked = counts
                    .blocked
                    .saturating_add(usize::try_from(skipped).unwrap_or(usize::MAX));
            }
        }
        self.sources.emitters = emitters;
        if !new_x.is_empty() {
            self.append_unchecked(&new_x, &new_v);
            self.emitted += new_x.len();
        }
        counts
    }
}

/// Points in cubic cells of one particle spacing, hashed: [`NearGrid::any_within`] scans the 27
/// cells around a point, which hold every point closer than a spacing (the emitter asks for
/// `0.9·spacing`), so it answers exactly as a scan of every point would.
struct NearGrid {
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

    fn insert(&mut self, x: Vector) {
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
