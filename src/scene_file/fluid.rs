//! A fluid's entry in a scene file: its preset, solver, equation of state, kernel, viscosity
//! solve, sleeping, blocks, and how they become [`FluidParams`].

use super::sources::{EmitterDesc, FillDesc, SinkDesc};
use super::values::{self, NonNegative, Positive, PositiveVec3, Vec3};
use crate::error::SphError;
use crate::kernel::KernelKind;
use crate::math::Real;
use crate::params::{EquationOfState, FluidParams, FluidParamsBuilder};
use serde::{Deserialize, Serialize};

/// The parameter preset a fluid starts from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Preset {
    /// SI water at this particle spacing (m) ([`FluidParamsBuilder::water`]).
    Water {
        /// Particle spacing (m).
        spacing: Positive,
    },
    /// The Unity paper's unit-mass setup ([`FluidParamsBuilder::paper`]).
    Paper,
}

/// WCSPH's pressure forces, as in [`crate::WcsphPressure`].
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum WcsphPressureDesc {
    /// The Unity paper's forces as printed (the default).
    Paper,
    /// The symmetric force with Adami et al. (2012)'s wall pressure (needs `wall_density`).
    Adami,
}

impl From<WcsphPressureDesc> for crate::WcsphPressure {
    fn from(d: WcsphPressureDesc) -> Self {
        match d {
            WcsphPressureDesc::Paper => crate::WcsphPressure::Paper,
            WcsphPressureDesc::Adami => crate::WcsphPressure::Adami,
        }
    }
}

/// WCSPH's densities, as in [`crate::WcsphDensity`].
#[derive(Copy, Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum WcsphDensityDesc {
    /// Kernel summation (the default).
    Summation,
    /// The continuity equation with δ-SPH density diffusion of coefficient `delta` (0.1 in
    /// the papers; checked within `0..=1` when the parameters are built).
    Continuity {
        /// The diffusion coefficient δ.
        delta: Real,
    },
}

impl From<WcsphDensityDesc> for crate::WcsphDensity {
    fn from(d: WcsphDensityDesc) -> Self {
        match d {
            WcsphDensityDesc::Summation => crate::WcsphDensity::Summation,
            WcsphDensityDesc::Continuity { delta } => crate::WcsphDensity::Continuity { delta },
        }
    }
}

/// How the viscosity is integrated ([`crate::ViscositySolve`]); omitted settings take the
/// implicit solve's defaults ([`crate::ImplicitViscosity`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ViscositySolveDesc {
    /// Müller's explicit force (the default).
    Explicit,
    /// Weiler et al. (2018)'s implicit solve.
    Implicit {
        /// Relative residual the solve stops at.
        #[serde(default)]
        tolerance: Option<Positive>,
        /// Most iterations per substep.
        #[serde(default)]
        max_iterations: Option<u32>,
    },
    /// The implicit solve on the viscous stress (Takahashi et al. 2015).
    Stress {
        /// Relative residual the solve stops at.
        #[serde(default)]
        tolerance: Option<Positive>,
        /// Most iterations per substep.
        #[serde(default)]
        max_iterations: Option<u32>,
    },
}

impl ViscositySolveDesc {
    /// The setting (checked when the parameters are built).
    pub fn solve(&self) -> crate::ViscositySolve {
        match self {
            ViscositySolveDesc::Explicit => crate::ViscositySolve::Explicit,
            ViscositySolveDesc::Implicit {
                tolerance,
                max_iterations,
            } => crate::ViscositySolve::Implicit(settings(*tolerance, *max_iterations)),
            ViscositySolveDesc::Stress {
                tolerance,
                max_iterations,
            } => crate::ViscositySolve::Stress(settings(*tolerance, *max_iterations)),
        }
    }
}

/// The implicit solves' settings, omitted ones at their defaults.
fn settings(tolerance: Option<Positive>, max_iterations: Option<u32>) -> crate::ImplicitViscosity {
    let d = crate::ImplicitViscosity::default();
    crate::ImplicitViscosity {
        tolerance: tolerance.map_or(d.tolerance, |t| t.0),
        max_iterations: max_iterations.unwrap_or(d.max_iterations),
    }
}

/// Sleeping water, as in [`crate::Sleep`]: `Sleep()` takes its defaults, `Sleep(time: 1.0,
/// mean_drift: 0.05)` overrides some (times in s, drifts in particle spacings, the density
/// error a fraction).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Sleep")]
pub struct SleepDesc {
    /// Seconds at rest before it falls asleep ([`crate::Sleep::time`]).
    #[serde(default)]
    pub time: Option<Positive>,
    /// Largest RMS drift of the water (averaged over cells of a kernel support) at rest, in
    /// spacings ([`crate::Sleep::mean_drift`]).
    #[serde(default)]
    pub mean_drift: Option<Positive>,
    /// Largest drift of any particle or body near at rest, in spacings
    /// ([`crate::Sleep::max_drift`]).
    #[serde(default)]
    pub max_drift: Option<Positive>,
    /// Largest mean density error at rest ([`crate::Sleep::density_error`]).
    #[serde(default)]
    pub density_error: Option<Positive>,
}

impl SleepDesc {
    /// The setting (checked when the parameters are built).
    pub fn sleep(&self) -> crate::Sleep {
        let d = crate::Sleep::default();
        crate::Sleep {
            time: self.time.map_or(d.time, |v| v.0),
            mean_drift: self.mean_drift.map_or(d.mean_drift, |v| v.0),
            max_drift: self.max_drift.map_or(d.max_drift, |v| v.0),
            density_error: self.density_error.map_or(d.density_error, |v| v.0),
        }
    }
}

/// A pressure solver, as in [`crate::Solver`]: every field is optional and defaults to the
/// solver's own default, e.g. `Dfsph()` or `Dfsph(max_density_error: 0.0005)`, `Pbf(iterations:
/// 8)`, `Clavet(springs: Some(Springs()))`, `Wcsph`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum SolverDesc {
    /// Weakly compressible SPH (the paper's method).
    Wcsph,
    /// Divergence-free SPH ([`crate::Dfsph`]).
    Dfsph {
        /// Average density error target (fraction of ρ0).
        #[serde(default)]
        max_density_error: Option<Positive>,
        /// Average divergence error target.
        #[serde(default)]
        max_divergence_error: Option<Positive>,
        /// Iterations always run by the constant-density solve.
        #[serde(default)]
        min_iterations: Option<u32>,
        /// Iterations always run by the divergence solve.
        #[serde(default)]
        min_divergence_iterations: Option<u32>,
        /// Iteration cap of each solve.
        #[serde(default)]
        max_iterations: Option<u32>,
        /// Run the divergence solve.
        #[serde(default)]
        divergence_solve: Option<bool>,
        /// Warm-start fraction of the constant-density solve, in `[0, 1]`.
        #[serde(default)]
        warm_start: Option<NonNegative>,
        /// Walls with hydrostatic pressure ([`crate::solver::Dfsph::hydrostatic_walls`]).
        #[serde(default)]
        hydrostatic_walls: Option<bool>,
        /// The whole warm start, taken back where under-dense
        /// ([`crate::solver::Dfsph::full_warm_start`]).
        #[serde(default)]
        full_warm_start: Option<bool>,
        /// Gravity's compression allowed within a substep, in multiples of the density
        /// error target ([`crate::solver::Dfsph::gravity_substep`]).
        #[serde(default)]
        gravity_substep: Option<Positive>,
        /// Carry each particle's last prediction error into the density solve
        /// ([`crate::solver::Dfsph::carry_density_error`]; needs `full_warm_start`).
        #[serde(default)]
        carry_density_error: Option<bool>,
        /// Predict what contact and the walls do to each particle over the substep
        /// ([`crate::solver::Dfsph::predict_walls`]).
        #[serde(default)]
        predict_walls: Option<bool>,
        /// Chebyshev acceleration of the constant-density solve with this spectral radius
        /// estimate in `(0, 1)` ([`crate::solver::Dfsph::chebyshev`]; needs `full_warm_start`).
        #[serde(default)]
        chebyshev: Option<Positive>,
    },
    /// Position-based fluids ([`crate::solver::Pbf`]).
    Pbf {
        /// Jacobi iterations per step.
        #[serde(default)]
        iterations: Option<u32>,
        /// Constraint relaxation ε.
        #[serde(default)]
        relaxation: Option<Positive>,
        /// Artificial pressure k.
        #[serde(default)]
        artificial_pressure: Option<NonNegative>,
        /// Artificial pressure exponent n.
        #[serde(default)]
        artificial_pressure_exponent: Option<i32>,
        /// Artificial pressure distance Δq, as a fraction of h.
        #[serde(default)]
        artificial_pressure_distance: Option<NonNegative>,
        /// Average compression the adaptive time step holds the solve to.
        #[serde(default)]
        max_density_error: Option<Positive>,
        /// Walls with hydrostatic pressure ([`crate::solver::Pbf::hydrostatic_walls`]).
        #[serde(default)]
        hydrostatic_walls: Option<bool>,
    },
    /// Double-density relaxation ([`crate::solver::Clavet`]).
    Clavet {
        /// Stiffness, in units of `c²/(h·ρ0)`.
        #[serde(default)]
        stiffness: Option<NonNegative>,
        /// Cohesion (the stiffness below rest density), same units. Default 1.
        #[serde(default)]
        cohesion: Option<NonNegative>,
        /// Near stiffness, same units. Default: the flat-surface equilibrium value.
        #[serde(default)]
        near_stiffness: Option<NonNegative>,
        /// Viscoelastic springs. Default: none.
        #[serde(default)]
        springs: Option<SpringsDesc>,
    },
}

/// Viscoelastic springs, as in [`crate::solver::Springs`]; unset fields keep its defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Springs")]
pub struct SpringsDesc {
    /// Stiffness, in units of `c²/(h²·N)`.
    #[serde(default)]
    pub stiffness: Option<NonNegative>,
    /// Yield ratio γ.
    #[serde(default)]
    pub yield_ratio: Option<NonNegative>,
    /// Plasticity α (1/s).
    #[serde(default)]
    pub plasticity: Option<NonNegative>,
}

impl SolverDesc {
    /// The solver, defaults filled in (validated with the rest of the parameters).
    pub fn solver(&self) -> crate::Solver {
        use crate::solver::{Clavet, Dfsph, Pbf, Solver, Springs};
        match self {
            SolverDesc::Wcsph => Solver::Wcsph,
            SolverDesc::Dfsph {
                max_density_error,
                max_divergence_error,
                min_iterations,
                min_divergence_iterations,
                max_iterations,
                divergence_solve,
                warm_start,
                hydrostatic_walls,
                full_warm_start,
                gravity_substep,
                carry_density_error,
                predict_walls,
                chebyshev,
            } => {
                let d = Dfsph::default();
                Solver::Dfsph(Dfsph {
                    max_density_error: max_density_error.map_or(d.max_density_error, |v| v.0),
                    max_divergence_error: max_divergence_error
                        .map_or(d.max_divergence_error, |v| v.0),
                    min_iterations: min_iterations.unwrap_or(d.min_iterations),
                    min_divergence_iterations: min_divergence_iterations
                        .unwrap_or(d.min_divergence_iterations),
                    max_iterations: max_iterations.unwrap_or(d.max_iterations),
                    divergence_solve: divergence_solve.unwrap_or(d.divergence_solve),
                    warm_start: warm_start.map_or(d.warm_start, |v| v.0),
                    hydrostatic_walls: hydrostatic_walls.unwrap_or(d.hydrostatic_walls),
                    full_warm_start: full_warm_start.unwrap_or(d.full_warm_start),
                    gravity_substep: gravity_substep.map_or(d.gravity_substep, |v| v.0),
                    carry_density_error: carry_density_error.unwrap_or(d.carry_density_error),
                    predict_walls: predict_walls.unwrap_or(d.predict_walls),
                    chebyshev: chebyshev.map_or(d.chebyshev, |v| Some(v.0)),
                })
            }
            SolverDesc::Pbf {
                iterations,
                relaxation,
                artificial_pressure,
                artificial_pressure_exponent,
                artificial_pressure_distance,
                max_density_error,
                hydrostatic_walls,
            } => {
                let d = Pbf::default();
                Solver::Pbf(Pbf {
                    iterations: iterations.unwrap_or(d.iterations),
                    relaxation: relaxation.map_or(d.relaxation, |v| v.0),
                    artificial_pressure: artificial_pressure.map_or(d.artificial_pressure, |v| v.0),
                    artificial_pressure_exponent: artificial_pressure_exponent
                        .unwrap_or(d.artificial_pressure_exponent),
                    artificial_pressure_distance: artificial_pressure_distance
                        .map_or(d.artificial_pressure_distance, |v| v.0),
                    max_density_error: max_density_error.map_or(d.max_density_error, |v| v.0),
                    hydrostatic_walls: hydrostatic_walls.unwrap_or(d.hydrostatic_walls),
                    ..d
                })
            }
            SolverDesc::Clavet {
                stiffness,
                cohesion,
                near_stiffness,
                springs,
            } => {
                let d = Clavet::default();
                Solver::Clavet(Clavet {
                    stiffness: stiffness.map_or(d.stiffness, |v| v.0),
                    cohesion: cohesion.map_or(d.cohesion, |v| v.0),
                    near_stiffness: near_stiffness.map(|v| v.0),
                    springs: springs.as_ref().map(|s| {
                        let d = Springs::default();
                        Springs {
                            stiffness: s.stiffness.map_or(d.stiffness, |v| v.0),
                            yield_ratio: s.yield_ratio.map_or(d.yield_ratio, |v| v.0),
                            plasticity: s.plasticity.map_or(d.plasticity, |v| v.0),
                        }
                    }),
                })
            }
        }
    }
}

/// The equation of state, as in [`EquationOfState`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum EosDesc {
    /// `p = k(ρ − ρ0)`.
    Linear {
        /// `k` (m²/s²).
        stiffness: Positive,
    },
    /// Tait's equation.
    Tait {
        /// Speed of sound (m/s).
        speed_of_sound: Positive,
        /// Exponent γ (7 for water).
        exponent: Positive,
    },
}

/// A kernel, as in [`KernelKind`].
#[derive(Copy, Clone, Debug, PartialEq, Serialize, Deserialize)]
#[allow(missing_docs)]
pub enum KernelDesc {
    Poly6,
    PaperPoly6,
    Spiky,
    CubicSpline,
    WendlandC2,
}

impl From<KernelDesc> for KernelKind {
    fn from(k: KernelDesc) -> Self {
        match k {
            KernelDesc::Poly6 => KernelKind::Poly6,
            KernelDesc::PaperPoly6 => KernelKind::PaperPoly6,
            KernelDesc::Spiky => KernelKind::Spiky,
            KernelDesc::CubicSpline => KernelKind::CubicSpline,
            KernelDesc::WendlandC2 => KernelKind::WendlandC2,
        }
    }
}

/// One fluid: a preset, optional overrides of its parameters, and its particles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Fluid")]
pub struct FluidDesc {
    /// A name for messages.
    #[serde(default)]
    pub name: String,
    /// The preset the parameters start from.
    pub preset: Preset,
    /// Rest density (kg/m³).
    #[serde(default)]
    pub rest_density: Option<Positive>,
    /// Particle spacing (m); h and the radius keep their ratios to it.
    #[serde(default)]
    pub particle_spacing: Option<Positive>,
    /// Contact radius (m).
    #[serde(default)]
    pub particle_radius: Option<Positive>,
    /// Particle mass (kg).
    #[serde(default)]
    pub particle_mass: Option<Positive>,
    /// Kernel support radius h (m).
    #[serde(default)]
    pub smoothing_length: Option<Positive>,
    /// Equation of state.
    #[serde(default)]
    pub equation_of_state: Option<EosDesc>,
    /// Clamp negative pressures to zero.
    #[serde(default)]
    pub clamp_negative_pressure: Option<bool>,
    /// Viscosity ε (Pa·s).
    #[serde(default)]
    pub viscosity: Option<NonNegative>,
    /// How the viscosity is integrated ([`crate::ViscositySolve`]): `Explicit` (the default) or
    /// `Implicit()`, `Implicit(tolerance: 1e-4, max_iterations: 200)`.
    #[serde(default)]
    pub viscosity_solve: Option<ViscositySolveDesc>,
    /// Viscosity ε_w between particles and walls (Pa·s; needs `wall_density`).
    #[serde(default)]
    pub wall_viscosity: Option<NonNegative>,
    /// Surface tension γ of Akinci et al. 2013 ([`FluidParamsBuilder::surface_tension`]).
    #[serde(default)]
    pub surface_tension: Option<NonNegative>,
    /// Adhesion β to colliders ([`FluidParamsBuilder::adhesion`]; needs `wall_density`).
    #[serde(default)]
    pub adhesion: Option<NonNegative>,
    /// Sleeping water ([`FluidParamsBuilder::sleep`]): `Sleep()` or `Sleep(time: 1.0)`; off
    /// when absent.
    #[serde(default)]
    pub sleep: Option<SleepDesc>,
    /// Density kernel.
    #[serde(default)]
    pub density_kernel: Option<KernelDesc>,
    /// Pressure-gradient kernel.
    #[serde(default)]
    pub pressure_kernel: Option<KernelDesc>,
    /// Contact restitution in `[0, 1]`.
    #[serde(default)]
    pub restitution: Option<NonNegative>,
    /// Contact friction μ.
    #[serde(default)]
    pub friction: Option<NonNegative>,
    /// Pressure solver ([`crate::Solver`]). Default: the preset's (water: DFSPH; paper: WCSPH).
    #[serde(default)]
    pub solver: Option<SolverDesc>,
    /// Walls count in the density ([`FluidParamsBuilder::wall_density`]; with Clavet the
    /// fixed and kinematic ones, dynamic bodies by contact only). Default: the preset's
    /// (water: on, with every solver; paper: off).
    #[serde(default)]
    pub wall_density: Option<bool>,
    /// How WCSPH turns pressures into forces ([`crate::WcsphPressure`]): `Paper` (the
    /// default) or `Adami` (the symmetric force with Adami et al. 2012's wall pressure; needs
    /// `wall_density`). Other solvers ignore it.
    #[serde(default)]
    pub wcsph_pressure: Option<WcsphPressureDesc>,
    /// How WCSPH gets its densities ([`crate::WcsphDensity`]): `Summation` (the default) or
    /// `Continuity(delta: 0.1)` (the continuity equation with δ-SPH density diffusion; best
    /// with `wcsph_pressure: Adami`). Other solvers ignore it.
    #[serde(default)]
    pub wcsph_density: Option<WcsphDensityDesc>,
    /// Interacts with every other fluid of the scene that says so (`fluid_groups` all; see
    /// [`crate::fluid::interaction`]). Default: no.
    #[serde(default)]
    pub interacts: Option<bool>,
    /// Phases mixed in every particle ([`crate::mixture`]): `Mixture(phases: [Phase(rest_density:
    /// 1000.0, viscosity: 0.5), …], drift: 5.6e-5, diffusivity: 1e-5, fractions: [0.5, 0.5])`,
    /// `fractions` every particle's at the start (default: pure phase 0). Default: none.
    #[serde(default)]
    pub mixture: Option<MixtureDesc>,
    /// Boxes filled with particles at the fluid's spacing ([`Fluid::add_block`](crate::Fluid::add_block)).
    #[serde(default)]
    pub blocks: Vec<BlockDesc>,
    /// Single particles (positions, m), at rest.
    #[serde(default)]
    pub particles: Vec<Vec3>,
    /// Volumes filled with particles at rest on the fluid's lattice: a named collider's
    /// ([`Fluid::fill_collider`](crate::Fluid::fill_collider)) or a shape's ([`Fluid::fill_shape`](crate::Fluid::fill_shape)).
    #[serde(default)]
    pub fill: Vec<FillDesc>,
    /// Nozzles that add particles while the scene runs ([`crate::Emitter`]).
    #[serde(default, deserialize_with = "values::checked_vec")]
    pub emitters: Vec<EmitterDesc>,
    /// Regions that remove particles ([`crate::Sink`]); a collider sink names a collider.
    #[serde(default, deserialize_with = "values::checked_vec")]
    pub sinks: Vec<SinkDesc>,
    /// Most particles the fluid may hold; emitters pause when it is reached
    /// ([`Fluid::set_capacity`](crate::Fluid::set_capacity), which reserves the memory up front). Default: no limit.
    #[serde(default)]
    pub capacity: Option<usize>,
}

impl FluidDesc {
    /// The validated parameters: the preset with the overrides applied.
    ///
    /// # Errors
    /// [`FluidParamsBuilder::build`]'s errors, naming the parameter.
    pub fn params(&self) -> Result<FluidParams, SphError> {
        let mut b = match &self.preset {
            Preset::Water { spacing } => FluidParamsBuilder::water(spacing.0),
            Preset::Paper => FluidParamsBuilder::paper(),
        };
        if let Some(v) = self.particle_spacing {
            b = b.particle_spacing(v.0);
        }
        if let Some(v) = self.rest_density {
            b = b.rest_density(v.0);
        }
        if let Some(v) = self.particle_radius {
            b = b.particle_radius(v.0);
        }
        if let Some(v) = self.particle_mass {
            b = b.particle_mass(v.0);
        }
        if let Some(v) = self.smoothing_length {
            b = b.smoothing_length(v.0);
        }
        if let Some(e) = &self.equation_of_state {
            b = b.equation_of_state(match e {
                EosDesc::Linear { stiffness } => EquationOfState::Linear {
                    stiffness: stiffness.0,
                },
                EosDesc::Tait {
                    speed_of_sound,
                    exponent,
                } => EquationOfState::Tait {
                    speed_of_sound: speed_of_sound.0,
                    exponent: exponent.0,
                },
            });
        }
        if let Some(v) = self.clamp_negative_pressure {
            b = b.clamp_negative_pressure(v);
        }
        if let Some(v) = self.viscosity {
            b = b.viscosity(v.0);
        }
        if let Some(v) = self.wall_viscosity {
            b = b.wall_viscosity(v.0);
        }
        if let Some(v) = &self.viscosity_solve {
            b = b.viscosity_solve(v.solve());
        }
        if let Some(v) = self.surface_tension {
            b = b.surface_tension(v.0);
        }
        if let Some(v) = self.adhesion {
            b = b.adhesion(v.0);
        }
        if let Some(v) = &self.sleep {
            b = b.sleep(v.sleep());
        }
        if let Some(k) = self.density_kernel {
            b = b.density_kernel(k.into());
        }
        if let Some(k) = self.pressure_kernel {
            b = b.pressure_kernel(k.into());
        }
        if let Some(v) = self.restitution {
            b = b.restitution(v.0);
        }
        if let Some(v) = self.friction {
            b = b.friction(v.0);
        }
        if let Some(solver) = &self.solver {
            b = b.solver(solver.solver());
        }
        if let Some(v) = self.wall_density {
            b = b.wall_density(v);
        }
        if let Some(v) = self.wcsph_pressure {
            b = b.wcsph_pressure(v.into());
        }
        if let Some(v) = self.wcsph_density {
            b = b.wcsph_density(v.into());
        }
        if self.interacts == Some(true) {
            b = b.fluid_groups(rapier3d::geometry::InteractionGroups::all());
        }
        if let Some(m) = &self.mixture {
            b = b.mixture(m.mixture());
        }
        b.build()
    }
}

impl values::Validate for FluidDesc {
    fn validate(&self) -> Result<(), String> {
        if self.capacity == Some(0) {
            return Err("capacity must be at least 1 (0 would stop every emitter)".into());
        }
        self.params().map(|_| ()).map_err(|e| e.to_string())
    }
}

/// A box `[min, min + size)` filled with particles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Block")]
pub struct BlockDesc {
    /// Lower corner (m).
    pub min: Vec3,
    /// Size (m), every component positive.
    pub size: PositiveVec3,
}

/// One phase of a [`MixtureDesc`] ([`crate::mixture::Phase`]).
#[derive(Copy, Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Phase")]
pub struct PhaseDesc {
    /// Rest density (kg/m³).
    pub rest_density: Positive,
    /// Viscosity ε (Pa·s).
    #[serde(default)]
    pub viscosity: NonNegative,
}

/// Phases mixed in every particle ([`crate::mixture::Mixture`]) and their fractions at the
/// start.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Mixture")]
pub struct MixtureDesc {
    /// The phases (phase 0 is what added particles are made of).
    pub phases: Vec<PhaseDesc>,
    /// The mobility τ (m³·s/kg).
    pub drift: NonNegative,
    /// The diffusivity D (m²/s).
    #[serde(default)]
    pub diffusivity: NonNegative,
    /// Every particle's fractions at the start, one per phase (default: pure phase 0).
    #[serde(default)]
    pub fractions: Option<Vec<crate::math::Real>>,
}

impl MixtureDesc {
    /// The mixture (checked when the parameters are built).
    pub fn mixture(&self) -> crate::mixture::Mixture {
        crate::mixture::Mixture {
            phases: self
                .phases
                .iter()
                .map(|p| crate::mixture::Phase {
                    rest_density: p.rest_density.0,
                    viscosity: p.viscosity.0,
                })
                .collect(),
            drift: self.drift.0,
            diffusivity: self.diffusivity.0,
        }
    }
}
