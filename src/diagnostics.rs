//! What a step did and how long each stage took.

use crate::math::Real;
use std::fmt;
use std::time::Duration;

/// The named stages of one step, in the order they run.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Sort particles by cell, build cells and neighbour lists.
    NeighbourSearch,
    /// Kernel-summed density.
    Density,
    /// Pressure from density (equation of state).
    Pressure,
    /// Symmetric pressure force.
    PressureForce,
    /// Viscosity force (skipped when ε = 0).
    ViscosityForce,
    /// Gravity (skipped when zero).
    ExternalForces,
    /// Symplectic Euler: velocity, then position.
    ParticleUpdate,
    /// Collider contact (skipped when no collider is near the fluid).
    Contact,
}

impl Stage {
    /// All stages in step order.
    pub const ALL: [Stage; 8] = [
        Stage::NeighbourSearch,
        Stage::Density,
        Stage::Pressure,
        Stage::PressureForce,
        Stage::ViscosityForce,
        Stage::ExternalForces,
        Stage::ParticleUpdate,
        Stage::Contact,
    ];

    /// The stage's name as printed in reports.
    pub fn name(self) -> &'static str {
        match self {
            Stage::NeighbourSearch => "neighbour search",
            Stage::Density => "density",
            Stage::Pressure => "pressure calculation",
            Stage::PressureForce => "pressure force",
            Stage::ViscosityForce => "viscosity force",
            Stage::ExternalForces => "external forces",
            Stage::ParticleUpdate => "particle update",
            Stage::Contact => "collider contact",
        }
    }
}

/// Wall time per stage, summed over fluids (and over steps when accumulated).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct StageTimings {
    times: [Duration; 8],
}

impl StageTimings {
    /// Time spent in `stage`.
    pub fn get(&self, stage: Stage) -> Duration {
        self.times[stage as usize]
    }

    /// Adds `d` to `stage`.
    pub fn add(&mut self, stage: Stage, d: Duration) {
        self.times[stage as usize] += d;
    }

    /// Total over all stages.
    pub fn total(&self) -> Duration {
        self.times.iter().sum()
    }

    /// Adds every stage of `other`.
    pub fn accumulate(&mut self, other: &StageTimings) {
        for (a, b) in self.times.iter_mut().zip(other.times) {
            *a += b;
        }
    }
}

/// What one call to [`crate::FluidPipeline::step`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Wall time of each stage.
    pub timings: StageTimings,
    /// Particles over all fluids.
    pub particles: usize,
    /// Directed neighbour pairs found (sum of neighbour-list lengths).
    pub neighbour_pairs: usize,
    /// Particles whose motion a collider changed.
    pub contacts: usize,
    /// Particles kept at their start position because a corrected position failed the check.
    pub contact_fallbacks: usize,
    /// Particles that started inside a solid and were pushed out.
    pub depenetrated: usize,
    /// Particles whose position or velocity became NaN or infinite during the step.
    pub non_finite: usize,
    /// Largest particle speed after the update (m/s).
    pub max_speed: Real,
    /// Largest relative density error `|ρ − ρ0|/ρ0` over all particles.
    pub max_density_error: Real,
    /// Mean relative density error over all particles (each fluid weighted by its count).
    pub mean_density_error: Real,
}

impl fmt::Display for StageTimings {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let total = self.total().as_secs_f64().max(1e-12);
        for stage in Stage::ALL {
            let t = self.get(stage).as_secs_f64();
            writeln!(
                f,
                "  {:<22} {:>10.3} ms {:>6.1} %",
                stage.name(),
                t * 1e3,
                100.0 * t / total
            )?;
        }
        write!(f, "  {:<22} {:>10.3} ms", "total", total * 1e3)
    }
}
