//! PBF's settings: what the game sets (a variant of [`crate::Solver`] carries it). Plain data with
//! defaults; the algorithm is the folder's other files.

use crate::math::Real;

/// Settings of the PBF solver (defaults from Macklin & Müller 2013).
///
/// # Examples
/// ```
/// use rapier_sph::{FluidParamsBuilder, Pbf, Solver};
/// // PBF with two more iterations than its default 4: stiffer water at a fixed cost.
/// let params = FluidParamsBuilder::water(0.05)
///     .solver(Solver::Pbf(Pbf { iterations: 6, ..Pbf::default() }))
///     .build()?;
/// assert_eq!(params.solver, Solver::Pbf(Pbf { iterations: 6, ..Pbf::default() }));
/// // Zero iterations would solve nothing: refused, naming the field.
/// let none = Solver::Pbf(Pbf { iterations: 0, ..Pbf::default() });
/// assert!(FluidParamsBuilder::water(0.05).solver(none).build().is_err());
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct Pbf {
    /// Jacobi iterations per step (default 4; the paper uses 2–4).
    pub iterations: u32,
    /// Constraint relaxation `ε` of eq. 11, as a fraction of the denominator
    /// `Σ_k |∇_k C_i|²` of a particle inside a full lattice (default 0.01). Larger values
    /// soften the fluid and damp the corrections.
    pub relaxation: Real,
    /// Artificial-pressure strength `k` of eq. 13 (default 0.1; 0 switches it off), relative to
    /// the `λ` of a lattice particle compressed by 100 % (λ has units here; the paper's `k`
    /// is in its own unit system). See [`Self::artificial_pressure_dt_scaling`].
    pub artificial_pressure: Real,
    /// Artificial-pressure exponent `n` (default 4).
    pub artificial_pressure_exponent: i32,
    /// Artificial-pressure reference distance `Δq` as a fraction of the support radius
    /// (default 0.2; the paper suggests 0.1–0.3).
    pub artificial_pressure_distance: Real,
    /// Average compression (fraction of ρ0) the adaptive time step aims the solve at (default
    /// 0.01, 1 %; `INFINITY` switches the limit off). A fixed number of Jacobi iterations
    /// leaves a compression that grows with gravity's displacement per substep `g·dt²` (a
    /// 1 m column left at 1/60 s substeps compresses by several per cent, then throws itself
    /// up when its bottom layers are corrected); with [`crate::TimeStepping::Adaptive`] the
    /// substep keeps `g·dt²` within `max_density_error` spacings (see `stable_time_step` in
    /// `src/pipeline/time_stepping.rs`). Fixed time steps are not changed.
    #[cfg_attr(feature = "snapshot", serde(default = "default_max_density_error"))]
    pub max_density_error: Real,
    /// Walls with hydrostatic pressure, as DFSPH's ([`crate::Dfsph::hydrostatic_walls`];
    /// default false): the wall's `λ` is the particle's own plus the average of its
    /// fluid-side neighbours' (`λ_i + λ̂_i` in eq. 14's wall term), and the hydrostatic
    /// difference `ρ0·g·(x_b − x_i)` moves the predicted position by `a_h·dt²`
    /// (`boundary::WallWorkspace::hydrostatic`). Measured in the hydrostatic scene
    /// (`column --solver pbf-hydrostatic --validation 6,8,12`): bottom pressure −12.5 / −4.2 /
    /// −1.6 % at N = 6 / 8 / 12 instead of +15.8 / +16.7 / +19.3 %, and no band of higher
    /// pressure along the side walls; docs/solvers.md.
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub hydrostatic_walls: bool,
    /// Scale the artificial pressure by `(dt/dt_ref)²` for substeps shorter than
    /// `dt_ref = √(0.01·spacing/g)` (PBF's time step limit at the default `max_density_error`;
    /// default true; without gravity it is not scaled). The artificial pressure is a position
    /// correction in every iteration, and the velocity update `Δx/dt` turns it into a speed
    /// growing as `1/dt`: a 5 cm tank at rest, one 1/60 s frame at 256 substeps, reaches 1.8e4
    /// J of kinetic energy without the scaling (0.25 J with it), and stability case 13 (65 µs
    /// substeps) 12.6× its initial energy (0.010× with it). With it, boxes of 1, 10 and 50
    /// kg/m³ dropped on PBF water float (at most 0.82 m/s against the 6.44 m/s bound,
    /// `tests/light_bodies.rs`) and 2.5 cm boxes of 250 / 500 / 750 kg/m³ float 0.252 / 0.497
    /// / 0.751 submerged (`tests/buoyancy.rs`).
    pub artificial_pressure_dt_scaling: bool,
}

impl Default for Pbf {
    fn default() -> Self {
        Self {
            iterations: 4,
            relaxation: 0.01,
            artificial_pressure: 0.1,
            artificial_pressure_exponent: 4,
            artificial_pressure_distance: 0.2,
            max_density_error: 0.01,
            hydrostatic_walls: false,
            artificial_pressure_dt_scaling: true,
        }
    }
}

impl Pbf {
    /// Checks the settings; returns the first problem, naming its field. `iterations` must be
    /// between 1 and [`crate::params::MAX_SOLVER_ITERATIONS`] (each iteration is two passes
    /// over the neighbours: the cap bounds a substep's work).
    ///
    /// # Errors
    /// [`crate::SphError::InvalidParameter`] naming the first bad field.
    pub fn validate(&self) -> crate::SphResult<()> {
        use crate::error::SphError;
        let bad = |field, value: f64, reason| {
            Err(SphError::InvalidParameter {
                field,
                value,
                reason,
            })
        };
        if self.iterations == 0 {
            return bad("iterations", 0.0, "PBF needs at least one iteration");
        }
        if self.iterations > crate::params::MAX_SOLVER_ITERATIONS {
            return bad(
                "iterations",
                self.iterations as f64,
                "more than MAX_SOLVER_ITERATIONS (2048) Jacobi iterations per substep",
            );
        }
        if !self.relaxation.is_finite() || self.relaxation < 0.0 {
            return bad(
                "relaxation",
                self.relaxation as f64,
                "must be finite and non-negative",
            );
        }
        if !self.artificial_pressure.is_finite() || self.artificial_pressure < 0.0 {
            return bad(
                "artificial_pressure",
                self.artificial_pressure as f64,
                "must be finite and non-negative",
            );
        }
        if !(self.artificial_pressure_distance > 0.0 && self.artificial_pressure_distance < 1.0) {
            return bad(
                "artificial_pressure_distance",
                self.artificial_pressure_distance as f64,
                "must be a fraction of the support radius, in (0, 1)",
            );
        }
        if self.max_density_error.is_nan() || self.max_density_error <= 0.0 {
            return bad(
                "max_density_error",
                self.max_density_error as f64,
                "must be positive (infinity switches the time step control off)",
            );
        }
        if !(1..=16).contains(&self.artificial_pressure_exponent) {
            return bad(
                "artificial_pressure_exponent",
                self.artificial_pressure_exponent as f64,
                "must be between 1 and 16",
            );
        }
        Ok(())
    }
}

#[cfg(feature = "snapshot")]
fn default_max_density_error() -> Real {
    Pbf::default().max_density_error
}
