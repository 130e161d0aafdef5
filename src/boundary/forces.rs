//! What the fluid does to the colliders a game watches: the force and torque on each
//! collider (fixed, kinematic and dynamic alike), and which particles touch it.
//!
//! **Opting in.** A collider is watched through rapier's own flags:
//! `ActiveEvents::CONTACT_FORCE_EVENTS` for its forces, `ActiveEvents::COLLISION_EVENTS` for
//! touch events (see [`crate::FluidPipeline::collider_force`],
//! [`crate::FluidPipeline::contact_events`]). A frame looks for them once (one pass over the
//! collider set); every stage below returns at its first check when no
//! collider near the fluid is watched, so a scene that watches nothing runs the step it ran
//! before, bit for bit.
//!
//! **Forces.** The fluid acts on a collider in three places; each impulse is recorded with the
//! point it acts at, and the frame's sum divided by the frame's length is the force (N) and
//! torque (N·m) reported, the mean over the frame's substeps as rapier reports its contact
//! forces:
//! 1. *Wall pressure* (walls that count in the density, DFSPH, WCSPH, PBF): particle `i`'s wall
//!    term from collider `k` gave it the impulse `−(g_k·s_i − h_k·m·dt)`, `g_k` collider `k`'s
//!    share of the wall density's gradient (the union of half-spaces of the walls
//!    (`boundary::wall`) split per collider: a later wall scales the earlier ones' shares by
//!    `1 − a`, as it scales their sum), `s_i` the solver's share
//!    (`PressureSolver::wall_impulse_scale`, the same the coupling gives dynamic bodies) and
//!    `h_k` the collider's share of the hydrostatic wall acceleration. The collider takes the
//!    opposite impulse, at its surface point closest to the particle. The wall stage records
//!    the shares as it unites the walls (one push per particle and watched wall near it).
//! 2. *Wall viscosity*: collider `k`'s share of the implicit velocity change,
//!    `(L_k v_k − L_k v_i)·f/(1 + α)` (see the walls' viscosity, [`crate::FluidParams::wall_viscosity`]).
//! 3. *Contact*: the velocity change collider contact made on a particle is `−Δv·m` on the
//!    collider it touched. Contact reflects a particle off several surfaces in one pass, so
//!    the change is split over the colliders within 1.1 contact radii of its end
//!    position: each takes its normal part `n (n·Δv)` (exact for one surface, and for
//!    perpendicular surfaces without friction), the rest in proportion to those normal parts.
//!    A dynamic body's impulses are those the coupling records and settles (contact and the
//!    wall terms, with the added-mass exchange's share: `boundary::bodies`), read from its
//!    records: what the body is given is what is reported, to the last bit of its sum.
//!
//! Every impulse is added in particle order into f64 sums per collider, per fluid; the
//! fluids' sums are added in the set's order: the results do not depend on the thread count.
//!
//! **Touch.** A particle touches a collider when, at the end of a substep, its center is
//! within [`touch_distance`] of the collider's surface (contact radius plus half a spacing:
//! the first layer of resting fluid and no other). Each watched
//! collider costs one box test per particle per substep, and a point projection for the
//! particles in its box. The ids of the frame's touching particles are kept per (fluid, collider),
//! sorted: a particle that touched and was drained by a sink later in the frame counts.

use super::bodies::{ImpulseRecord, MovingCollider, ParticleMass, entry_of};
use super::candidates::ContactWorkspace;
use crate::fluid::FluidHandle;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborGrid;
use parry3d::bounding_volume::BoundingVolume;
use rapier3d::dynamics::{RigidBodyHandle, RigidBodySet};
use rapier3d::geometry::{ColliderHandle, ColliderSet};
use rapier3d::pipeline::ActiveEvents;

/// Contact's velocity change on a particle goes to the colliders within this many contact
/// radii of its end position (contact leaves a particle it pushed one radius off, between
/// `1 − 10⁻³` and 1).
const TOUCH: Real = 1.1;

/// How close a particle's center comes to a collider's surface to touch it: its contact
/// radius `r` plus half a spacing `s`, midway between the first layer of resting fluid
/// (`r` off, or a little farther where the walls' pressure holds it) and the second
/// (`r + s`).
pub fn touch_distance(params: &crate::FluidParams) -> Real {
    params.particle_radius + 0.5 * params.particle_spacing
}

/// One watched collider, as the frame's start found it.
#[derive(Copy, Clone, Debug)]
pub(crate) struct Watched {
    pub handle: ColliderHandle,
    pub body: Option<RigidBodyHandle>,
    /// Its body is dynamic: its impulses are read from the coupling's records.
    pub dynamic: bool,
    /// `CONTACT_FORCE_EVENTS`.
    pub forces: bool,
    /// `COLLISION_EVENTS`.
    pub events: bool,
    /// The torques' reference point: the body's center of mass (the collider's position
    /// without a body).
    pub center: Vector,
}

/// The watched colliders of a frame, sorted by handle.
#[derive(Clone, Debug, Default)]
pub(crate) struct Watch {
    pub list: Vec<Watched>,
    pub any_forces: bool,
    pub any_events: bool,
    /// Some watched force is a dynamic body's.
    pub any_dynamic_forces: bool,
}

impl Watch {
    /// Finds the colliders with `CONTACT_FORCE_EVENTS` or `COLLISION_EVENTS`: one pass over
    /// the collider set.
    pub fn collect(&mut self, colliders: &ColliderSet, bodies: &RigidBodySet) {
        self.list.clear();
        let wanted = ActiveEvents::CONTACT_FORCE_EVENTS | ActiveEvents::COLLISION_EVENTS;
        for (handle, co) in colliders.iter() {
            let flags = co.active_events();
            if !flags.intersects(wanted) || !co.is_enabled() {
                continue;
            }
            let body = co.parent().and_then(|b| Some((b, bodies.get(b)?)));
            self.list.push(Watched {
                handle,
                body: body.map(|(b, _)| b),
                dynamic: body.is_some_and(|(_, b)| b.is_dynamic()),
                forces: flags.contains(ActiveEvents::CONTACT_FORCE_EVENTS),
                events: flags.contains(ActiveEvents::COLLISION_EVENTS),
                center: body.map_or(co.position().translation, |(_, b)| b.center_of_mass()),
            });
        }
        self.list.sort_by_key(|w| w.handle.0);
        self.any_forces = self.list.iter().any(|w| w.forces);
        self.any_events = self.list.iter().any(|w| w.events);
        self.any_dynamic_forces = self.list.iter().any(|w| w.forces && w.dynamic);
    }

    /// The slot of `handle`, if watched.
    #[inline]
    pub fn slot(&self, handle: ColliderHandle) -> Option<usize> {
        if self.list.is_empty() {
            return None;
        }
        self.list
            .binary_search_by_key(&handle.0, |w| w.handle.0)
            .ok()
    }

    /// The slot of `handle` if its forces are watched and it is not a dynamic body's.
    #[inline]
    fn passive_force_slot(&self, handle: ColliderHandle) -> Option<usize> {
        self.slot(handle)
            .filter(|&k| self.list[k].forces && !self.list[k].dynamic)
    }
}

/// One collider's share of a particle's wall terms (recorded by the wall stage).
#[derive(Copy, Clone, Debug)]
pub(crate) struct Share {
    pub particle: u32,
    pub slot: u32,
    /// Share of the wall density's gradient, in units of the whole force kernel.
    pub gradient: Vector,
    /// Share of the hydrostatic wall acceleration (m/s²).
    pub hydrostatic: Vector,
    /// Share `L_k` of the viscous sum, and `L_k·v_k`.
    pub viscous: Real,
    pub viscous_velocity: Vector,
    /// The collider's surface point closest to the particle.
    pub point: Vector,
}

/// Collects the shares of one particle's walls: [`super::wall`] calls it per wall, in the
/// order it unites them.
pub(crate) trait WallSink {
    /// The next wall is collider `handle`.
    fn begin(&mut self, handle: ColliderHandle);
    /// That wall's coverage `a` and its terms (before the union's later scaling).
    fn wall(
        &mut self,
        a: Real,
        gradient: Vector,
        hydrostatic: Vector,
        l: Real,
        lv: Vector,
        point: Vector,
    );
    /// The neighbours' center term: every share's hydrostatic part gains its gradient × `c`.
    fn center(&mut self, c: Real);
}

/// The wall stage's own sink: nothing (compiled away).
impl WallSink for () {
    #[inline(always)]
    fn begin(&mut self, _: ColliderHandle) {}
    #[inline(always)]
    fn wall(&mut self, _: Real, _: Vector, _: Vector, _: Real, _: Vector, _: Vector) {}
    #[inline(always)]
    fn center(&mut self, _: Real) {}
}

/// The wall stage's sink when forces are watched: the watched colliders' shares of one
/// particle.
pub(crate) struct ParticleShares<'a> {
    pub watch: &'a Watch,
    pub particle: u32,
    /// Where this particle's shares start in `out`.
    pub first: usize,
    pub out: &'a mut Vec<Share>,
    /// The slot of the wall begun (`None`: not watched).
    pub current: Option<u32>,
}

impl WallSink for ParticleShares<'_> {
    #[inline]
    fn begin(&mut self, handle: ColliderHandle) {
        self.current = self.watch.passive_force_slot(handle).map(|k| k as u32);
    }

    #[inline]
    fn wall(
        &mut self,
        a: Real,
        gradient: Vector,
        hydrostatic: Vector,
        l: Real,
        lv: Vector,
        point: Vector,
    ) {
        for s in &mut self.out[self.first..] {
            s.gradient *= 1.0 - a;
            s.hydrostatic *= 1.0 - a;
        }
        if let Some(slot) = self.current {
            self.out.push(Share {
                particle: self.particle,
                slot,
                gradient,
                hydrostatic,
                viscous: l,
                viscous_velocity: lv,
                point,
            });
        }
    }

    #[inline]
    fn center(&mut self, c: Real) {
        for s in &mut self.out[self.first..] {
            s.hydrostatic += s.gradient * c;
        }
    }
}

/// One fluid's records during a frame (held in its workspace).
#[derive(Clone, Debug, Default)]
pub(crate) struct FluidForces {
    /// Per watched slot: linear and angular impulse of the frame (f64).
    pub acc: Vec<[f64; 6]>,
    /// Per watched slot: ids of the particles that touched it this frame (unsorted until
    /// [`FluidForces::finish_touch`]).
    pub touched: Vec<Vec<u32>>,
    /// The wall shares of the current substep (particle order).
    pub shares: Vec<Share>,
    /// Velocities before contact, and after its resolution.
    before: Vec<Vector>,
    mid: Vec<Vector>,
    /// Whether `before`/`mid` hold this substep's snapshot.
    snapped: bool,
    mid_snapped: bool,
}

/// What the contact accounting reads.
pub(crate) struct ContactView<'a> {
    pub watch: &'a Watch,
    pub grid: &'a NeighborGrid,
    pub candidates: &'a ContactWorkspace,
    pub colliders: &'a ColliderSet,
    /// The coupling table of the substep (empty without moving bodies).
    pub table: &'a [MovingCollider],
    /// The contact radius, each particle's mass and the touch distance.
    pub radius: Real,
    pub mass: ParticleMass<'a>,
    pub touch: Real,
}

impl FluidForces {
    /// Sized for `watch`, zeroed: at the start of each frame.
    pub fn begin_frame(&mut self, watch: &Watch) {
        self.acc.clear();
        self.acc.resize(watch.list.len(), [0.0; 6]);
        self.touched.resize_with(watch.list.len(), Vec::new);
        self.touched.truncate(watch.list.len());
        self.touched.iter_mut().for_each(Vec::clear);
        self.shares.clear();
    }

    /// The watched colliders' slots this fluid's records hold (those of the last frame it
    /// was stepped in).
    pub fn slots(&self) -> usize {
        self.acc.len()
    }

    /// Adds `impulse` at `point` to slot `k`.
    #[inline]
    fn add(&mut self, watch: &Watch, k: usize, impulse: Vector, point: Vector) {
        let torque = (point - watch.list[k].center).cross(impulse);
        let a = &mut self.acc[k];
        for c in 0..3 {
            a[c] += impulse[c] as f64;
            a[3 + c] += torque[c] as f64;
        }
    }

    /// Stage 5 and 6's part, after the solver and before the walls' viscosity: each share's
    /// pressure impulse (`scale(i)`: the solver's share, `unit`: ρ0 times the force kernel's
    /// full integral, turning a share into kg/m⁴) and viscous impulse, on the velocities the
    /// solver left (`inv_densities`: `1/ρ`, `l_total`: the particle's whole viscous sum).
    pub fn wall_impulses(
        &mut self,
        watch: &Watch,
        terms: WallTerms<'_>,
        scale: impl Fn(usize) -> Real,
    ) {
        if self.shares.is_empty() {
            return;
        }
        let shares = std::mem::take(&mut self.shares);
        let WallTerms {
            unit,
            mass,
            dt,
            epsilon,
            velocities,
            inv_densities,
            viscous_total,
        } = terms;
        for s in &shares {
            let i = s.particle as usize;
            let mi = mass.of(i);
            let pressure = s.gradient * (unit * scale(i)) - s.hydrostatic * (mi * dt);
            let mut impulse = pressure;
            if epsilon > 0.0 && s.viscous > 0.0 {
                let f = dt * epsilon * inv_densities[i];
                let alpha = f * viscous_total[i];
                let dv = (s.viscous_velocity - velocities[i] * s.viscous) * (f / (1.0 + alpha));
                impulse -= dv * mi;
            }
            if impulse != Vector::ZERO {
                self.add(watch, s.slot as usize, impulse, s.point);
            }
        }
        self.shares = shares;
        self.shares.clear();
    }

    /// Before collider contact (or a coupling exchange): keeps the velocities when a watched
    /// collider may be touched.
    pub fn snapshot(&mut self, watch: &Watch, velocities: &[Vector]) {
        self.snapped = watch.any_forces;
        if self.snapped {
            self.before.clear();
            self.before.extend_from_slice(velocities);
        }
    }

    /// After contact's resolution, before the coupling's exchange: every particle's velocity
    /// change against non-dynamic colliders goes to the watched ones it touched; the dynamic
    /// bodies' part is their records' (`records`, in particle order).
    pub fn after_resolve(
        &mut self,
        view: &ContactView<'_>,
        records: &[Vec<ImpulseRecord>],
        positions: &[Vector],
        velocities: &[Vector],
    ) {
        if !self.snapped {
            return;
        }
        let watch = view.watch;
        let before = std::mem::take(&mut self.before);
        let mut recs = records.iter().flatten().peekable();
        for (i, (&v, &v0)) in velocities.iter().zip(&before).enumerate() {
            let mut dv = v - v0;
            // The dynamic bodies' part of the change is their records' (−J/m).
            let mi = view.mass.of(i);
            while let Some(r) = recs.next_if(|r| r.particle as usize == i) {
                dv += r.impulse / mi;
            }
            if dv == Vector::ZERO {
                continue;
            }
            let cands = view.candidates.of_cell(view.grid.cell_of(i));
            if !cands.iter().any(|&h| watch.passive_force_slot(h).is_some()) {
                continue;
            }
            self.split_contact(view, cands, positions[i], (dv, mi));
        }
        self.before = before;
        self.mid_snapped =
            watch.list.iter().any(|w| w.dynamic && w.forces) && !records.iter().all(Vec::is_empty);
        if self.mid_snapped {
            self.mid.clear();
            self.mid.extend_from_slice(velocities);
        }
    }

    /// The velocity change `dv` of a particle of mass `mass` that ended at `x`, split over the
    /// non-dynamic colliders among `cands` within `TOUCH` contact radii (see the module docs).
    fn split_contact(
        &mut self,
        view: &ContactView<'_>,
        cands: &[ColliderHandle],
        x: Vector,
        (dv, mass): (Vector, Real),
    ) {
        let mut near: [(usize, Vector, Vector, Real); 4] =
            [(usize::MAX, Vector::ZERO, Vector::ZERO, 0.0); 4];
        let mut count = 0;
        for &h in cands {
            let Some(co) = view.colliders.get(h) else {
                continue;
            };
            let entry = entry_of(view.table, h).map(|(_, m)| m);
            if entry.is_some_and(|m| m.dynamic) {
                continue;
            }
            let pose = match entry {
                Some(m) if m.moving => &m.stop,
                _ => co.position(),
            };
            let reach = TOUCH * view.radius;
            let Some(proj) = co
                .shape()
                .project_point_with_max_dist(pose, x, false, reach)
            else {
                continue;
            };
            let off = x - proj.point;
            let n = if proj.is_inside { -off } else { off }.normalize_or_zero();
            if count < near.len() {
                let slot = view.watch.passive_force_slot(h).unwrap_or(usize::MAX);
                near[count] = (slot, n, proj.point, dv.dot(n).max(0.0));
                count += 1;
            }
        }
        let near = &near[..count];
        let total: Real = near.iter().map(|c| c.3).sum();
        let mut rest = dv;
        for c in near {
            rest -= c.1 * c.3;
        }
        for &(slot, n, point, a) in near {
            if slot == usize::MAX {
                continue;
            }
            let weight = if total > 0.0 {
                a / total
            } else {
                1.0 / near.len() as Real
            };
            let part = n * a + rest * weight;
            self.add(view.watch, slot, -part * mass, point);
        }
    }

    /// After a coupling exchange: the dynamic bodies' records (`records`, in particle order)
    /// with the share of the exchange each particle took (its velocity change since
    /// `from_mid`: the snapshot after contact's resolution, else [`FluidForces::snapshot`]'s).
    pub fn after_exchange(
        &mut self,
        watch: &Watch,
        table: &[MovingCollider],
        records: &[Vec<ImpulseRecord>],
        velocities: &[Vector],
        (mass, from_mid): (ParticleMass<'_>, bool),
    ) {
        let snapped = if from_mid {
            self.mid_snapped
        } else {
            self.snapped
        };
        if !snapped || table.is_empty() {
            return;
        }
        let base = std::mem::take(if from_mid {
            &mut self.mid
        } else {
            &mut self.before
        });
        let mut last = u32::MAX;
        for r in records.iter().flatten() {
            let Some(k) = watch
                .slot(table[r.entry as usize].handle)
                .filter(|&k| watch.list[k].forces)
            else {
                continue;
            };
            let mut impulse = r.impulse;
            // The particle's whole share of the exchange, with its first record.
            if r.particle != last {
                let i = r.particle as usize;
                impulse -= (velocities[i] - base[i]) * mass.of(i);
                last = r.particle;
            }
            self.add(watch, k, impulse, r.point);
            // The moment the body gave up with no impulse (see `ImpulseRecord::moment`).
            for c in 0..3 {
                self.acc[k][3 + c] -= r.moment[c] as f64;
            }
        }
        if from_mid {
            self.mid = base;
        } else {
            self.before = base;
        }
    }

    /// At the end of a substep: the ids of the particles within [`touch_distance`] of a
    /// collider whose touch events are watched. Per such collider, one box test per particle
    /// (the collider's box grown by the touch distance), then a point projection for those
    /// inside it.
    pub fn touch(&mut self, view: &ContactView<'_>, positions: &[Vector], ids: &[u32]) {
        let watch = view.watch;
        if !watch.any_events {
            return;
        }
        let reach = view.touch;
        for (k, w) in watch.list.iter().enumerate().filter(|(_, w)| w.events) {
            let Some(co) = view.colliders.get(w.handle) else {
                continue;
            };
            let pose = match entry_of(view.table, w.handle) {
                Some((_, m)) if m.moving => &m.stop,
                _ => co.position(),
            };
            let aabb = co.shape().compute_aabb(pose).loosened(reach);
            for (x, id) in positions.iter().zip(ids) {
                if aabb.contains_local_point(*x)
                    && co
                        .shape()
                        .project_point_with_max_dist(pose, *x, true, reach)
                        .is_some()
                {
                    self.touched[k].push(*id);
                }
            }
        }
    }

    /// Sorts and dedups the frame's touching ids.
    pub fn finish_touch(&mut self) {
        for t in &mut self.touched {
            t.sort_unstable();
            t.dedup();
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.acc.capacity() * 48
            + self.touched.iter().map(|t| t.capacity() * 4).sum::<usize>()
            + self.shares.capacity() * std::mem::size_of::<Share>()
            + (self.before.capacity() + self.mid.capacity()) * std::mem::size_of::<Vector>()
    }
}

/// What [`FluidForces::wall_impulses`] reads of the substep.
pub(crate) struct WallTerms<'a> {
    /// `ρ0` times the force kernel's full integral (a share's gradient in kg/m⁴ per unit).
    pub unit: Real,
    /// Each particle's mass.
    pub mass: ParticleMass<'a>,
    pub dt: Real,
    /// The walls' viscosity `ε_w` (0: off).
    pub epsilon: Real,
    pub velocities: &'a [Vector],
    pub inv_densities: &'a [Real],
    /// Each particle's whole viscous sum `L_i`.
    pub viscous_total: &'a [Real],
}

/// The force and torque the fluid applied to one collider (or one body) over the last frame,
/// averaged over its substeps: the frame's impulse divided by its length, in rapier's units.
///
/// # Examples
/// See [`FluidPipeline::collider_force`](crate::FluidPipeline::collider_force).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ColliderForce {
    /// The collider (for a body's sum: its first watched collider).
    pub collider: ColliderHandle,
    /// Its body, if it has one.
    pub body: Option<RigidBodyHandle>,
    /// Force (N): wall pressure, viscosity and contact together.
    pub force: Vector,
    /// Torque (N·m) about [`ColliderForce::center`].
    pub torque: Vector,
    /// The torque's reference point (m): the body's center of mass as rapier left it when the
    /// fluid stepped (the collider's position for a collider without a body).
    pub center: Vector,
    /// Particles that touched it during the frame (0 unless its touch events are watched
    /// too).
    pub touching: usize,
}

/// Whether a fluid started or stopped touching a collider.
///
/// # Examples
/// See [`FluidPipeline::contact_events`](crate::FluidPipeline::contact_events).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum FluidContactKind {
    /// No particle of the fluid touched the collider in the frame before, some did in this
    /// one.
    Started,
    /// Some did in the frame before, none in this one (or the collider stopped being watched,
    /// or the fluid was removed).
    Stopped,
}

/// A fluid started or stopped touching a collider whose `COLLISION_EVENTS` flag is set
/// (rapier's `ActiveEvents`).
///
/// # Examples
/// See [`FluidPipeline::contact_events`](crate::FluidPipeline::contact_events).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct FluidContactEvent {
    /// The fluid.
    pub fluid: FluidHandle,
    /// The collider.
    pub collider: ColliderHandle,
    /// Started or stopped.
    pub kind: FluidContactKind,
    /// Particles of the fluid that touched it during the frame (0 for `Stopped`).
    pub particles: usize,
}

/// What the pipeline keeps of the last frame: per watched collider its force and the
/// touching ids per fluid, and the events.
#[derive(Clone, Debug, Default)]
pub(crate) struct Records {
    pub watch: Watch,
    pub forces: Vec<ColliderForce>,
    /// `(fluid, collider, sorted ids)` of the frame.
    pub touching: Vec<(FluidHandle, ColliderHandle, Vec<u32>)>,
    /// Last frame's `touching`, kept to find what started and stopped.
    previous: Vec<(FluidHandle, ColliderHandle, Vec<u32>)>,
    pub events: Vec<FluidContactEvent>,
}

impl Records {
    /// Gathers the fluids' records of a frame of `dt` seconds (`fluids` in the set's order).
    pub fn finish<'a>(
        &mut self,
        dt: Real,
        fluids: impl Iterator<Item = (FluidHandle, &'a mut FluidForces, bool)>,
    ) {
        std::mem::swap(&mut self.previous, &mut self.touching);
        self.touching.clear();
        self.events.clear();
        let mut sums = vec![[0.0f64; 6]; self.watch.list.len()];
        let mut counts = vec![0usize; self.watch.list.len()];
        for (fh, f, asleep) in fluids {
            if asleep {
                // A sleeping fluid was not stepped: its forces and touches are those of the
                // last frame it was (its `acc` was kept, its touches are last frame's).
                for t in self.previous.iter().filter(|t| t.0 == fh) {
                    if let Some(k) = self.watch.slot(t.1) {
                        counts[k] += t.2.len();
                    }
                    self.touching.push(t.clone());
                }
            }
            for (s, a) in sums.iter_mut().zip(&f.acc) {
                for c in 0..6 {
                    s[c] += a[c];
                }
            }
            f.finish_touch();
            for (k, ids) in f.touched.iter_mut().enumerate() {
                if !ids.is_empty() {
                    counts[k] += ids.len();
                    self.touching
                        .push((fh, self.watch.list[k].handle, std::mem::take(ids)));
                }
            }
        }
        let inv = 1.0 / dt as f64;
        let v = |a: &[f64]| {
            Vector::new(
                (a[0] * inv) as Real,
                (a[1] * inv) as Real,
                (a[2] * inv) as Real,
            )
        };
        self.forces.clear();
        for ((w, s), n) in self.watch.list.iter().zip(&sums).zip(&counts) {
            if w.forces {
                self.forces.push(ColliderForce {
                    collider: w.handle,
                    body: w.body,
                    force: v(&s[..3]),
                    torque: v(&s[3..]),
                    center: w.center,
                    touching: *n,
                });
            }
        }
        self.events_of_frame();
    }

    /// Started: pairs touching now and not before; stopped: the reverse.
    fn events_of_frame(&mut self) {
        let had =
            |list: &[(FluidHandle, ColliderHandle, Vec<u32>)],
             f: FluidHandle,
             c: ColliderHandle| { list.iter().any(|t| t.0 == f && t.1 == c) };
        for (f, c, ids) in &self.touching {
            if !had(&self.previous, *f, *c) {
                self.events.push(FluidContactEvent {
                    fluid: *f,
                    collider: *c,
                    kind: FluidContactKind::Started,
                    particles: ids.len(),
                });
            }
        }
        for (f, c, _) in &self.previous {
            if !had(&self.touching, *f, *c) {
                self.events.push(FluidContactEvent {
                    fluid: *f,
                    collider: *c,
                    kind: FluidContactKind::Stopped,
                    particles: 0,
                });
            }
        }
    }
}
