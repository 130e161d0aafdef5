//! Emitters (nozzles that add particles) and sinks (regions that remove them).
//!
//! Both belong to one [`Fluid`](crate::Fluid) and are stored in it, in small sets with generational
//! handles in rapier's style ([`EmitterHandle`], [`SinkHandle`]); the pipeline's step reaches
//! them through the fluid, so there are no globals. A fluid with neither pays one emptiness
//! check per substep.
//!
//! ## Emitters
//!
//! A nozzle ([`Nozzle`]: a disk or a square across `direction`, or a sphere emitting radially)
//! is covered by *slots* on a square lattice at the fluid's particle spacing (a sphere: a
//! Fibonacci lattice of the same density). Particles are due at `rate` per second on the
//! emitter's own clock, between `start` and `stop`, until the optional `budget` is spent,
//! and fill the slots in turn. A particle due at time `t` of a frame ending at `T` is placed
//! where it would be at `T`: `slot + direction·speed·(T − t)`, so the jet is the same at any
//! frame rate. A particle is placed only
//!
//! - at least `0.9·spacing` from every particle (old or just emitted): no overlap;
//! - outside every solid collider, at least one contact radius off its surface, and with a
//!   straight path from its slot that crosses no surface (parry queries on the colliders
//!   rapier's broad-phase finds around the nozzle).
//!
//! A due particle that cannot be placed is not emitted (the nozzle is blocked: counted in
//! [`crate::StepReport::emitter_blocked`]); emitting faster than `speed·slots/spacing` always
//! blocks some, since the previous layer has not moved one spacing away yet
//! ([`Emitter::max_rate`]). When the fluid reaches its capacity ([`Fluid::set_capacity`](crate::Fluid::set_capacity))
//! emitters pause and the report says so (`capacity_reached`).
//!
//! ### Bounds
//!
//! An emitter's work per frame is bounded whatever its settings:
//! - the rate is at most [`MAX_RATE`] (2^32 per second: a fluid's ids run out after 2^32 − 1
//!   particles, [`crate::fluid::MAX_PARTICLES`]);
//! - a nozzle has at most [`MAX_NOZZLE_SLOTS`] slots at its fluid's spacing, checked by
//!   [`crate::Fluid::add_emitter`] and again by [`crate::Fluid::set_params`] when the spacing changes;
//! - a frame tries at most `4·slots·(⌊speed·dt/(0.9·spacing)⌋ + 1)` due particles per emitter,
//!   and never more than [`MAX_ATTEMPTS_PER_FRAME`]. A slot's particles must stay `0.9·spacing`
//!   apart along its jet, so at most `⌊speed·dt/(0.9·spacing)⌋ + 1` of them fit in a frame:
//!   the first bound is four times what can possibly be placed. When more particles are due,
//!   they are tried evenly spread over the frame (every `k`-th due instant) and the others are
//!   counted as blocked ([`crate::StepReport::emitter_blocked`]);
//! - emitters stop when the fluid's ids run out, as at its capacity (`capacity_reached`), and
//!   pause for a frame whose particles' memory ([`crate::fluid::bytes_per_particle`]) could
//!   not be reserved.
//!
//! Placement checks each candidate against the particles near it through a hashed grid, so a
//! frame's emission costs in proportion to what it tries.
//!
//! ## Sinks
//!
//! A sink (over a [`Region`]: a box, a ball, or a rapier collider, the same regions the
//! queries take) removes every particle of its fluid inside it after every substep. A
//! [`Region::NearCollider`] sink also takes particles within `reach` of the collider's surface
//! (default: one particle spacing), so a solid drain plate, which contact keeps particles half
//! a spacing off, drains what rests on it; a sensor collider ([`Region::Collider`]) drains
//! what enters it.

mod emit;
mod run;

pub(crate) use emit::EmitWorld;

use crate::error::{SphError, SphResult};
use crate::math::{Real, Vector, is_finite};
pub use crate::region::Region;
use rapier3d::dynamics::RigidBodyHandle;
use rapier3d::geometry::ColliderHandle;

/// Fastest emission rate (particles per second): 2^32. A fluid hands out at most 2^32 − 1
/// particle ids over its life ([`crate::fluid::MAX_PARTICLES`]), so a faster emitter would use
/// them all up within its first second; the bound also keeps the emitter's 64-bit count of due
/// instants from overflowing for 136 years of its clock.
pub const MAX_RATE: Real = 4_294_967_296.0;

/// Most slots a nozzle may have at its fluid's spacing: 2^22 (4,194,304; a disk of radius
/// 1.15 m at 1 mm spacing, or 115 m at 10 cm). Each frame builds the slot list (24 bytes a
/// slot, 100 MB at the bound) and may place a layer of particles per slot (6.7 GB of fluid
/// at the bound at DFSPH's [`crate::fluid::bytes_per_particle`], 1,588 bytes).
pub const MAX_NOZZLE_SLOTS: usize = 1 << 22;

/// Most due particles one emitter tries to place in one frame: two layers of the largest
/// nozzle ([`MAX_NOZZLE_SLOTS`]). Beyond it the due particles are thinned evenly and counted
/// as blocked (see the [module docs](self), "Bounds").
pub const MAX_ATTEMPTS_PER_FRAME: usize = 2 * MAX_NOZZLE_SLOTS;

/// Shape of an emitter's opening.
///
/// # Examples
///
/// ```
/// use rapier_sph::{Emitter, Nozzle, math::Vector};
/// // A 10 cm square spout pouring down at 1 m/s, 500 particles a second.
/// let spout = Emitter::new(Nozzle::Square { half_width: 0.05 }, Vector::new(0.0, 1.0, 0.0),
///                          -Vector::Y, 1.0, 500.0);
/// assert!(spout.validate().is_ok());
/// let negative = Emitter::new(Nozzle::Square { half_width: -0.05 }, Vector::ZERO, Vector::Y,
///                             1.0, 500.0);
/// assert!(negative.validate().is_err()); // names `half_width`
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub enum Nozzle {
    /// A disk of `radius` (m) across the emitter's direction.
    Disk {
        /// Radius (m).
        radius: Real,
    },
    /// A square of side `2·half_width` (m) across the emitter's direction.
    Square {
        /// Half the side (m).
        half_width: Real,
    },
    /// A sphere of `radius` (m) emitting radially outward from its surface (the emitter's
    /// direction is not used).
    Sphere {
        /// Radius (m).
        radius: Real,
    },
}

/// What an emitter is carried by ([`crate::Fluid::attach_emitter`]): a hose in a hand, a
/// watering can, a leaking barrel. Each frame the nozzle takes the pose of the body or
/// collider at the frame's end (the emitter's position and direction are then in its frame),
/// and every particle it emits adds the body's velocity at the nozzle, `v + ω × (x − c)`, to
/// the jet's.
///
/// # Examples
/// See [`crate::Fluid::attach_emitter`].
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub enum Attachment {
    /// A rigid body: the emitter's position and direction are in the body's frame.
    Body(RigidBodyHandle),
    /// A collider: the emitter's position and direction are in the collider's frame, the
    /// velocity is its body's (none for a collider without a body).
    Collider(ColliderHandle),
}

/// A nozzle that adds particles to its fluid. Build it with [`Emitter::new`] and the setters,
/// add it with [`crate::Fluid::add_emitter`](crate::Fluid::add_emitter) (which validates it),
/// and attach it to a body or collider with [`crate::Fluid::attach_emitter`] to carry it.
///
/// # Examples
/// ```
/// use rapier_sph::{Emitter, Nozzle, math::Vector};
/// // A sprinkler: a 5 cm ball spraying radially at 1.5 m/s, 800 particles a second for 2 s.
/// let sprinkler = Emitter::new(Nozzle::Sphere { radius: 0.05 }, Vector::new(0.0, 0.3, 0.0),
///                              Vector::Y, 1.5, 800.0)
///     .active_between(0.0, 2.0);
/// assert!(sprinkler.validate().is_ok());
/// // The rate above which its slots always block, at a 2 cm spacing.
/// assert!(sprinkler.max_rate(0.02) > 800.0);
/// let zero = Emitter::new(Nozzle::Disk { radius: 0.0 }, Vector::ZERO, Vector::X, 1.0, 10.0);
/// assert!(zero.validate().is_err()); // names `radius`
/// ```
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct Emitter {
    nozzle: Nozzle,
    position: Vector,
    direction: Vector,
    /// What carries it (`None`: `position` and `direction` are in world space).
    #[cfg_attr(feature = "snapshot", serde(default))]
    attachment: Option<Attachment>,
    speed: Real,
    rate: Real,
    start: Real,
    stop: Real,
    budget: Option<u64>,
    enabled: bool,
    // State.
    clock: f64,
    /// Index of the next due instant: instant `k` is at `start + k/rate` on the clock.
    due: u64,
    emitted: u64,
    next_slot: usize,
}

impl Emitter {
    /// An emitter at `position` shooting along `direction` (any length, normalised) at
    /// `speed` (m/s), `rate` particles per second, from time 0 forever, no budget.
    pub fn new(
        nozzle: Nozzle,
        position: Vector,
        direction: Vector,
        speed: Real,
        rate: Real,
    ) -> Self {
        Self {
            nozzle,
            position,
            direction,
            attachment: None,
            speed,
            rate,
            start: 0.0,
            stop: Real::INFINITY,
            budget: None,
            enabled: true,
            clock: 0.0,
            due: 0,
            emitted: 0,
            next_slot: 0,
        }
    }

    /// Emits only between `start` and `stop` seconds of the emitter's clock (which starts at 0
    /// when the emitter is added and advances with every step of its fluid).
    pub fn active_between(mut self, start: Real, stop: Real) -> Self {
        self.start = start;
        self.stop = stop;
        self
    }

    /// Emits at most `budget` particles in total.
    pub fn budget(mut self, budget: u64) -> Self {
        self.budget = Some(budget);
        self
    }

    /// Checks every field; returns the first problem, naming it. The nozzle's slot count
    /// depends on the fluid's spacing and is checked by [`crate::Fluid::add_emitter`]
    /// ([`MAX_NOZZLE_SLOTS`]).
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming the nozzle size (`radius`, `half_width`),
    /// `position`, `direction`, `speed`, `rate` (positive, finite, at most [`MAX_RATE`]),
    /// `start` or `stop`.
    pub fn validate(&self) -> SphResult<()> {
        let bad = |field, value: Real, reason| {
            Err(SphError::InvalidParameter {
                field,
                value: value as f64,
                reason,
            })
        };
        let size = match self.nozzle {
            Nozzle::Disk { radius } | Nozzle::Sphere { radius } => ("radius", radius),
            Nozzle::Square { half_width } => ("half_width", half_width),
        };
        if !size.1.is_finite() || size.1 <= 0.0 {
            return bad(size.0, size.1, "a nozzle size must be positive and finite");
        }
        if !is_finite(self.position) || self.position.abs().max_element() > 1.0e7 {
            return bad(
                "position",
                self.position.length(),
                "must be finite (and within 10,000 km)",
            );
        }
        let l = self.direction.length();
        if !(matches!(self.nozzle, Nozzle::Sphere { .. }) || l.is_finite() && l > 0.0) {
            return bad("direction", l, "must be a finite non-zero vector");
        }
        if !self.speed.is_finite() || self.speed <= 0.0 {
            return bad("speed", self.speed, "must be positive and finite");
        }
        if !self.rate.is_finite() || self.rate <= 0.0 {
            return bad("rate", self.rate, "must be positive and finite");
        }
        if self.rate > MAX_RATE {
            return bad(
                "rate",
                self.rate,
                "more than MAX_RATE (2^32 particles per second: a fluid's ids would run out \
                 within a second)",
            );
        }
        if !self.start.is_finite() || self.start < 0.0 {
            return bad("start", self.start, "must be finite and non-negative");
        }
        if self.stop.is_nan() || self.stop < self.start {
            return bad("stop", self.stop, "must not be before start");
        }
        Ok(())
    }

    /// [`Emitter::validate`], the slot count at `spacing`, and the state a snapshot carries
    /// (the clock finite and not negative).
    #[cfg(feature = "snapshot")]
    pub(crate) fn validate_state(&self, spacing: Real) -> SphResult<()> {
        self.validate()?;
        self.check_slots(spacing)?;
        if !(self.clock.is_finite() && self.clock >= 0.0) {
            return Err(SphError::InvalidParameter {
                field: "clock",
                value: self.clock,
                reason: "an emitter's clock must be finite and not negative",
            });
        }
        Ok(())
    }

    /// The nozzle.
    pub fn nozzle(&self) -> Nozzle {
        self.nozzle
    }

    /// Center of the nozzle (m; in the frame of its [`Attachment`], if attached).
    pub fn position(&self) -> Vector {
        self.position
    }

    /// Unit direction of the jet (in the frame of its [`Attachment`], if attached).
    pub fn direction(&self) -> Vector {
        self.direction.normalize_or_zero()
    }

    /// The body or collider carrying it, if any ([`crate::Fluid::attach_emitter`]).
    pub fn attachment(&self) -> Option<Attachment> {
        self.attachment
    }

    /// Jet speed (m/s).
    pub fn speed(&self) -> Real {
        self.speed
    }

    /// Particles per second.
    pub fn rate(&self) -> Real {
        self.rate
    }

    /// The emitter clock times `(start, stop)` between which it emits (s; `stop` may be
    /// infinite).
    pub fn active_times(&self) -> (Real, Real) {
        (self.start, self.stop)
    }

    /// The most particles it emits in total, if limited.
    pub fn particle_budget(&self) -> Option<u64> {
        self.budget
    }

    /// Whether it is switched on.
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    /// Moves the nozzle (a hose aimed by game code; for one carried by a body,
    /// [`crate::Fluid::attach_emitter`] makes it follow by itself). For an attached emitter,
    /// `position` and `direction` are in the body's (or collider's) frame.
    ///
    /// # Errors
    ///
    /// [`SphError::InvalidParameter`] for a non-finite position or a zero direction; the
    /// emitter is left unchanged.
    pub fn set_pose(&mut self, position: Vector, direction: Vector) -> SphResult<()> {
        let mut e = self.clone();
        e.position = position;
        e.direction = direction;
        e.validate()?;
        *self = e;
        Ok(())
    }

    /// Changes the rate (particles per second).
    ///
    /// # Errors
    ///
    /// [`SphError::InvalidParameter`] unless the rate is positive and finite; the emitter is
    /// left unchanged.
    pub fn set_rate(&mut self, rate: Real) -> SphResult<()> {
        let mut e = self.clone();
        e.rate = rate;
        e.validate()?;
        *self = e;
        Ok(())
    }

    /// Switches the emitter on or off (off: its clock still runs, nothing is due).
    pub fn set_enabled(&mut self, on: bool) {
        self.enabled = on;
    }

    /// Particles emitted so far.
    pub fn emitted(&self) -> u64 {
        self.emitted
    }

    /// The emitter's clock (s).
    pub fn clock(&self) -> f64 {
        self.clock
    }

    /// Largest rate (particles/s) at which slots never block: one layer of slots per
    /// `spacing` of travel, `speed·slots/spacing`. For a nozzle with more than
    /// [`MAX_NOZZLE_SLOTS`] slots at `spacing` (which [`crate::Fluid::add_emitter`] refuses), the
    /// slots are not built and their count is estimated from the nozzle's area.
    pub fn max_rate(&self, spacing: Real) -> Real {
        let slots = if self.slot_bound(spacing) <= MAX_NOZZLE_SLOTS as f64 {
            self.slot_offsets(spacing).len() as f64
        } else {
            self.slot_estimate(spacing)
        };
        (self.speed as f64 * slots / spacing as f64) as Real
    }

    /// An upper bound of the slot count at spacing `s`, computed without building the slots:
    /// `(2⌊r/s⌋ + 1)²` across a disk or square, the Fibonacci count for a sphere.
    fn slot_bound(&self, s: Real) -> f64 {
        let across = |r: Real| {
            let n = (r / s).floor() as f64;
            (2.0 * n + 1.0) * (2.0 * n + 1.0)
        };
        match self.nozzle {
            Nozzle::Disk { radius } => across(radius),
            Nozzle::Square { half_width } => across(half_width),
            Nozzle::Sphere { .. } => self.slot_estimate(s),
        }
    }

    /// The slot count from the nozzle's area (exact for a sphere).
    fn slot_estimate(&self, s: Real) -> f64 {
        let (s, pi) = (s as f64, std::f64::consts::PI);
        match self.nozzle {
            Nozzle::Disk { radius } => (pi * (radius as f64 / s).powi(2)).max(1.0),
            Nozzle::Square { half_width } => {
                let n = (half_width as f64 / s).floor();
                (2.0 * n + 1.0) * (2.0 * n + 1.0)
            }
            Nozzle::Sphere { radius } => {
                // As `slot_offsets` counts them (in `Real`).
                ((4.0 * std::f32::consts::PI * radius * radius) / (s as Real * s as Real))
                    .round()
                    .max(1.0) as f64
            }
        }
    }

    /// Refuses a nozzle with more than [`MAX_NOZZLE_SLOTS`] slots at spacing `s`, naming its
    /// size.
    pub(crate) fn check_slots(&self, s: Real) -> SphResult<()> {
        if self.slot_bound(s) <= MAX_NOZZLE_SLOTS as f64 {
            return Ok(());
        }
        let (field, value) = match self.nozzle {
            Nozzle::Disk { radius } | Nozzle::Sphere { radius } => ("radius", radius),
            Nozzle::Square { half_width } => ("half_width", half_width),
        };
        Err(SphError::InvalidParameter {
            field,
            value: value as f64,
            reason: "the nozzle has more than MAX_NOZZLE_SLOTS (2^22) slots at the fluid's \
                     particle spacing",
        })
    }

    /// Slot positions relative to the center, with their jet directions.
    fn slot_offsets(&self, s: Real) -> Vec<(Vector, Vector)> {
        let dir = self.direction();
        let (u, w) = dir.any_orthonormal_pair();
        let across = |r: Real, disk: bool| {
            let n = (r / s).floor() as i32;
            let mut out = Vec::new();
            for j in -n..=n {
                for i in -n..=n {
                    let (a, b) = (i as Real * s, j as Real * s);
                    if !disk || a * a + b * b <= r * r {
                        out.push((u * a + w * b, dir));
                    }
                }
            }
            out
        };
        match self.nozzle {
            Nozzle::Disk { radius } => across(radius, true),
            Nozzle::Square { half_width } => across(half_width, false),
            Nozzle::Sphere { radius } => {
                let n = ((4.0 * std::f32::consts::PI * radius * radius) / (s * s))
                    .round()
                    .max(1.0) as usize;
                let golden = std::f32::consts::PI * (3.0 - (5.0f32).sqrt());
                (0..n)
                    .map(|k| {
                        let y = 1.0 - 2.0 * (k as Real + 0.5) / n as Real;
                        let r = (1.0 - y * y).max(0.0).sqrt();
                        let phi = golden * k as Real;
                        let d = Vector::new(r * phi.cos(), y, r * phi.sin());
                        (d * radius, d)
                    })
                    .collect()
            }
        }
    }

    /// Bounding radius of the slots around the center.
    fn reach(&self) -> Real {
        match self.nozzle {
            Nozzle::Disk { radius } | Nozzle::Sphere { radius } => radius,
            Nozzle::Square { half_width } => half_width * std::f32::consts::SQRT_2,
        }
    }
}

/// The region of a sink: now the one [`Region`] of queries and sinks alike (its variant
/// `Collider { handle, reach }` is [`Region::NearCollider`]).
#[deprecated(note = "use `Region`: sinks and queries share it")]
pub type SinkRegion = Region;

/// A region that removes the particles of its fluid that enter it.
///
/// # Examples
///
/// ```
/// use rapier_sph::prelude::*;
/// // A 0.6 m cube of water with a 15 cm drain ball at its middle.
/// let mut world = FluidWorld::new();
/// let mut water = Fluid::new(FluidParamsBuilder::water(0.05))?;
/// water.add_block(Vector::ZERO, Vector::splat(0.6))?;
/// let ball = Region::Ball { center: Vector::splat(0.3), radius: 0.15 };
/// let drain = water.add_sink(Sink::new(ball))?;
/// let before = water.len();
/// let water = world.fluids.insert(water);
/// world.step()?;
/// let fluid = &world.fluids[water];
/// let drained = fluid.sink(drain).unwrap().drained();
/// assert!(drained > 0);
/// assert_eq!(fluid.len() as u64, before as u64 - drained); // no emitter: only the sink removed
/// # Ok::<(), SphError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct Sink {
    region: Region,
    enabled: bool,
    drained: u64,
}

impl Sink {
    /// A sink over `region`.
    pub fn new(region: Region) -> Self {
        Self {
            region,
            enabled: true,
            drained: 0,
        }
    }

    /// The region.
    pub fn region(&self) -> Region {
        self.region
    }

    /// Particles this sink removed so far.
    pub fn drained(&self) -> u64 {
        self.drained
    }

    /// Switches the sink on or off.
    pub fn set_enabled(&mut self, on: bool) {
        self.enabled = on;
    }

    /// Checks the region; returns the first problem, naming it.
    ///
    /// # Errors
    ///
    /// As [`Region::validate`].
    pub fn validate(&self) -> SphResult<()> {
        self.region.validate()
    }
}

macro_rules! handle_type {
    ($name:ident, $what:literal, $example:literal) => {
        #[doc = concat!("A generational handle naming one ", $what, " of a fluid: a removed ")]
        #[doc = concat!($what, "'s handle never names another one added later.")]
        #[doc = ""]
        #[doc = "# Examples"]
        #[doc = ""]
        #[doc = $example]
        #[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
        #[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
        pub struct $name {
            index: u32,
            generation: u32,
        }
    };
}
handle_type!(
    EmitterHandle,
    "emitter",
    "```
use rapier_sph::{Emitter, Fluid, FluidParamsBuilder, Nozzle};
use rapier_sph::math::Vector;

let mut fluid = Fluid::new(FluidParamsBuilder::water(0.04))?;
let tap = Emitter::new(Nozzle::Disk { radius: 0.03 }, Vector::Y, -Vector::Y, 1.0, 100.0);
let handle = fluid.add_emitter(tap.clone())?;
assert!(fluid.emitter(handle).is_some());
fluid.remove_emitter(handle); // the tap is turned off for good
assert!(fluid.emitter(handle).is_none());
let again = fluid.add_emitter(tap)?; // reuses the slot, not the handle
assert!(again != handle && fluid.emitter(handle).is_none());
# Ok::<(), rapier_sph::SphError>(())
```"
);
handle_type!(
    SinkHandle,
    "sink",
    "```
use rapier_sph::{Fluid, FluidParamsBuilder, Region, Sink};
use rapier_sph::math::Vector;

let mut fluid = Fluid::new(FluidParamsBuilder::water(0.04))?;
let drain = Sink::new(Region::Ball { center: Vector::ZERO, radius: 0.1 });
let handle = fluid.add_sink(drain)?;
assert!(fluid.sink(handle).is_some());
assert!(fluid.remove_sink(handle).is_some()); // the drain is plugged
assert!(fluid.sink(handle).is_none());
# Ok::<(), rapier_sph::SphError>(())
```"
);

/// A small arena with generational handles (the `(index, generation)` pair of a handle).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct Slots<T> {
    entries: Vec<(u32, Option<T>)>,
    len: usize,
}

impl<T> Default for Slots<T> {
    fn default() -> Self {
        Self {
            entries: Vec::new(),
            len: 0,
        }
    }
}

impl<T> Slots<T> {
    fn insert(&mut self, value: T) -> (u32, u32) {
        self.len += 1;
        if let Some(i) = self.entries.iter().position(|e| e.1.is_none()) {
            let e = &mut self.entries[i];
            e.0 += 1;
            e.1 = Some(value);
            (i as u32, e.0)
        } else {
            self.entries.push((0, Some(value)));
            (self.entries.len() as u32 - 1, 0)
        }
    }
    fn remove(&mut self, index: u32, generation: u32) -> Option<T> {
        let e = self.entries.get_mut(index as usize)?;
        if e.0 != generation {
            return None;
        }
        let v = e.1.take();
        if v.is_some() {
            self.len -= 1;
        }
        v
    }
    fn get(&self, index: u32, generation: u32) -> Option<&T> {
        self.entries
            .get(index as usize)
            .filter(|e| e.0 == generation)
            .and_then(|e| e.1.as_ref())
    }
    fn get_mut(&mut self, index: u32, generation: u32) -> Option<&mut T> {
        self.entries
            .get_mut(index as usize)
            .filter(|e| e.0 == generation)
            .and_then(|e| e.1.as_mut())
    }
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }
    /// `true` when the count matches the entries and no generation is at its end (used when
    /// a snapshot is restored).
    #[cfg(feature = "snapshot")]
    pub(crate) fn is_consistent(&self) -> bool {
        self.entries.len() <= u32::MAX as usize
            && self.len == self.entries.iter().filter(|e| e.1.is_some()).count()
            && self.entries.iter().all(|e| e.0 < u32::MAX)
    }
    pub(crate) fn iter_mut(&mut self) -> impl Iterator<Item = &mut T> {
        self.entries.iter_mut().filter_map(|e| e.1.as_mut())
    }
    pub(crate) fn iter(&self) -> impl Iterator<Item = ((u32, u32), &T)> {
        self.entries
            .iter()
            .enumerate()
            .filter_map(|(i, e)| e.1.as_ref().map(|v| ((i as u32, e.0), v)))
    }
}

/// Emitters and sinks of one fluid.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct Sources {
    pub emitters: Slots<Emitter>,
    pub sinks: Slots<Sink>,
}

impl Sources {
    /// Every emitter's clock and counts and every sink's count back to zero, as when they were
    /// added ([`crate::Fluid::reset`]).
    pub(crate) fn restart(&mut self) {
        for e in self.emitters.iter_mut() {
            e.clock = 0.0;
            e.due = 0;
            e.emitted = 0;
            e.next_slot = 0;
        }
        for s in self.sinks.iter_mut() {
            s.drained = 0;
        }
    }
}
