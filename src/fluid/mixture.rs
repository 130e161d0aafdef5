//! A fluid's volume fractions when its parameters hold a [`crate::mixture::Mixture`]: one
//! attribute per phase (`mixture:0`, …), so re-sorts, removals and snapshots carry them
//! with the particles. Particles added without fractions are pure phase 0.

use super::Fluid;
use crate::error::{SphError, SphResult};
use crate::math::Real;
use crate::mixture::{self, PREFIX};

impl Fluid {
    /// The index of phase `k`'s fractions among the attributes, if the fluid's mixture has
    /// that phase.
    fn fraction_index(&self, k: usize) -> Option<usize> {
        let m = self.params.mixture.as_ref()?;
        if k >= m.len() {
            return None;
        }
        self.attributes.index_of(PREFIX, mixture::name(k))
    }

    /// Makes the fractions' attributes of the fluid's mixture (if any); particles without
    /// fractions (every phase 0: added before the mixture was set) become pure phase 0.
    pub(crate) fn ensure_fractions(&mut self) {
        let Some(m) = self.params.mixture.as_ref() else {
            return;
        };
        let n = self.positions.len();
        let idx: Vec<usize> = (0..m.len())
            .map(|k| self.attributes.ensure(&format!("{PREFIX}{k}"), n))
            .collect();
        for i in 0..n {
            if idx.iter().all(|&a| self.attributes.get(a)[i] == 0.0) {
                self.attributes.get_mut(idx[0])[i] = 1.0;
            }
        }
    }

    /// After an append of particles from `start` on: the new ones are pure phase 0.
    pub(crate) fn appended_fractions(&mut self, start: usize) {
        if let Some(a) = self.fraction_index(0) {
            self.attributes.get_mut(a)[start..].fill(1.0);
        }
    }

    /// The volume fractions of phase `k` of the fluid's mixture
    /// ([`crate::FluidParams::mixture`]), one per particle in the order of
    /// [`Fluid::positions`]; `None` without a mixture or such a phase.
    pub fn fractions(&self, k: usize) -> Option<&[Real]> {
        self.fraction_index(k).map(|a| self.attributes.get(a))
    }

    /// The volume fractions of phase `k`, writable; the step checks that each particle's
    /// fractions lie in `[0, 1]` and sum to 1 (within
    /// [`crate::mixture::FRACTION_SUM_TOLERANCE`]). Writing wakes the fluid.
    pub fn fractions_mut(&mut self, k: usize) -> Option<&mut [Real]> {
        let a = self.fraction_index(k)?;
        self.sleep.wake();
        Some(self.attributes.get_mut(a))
    }

    /// Sets every particle's fractions to `fractions` (one per phase).
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `mixture` when the fluid has no mixture or
    /// `fractions` has not one value per phase, or `mixture.fractions` when a value is
    /// outside `[0, 1]` or they do not sum to 1. Nothing changes on error.
    pub fn set_fractions(&mut self, fractions: &[Real]) -> SphResult<()> {
        let phases = self.params.mixture.as_ref().map_or(0, |m| m.len());
        if phases == 0 || fractions.len() != phases {
            return Err(SphError::InvalidParameter {
                field: "mixture",
                value: fractions.len() as f64,
                reason: "one fraction per phase of the fluid's mixture",
            });
        }
        mixture::check_fractions(fractions.iter().copied())?;
        self.ensure_fractions();
        for (k, &a) in fractions.iter().enumerate() {
            if let Some(values) = self.fractions_mut(k) {
                values.fill(a);
            }
        }
        Ok(())
    }

    /// Each particle's mass with a mixture, `V·ρ0_i` from its fractions (`V` the particle
    /// volume); `None` without one.
    pub(crate) fn mixture_masses(&self) -> Option<Vec<f64>> {
        let m = self.params.mixture.as_ref()?;
        let v = (self.params.particle_mass / self.params.rest_density) as f64;
        let mut out = vec![0.0f64; self.len()];
        for (k, p) in m.phases.iter().enumerate() {
            let a = self.fractions(k)?;
            for (o, &x) in out.iter_mut().zip(a) {
                *o += v * (p.rest_density as f64) * x as f64;
            }
        }
        Some(out)
    }

    /// The step's check of every particle's fractions (nothing without a mixture).
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] naming `mixture.fractions`.
    pub(crate) fn check_fractions(&self) -> SphResult<()> {
        let Some(m) = self.params.mixture.as_ref() else {
            return Ok(());
        };
        let columns: Vec<&[Real]> = (0..m.len()).filter_map(|k| self.fractions(k)).collect();
        if columns.len() != m.len() {
            return Err(SphError::InvalidParameter {
                field: "mixture.fractions",
                value: columns.len() as f64,
                reason: "a phase's fractions are missing",
            });
        }
        for i in 0..self.len() {
            mixture::check_fractions(columns.iter().map(|c| c[i]))?;
        }
        Ok(())
    }
}
