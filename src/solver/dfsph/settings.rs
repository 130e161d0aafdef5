//! DFSPH's settings: what the game sets (a variant of [`crate::Solver`] carries it). Plain data with
//! defaults; the algorithm is the folder's other files.

use crate::math::Real;

/// Settings of the DFSPH solver. Defaults follow Bender & Koschier (2017): 0.1 % average
/// density error, 1 % divergence error.
///
/// # Examples
/// ```
/// use rapier_sph::{Dfsph, FluidParamsBuilder, Solver};
/// // The water preset's solver, with a looser target and cheaper walls for a game's
/// // background water (pressures next to walls are then about 15 % high).
/// let params = FluidParamsBuilder::water(0.05)
///     .solver(Solver::Dfsph(Dfsph {
///         max_density_error: 0.005,
///         hydrostatic_walls: false,
///         ..Dfsph::default()
///     }))
///     .build()?;
/// assert!(matches!(params.solver, Solver::Dfsph(d) if d.max_density_error == 0.005));
/// // Bad settings are refused when the parameters are built, naming the field.
/// let bad = Solver::Dfsph(Dfsph { max_iterations: 0, ..Dfsph::default() });
/// assert!(FluidParamsBuilder::water(0.05).solver(bad).build().is_err());
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct Dfsph {
    /// Largest accepted average density error after the constant-density solve, as a fraction
    /// of `ρ0` (default 0.001, i.e. 0.1 %).
    pub max_density_error: Real,
    /// Largest accepted average divergence error, `|Dρ/Dt|·dt/ρ0` averaged (default 0.01).
    pub max_divergence_error: Real,
    /// Iterations always run by the constant-density solve (default 2, as in Bender &
    /// Koschier's reference implementation, SPlisHSPlasH).
    pub min_iterations: u32,
    /// Iterations always run by the divergence solve (default 1, as in SPlisHSPlasH: the
    /// divergence solve only keeps the velocity field from drifting, its error target is
    /// usually met by the warm start and one correction).
    pub min_divergence_iterations: u32,
    /// Iteration cap of each solve (default 100). When it binds, the step report's
    /// `solver_capped` count says so.
    pub max_iterations: u32,
    /// Run the divergence solve (default true). Off gives "constant-density only" SPH, cheaper
    /// and less stable.
    pub divergence_solve: bool,
    /// Warm start of the constant-density solve: the fraction of the previous step's
    /// pressure applied before iterating (default 0.75), and only to particles whose density
    /// is predicted to exceed `ρ0` (the rest are separating: pressure carried over there
    /// would push fluid that is already coming apart, and the solve's increments, never
    /// negative, could not take it back). Higher values need fewer iterations, since the
    /// solve only rebuilds the remaining fraction each step; see docs/solvers.md for the measured
    /// trade-off (at 1.0 a column at rest in a closed tank kept jittering).
    #[cfg_attr(feature = "snapshot", serde(default = "default_warm_start"))]
    pub warm_start: Real,
    /// Carry the whole previous pressure of every particle into the constant-density solve
    /// (`warm_start` then unused), and let the solve take it back where a particle is
    /// predicted under-dense: signed increments, each particle's pressure kept `≥ 0`
    /// (projected Jacobi). Default `false` (Bender & Koschier's one-sided solve with the
    /// partial, masked warm start above). In the game pool at rest (10,200 particles) it needs
    /// 2.8 density iterations per substep instead of 5.4, with the paddle moving 2.9 instead
    /// of 2.5 (`cargo bench --bench game -- --full-warm-start true`; docs/performance.md).
    /// The cost: a resting 8 × 16 × 8 column is less calm (largest kinetic energy 52× and
    /// over the last 10 of 60 frames 13× the default's), and with a kernel support of 3
    /// spacings it does not settle within 1 s (docs/solvers.md): keep it off there. A still
    /// pool does not calm down with it: 10–12 J of kinetic energy in the 2,604-particle game
    /// pool over 4 s against 1–2.5 J and falling by default (`cargo run --release --example
    /// pool_energy -- --preset game --particles 2500 --seconds 4 --hull none
    /// --full-warm-start true`): pressure carried into particles that would not compress without
    /// it, which its two iterations do not take back (docs/solvers.md, "Why the full warm
    /// start stirs a still pool"). Carrying the value only where the particle compresses
    /// without it calms that pool (3.8 J) but was measured and not adopted: in the salva scene
    /// with `carry_density_error` and `chebyshev` it takes 5.51 density iterations per step
    /// instead of 3.46, and the 62,234-particle tank then reads 0.104 % instead of 0.094 %
    /// (docs/solvers.md, "The mask as the full warm start's rule").
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub full_warm_start: bool,
    /// Walls with hydrostatic pressure (default true): the wall's pressure
    /// is the fluid's around the particle carried to the wall, `ρ0·g·(x_b − x_i)` included
    /// (see [`HYDROSTATIC_WALL_MIRROR`](crate::solver::HYDROSTATIC_WALL_MIRROR)), instead of the particle's own weighted by
    /// [`WALL_MIRROR`](crate::solver::WALL_MIRROR). The pressure next to walls then comes out hydrostatic: a settled
    /// column's bottom pressure within 2 % (−0.1 / +1.5 / +0.3 % at N = 6 / 8 / 12 in the
    /// validation scene; +14 to +16 % with `false`, where contact carries half the column's
    /// weight), no compressed layer above the floor. A solve that diverges finishes without
    /// the neighbours' part (see `DfsphBuffers::applied_neighbour`). The cost: the density
    /// solve iterates more (in the salva scene 9.7 iterations per step instead of 3.7, ending
    /// at a lower mean compression), and the wall stage scans the neighbours of the particles
    /// next to walls a second time. `false` is the cheaper choice where pressures are not
    /// read (docs/solvers.md has the measurements).
    pub hydrostatic_walls: bool,
    /// How much compression gravity may build within one substep, in multiples of
    /// `max_density_error`: under gravity `g` the adaptive time stepping keeps substeps to
    /// `g·dt² ≤ gravity_substep · max_density_error · spacing` (default 5; see
    /// [`crate::TimeStepping::Adaptive`]). A particle falling freely for one substep moves
    /// `g·dt²` towards the one under it, about `g·dt²/spacing` of compression the density
    /// solve must undo from a linear prediction; at 5 that stays a few times the solve's
    /// target. `Real::INFINITY` lifts the limit (the CFL condition and the others remain).
    #[cfg_attr(feature = "snapshot", serde(default = "default_gravity_substep"))]
    pub gravity_substep: Real,
    /// Carry each particle's last prediction error into the constant-density solve
    /// (needs `full_warm_start`): the density summed at the start of a step minus the density
    /// the previous step's solve predicted for it (`ρ + dt·Dρ/Dt`, linear in the velocities)
    /// is added to this step's prediction, so the solve stops on an estimate of the density
    /// the step reaches rather than on its linear prediction, whose error over a step is
    /// second order in `dt` and mostly compression (so it is scaled by `(dt/dt_last)²` when
    /// the step changes). Default `false`. In the salva scene
    /// (20,000 particles, 5 ms steps) the mean compression at the steps' start is 0.09 %
    /// with it against 0.18 % with `full_warm_start` alone and 0.19 % by default, at 5.2
    /// density iterations per step against 5.1 and 9.7 (`cargo bench --bench step --
    /// --salva --carry-density-error`; docs/performance.md). With the one-sided solve (the
    /// default warm start) the carried errors diverged in that scene (1,639 particles
    /// escaped), hence the requirement. Each carried value is clamped to ±5 % of `ρ0`: where
    /// the front hits a wall the prediction misses by tens of percent for one step, and
    /// carried unbounded that drove a runaway (the bench's 62,234-particle tank diverged,
    /// 4,085 particles escaped; the 2,500-particle one at 10 ms steps too). With the clamp
    /// the 62,234-particle tank reads 0.105 % at 7.2 iterations per step (`full_warm_start`
    /// alone 0.19 % at 6.6; `cargo bench --bench step -- --salva --carry-density-error`).
    /// Opt-in: measured in the dam breaks of the salva bench and `tests/solvers.rs` only.
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub carry_density_error: bool,
    /// Predict what the walls do to each particle over the substep (default `false`): the
    /// constant-density solve's prediction of the density after `dt` (`ρ + dt·Dρ/Dt`, from
    /// the velocities) reads each particle's velocity as contact will leave it, stopped at
    /// the contact radius (`FluidParams::particle_radius`) from every wall near, and the
    /// walls' density at the distances that velocity leads to instead of to first order. The
    /// wall stage keeps each particle's walls as planes for it (distance, normal, the wall's
    /// normal speed at the closest point; up to four, a particle with more keeps the plain
    /// prediction); each density iteration adds a pass over the particles (not the pairs).
    /// The divergence solve is unchanged.
    ///
    /// Why: next to a floor, a particle half a spacing above it has the walls' density in
    /// place of the missing rows of fluid, so its own motion changes its density only to
    /// second order; over a long substep the solve lets it sink into the contact radius while
    /// holding its density (the layer above is left under-dense, which the one-sided solve
    /// allows), and contact, after the solve, puts it back: the layer ends compressed. In
    /// the game pool with the gravity bound lifted (10,200 particles, one 16.7 ms substep in
    /// most frames) the floor layer ended 2.9 % denser than predicted, contact having moved
    /// it 0.04 spacings up; with this on, 0.05 %, and the pool's mean compression falls from
    /// 1.09 to 0.62 % (docs/performance.md, "The game pool"). Its cost at the same
    /// iteration count: about 16 % more CPU in that pool.
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub predict_walls: bool,
    /// Chebyshev semi-iterative acceleration of the constant-density solve (Wang 2015,
    /// "A Chebyshev semi-iterative approach for accelerating projective and position-based
    /// dynamics"), with this estimate `ρ` of the Jacobi iteration's spectral radius, in
    /// `(0, 1)`; `None` (default): plain Jacobi. Needs `full_warm_start` (the projected
    /// solve, which can take back what an extrapolated step over-corrects); ignored in a
    /// fluid that fills a periodic box. `ρ` is a per-scene setting, as in Wang's method: too
    /// small accelerates little, too large over-extrapolates. In the salva scene (20,000
    /// particles, 5 ms steps, with `carry_density_error`) `ρ = 0.8` takes 3.46 density
    /// iterations per step instead of 5.18, at 0.090 % mean compression against 0.094 %
    /// (`examples/dam_break.rs` with `--carry-density-error --chebyshev 0.8`, the command in
    /// docs/performance.md); a resting column is a little less calm with it. See docs/solvers.md for the method, its
    /// safeguards and the measurements.
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub chebyshev: Option<Real>,
}

#[cfg(feature = "snapshot")]
fn default_gravity_substep() -> Real {
    Dfsph::default().gravity_substep
}

#[cfg(feature = "snapshot")]
fn default_warm_start() -> Real {
    Dfsph::default().warm_start
}

impl Default for Dfsph {
    fn default() -> Self {
        Self {
            max_density_error: 0.001,
            max_divergence_error: 0.01,
            min_iterations: 2,
            min_divergence_iterations: 1,
            max_iterations: 100,
            divergence_solve: true,
            warm_start: 0.75,
            full_warm_start: false,
            hydrostatic_walls: true,
            gravity_substep: 5.0,
            carry_density_error: false,
            predict_walls: false,
            chebyshev: None,
        }
    }
}

impl Dfsph {
    /// Checks the settings; returns the first problem, naming its field. `max_iterations`
    /// must be between 1 and [`crate::params::MAX_SOLVER_ITERATIONS`] and at least both
    /// minimum counts (the cap bounds a substep's work).
    ///
    /// # Errors
    /// [`crate::SphError::InvalidParameter`] naming the first bad field.
    pub fn validate(&self) -> crate::SphResult<()> {
        use crate::error::SphError;
        for (field, v) in [
            ("max_density_error", self.max_density_error),
            ("max_divergence_error", self.max_divergence_error),
        ] {
            if !v.is_finite() || v <= 0.0 {
                return Err(SphError::InvalidParameter {
                    field,
                    value: v as f64,
                    reason: if v.is_finite() {
                        "must be positive"
                    } else {
                        "must be finite"
                    },
                });
            }
        }
        if self.gravity_substep.is_nan() || self.gravity_substep <= 0.0 {
            return Err(SphError::InvalidParameter {
                field: "gravity_substep",
                value: self.gravity_substep as f64,
                reason: "must be positive (infinite lifts the limit)",
            });
        }
        if !(0.0..=1.0).contains(&self.warm_start) {
            return Err(SphError::InvalidParameter {
                field: "warm_start",
                value: self.warm_start as f64,
                reason: "must be a fraction in [0, 1]",
            });
        }
        if self.max_iterations == 0
            || self.min_iterations > self.max_iterations
            || self.min_divergence_iterations > self.max_iterations
        {
            return Err(SphError::InvalidParameter {
                field: "max_iterations",
                value: self.max_iterations as f64,
                reason: "must be at least 1 and at least both minimum iteration counts",
            });
        }
        if self.carry_density_error && !self.full_warm_start {
            return Err(SphError::InvalidParameter {
                field: "carry_density_error",
                value: 1.0,
                reason: "needs full_warm_start (the one-sided solve cannot take back what the \
                         carried error over-corrects)",
            });
        }
        if let Some(rho) = self.chebyshev {
            if !(rho > 0.0 && rho < 1.0) {
                return Err(SphError::InvalidParameter {
                    field: "chebyshev",
                    value: rho as f64,
                    reason: "the spectral radius estimate must be in (0, 1)",
                });
            }
            if !self.full_warm_start {
                return Err(SphError::InvalidParameter {
                    field: "chebyshev",
                    value: rho as f64,
                    reason: "needs full_warm_start (the one-sided solve cannot take back what \
                             an extrapolated step over-corrects)",
                });
            }
        }
        if self.max_iterations > crate::params::MAX_SOLVER_ITERATIONS {
            return Err(SphError::InvalidParameter {
                field: "max_iterations",
                value: self.max_iterations as f64,
                reason: "more than MAX_SOLVER_ITERATIONS (2048) iterations per solve",
            });
        }
        Ok(())
    }
}
