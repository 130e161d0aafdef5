//! Fluids: particles stored as structure of arrays, and the set that holds several fluids.

mod attributes;
mod edit;
mod fill;
mod fluid_set;
pub mod interaction;
mod mixture;
#[cfg(feature = "snapshot")]
pub(crate) mod snapshot;

pub(crate) use attributes::Attributes;

pub use edit::IntoFluidParams;
pub use fill::shape_lattice;
pub(crate) use fill::unknown_collider;
pub use fluid_set::{FluidHandle, FluidSet};

use crate::error::{SphError, SphResult};
use crate::math::{Real, Vector, is_finite};
use crate::params::FluidParams;

/// Most particles one fluid can hold, and be given over its life: particle ids are `u32`
/// ([`Fluid::ids`]), so a fluid hands out at most 2^32 − 1 of them. Every call that adds
/// particles ([`Fluid::add_particles`], [`Fluid::add_block`], [`try_lattice`],
/// [`Fluid::set_capacity`], emitters) checks it before allocating.
pub const MAX_PARTICLES: usize = u32::MAX as usize;

/// Heap bytes one particle of a fluid with these parameters costs once it has stepped: its
/// attribute arrays, the neighbour grid and lists, the solver's buffers and the step's scratch
/// ([`Fluid::heap_bytes`] divided by the particle count), as an upper bound
/// `fixed + per_neighbour·N` with `N` the expected neighbour count
/// ([`FluidParams::expected_neighbours`]): DFSPH `500 + 32·N` (it stores every pair's kernel
/// gradient), Clavet with springs `300 + 45·N`, the others `300 + 7·N`.
///
/// Measured on the water dam break with 20,000 particles, largest over 20 frames (`H=2
/// N=20000 cargo test --release --test limits -- --ignored --nocapture bytes_per_particle`,
/// and `H=3` for a support of 3 spacings), in bytes per particle at N = 33.5 / 113.1: DFSPH
/// 1,467 / 3,817, WCSPH 390 / 689, PBF 421 / 717, Clavet 275 / 572, Clavet with springs
/// 1,400 / 4,629; the bounds above (with `N` rounded up) give 1,588 / 4,148 for DFSPH, 538 /
/// 1,098 for WCSPH, PBF and Clavet, 1,830 / 5,430 for Clavet with springs.
///
/// Before a call adds particles, the memory the fluid will need with them
/// (`particles × bytes_per_particle`) is reserved once and released (a probe): a request the
/// machine cannot hold is refused with a typed error instead of aborting later. On Linux with
/// the default overcommit policy a reservation larger than the RAM plus swap fails; with
/// `vm.overcommit_memory = 1` every reservation succeeds, and only [`MAX_PARTICLES`] is
/// checked.
pub fn bytes_per_particle(params: &FluidParams) -> usize {
    params.bytes_per_particle()
}

/// Refuses a fluid of `total` particles that exceeds [`MAX_PARTICLES`] or whose working set
/// (`total × bytes_each`) cannot be reserved; `field` names the argument at fault.
pub(crate) fn check_particle_count(
    total: f64,
    bytes_each: usize,
    field: &'static str,
) -> SphResult<()> {
    if total.is_nan() || total > MAX_PARTICLES as f64 {
        return Err(SphError::InvalidParameter {
            field,
            value: total,
            reason: "more particles than a fluid can hold (MAX_PARTICLES = 2^32 - 1: ids are u32)",
        });
    }
    let bytes = (total as usize).saturating_mul(bytes_each);
    let mut probe: Vec<u8> = Vec::new();
    probe
        .try_reserve_exact(bytes)
        .map_err(|_| SphError::InvalidParameter {
            field,
            value: total,
            reason: "the memory for that many particles cannot be reserved \
                     (see `fluid::bytes_per_particle`)",
        })
}

/// Mutable views of one fluid's particle arrays, borrowed together: the step's stages take
/// the ones they use. Every array has one entry per particle, in the same order.
pub(crate) struct ParticlesMut<'a> {
    pub positions: &'a mut Vec<Vector>,
    pub velocities: &'a mut Vec<Vector>,
    pub accelerations: &'a mut Vec<Vector>,
    pub densities: &'a mut Vec<Real>,
    pub pressures: &'a mut Vec<Real>,
    pub ids: &'a mut Vec<u32>,
    pub attributes: &'a mut Attributes,
}

/// One fluid: its parameters and its particles, one `Vec` per attribute.
///
/// Particles are re-sorted by grid cell at every step, so a particle's index changes from
/// step to step; [`Fluid::ids`] gives each particle a stable identifier. All attribute
/// slices share the same order.
///
/// # Examples
/// ```
/// use rapier_sph::{Fluid, FluidParamsBuilder, math::Vector};
/// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.1))?;
/// let ids = fluid.add_block(Vector::ZERO, Vector::new(0.3, 0.2, 0.1))?; // 3 × 2 × 1
/// assert_eq!((fluid.len(), ids), (6, 0..6));
/// fluid.velocities_mut()[0] = Vector::new(1.0, 0.0, 0.0); // game code may kick particles
/// let first = fluid.ids().iter().position(|&id| id == 0).unwrap();
/// assert_eq!(fluid.velocities()[first].x, 1.0);
/// assert!(fluid.add_particles(&[Vector::splat(f32::NAN)]).is_err()); // refused, typed
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Clone, Debug)]
pub struct Fluid {
    params: FluidParams,
    pub(crate) positions: Vec<Vector>,
    pub(crate) velocities: Vec<Vector>,
    pub(crate) accelerations: Vec<Vector>,
    pub(crate) densities: Vec<Real>,
    pub(crate) pressures: Vec<Real>,
    pub(crate) ids: Vec<u32>,
    /// Named per-particle values kept by the stages (e.g. DFSPH's warm starts); they follow
    /// the particles through every re-sort, removal and append.
    pub(crate) attributes: Attributes,
    /// The scalars the game added ([`Fluid::add_scalar`]): names and diffusivities; their
    /// values are attributes.
    pub(crate) scalars: Vec<crate::scalars::ScalarSpec>,
    next_id: u32,
    quarantined: usize,
    /// Particles removed by the game ([`Fluid::remove_particles`],
    /// [`Fluid::remove_particles_where`], [`Fluid::clear`]) over the fluid's life.
    removed: usize,
    /// Bumped by [`Fluid::clear`] and [`Fluid::reset`]: the pipeline then starts the fluid's
    /// solver state afresh (its runtimes are matched by handle and epoch).
    pub(crate) epoch: u64,
    /// Particles added by emitters / removed by sinks over the fluid's life.
    pub(crate) emitted: usize,
    pub(crate) drained: usize,
    /// Emitters and sinks (see [`crate::emitter`]).
    pub(crate) sources: crate::emitter::Sources,
    /// Particle capacity: emitters pause when it is reached.
    pub(crate) capacity: Option<usize>,
    /// Set when particles were added: the next contact stage first pushes particles that
    /// start inside a solid out through its nearest surface.
    pub(crate) needs_depenetration: bool,
    /// Set when an overlap relaxation was stopped by its round cap: the next substep goes on
    /// relaxing.
    pub(crate) relax_pending: bool,
    /// Whether it sleeps, and since when it has been at rest (see [`crate::sleep`]); every
    /// edit of the particles or parameters wakes it.
    pub(crate) sleep: crate::sleep::SleepState,
}

impl Fluid {
    /// An empty fluid, from parameters or straight from their builder (one fallible call, as
    /// rapier's builders go straight into its sets). Parameters are validated again here.
    ///
    /// # Errors
    /// [`FluidParams::validate`]'s errors, naming the first bad field.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::{Fluid, FluidParamsBuilder};
    /// let water = Fluid::new(FluidParamsBuilder::water(0.05))?; // the builder, built here
    /// let params = FluidParamsBuilder::water(0.05).viscosity(0.2).build()?;
    /// let thinner = Fluid::new(params)?; // or parameters built before
    /// assert!(water.is_empty() && thinner.params().viscosity == 0.2);
    /// assert!(Fluid::new(FluidParamsBuilder::water(-1.0)).is_err()); // names `particle_spacing`
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn new(params: impl IntoFluidParams) -> SphResult<Self> {
        let params = params.into_fluid_params()?;
        params.validate()?;
        let mut fluid = Self {
            params,
            positions: Vec::new(),
            velocities: Vec::new(),
            accelerations: Vec::new(),
            densities: Vec::new(),
            pressures: Vec::new(),
            ids: Vec::new(),
            attributes: Attributes::default(),
            scalars: Vec::new(),
            next_id: 0,
            quarantined: 0,
            removed: 0,
            epoch: 0,
            emitted: 0,
            drained: 0,
            sources: Default::default(),
            capacity: None,
            needs_depenetration: false,
            relax_pending: false,
            sleep: Default::default(),
        };
        fluid.ensure_fractions();
        Ok(fluid)
    }

    /// The fluid's parameters.
    pub fn params(&self) -> &FluidParams {
        &self.params
    }

    /// Replaces the parameters (validated), e.g. to change the rest density mid-run as the
    /// paper's Figure 8 does.
    ///
    /// # Errors
    /// [`FluidParams::validate`]'s errors, and the nozzle size of an emitter that would have
    /// more than [`crate::emitter::MAX_NOZZLE_SLOTS`] slots at the new spacing. Nothing changes
    /// on error.
    pub fn set_params(&mut self, params: FluidParams) -> SphResult<()> {
        params.validate()?;
        for (_, e) in self.emitters() {
            e.check_slots(params.particle_spacing)?;
        }
        self.params = params;
        self.ensure_fractions();
        self.sleep.wake();
        Ok(())
    }

    /// Adds particles at rest. Returns the range of their ids. Refuses non-finite positions
    /// with [`SphError::InvalidParticle`] (and then adds nothing).
    ///
    /// # Errors
    /// [`SphError::InvalidParticle`] naming the first non-finite position or one beyond
    /// 10,000 km; [`SphError::InvalidParameter`] when the fluid's capacity or memory is
    /// exceeded. Nothing is added on error.
    pub fn add_particles(&mut self, positions: &[Vector]) -> SphResult<std::ops::Range<u32>> {
        self.add_particles_with_velocities(positions, None)
    }

    /// Adds particles with initial velocities (`velocities.len()` must equal
    /// `positions.len()`). Returns the range of their ids.
    ///
    /// # Errors
    /// [`Fluid::add_particles`]'s, and [`SphError::InvalidParticle`] when the lengths
    /// differ or a velocity is not finite. Nothing is added on error.
    pub fn add_particles_with_velocities(
        &mut self,
        positions: &[Vector],
        velocities: Option<&[Vector]>,
    ) -> SphResult<std::ops::Range<u32>> {
        if let Some(v) = velocities
            && v.len() != positions.len()
        {
            return Err(SphError::InvalidParticle {
                index: v.len().min(positions.len()),
                reason: "positions and velocities differ in length",
            });
        }
        for (index, p) in positions.iter().enumerate() {
            if !is_finite(*p) {
                return Err(SphError::InvalidParticle {
                    index,
                    reason: "position is not finite",
                });
            }
            if p.abs().max_element() > 1.0e7 {
                return Err(SphError::InvalidParticle {
                    index,
                    reason: "position beyond 10,000 km: single precision cannot resolve particle spacing there",
                });
            }
        }
        if let Some(v) = velocities {
            for (index, v) in v.iter().enumerate() {
                if !is_finite(*v) {
                    return Err(SphError::InvalidParticle {
                        index,
                        reason: "velocity is not finite",
                    });
                }
            }
        }
        if positions.len() > MAX_PARTICLES
            || self.next_id.checked_add(positions.len() as u32).is_none()
        {
            return Err(SphError::InvalidParticle {
                index: 0,
                reason: "more than 2^32 - 1 particles added over the fluid's life (ids are u32)",
            });
        }
        if let Some(cap) = self.capacity
            && self.positions.len() + positions.len() > cap
        {
            return Err(SphError::InvalidParticle {
                index: cap.saturating_sub(self.positions.len()),
                reason: "the fluid's capacity is reached (see `Fluid::set_capacity`)",
            });
        }
        if !positions.is_empty() {
            check_particle_count(
                (self.positions.len() + positions.len()) as f64,
                bytes_per_particle(&self.params),
                "positions",
            )?;
            self.reserve(positions.len())
                .map_err(|_| SphError::InvalidParameter {
                    field: "positions",
                    value: positions.len() as f64,
                    reason: "cannot reserve memory for that many particles",
                })?;
        }
        self.append_unchecked(positions, velocities.unwrap_or(&[]));
        self.needs_depenetration = true;
        Ok(self.next_id - positions.len() as u32..self.next_id)
    }

    /// Reserves room for `extra` more particles in every per-particle array.
    fn reserve(&mut self, extra: usize) -> Result<(), std::collections::TryReserveError> {
        self.positions.try_reserve(extra)?;
        self.velocities.try_reserve(extra)?;
        self.accelerations.try_reserve(extra)?;
        self.densities.try_reserve(extra)?;
        self.pressures.try_reserve(extra)?;
        self.ids.try_reserve(extra)?;
        for v in self.attributes.values_mut() {
            v.try_reserve(extra)?;
        }
        Ok(())
    }

    /// The id the next particle added gets (every id below it was handed out).
    #[cfg_attr(not(feature = "snapshot"), allow(dead_code))]
    pub(crate) fn next_id(&self) -> u32 {
        self.next_id
    }

    /// Ids this fluid can still hand out (see [`MAX_PARTICLES`]).
    pub(crate) fn ids_left(&self) -> usize {
        (u32::MAX - self.next_id) as usize
    }

    /// Appends particles already checked (finite, outside solids); `velocities` empty means at
    /// rest. Gives up silently only past 2^32 ids, which `add_particles_with_velocities`
    /// refuses first.
    pub(crate) fn append_unchecked(&mut self, positions: &[Vector], velocities: &[Vector]) {
        self.sleep.wake();
        let count = positions.len() as u32;
        let start = self.next_id;
        let end = start.wrapping_add(count);
        let first = self.positions.len();
        self.positions.extend_from_slice(positions);
        if velocities.len() == positions.len() {
            self.velocities.extend_from_slice(velocities);
        } else {
            self.velocities.resize(self.positions.len(), Vector::ZERO);
        }
        self.ids.extend(start..end);
        self.next_id = end;
        let n = self.positions.len();
        self.accelerations.resize(n, Vector::ZERO);
        self.densities.resize(n, self.params.rest_density);
        self.pressures.resize(n, 0.0);
        self.attributes.resize(n);
        self.appended_fractions(first);
    }

    /// Sets the particle capacity (`None`: unbounded). With a capacity, every per-particle
    /// array is reserved for it once (the pipeline's scratch for the fluid at its next step),
    /// so emitting up to it never reallocates them; emitters pause when it is reached (the
    /// step report says so) and [`Fluid::add_particles`] refuses to go beyond it.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `capacity` when it is below the current particle
    /// count, above [`MAX_PARTICLES`], or when the memory for that many particles
    /// ([`bytes_per_particle`] each) cannot be reserved.
    pub fn set_capacity(&mut self, capacity: Option<usize>) -> SphResult<()> {
        if let Some(cap) = capacity {
            if cap < self.len() {
                return Err(SphError::InvalidParameter {
                    field: "capacity",
                    value: cap as f64,
                    reason: "below the current particle count",
                });
            }
            check_particle_count(cap as f64, bytes_per_particle(&self.params), "capacity")?;
            // An impossible capacity (a typo in a scene file) is an error, not an abort.
            let fail = |_| SphError::InvalidParameter {
                field: "capacity",
                value: cap as f64,
                reason: "cannot reserve memory for that many particles",
            };
            let extra = cap - self.len();
            self.positions.try_reserve_exact(extra).map_err(fail)?;
            self.velocities.try_reserve_exact(extra).map_err(fail)?;
            self.accelerations.try_reserve_exact(extra).map_err(fail)?;
            self.densities.try_reserve_exact(extra).map_err(fail)?;
            self.pressures.try_reserve_exact(extra).map_err(fail)?;
            self.ids.try_reserve_exact(extra).map_err(fail)?;
            for v in self.attributes.values_mut() {
                v.try_reserve_exact(extra).map_err(fail)?;
            }
        }
        self.capacity = capacity;
        Ok(())
    }

    /// The particle capacity, if any (see [`Fluid::set_capacity`]).
    pub fn capacity(&self) -> Option<usize> {
        self.capacity
    }

    /// Particles added by this fluid's emitters over its life.
    pub fn emitted(&self) -> usize {
        self.emitted
    }

    /// Particles removed by this fluid's sinks over its life.
    pub fn drained(&self) -> usize {
        self.drained
    }

    /// Particles removed by the game over the fluid's life ([`Fluid::remove_particles`],
    /// [`Fluid::remove_particles_where`], [`Fluid::clear`]). Every particle ever added is
    /// live, drained, quarantined or removed.
    pub fn removed(&self) -> usize {
        self.removed
    }

    /// Fills the box `[min, min + size)` with particles on a cubic lattice at the fluid's
    /// particle spacing (the first particle half a spacing inside `min`). Returns the ids.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `size` when the box is not finite and positive,
    /// when it holds more particles than the fluid can ([`MAX_PARTICLES`], counting the
    /// particles it has), or when their memory ([`bytes_per_particle`] each) cannot be
    /// reserved: a 1 km block at 1 mm spacing (10^18 particles) is refused before anything is
    /// allocated. Then, [`Fluid::add_particles`]'s errors (positions beyond 10,000 km, the
    /// capacity). Nothing is added on error.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::{Fluid, FluidParamsBuilder, math::Vector};
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.1).build().unwrap()).unwrap();
    /// assert_eq!(fluid.add_block(Vector::ZERO, Vector::splat(0.5)).unwrap().len(), 125);
    /// // A kilometre at a millimetre: refused, not an abort.
    /// let mut fine = Fluid::new(FluidParamsBuilder::water(0.001).build().unwrap()).unwrap();
    /// assert!(fine.add_block(Vector::ZERO, Vector::splat(1000.0)).is_err());
    /// ```
    pub fn add_block(&mut self, min: Vector, size: Vector) -> SphResult<std::ops::Range<u32>> {
        if !is_finite(min) || !is_finite(size) || size.min_element() <= 0.0 {
            return Err(SphError::InvalidParameter {
                field: "size",
                value: size.min_element() as f64,
                reason: "a block needs a finite origin and positive finite size",
            });
        }
        let s = self.params.particle_spacing;
        let counts = block_counts(s, size);
        // Counted in f64 before any allocation (the per-axis counts may each fit while their
        // product overflows).
        let total = counts.x as f64 * counts.y as f64 * counts.z as f64;
        check_particle_count(
            self.len() as f64 + total,
            bytes_per_particle(&self.params),
            "size",
        )?;
        let points = try_lattice(
            min + Vector::splat(0.5 * s),
            counts.x as usize,
            counts.y as usize,
            counts.z as usize,
            s,
        )
        .map_err(|e| match e {
            SphError::InvalidParameter { value, reason, .. } => SphError::InvalidParameter {
                field: "size",
                value,
                reason,
            },
            e => e,
        })?;
        self.add_particles(&points)
    }

    /// Removes every particle for which `remove(position, velocity, id)` is true. Returns how
    /// many were removed; they are counted in [`Fluid::removed`].
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::{Fluid, FluidParamsBuilder, math::Vector};
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.1))?;
    /// fluid.add_block(Vector::ZERO, Vector::splat(0.5))?; // 5 × 5 × 5
    /// assert_eq!(fluid.remove_particles_where(|x, _, _| x.y > 0.3), 50); // the top two layers
    /// assert_eq!((fluid.len(), fluid.removed()), (75, 50));
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn remove_particles_where(
        &mut self,
        remove: impl FnMut(Vector, Vector, u32) -> bool,
    ) -> usize {
        let n = self.remove_where(remove);
        self.removed += n;
        n
    }

    /// [`Fluid::remove_particles_where`] without counting them as removed by the game (sinks
    /// and the quarantine count their own).
    pub(crate) fn remove_where(
        &mut self,
        mut remove: impl FnMut(Vector, Vector, u32) -> bool,
    ) -> usize {
        let n = self.positions.len();
        // Nothing moves before the first removed particle: find it first (most calls remove
        // nothing and then only read).
        let Some(first) =
            (0..n).position(|r| remove(self.positions[r], self.velocities[r], self.ids[r]))
        else {
            return 0;
        };
        self.sleep.wake();
        let mut w = first;
        for r in first + 1..n {
            if !remove(self.positions[r], self.velocities[r], self.ids[r]) {
                self.positions[w] = self.positions[r];
                self.velocities[w] = self.velocities[r];
                self.ids[w] = self.ids[r];
                self.accelerations[w] = self.accelerations[r];
                self.densities[w] = self.densities[r];
                self.pressures[w] = self.pressures[r];
                for a in self.attributes.values_mut() {
                    a[w] = a[r];
                }
                w += 1;
            }
        }
        for v in [
            &mut self.positions,
            &mut self.velocities,
            &mut self.accelerations,
        ] {
            v.truncate(w);
        }
        self.ids.truncate(w);
        self.densities.truncate(w);
        self.pressures.truncate(w);
        for a in self.attributes.values_mut() {
            a.truncate(w);
        }
        n - w
    }

    /// Removes every particle whose position or velocity is not finite (NaN or infinite, or a
    /// speed whose square overflows: [`crate::math::is_finite_velocity`]), before it can poison
    /// its neighbours through the density sums. Returns how many were
    /// removed; the pipeline calls this at the start of every frame and after any substep that
    /// produced such a particle, and reports the count as `StepReport::quarantined`.
    pub fn quarantine_non_finite(&mut self) -> usize {
        let removed =
            self.remove_where(|x, v, _| !is_finite(x) || !crate::math::is_finite_velocity(v));
        self.quarantined += removed;
        removed
    }

    /// Particles removed over the fluid's life because they became non-finite.
    pub fn quarantined(&self) -> usize {
        self.quarantined
    }

    /// The parameters and the particle arrays, borrowed apart (the step reads the first and
    /// writes the second).
    pub(crate) fn split_mut(&mut self) -> (&FluidParams, ParticlesMut<'_>) {
        (
            &self.params,
            ParticlesMut {
                positions: &mut self.positions,
                velocities: &mut self.velocities,
                accelerations: &mut self.accelerations,
                densities: &mut self.densities,
                pressures: &mut self.pressures,
                ids: &mut self.ids,
                attributes: &mut self.attributes,
            },
        )
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// `true` when the fluid has no particle.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Particle positions (m).
    pub fn positions(&self) -> &[Vector] {
        &self.positions
    }

    /// Particle velocities (m/s).
    pub fn velocities(&self) -> &[Vector] {
        &self.velocities
    }

    /// Mutable velocities, to kick particles from game code.
    pub fn velocities_mut(&mut self) -> &mut [Vector] {
        self.sleep.wake();
        &mut self.velocities
    }

    /// Densities computed by the last step (kg/m³).
    pub fn densities(&self) -> &[Real] {
        &self.densities
    }

    /// Pressures computed by the last step (Pa).
    pub fn pressures(&self) -> &[Real] {
        &self.pressures
    }

    /// Accelerations of the last step (m/s²), all forces included.
    pub fn accelerations(&self) -> &[Vector] {
        &self.accelerations
    }

    /// Stable particle identifiers (the order of every attribute slice changes each step).
    pub fn ids(&self) -> &[u32] {
        &self.ids
    }

    /// Adds a scalar every particle carries — a dye, one channel of a paint colour, a
    /// temperature — named `name`, diffusing between neighbours with `diffusivity` `D`
    /// (m²/s; 0 for none) each substep (see [`crate::scalars`] for the scheme and its
    /// bound). Every particle starts at 0, as do particles added later; set values with
    /// [`Fluid::scalar_mut`]. Adding a scalar that exists changes its diffusivity only.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `diffusivity` when it is negative or not finite,
    /// or `name` when it is empty.
    ///
    /// # Examples
    /// Red paint poured into white: the red channel mixes, and the amount of red is kept.
    /// ```
    /// use rapier_sph::prelude::*;
    /// let mut world = FluidWorld::new();
    /// world.physics.gravity = Vector::ZERO;
    /// let mut paint = Fluid::new(FluidParamsBuilder::water(0.05))?;
    /// paint.add_block(Vector::ZERO, Vector::new(0.4, 0.2, 0.2))?;
    /// paint.add_scalar("red", 0.01)?;
    /// let xs: Vec<f32> = paint.positions().iter().map(|p| p.x).collect();
    /// for (red, x) in paint.scalar_mut("red").unwrap().iter_mut().zip(xs) {
    ///     *red = if x < 0.2 { 1.0 } else { 0.0 }; // the left half red
    /// }
    /// let before: f32 = paint.scalar("red").unwrap().iter().sum();
    /// let h = world.fluids.insert(paint);
    /// for _ in 0..10 {
    ///     world.step()?;
    /// }
    /// let red = world.fluids[h].scalar("red").unwrap();
    /// let after: f32 = red.iter().sum();
    /// assert!((after - before).abs() < 1e-3 * before); // conserved
    /// assert!(red.iter().all(|&r| (0.0..=1.0).contains(&r))); // no new extremes
    /// assert!(red.iter().any(|&r| r > 0.05 && r < 0.95)); // mixed at the interface
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn add_scalar(&mut self, name: &str, diffusivity: Real) -> SphResult<()> {
        if name.is_empty() {
            return Err(SphError::InvalidParameter {
                field: "name",
                value: 0.0,
                reason: "a scalar needs a name",
            });
        }
        if !(diffusivity.is_finite() && diffusivity >= 0.0) {
            return Err(SphError::InvalidParameter {
                field: "diffusivity",
                value: diffusivity as f64,
                reason: "must be finite and non-negative (m^2/s)",
            });
        }
        let spec = crate::scalars::ScalarSpec {
            name: name.to_owned(),
            diffusivity,
        };
        self.attributes.ensure(&spec.attribute(), self.len());
        self.sleep.wake();
        match self.scalars.iter_mut().find(|s| s.name == name) {
            Some(s) => s.diffusivity = diffusivity,
            None => self.scalars.push(spec),
        }
        Ok(())
    }

    /// The values of scalar `name`, one per particle in the order of [`Fluid::positions`];
    /// `None` when the fluid has no such scalar ([`Fluid::add_scalar`]).
    pub fn scalar(&self, name: &str) -> Option<&[Real]> {
        self.scalars.iter().find(|s| s.name == name)?;
        let k = self.attributes.index_of(crate::scalars::PREFIX, name)?;
        Some(self.attributes.get(k))
    }

    /// The values of scalar `name`, writable (to paint particles); `None` when the fluid has
    /// no such scalar.
    pub fn scalar_mut(&mut self, name: &str) -> Option<&mut [Real]> {
        self.scalars.iter().find(|s| s.name == name)?;
        let k = self.attributes.index_of(crate::scalars::PREFIX, name)?;
        self.sleep.wake();
        Some(self.attributes.get_mut(k))
    }

    /// Whether the fluid sleeps (see [`crate::sleep`]): it is then not stepped until
    /// something wakes it.
    pub fn is_sleeping(&self) -> bool {
        self.sleep.asleep()
    }

    /// Wakes the fluid if it sleeps, and restarts the time it must stay at rest before it
    /// falls asleep again (see [`crate::sleep`]). Every edit of its particles or parameters
    /// does this too.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::prelude::*;
    /// let mut world = FluidWorld::new();
    /// world.physics.gravity = Vector::ZERO; // a block at rest density stays exactly at rest
    /// let sleep = Sleep { time: 0.05, ..Sleep::default() };
    /// let mut water = Fluid::new(FluidParamsBuilder::water(0.05).sleep(sleep))?;
    /// water.add_block(Vector::ZERO, Vector::splat(0.2))?;
    /// let water = world.fluids.insert(water);
    /// for _ in 0..10 {
    ///     world.step()?;
    /// }
    /// assert!(world.fluids[water].is_sleeping());
    /// world.fluids[water].wake_up();
    /// assert!(!world.fluids[water].is_sleeping());
    /// # Ok::<(), SphError>(())
    /// ```
    pub fn wake_up(&mut self) {
        self.sleep.wake();
    }

    /// What the fluid's sleeping did: whether it sleeps, how long it has been at rest, and
    /// what falling asleep last dropped (see [`crate::sleep`]).
    pub fn sleep_info(&self) -> crate::sleep::SleepInfo {
        self.sleep.public()
    }

    /// The names of the fluid's scalars and their diffusivities (m²/s), in the order they
    /// were added.
    pub fn scalars(&self) -> impl Iterator<Item = (&str, Real)> {
        self.scalars
            .iter()
            .map(|s| (s.name.as_str(), s.diffusivity))
    }

    /// Total mass (kg): particle count times particle mass (with a mixture, the sum of each
    /// particle's, [`crate::mixture`]).
    pub fn total_mass(&self) -> Real {
        match self.mixture_masses() {
            Some(m) => m.iter().sum::<f64>() as Real,
            None => self.len() as Real * self.params.particle_mass,
        }
    }

    /// Total linear momentum (kg·m/s), summed in f64 (with a mixture, each particle at its
    /// own mass).
    pub fn linear_momentum(&self) -> [f64; 3] {
        let own = self.mixture_masses();
        let m = |i: usize| {
            own.as_ref()
                .map_or(self.params.particle_mass as f64, |m| m[i])
        };
        let mut p = [0.0f64; 3];
        for (i, v) in self.velocities.iter().enumerate() {
            p[0] += m(i) * v.x as f64;
            p[1] += m(i) * v.y as f64;
            p[2] += m(i) * v.z as f64;
        }
        p
    }

    /// Total kinetic energy (J), summed in f64 (with a mixture, each particle at its own
    /// mass).
    pub fn kinetic_energy(&self) -> f64 {
        let own = self.mixture_masses();
        let m = |i: usize| {
            own.as_ref()
                .map_or(self.params.particle_mass as f64, |m| m[i])
        };
        self.velocities
            .iter()
            .enumerate()
            .map(|(i, v)| 0.5 * m(i) * v.length_squared() as f64)
            .sum()
    }

    /// Heap bytes held by the fluid's particle arrays (the step's scratch for the fluid is
    /// the pipeline's: [`crate::FluidPipeline::heap_bytes`]).
    pub fn heap_bytes(&self) -> usize {
        let v = std::mem::size_of::<Vector>();
        (self.positions.capacity() + self.velocities.capacity() + self.accelerations.capacity()) * v
            + (self.densities.capacity() + self.pressures.capacity()) * 4
            + self.ids.capacity() * 4
            + self.attributes.heap_bytes()
    }
}

/// Particles along each axis of [`Fluid::add_block`]'s lattice (at least one).
pub(crate) fn block_counts(spacing: Real, size: Vector) -> Vector {
    (size / spacing).floor().max(Vector::ONE)
}

/// Points of an `nx × ny × nz` cubic lattice with spacing `s` starting at `origin`,
/// x fastest.
///
/// # Panics
/// When the count overflows, exceeds [`MAX_PARTICLES`] or its memory cannot be reserved (see
/// [`try_lattice`], which returns an error instead: use it for counts from user input).
pub fn lattice(origin: Vector, nx: usize, ny: usize, nz: usize, s: Real) -> Vec<Vector> {
    match try_lattice(origin, nx, ny, nz, s) {
        Ok(points) => points,
        Err(e) => panic!("lattice {nx} x {ny} x {nz}: {e}"),
    }
}

/// [`lattice`], checked: the count `nx·ny·nz` is computed without overflow, must be at most
/// [`MAX_PARTICLES`], and its memory (12 bytes a point) must be reservable (a fluid checks the
/// memory its particles will need, [`bytes_per_particle`], when they are added).
///
/// # Errors
/// [`SphError::InvalidParameter`] naming `counts`.
///
/// # Examples
/// ```
/// use rapier_sph::{fluid::try_lattice, math::Vector};
/// assert_eq!(try_lattice(Vector::ZERO, 4, 3, 2, 0.1).unwrap().len(), 24);
/// assert!(try_lattice(Vector::ZERO, 1 << 22, 1 << 22, 1 << 22, 0.1).is_err());
/// ```
pub fn try_lattice(
    origin: Vector,
    nx: usize,
    ny: usize,
    nz: usize,
    s: Real,
) -> SphResult<Vec<Vector>> {
    let count = nx.checked_mul(ny).and_then(|c| c.checked_mul(nz));
    let count = match count {
        Some(c) if c <= MAX_PARTICLES => c,
        _ => {
            return Err(SphError::InvalidParameter {
                field: "counts",
                value: nx as f64 * ny as f64 * nz as f64,
                reason: "more particles than a fluid can hold (MAX_PARTICLES = 2^32 - 1: ids are u32)",
            });
        }
    };
    let mut out = Vec::new();
    out.try_reserve_exact(count)
        .map_err(|_| SphError::InvalidParameter {
            field: "counts",
            value: count as f64,
            reason: "cannot reserve memory for that many points",
        })?;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                out.push(origin + Vector::new(i as Real, j as Real, k as Real) * s);
            }
        }
    }
    Ok(out)
}
