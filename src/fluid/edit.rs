//! What a game does to a fluid between steps: remove particles by id, clear it, reset it for a
//! new level, hash its state; and the one-call construction from a parameter builder.

use super::Fluid;
use crate::error::{SphError, SphResult};
use crate::params::{FluidParams, FluidParamsBuilder};

/// What [`Fluid::new`] accepts: [`FluidParams`] (validated again) or a [`FluidParamsBuilder`]
/// (built, which validates), so `Fluid::new(FluidParamsBuilder::water(0.05))?` is one fallible
/// call.
///
/// # Examples
/// ```
/// use rapier_sph::{Fluid, FluidParamsBuilder, IntoFluidParams};
/// let from_builder = Fluid::new(FluidParamsBuilder::water(0.05))?;
/// let params = FluidParamsBuilder::water(0.05).build()?;
/// let from_params = Fluid::new(params.clone())?;
/// assert_eq!(from_builder.params(), from_params.params());
/// // A function of the game's own that takes either.
/// fn spacing(p: impl IntoFluidParams) -> rapier_sph::SphResult<f32> {
///     Ok(p.into_fluid_params()?.particle_spacing)
/// }
/// assert_eq!(spacing(params)?, 0.05);
/// assert!(spacing(FluidParamsBuilder::water(-1.0)).is_err()); // names the field
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
pub trait IntoFluidParams {
    /// The parameters, validated.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming the first bad field.
    fn into_fluid_params(self) -> SphResult<FluidParams>;
}

impl IntoFluidParams for FluidParams {
    fn into_fluid_params(self) -> SphResult<FluidParams> {
        self.validate()?;
        Ok(self)
    }
}

impl IntoFluidParams for FluidParamsBuilder {
    fn into_fluid_params(self) -> SphResult<FluidParams> {
        self.build()
    }
}

impl Fluid {
    /// Removes the particles with these ids (in any order, repeats allowed; an id already
    /// removed, drained or quarantined is skipped). Returns how many were removed; they are
    /// counted in [`Fluid::removed`]. Costs one pass over the particles.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `ids` when an id was never handed out by this
    /// fluid (at or above the next id: a typo, or an id of another fluid); nothing is removed.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::{Fluid, FluidParamsBuilder, math::Vector};
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.1))?;
    /// let ids = fluid.add_block(Vector::ZERO, Vector::splat(0.5))?; // 125 particles
    /// assert_eq!(fluid.remove_particles(&[ids.start, ids.start + 7, ids.start])?, 2);
    /// assert_eq!(fluid.remove_particles(&[ids.start])?, 0); // already gone
    /// assert!(fluid.remove_particles(&[ids.end]).is_err()); // never handed out
    /// assert_eq!((fluid.len(), fluid.removed()), (123, 2));
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn remove_particles(&mut self, ids: &[u32]) -> SphResult<usize> {
        if let Some(&bad) = ids.iter().find(|&&id| id >= self.next_id) {
            return Err(SphError::InvalidParameter {
                field: "ids",
                value: bad as f64,
                reason: "this fluid never handed out that particle id",
            });
        }
        if ids.is_empty() {
            return Ok(0);
        }
        let mut sorted = ids.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        Ok(self.remove_particles_where(|_, _, id| sorted.binary_search(&id).is_ok()))
    }

    /// Removes every particle (counted in [`Fluid::removed`]); parameters, emitters (with
    /// their clocks), sinks, capacity and the fluid's counters stay. The pipeline starts the
    /// fluid's solver state afresh at its next step.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::{Fluid, FluidParamsBuilder, math::Vector};
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.1))?;
    /// fluid.add_block(Vector::ZERO, Vector::splat(0.5))?;
    /// fluid.clear();
    /// assert!(fluid.is_empty() && fluid.removed() == 125);
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn clear(&mut self) {
        let n = self.len();
        self.truncate_particles();
        self.removed += n;
        self.epoch = self.epoch.wrapping_add(1);
    }

    /// Back to the state [`Fluid::new`] left it in, keeping its parameters, emitters, sinks and
    /// capacity: no particle, every counter zero (emitted, drained, quarantined, removed),
    /// particle ids handed out from 0 again, emitters' clocks and counts and sinks' counts at
    /// zero. For restarting a level: filled and stepped as before, the fluid then runs bit for
    /// bit as a new one would, in the same [`crate::FluidPipeline`] (which starts the fluid's
    /// solver state afresh at its next step).
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::{Fluid, FluidParamsBuilder, math::Vector};
    /// let mut fluid = Fluid::new(FluidParamsBuilder::water(0.1))?;
    /// let first = fluid.add_block(Vector::ZERO, Vector::splat(0.5))?;
    /// fluid.remove_particles(&[3])?;
    /// fluid.reset();
    /// assert_eq!((fluid.len(), fluid.removed()), (0, 0));
    /// assert_eq!(fluid.add_block(Vector::ZERO, Vector::splat(0.5))?, first); // same ids again
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn reset(&mut self) {
        self.truncate_particles();
        self.attributes = Default::default();
        self.next_id = 0;
        self.quarantined = 0;
        self.removed = 0;
        self.emitted = 0;
        self.drained = 0;
        self.needs_depenetration = false;
        self.relax_pending = false;
        self.sources.restart();
        self.epoch = self.epoch.wrapping_add(1);
    }

    /// Every per-particle array emptied (capacity kept).
    fn truncate_particles(&mut self) {
        self.sleep = Default::default();
        self.positions.clear();
        self.velocities.clear();
        self.accelerations.clear();
        self.densities.clear();
        self.pressures.clear();
        self.ids.clear();
        self.attributes.resize(0);
    }

    /// A 64-bit FNV-1a hash of the bits of every particle's id, position and velocity, in the
    /// fluid's order: two runs with equal hashes are bitwise equal (up to a hash collision),
    /// and a run that differs in one bit of one particle almost surely hashes differently.
    /// The dam-break example prints it; tests compare it across thread counts and runs.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::{Fluid, FluidParamsBuilder, math::Vector};
    /// let mut a = Fluid::new(FluidParamsBuilder::water(0.1))?;
    /// a.add_block(Vector::ZERO, Vector::splat(0.3))?;
    /// let mut b = a.clone();
    /// assert_eq!(a.state_hash(), b.state_hash());
    /// b.velocities_mut()[0].x = 1.0e-30; // one particle, one bit of difference
    /// assert_ne!(a.state_hash(), b.state_hash());
    /// # Ok::<(), rapier_sph::SphError>(())
    /// ```
    pub fn state_hash(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |w: u32| {
            for b in w.to_le_bytes() {
                h ^= b as u64;
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for ((p, v), &id) in self.positions.iter().zip(&self.velocities).zip(&self.ids) {
            eat(id);
            for c in [p.x, p.y, p.z, v.x, v.y, v.z] {
                eat(c.to_bits());
            }
        }
        h
    }
}
