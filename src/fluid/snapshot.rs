//! A fluid's complete state as plain serde data (feature `snapshot`): every per-particle
//! array and counter the step reads. The workspace (grid, neighbour lists, scratch) is
//! rebuilt from the particles by the next step, so it is not stored.

use super::{Attributes, Fluid};
use crate::error::SphResult;
use crate::math::{Real, Vector, is_finite};
use crate::params::FluidParams;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct FluidState {
    params: FluidParams,
    positions: Vec<Vector>,
    velocities: Vec<Vector>,
    accelerations: Vec<Vector>,
    densities: Vec<Real>,
    pressures: Vec<Real>,
    ids: Vec<u32>,
    attributes: Attributes,
    scalars: Vec<crate::scalars::ScalarSpec>,
    next_id: u32,
    quarantined: usize,
    #[serde(default)]
    removed: usize,
    needs_depenetration: bool,
    #[serde(default)]
    relax_pending: bool,
    emitted: usize,
    drained: usize,
    sources: crate::emitter::Sources,
    capacity: Option<usize>,
    #[serde(default)]
    sleep: crate::sleep::SleepState,
}

impl FluidState {
    pub(crate) fn capture(f: &Fluid) -> Self {
        Self {
            params: f.params.clone(),
            positions: f.positions.clone(),
            velocities: f.velocities.clone(),
            accelerations: f.accelerations.clone(),
            densities: f.densities.clone(),
            pressures: f.pressures.clone(),
            ids: f.ids.clone(),
            attributes: f.attributes.clone(),
            scalars: f.scalars.clone(),
            next_id: f.next_id,
            quarantined: f.quarantined,
            removed: f.removed,
            needs_depenetration: f.needs_depenetration,
            relax_pending: f.relax_pending,
            emitted: f.emitted,
            drained: f.drained,
            sources: f.sources.clone(),
            capacity: f.capacity,
            sleep: f.sleep.clone(),
        }
    }

    /// The fluid back, checked: parameters valid, every array of the same length, every value
    /// finite, ids unique and below the next id, emitters and sinks valid, the capacity
    /// reservable. (The solver's memory, Clavet's springs, is checked beside it:
    /// `crate::snapshot`.)
    pub(crate) fn restore(self) -> SphResult<Fluid> {
        use crate::SphError;
        let invalid =
            |index: usize, reason: &'static str| Err(SphError::InvalidParticle { index, reason });
        let mut f = Fluid::new(self.params)?;
        let n = self.positions.len();
        let lens = [
            self.velocities.len(),
            self.accelerations.len(),
            self.densities.len(),
            self.pressures.len(),
            self.ids.len(),
        ];
        if lens.iter().any(|&l| l != n) {
            return invalid(
                lens.iter().copied().min().unwrap_or(0).min(n),
                "snapshot arrays differ in length",
            );
        }
        // Reuse the checks of `add_particles` on positions and velocities (finite, within
        // 10,000 km, the id range and the memory the fluid will need).
        f.add_particles_with_velocities(&self.positions, Some(&self.velocities))?;
        if let Some(i) = self.accelerations.iter().position(|a| !is_finite(*a)) {
            return invalid(i, "snapshot acceleration is not finite");
        }
        for values in [&self.densities, &self.pressures] {
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return invalid(i, "snapshot density or pressure is not finite");
            }
        }
        let mut attributes = self.attributes;
        if !attributes.is_consistent(n) {
            return invalid(0, "snapshot attributes differ in length from the particles");
        }
        for values in attributes.values_mut() {
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return invalid(
                    i,
                    "snapshot attribute (a solver's warm start) is not finite",
                );
            }
        }
        if let Some(i) = self.ids.iter().position(|&id| id >= self.next_id) {
            return invalid(i, "snapshot particle id is not below the fluid's next id");
        }
        let mut sorted = self.ids.clone();
        sorted.sort_unstable();
        if let Some(w) = sorted.windows(2).position(|w| w[0] == w[1]) {
            return invalid(w, "snapshot particle ids are not unique");
        }
        f.accelerations = self.accelerations;
        f.densities = self.densities;
        f.pressures = self.pressures;
        f.ids = self.ids;
        if let Some(k) = self.scalars.iter().position(|s| {
            s.name.is_empty()
                || !(s.diffusivity.is_finite() && s.diffusivity >= 0.0)
                || attributes.find(&s.attribute(), n).is_none()
        }) {
            return invalid(
                k,
                "snapshot scalar is unnamed, has a bad diffusivity or no values",
            );
        }
        f.attributes = attributes;
        f.scalars = self.scalars;
        f.next_id = self.next_id;
        f.quarantined = self.quarantined;
        f.removed = self.removed;
        f.needs_depenetration = self.needs_depenetration;
        f.relax_pending = self.relax_pending;
        f.emitted = self.emitted;
        f.drained = self.drained;
        if !self.sources.emitters.is_consistent() || !self.sources.sinks.is_consistent() {
            return invalid(0, "snapshot emitter or sink slots are malformed");
        }
        let spacing = f.params().particle_spacing;
        for e in self.sources.emitters.iter() {
            e.1.validate_state(spacing)?;
        }
        for s in self.sources.sinks.iter() {
            s.1.validate()?;
        }
        f.sources = self.sources;
        f.set_capacity(self.capacity)?;
        if !self.sleep.is_finite() {
            return invalid(0, "snapshot sleep state is not finite");
        }
        f.sleep = self.sleep;
        Ok(f)
    }
}
