//! Fluid parameters: physical constants, kernels and contact response, with units and defaults.
//!
//! Build them with [`FluidParamsBuilder`]; [`FluidParamsBuilder::build`] validates every field
//! and returns a typed [`SphError`] naming the field at fault. Two presets exist:
//!
//! - [`FluidParamsBuilder::water`]: SI water (1000 kg/m³) at a particle spacing you choose.
//! - [`FluidParamsBuilder::paper`]: the Unity paper's unit-mass setup (mass 1, ρ0 = 8, k = 3,
//!   ε = 0.02, h = 0.4, particle size 0.2) with its tuned density kernel, to reproduce its scenes.

use crate::error::{SphError, SphResult};
use crate::kernel::KernelKind;
use crate::math::Real;
use crate::solver::settings::{Solver, WcsphDensity, WcsphPressure};
use rapier3d::geometry::InteractionGroups;

/// Most iterations a solver may run per substep: PBF's `iterations`
/// ([`crate::solver::Pbf::validate`]) and DFSPH's `max_iterations`
/// ([`crate::solver::Dfsph::validate`]).
///
/// Why 2048: a Jacobi iteration carries a correction one kernel support (at least one
/// particle spacing) further, so 2048 iterations carry it across 2048 spacings, more than the
/// side of the largest cube of particles a fluid can hold (2^32 particles, 1,626 per side; see
/// [`crate::fluid::MAX_PARTICLES`]): more iterations cannot reach particles the previous ones
/// did not. A substep's solver work is then at most 512 times PBF's default (4 iterations) and
/// about 20 times DFSPH's default cap (100).
pub const MAX_SOLVER_ITERATIONS: u32 = 2048;

/// How the fluid's viscosity ([`FluidParams::viscosity`]) is integrated over a substep.
///
/// - [`ViscositySolve::Explicit`] (the default): Müller et al. (2003)'s pair force inside the
///   solver's substep (`src/forces/viscosity.rs`). Its stable substep is `ρ0 h²/(30 ε)`, so a
///   thick liquid asks for many substeps; beyond the substep cap its exchange is limited
///   (it never adds energy, but it no longer holds the viscosity asked for).
/// - [`ViscositySolve::Implicit`]: the implicit solve of Weiler, Koschier, Brand & Bender
///   (2018), "A Physically Consistent Implicit Viscosity Solver for SPH Fluids" (Computer
///   Graphics Forum 37(2)), after the solver's substep (`src/forces/viscosity_implicit.rs`):
///   `ε` is the dynamic viscosity `μ` (Pa·s) of a consistent SPH Laplacian, any substep holds
///   it, and the time step no longer depends on it. Honey: about 10 Pa·s at 1400 kg/m³.
/// - [`ViscositySolve::Stress`]: an implicit solve on the viscous stress `2μD` (Takahashi,
///   Dobashi, Fujishiro, Nishita & Lin 2015, "Implicit Formulation for SPH-based Viscous
///   Fluids", Computer Graphics Forum 34(2)), after the solver's substep
///   (`src/forces/viscosity_stress.rs`): the acceleration is the SPH divergence of each
///   particle's own stress, so the stress drops to zero across a free surface, which feels its
///   traction. Same settings and stability as `Implicit`; each iteration costs about twice
///   as much.
///
/// # Examples
///
/// ```
/// use rapier_sph::prelude::*;
/// use rapier_sph::{ImplicitViscosity, ViscositySolve};
/// let honey = FluidParamsBuilder::water(0.02)
///     .rest_density(1400.0)
///     .viscosity(10.0)
///     .viscosity_solve(ViscositySolve::Implicit(ImplicitViscosity::default()))
///     .build()?;
/// assert!(matches!(honey.viscosity_solve, ViscositySolve::Implicit(_)));
/// # Ok::<(), SphError>(())
/// ```
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub enum ViscositySolve {
    /// Müller's explicit pair force in the solver's substep (the default).
    #[default]
    Explicit,
    /// Weiler et al. (2018)'s implicit solve after the solver's substep.
    Implicit(ImplicitViscosity),
    /// The implicit solve on the viscous stress (Takahashi et al. 2015) after the solver's
    /// substep.
    Stress(ImplicitViscosity),
}

/// Settings of the implicit viscosity solve ([`ViscositySolve::Implicit`]): a preconditioned
/// conjugate gradient on `(I − dt ν L) v = v*`, stopped when the residual's norm is below
/// `tolerance` times the right-hand side's, or after `max_iterations`.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct ImplicitViscosity {
    /// Relative residual the solve stops at, in `(0, 1)`. Default 1e-3.
    pub tolerance: Real,
    /// Most conjugate-gradient iterations per substep, in `1..=`[`MAX_SOLVER_ITERATIONS`].
    /// Default 100.
    pub max_iterations: u32,
}

impl Default for ImplicitViscosity {
    fn default() -> Self {
        Self {
            tolerance: 1e-3,
            max_iterations: 100,
        }
    }
}

impl ImplicitViscosity {
    /// Checks the settings.
    ///
    /// # Errors
    ///
    /// [`SphError::InvalidParameter`] naming `viscosity_solve.tolerance` (not in `(0, 1)`)
    /// or `viscosity_solve.max_iterations` (0 or above [`MAX_SOLVER_ITERATIONS`]).
    pub fn validate(&self) -> SphResult<()> {
        let t = self.tolerance;
        if !(t > 0.0 && t < 1.0) {
            return invalid(
                "viscosity_solve.tolerance",
                t,
                "must be finite and in (0, 1)",
            );
        }
        if self.max_iterations == 0 || self.max_iterations > MAX_SOLVER_ITERATIONS {
            return invalid(
                "viscosity_solve.max_iterations",
                self.max_iterations as Real,
                "must be at least 1 and at most MAX_SOLVER_ITERATIONS (2048)",
            );
        }
        Ok(())
    }
}

/// The equation of state: how pressure follows from density (used by WCSPH, and for the
/// speed of sound that bounds every solver's time step).
///
/// # Examples
/// ```
/// use rapier_sph::{EquationOfState, FluidParamsBuilder, Solver};
/// // WCSPH water with a faster speed of sound (less compression, smaller substeps).
/// let params = FluidParamsBuilder::water(0.05)
///     .solver(Solver::Wcsph)
///     .equation_of_state(EquationOfState::Tait { speed_of_sound: 60.0, exponent: 7.0 })
///     .build()?;
/// assert_eq!(params.equation_of_state.speed_of_sound(), 60.0);
/// // The paper's linear law: its stiffness k is c².
/// assert_eq!(EquationOfState::Linear { stiffness: 9.0 }.speed_of_sound(), 3.0);
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub enum EquationOfState {
    /// `p = k·(ρ − ρ0)` (Desbrun & Gascuel 1996; the Unity paper's eq. 11).
    ///
    /// `stiffness` `k` is in Pa per (kg/m³), i.e. m²/s²: it is the square of the
    /// speed of sound.
    Linear {
        /// `k` (m²/s²). Larger is less compressible and needs a smaller time step.
        stiffness: Real,
    },
    /// Tait's equation `p = B·((ρ/ρ0)^γ − 1)` with `B = ρ0·c²/γ` (Monaghan 1994; Becker &
    /// Teschner 2007). The usual weakly-compressible choice: density errors of about
    /// `(v_max/c)²`.
    Tait {
        /// Numerical speed of sound `c` (m/s); pick about 10× the fastest expected flow speed.
        speed_of_sound: Real,
        /// Exponent `γ` (7 for water).
        exponent: Real,
    },
}

impl EquationOfState {
    /// The speed of sound this equation of state implies at rest density (m/s), used to
    /// choose stable time steps.
    pub fn speed_of_sound(&self) -> Real {
        match *self {
            EquationOfState::Linear { stiffness } => stiffness.sqrt(),
            EquationOfState::Tait { speed_of_sound, .. } => speed_of_sound,
        }
    }
}

/// Parameters of one fluid. Fields are documented with their unit and default; build them
/// through [`FluidParamsBuilder`] so they are validated.
///
/// # Examples
/// ```
/// use rapier_sph::{Fluid, FluidParamsBuilder};
/// let params = FluidParamsBuilder::water(0.04).viscosity(0.2).build()?;
/// // What the water preset derives from the spacing: h = 2s, mass ρ0·s³.
/// assert_eq!(params.smoothing_length, 0.08);
/// assert!((params.particle_mass - 1000.0 * 0.04f32.powi(3)).abs() < 1e-6);
/// // Edited by hand, the fields are validated again where they are used.
/// let mut edited = params.clone();
/// edited.viscosity = -1.0;
/// assert!(edited.validate().is_err()); // names `viscosity`
/// assert!(Fluid::new(edited).is_err());
/// let fluid = Fluid::new(params)?;
/// assert_eq!(fluid.params().viscosity, 0.2);
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct FluidParams {
    /// Rest density `ρ0` (kg/m³). Water preset: 1000. Paper preset: 8.
    pub rest_density: Real,
    /// Spacing of the lattice particles are seeded on (m). Water preset: the value given.
    /// Paper preset: 0.2.
    pub particle_spacing: Real,
    /// Contact radius (m): collider contact keeps particle centers this far from every
    /// collider surface. Default: half the spacing (paper preset: 0.2).
    pub particle_radius: Real,
    /// Mass of every particle of this fluid (kg). Default: `rest_density · spacing³`
    /// (paper preset: 1).
    pub particle_mass: Real,
    /// Kernel support radius `h` (m): particles closer than `h` interact. Default: twice the
    /// spacing (about 33 neighbours). Paper preset: 0.4. Must be at least the spacing.
    pub smoothing_length: Real,
    /// How pressure follows from density. Water preset: Tait, c = 30 m/s, γ = 7.
    /// Paper preset: linear, k = 3.
    pub equation_of_state: EquationOfState,
    /// Clamp negative pressures to zero (default: true; paper preset: false). Negative
    /// pressure at the free surface makes particles clump (the tensile instability).
    pub clamp_negative_pressure: bool,
    /// How WCSPH's pressures push, in the fluid and at the walls (see [`WcsphPressure`]);
    /// other solvers ignore it. Both presets: [`WcsphPressure::Paper`].
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub wcsph_pressure: WcsphPressure,
    /// How WCSPH gets its densities: kernel summation, or the continuity equation with δ-SPH
    /// density diffusion (see [`WcsphDensity`]); other solvers ignore it. Both presets:
    /// [`WcsphDensity::Summation`].
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub wcsph_density: WcsphDensity,
    /// Viscosity constant `ε` of the Müller/Unity viscosity force (Pa·s), 0 switches the
    /// viscosity stage off entirely. Water preset: 0.5 (a numerical viscosity that keeps
    /// weakly-compressible SPH calm at game resolutions, far above water's 0.001).
    /// Paper preset: 0.02. With [`ViscositySolve::Implicit`] it is the dynamic viscosity `μ`
    /// of Weiler et al. (2018)'s implicit solve (honey: about 10), held at any substep.
    pub viscosity: Real,
    /// Viscosity constant `ε_w` (Pa·s) between the particles and the walls: the walls'
    /// solid volume acts as fluid moving with the wall in the viscosity term, so a particle
    /// next to a wall is dragged towards the wall's velocity (no-slip in the limit) and a
    /// moving body feels the fluid's shear stress (see `src/boundary/wall/`). Needs
    /// [`Self::wall_density`] (the same half-space integrals); not available with the Clavet
    /// solver (its exchange with moving bodies drifted by 1.6 % of the momentum in a test).
    /// Both presets: 0 (free-slip walls; the stage is skipped).
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub wall_viscosity: Real,
    /// How [`Self::viscosity`] is integrated: Müller's explicit force (the default) or Weiler
    /// et al. (2018)'s implicit solve, which holds thick liquids (honey and beyond) at any
    /// substep (see [`ViscositySolve`]). Both presets: explicit.
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub viscosity_solve: ViscositySolve,
    /// Surface tension `γ` of Akinci et al. (2013)'s cohesion and curvature terms (the
    /// paper's constant: m⁴ kg⁻¹ s⁻² in the cohesion term; not the SI surface tension `σ`,
    /// which it gives in proportion: `src/forces/surface_tension.rs` has the model, the
    /// README the measured `σ` per `γ`). Pulls the fluid into droplets. Not available with
    /// the Clavet solver, whose cohesion (the attraction below rest density) already acts as
    /// surface tension. Both presets: 0 (the stage is skipped).
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub surface_tension: Real,
    /// Adhesion `β` of Akinci et al. (2013) to colliders (m⁴ kg⁻¹ s⁻², as `γ`'s cohesion
    /// term): particles within `h` of a collider are pulled towards its surface, which sets
    /// the contact angle a droplet takes on it (larger `β`: smaller angle, more wetting).
    /// Needs [`Self::wall_density`] (the walls' distance field); not available with Clavet.
    /// Both presets: 0.
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub adhesion: Real,
    /// Kernel for density. Water preset: cubic spline. Paper preset: the paper's tuned poly6.
    pub density_kernel: KernelKind,
    /// Kernel whose gradient drives the pressure force. Water preset: cubic spline.
    /// Paper preset: spiky.
    pub pressure_kernel: KernelKind,
    /// Restitution `e` of collider contact, in `[0, 1]`: the normal velocity into a surface
    /// is reflected as `−e·v_n`. Default 0 (water does not bounce off walls); paper preset 0.5.
    pub restitution: Real,
    /// Coulomb friction `μ ≥ 0` of collider contact: the tangential speed is reduced by
    /// `μ` times the normal speed change. Default 0 (free slip).
    pub friction: Real,
    /// Which colliders the particles touch (rapier's collision groups; sensors are always
    /// ignored). Default: all.
    pub collision_groups: InteractionGroups,
    /// Which other fluids of the same [`crate::FluidSet`] this fluid interacts with
    /// (rapier's [`InteractionGroups`], tested both ways as for colliders): fluids that
    /// interact share one neighbour search and one pressure solve, so pressure and viscosity
    /// act across them and each keeps its own rest density and viscosity (see
    /// [`crate::fluid::interaction`] for the formulation and what must match). Default:
    /// [`InteractionGroups::none`], the fluid sees no other fluid and pays nothing for them.
    #[cfg_attr(
        feature = "snapshot",
        serde(default = "crate::fluid::interaction::no_groups")
    )]
    pub fluid_groups: InteractionGroups,
    /// The pressure solver. Water preset: DFSPH ([`Solver::dfsph`], the accurate default);
    /// paper preset: WCSPH (the paper's method).
    pub solver: Solver,
    /// Colliders near a particle add their volume's density to it and push with the
    /// particle's pressure (see `src/boundary/wall/`), so particles do not cling to or
    /// clump along walls. Water preset: on, whatever the solver; paper preset: off (the
    /// paper's walls only reflect). With the Clavet solver only fixed and kinematic
    /// colliders count; dynamic bodies meet its water through contact alone (their impulses
    /// go to the body): counted, their wall term held a 16 cm box of 1,400 kg/m³ in 0.44 m
    /// of water at 4 cm spacing (stopped 3.5 spacings above the floor without cohesion, where
    /// the other solvers land it), and contact alone lands it on the last particle layer
    /// within 4 s. With Clavet `false` is the cheap opt-out (every wall by contact only),
    /// which leaves the walls non-wetting for its cohesion: a particle in a tank's corner
    /// then has 0.384·ρ0 against the cohesion threshold 0.751·ρ0, and a block spawned in a
    /// tank throws its corners (see [`crate::solver::clavet`], "Walls").
    pub wall_density: bool,
    /// Where the particles live: open space (default) or a periodic box (see
    /// [`crate::domain`]). Both presets: open.
    pub domain: crate::domain::Domain,
    /// When the fluid may fall asleep when it is at rest, and stop costing a step (see
    /// [`crate::sleep`]); `None` (both presets' default) never sleeps: exact results.
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub sleep: Option<crate::sleep::Sleep>,
    /// Phases mixed in every particle, which separate by drifting through the particles
    /// (Ren et al. 2014's mixture model, see [`crate::mixture`]); `None` (both presets'
    /// default) for one liquid, at no cost.
    #[cfg_attr(feature = "snapshot", serde(default))]
    pub mixture: Option<crate::mixture::Mixture>,
}

fn invalid(field: &'static str, value: Real, reason: &'static str) -> SphResult<()> {
    Err(SphError::InvalidParameter {
        field,
        value: value as f64,
        reason,
    })
}

fn positive(field: &'static str, v: Real) -> SphResult<()> {
    if !v.is_finite() {
        invalid(field, v, "must be finite")
    } else if v <= 0.0 {
        invalid(field, v, "must be positive")
    } else {
        Ok(())
    }
}

fn non_negative(field: &'static str, v: Real) -> SphResult<()> {
    if !v.is_finite() || v < 0.0 {
        invalid(field, v, "must be finite and non-negative")
    } else {
        Ok(())
    }
}

impl FluidParams {
    /// A mixture's checks (`crate::mixture`): its own, DFSPH, the explicit viscosity.
    fn validate_mixture(&self, m: &crate::mixture::Mixture) -> SphResult<()> {
        m.validate(self.rest_density, self.viscosity)?;
        if !matches!(self.solver, Solver::Dfsph(_)) {
            return invalid(
                "mixture",
                0.0,
                "the mixture model runs with DFSPH only (the other solvers are not tested with it)",
            );
        }
        if !matches!(self.viscosity_solve, ViscositySolve::Explicit) {
            return invalid(
                "mixture",
                0.0,
                "the mixture model takes the explicit viscosity only",
            );
        }
        Ok(())
    }

    /// The viscosity the solvers' explicit force applies: [`Self::viscosity`] with
    /// [`ViscositySolve::Explicit`], 0 when the implicit solve takes it.
    pub(crate) fn explicit_viscosity(&self) -> Real {
        match self.viscosity_solve {
            ViscositySolve::Explicit => self.viscosity,
            ViscositySolve::Implicit(_) | ViscositySolve::Stress(_) => 0.0,
        }
    }

    /// Checks every field; returns the first problem found.
    ///
    /// # Errors
    ///
    /// [`SphError::InvalidParameter`] naming the first field out of its range: a non-finite
    /// or non-positive size, mass or density, a smoothing length below the spacing, a solver
    /// setting out of range, wall viscosity or adhesion without wall density, negative
    /// surface tension or adhesion (or either with Clavet), a periodic box smaller than
    /// three supports.
    pub fn validate(&self) -> SphResult<()> {
        self.validate_sizes()?;
        self.validate_equation_of_state()?;
        self.validate_walls_and_contact()?;
        self.domain.validate(self.smoothing_length)?;
        match &self.solver {
            Solver::Wcsph => {}
            Solver::Dfsph(d) => d.validate()?,
            Solver::Pbf(b) => b.validate()?,
            Solver::Clavet(c) => c.validate()?,
        }
        if let Some(sleep) = &self.sleep {
            sleep.validate()?;
        }
        if let Some(m) = &self.mixture {
            self.validate_mixture(m)?;
        }
        Ok(())
    }

    /// Density, spacing, radius, mass and smoothing length: positive, and the smoothing
    /// length between one and six spacings.
    fn validate_sizes(&self) -> SphResult<()> {
        positive("rest_density", self.rest_density)?;
        positive("particle_spacing", self.particle_spacing)?;
        positive("particle_radius", self.particle_radius)?;
        positive("particle_mass", self.particle_mass)?;
        positive("smoothing_length", self.smoothing_length)?;
        let h = self.smoothing_length;
        if h < self.particle_spacing {
            return invalid(
                "smoothing_length",
                h,
                "must be at least the particle spacing (particles would have no neighbours)",
            );
        }
        if h > 6.0 * self.particle_spacing {
            return invalid(
                "smoothing_length",
                h,
                "more than 6 particle spacings (over 900 neighbours per particle)",
            );
        }
        Ok(())
    }

    fn validate_equation_of_state(&self) -> SphResult<()> {
        match self.equation_of_state {
            EquationOfState::Linear { stiffness } => positive("stiffness", stiffness),
            EquationOfState::Tait {
                speed_of_sound,
                exponent,
            } => {
                positive("speed_of_sound", speed_of_sound)?;
                positive("exponent", exponent)?;
                if exponent < 1.0 {
                    return invalid("exponent", exponent, "Tait's exponent must be at least 1");
                }
                Ok(())
            }
        }
    }

    /// Viscosities, wall viscosity's needs, restitution and friction.
    fn validate_walls_and_contact(&self) -> SphResult<()> {
        non_negative("viscosity", self.viscosity)?;
        non_negative("wall_viscosity", self.wall_viscosity)?;
        if let ViscositySolve::Implicit(settings) | ViscositySolve::Stress(settings) =
            &self.viscosity_solve
        {
            settings.validate()?;
        }
        if self.wall_viscosity > 0.0 && !self.wall_density {
            return invalid(
                "wall_viscosity",
                self.wall_viscosity,
                "needs wall_density (the walls' viscous term uses its half-space integrals)",
            );
        }
        if let WcsphDensity::Continuity { delta } = self.wcsph_density
            && !(0.0..=1.0).contains(&delta)
        {
            return invalid(
                "wcsph_density",
                delta,
                "the δ-SPH diffusion coefficient must be within 0..=1 (0.1 in the papers)",
            );
        }
        if self.wcsph_pressure == WcsphPressure::Adami && !self.wall_density {
            return invalid(
                "wcsph_pressure",
                1.0,
                "Adami walls need wall_density (the wall pressure acts through it)",
            );
        }
        if self.wall_viscosity > 0.0 && matches!(self.solver, Solver::Clavet(_)) {
            // Measured in tests/moving_bodies.rs's sloshing box (Clavet without cohesion,
            // walls in its densities, ε_w = 0.5): the momentum of fluid + bodies drifted by
            // 1.6 % over 5 s (PBF with the same walls: 0.003 %); not understood.
            return invalid(
                "wall_viscosity",
                self.wall_viscosity,
                "not available with the Clavet solver (its exchange with moving bodies \
                 does not conserve momentum yet)",
            );
        }
        self.validate_surface_tension()?;
        non_negative("restitution", self.restitution)?;
        if self.restitution > 1.0 {
            return invalid(
                "restitution",
                self.restitution,
                "must be at most 1 (contact must not add energy)",
            );
        }
        non_negative("friction", self.friction)
    }

    /// Surface tension and adhesion: non-negative; adhesion needs the walls' distance field;
    /// neither with Clavet (its cohesion is its surface tension).
    fn validate_surface_tension(&self) -> SphResult<()> {
        non_negative("surface_tension", self.surface_tension)?;
        non_negative("adhesion", self.adhesion)?;
        if self.adhesion > 0.0 && !self.wall_density {
            return invalid(
                "adhesion",
                self.adhesion,
                "needs wall_density (adhesion uses the walls' distance field)",
            );
        }
        let clavet = matches!(self.solver, Solver::Clavet(_));
        for (field, v) in [
            ("surface_tension", self.surface_tension),
            ("adhesion", self.adhesion),
        ] {
            if clavet && v > 0.0 {
                return invalid(
                    field,
                    v,
                    "not available with the Clavet solver (its cohesion, the attraction \
                     below rest density, is its surface tension)",
                );
            }
        }
        Ok(())
    }

    /// Upper bound of the memory a particle of this fluid needs in a step (bytes): its
    /// solver's `fixed + per_neighbour·N` with `N` the expected neighbour count (see
    /// [`crate::fluid::bytes_per_particle`] for the measurements behind it).
    pub fn bytes_per_particle(&self) -> usize {
        let (fixed, per_neighbour) = match &self.solver {
            Solver::Dfsph(_) => (500.0, 32.0),
            Solver::Clavet(c) if c.springs.is_some() => (300.0, 45.0),
            _ => (300.0, 7.0),
        };
        let n = self.expected_neighbours().ceil() as f64;
        (fixed + per_neighbour * n) as usize
    }

    /// Number of neighbours a particle has inside a uniform lattice (`≈ 4/3·π·(h/spacing)³`).
    pub fn expected_neighbours(&self) -> Real {
        let q = self.smoothing_length / self.particle_spacing;
        4.0 / 3.0 * std::f32::consts::PI * q * q * q
    }

    /// A time step that satisfies the acoustic CFL condition `dt ≤ 0.4·h/c`, for fixed-step
    /// weakly-compressible runs.
    pub fn acoustic_time_step(&self) -> Real {
        0.4 * self.smoothing_length / self.equation_of_state.speed_of_sound()
    }

    /// The SI surface tension `σ` (N/m) that [`Self::surface_tension`]'s `γ` gives:
    /// `0.00675·ρ0²·γ·h²`, measured from the Laplace pressure of water droplets (DFSPH, h = 2 cm,
    /// γ = 1: 2.0–3.9 N/m, so about ±40 %; `tests/surface_tension.rs`) and scaled as
    /// `ρ0²h²`: at a fixed droplet size in spacings statics are self-similar, `σ ∝ γh²`
    /// exactly (the core pressures at h = 1, 2 and 4 cm, 292, 585 and 1,172 Pa, are `∝ h`);
    /// the `ρ0²` is the cohesion term's (the curvature term's share, `∝ ρ0`, is not
    /// measured apart, so other rest densities carry a further error). The capillary waves
    /// this `σ` carries bound the substep, `dt ≤ courant·2√(ρ0Δx³/(π³σ_coh))` with the
    /// cohesion's mean-field share `σ_coh ≈ 0.44σ`: for water's 0.072 N/m that is 26 ms at
    /// 1 cm spacing and 0.29 s at 5 cm (courant 0.4), no limit at game steps. Small droplets
    /// ring as soft elastic solids rather than at Rayleigh's capillary period (see
    /// `src/forces/surface_tension.rs`).
    pub fn surface_tension_sigma(&self) -> Real {
        crate::forces::surface_tension::sigma_for_gamma(
            self.surface_tension,
            self.rest_density,
            self.smoothing_length,
        )
    }
}

/// Builds validated [`FluidParams`].
///
/// # Examples
///
/// ```
/// use rapier_sph::{FluidParamsBuilder, EquationOfState};
/// let water = FluidParamsBuilder::water(0.05).viscosity(0.2).build().unwrap();
/// assert_eq!(water.smoothing_length, 0.1);
/// let bad = FluidParamsBuilder::water(0.05).smoothing_length(0.01).build();
/// assert!(bad.is_err()); // h below the spacing: a typed error naming the field
/// ```
#[derive(Clone, Debug)]
pub struct FluidParamsBuilder {
    params: FluidParams,
    mass_given: bool,
    /// [`Self::surface_tension_sigma`]'s `σ`, turned into `γ` by [`Self::build`].
    sigma: Option<Real>,
}

impl FluidParamsBuilder {
    /// SI water at the given particle spacing (m): ρ0 = 1000 kg/m³, mass ρ0·s³, h = 2s,
    /// radius s/2, the DFSPH solver with its default error targets and walls that count in
    /// the density, cubic-spline kernels, numerical viscosity 0.5 Pa·s, free-slip walls with
    /// no bounce. The Tait equation of state (c = 30 m/s, clamped negative pressure) is
    /// what WCSPH uses when asked for with [`Self::solver`]`(Solver::Wcsph)`.
    pub fn water(spacing: Real) -> Self {
        Self {
            params: FluidParams {
                rest_density: 1000.0,
                particle_spacing: spacing,
                particle_radius: 0.5 * spacing,
                particle_mass: 1000.0 * spacing * spacing * spacing,
                smoothing_length: 2.0 * spacing,
                equation_of_state: EquationOfState::Tait {
                    speed_of_sound: 30.0,
                    exponent: 7.0,
                },
                clamp_negative_pressure: true,
                wcsph_pressure: WcsphPressure::Paper,
                wcsph_density: WcsphDensity::Summation,
                viscosity: 0.5,
                wall_viscosity: 0.0,
                viscosity_solve: ViscositySolve::Explicit,
                surface_tension: 0.0,
                adhesion: 0.0,
                density_kernel: KernelKind::CubicSpline,
                pressure_kernel: KernelKind::CubicSpline,
                restitution: 0.0,
                friction: 0.0,
                collision_groups: InteractionGroups::all(),
                fluid_groups: InteractionGroups::none(),
                solver: Solver::dfsph(),
                wall_density: true,
                domain: crate::domain::Domain::Open,
                sleep: None,
                mixture: None,
            },
            mass_given: false,
            sigma: None,
        }
    }

    /// Water for a game's frame budget: [`Self::water`] with DFSPH's average density error
    /// target at 0.5 % instead of 0.1 % (`Dfsph::max_density_error: 0.005`), everything else
    /// the water preset's (walls with hydrostatic pressure included, so bodies float at the
    /// same depth). DFSPH bounds its substep by gravity (`g·dt² ≤ 5·max_density_error·spacing`),
    /// so the looser target also means longer substeps: two per 1/60 s frame at 4 cm where the
    /// water preset takes four, and fewer iterations in each.
    ///
    /// In the game pool (`cargo bench --bench game`, 10,200 particles, a floating hull,
    /// docs/performance.md) it costs about half the water preset's CPU time per frame (15–18 ms
    /// against 29–39 ms, both threads), at a mean compression of 0.4–0.6 % against 0.11 %,
    /// the hull floating within a few per cent of the same depth. Pressures and flows are
    /// less exact than the water preset's: use it where the water is seen, not measured.
    ///
    /// # Examples
    /// ```
    /// use rapier_sph::prelude::*;
    /// let params = FluidParamsBuilder::game_water(0.04).build()?;
    /// let Solver::Dfsph(dfsph) = params.solver else { unreachable!() };
    /// assert_eq!(dfsph.max_density_error, 0.005);
    /// # Ok::<(), SphError>(())
    /// ```
    pub fn game_water(spacing: Real) -> Self {
        Self::water(spacing).solver(Solver::Dfsph(crate::solver::Dfsph {
            max_density_error: 0.005,
            ..crate::solver::Dfsph::default()
        }))
    }

    /// The Unity paper's setup (its section 4.3): particle mass 1, rest density 8, linear
    /// equation of state with k = 3, viscosity ε = 0.02, h = 0.4, particle size 0.2, the
    /// paper's tuned density kernel and the spiky pressure gradient, no pressure clamping.
    /// The paper reflects and damps particles at walls without giving numbers; this preset
    /// uses restitution 0.5 and no friction.
    pub fn paper() -> Self {
        Self {
            params: FluidParams {
                rest_density: 8.0,
                particle_spacing: 0.2,
                particle_radius: 0.2,
                particle_mass: 1.0,
                smoothing_length: 0.4,
                equation_of_state: EquationOfState::Linear { stiffness: 3.0 },
                clamp_negative_pressure: false,
                wcsph_pressure: WcsphPressure::Paper,
                wcsph_density: WcsphDensity::Summation,
                viscosity: 0.02,
                wall_viscosity: 0.0,
                viscosity_solve: ViscositySolve::Explicit,
                surface_tension: 0.0,
                adhesion: 0.0,
                density_kernel: KernelKind::PaperPoly6,
                pressure_kernel: KernelKind::Spiky,
                restitution: 0.5,
                friction: 0.0,
                collision_groups: InteractionGroups::all(),
                fluid_groups: InteractionGroups::none(),
                solver: Solver::Wcsph,
                wall_density: false,
                domain: crate::domain::Domain::Open,
                sleep: None,
                mixture: None,
            },
            mass_given: true,
            sigma: None,
        }
    }

    /// A periodic box `[min, max)` along all three axes (see [`crate::domain`]): particles
    /// leaving through a face re-enter through the opposite one. Validated by
    /// [`Self::build`]: finite corners, every edge at least 3 smoothing lengths.
    pub fn periodic(mut self, min: crate::math::Vector, max: crate::math::Vector) -> Self {
        self.params.domain = crate::domain::Domain::Periodic { min, max };
        self
    }

    /// Lets the fluid fall asleep when it is at rest (see [`crate::sleep`]; `None`, the
    /// default, never sleeps).
    pub fn sleep(mut self, sleep: impl Into<Option<crate::sleep::Sleep>>) -> Self {
        self.params.sleep = sleep.into();
        self
    }

    /// The domain (open or periodic; see [`crate::domain`]).
    pub fn domain(mut self, domain: crate::domain::Domain) -> Self {
        self.params.domain = domain;
        self
    }

    /// The pressure solver.
    pub fn solver(mut self, solver: Solver) -> Self {
        self.params.solver = solver;
        self
    }
    /// Whether walls add density (see [`FluidParams::wall_density`]). Unless this is
    /// called, the preset's choice holds (water: on, with every solver; paper: off). With
    /// the Clavet solver dynamic bodies act through contact only either way (see
    /// [`FluidParams::wall_density`]), and `false` makes every wall act so (cheaper, but
    /// non-wetting for its cohesion; see [`crate::solver::clavet`], "Walls").
    pub fn wall_density(mut self, on: bool) -> Self {
        self.params.wall_density = on;
        self
    }
    /// Rest density (kg/m³). Unless a mass was set explicitly, the mass follows.
    pub fn rest_density(mut self, v: Real) -> Self {
        self.params.rest_density = v;
        self
    }
    /// Particle spacing (m). Unless set explicitly, mass, radius and h keep their ratios.
    pub fn particle_spacing(mut self, v: Real) -> Self {
        let old = self.params.particle_spacing;
        let ratio_h = self.params.smoothing_length / old;
        let ratio_r = self.params.particle_radius / old;
        self.params.particle_spacing = v;
        self.params.smoothing_length = ratio_h * v;
        self.params.particle_radius = ratio_r * v;
        self
    }
    /// Contact radius (m).
    pub fn particle_radius(mut self, v: Real) -> Self {
        self.params.particle_radius = v;
        self
    }
    /// Particle mass (kg); by default it follows from spacing and rest density.
    pub fn particle_mass(mut self, v: Real) -> Self {
        self.params.particle_mass = v;
        self.mass_given = true;
        self
    }
    /// Kernel support radius `h` (m).
    ///
    /// Supports above about 2.5 particle spacings with walls that count in the density: DFSPH
    /// and PBF relax their Jacobi iterations on their own there (see
    /// [`crate::solver::dfsph::MAX_RELAXATION_HALVINGS`] and
    /// [`crate::solver::pbf::MAX_RELAXATION_HALVINGS`]), and Clavet's adaptive substep follows
    /// the relaxation's stiffest mode ([`crate::solver::clavet::stiffest_rest_mode`]); at 3
    /// spacings a Clavet column at rest still does not come to rest (measured in
    /// docs/solvers.md, "Larger supports"). The presets use 2 spacings; WCSPH is not affected.
    pub fn smoothing_length(mut self, v: Real) -> Self {
        self.params.smoothing_length = v;
        self
    }
    /// Equation of state.
    pub fn equation_of_state(mut self, eos: EquationOfState) -> Self {
        self.params.equation_of_state = eos;
        self
    }
    /// Linear equation of state `p = k(ρ − ρ0)` with this stiffness (m²/s²).
    pub fn stiffness(self, k: Real) -> Self {
        self.equation_of_state(EquationOfState::Linear { stiffness: k })
    }
    /// Clamp negative pressures to zero.
    pub fn clamp_negative_pressure(mut self, v: bool) -> Self {
        self.params.clamp_negative_pressure = v;
        self
    }

    /// Sets [`FluidParams::wcsph_pressure`].
    pub fn wcsph_pressure(mut self, v: WcsphPressure) -> Self {
        self.params.wcsph_pressure = v;
        self
    }
    /// Sets [`FluidParams::wcsph_density`].
    pub fn wcsph_density(mut self, v: WcsphDensity) -> Self {
        self.params.wcsph_density = v;
        self
    }
    /// Viscosity constant ε (Pa·s); 0 switches the viscosity stage off.
    pub fn viscosity(mut self, v: Real) -> Self {
        self.params.viscosity = v;
        self
    }
    /// How the viscosity is integrated (see [`FluidParams::viscosity_solve`]).
    pub fn viscosity_solve(mut self, v: ViscositySolve) -> Self {
        self.params.viscosity_solve = v;
        self
    }
    /// Viscosity `ε_w` (Pa·s) between particles and walls (see
    /// [`FluidParams::wall_viscosity`]); 0 (the default) keeps walls free-slip.
    pub fn wall_viscosity(mut self, v: Real) -> Self {
        self.params.wall_viscosity = v;
        self
    }
    /// Surface tension `γ` of Akinci et al. 2013 (see [`FluidParams::surface_tension`]); 0
    /// (the default) skips the stage.
    ///
    /// # Examples
    ///
    /// ```
    /// use rapier_sph::{FluidParamsBuilder, SphError};
    /// let p = FluidParamsBuilder::water(0.01).surface_tension(2.0).adhesion(1.0).build()?;
    /// assert_eq!((p.surface_tension, p.adhesion), (2.0, 1.0));
    /// let bad = FluidParamsBuilder::water(0.01).surface_tension(-1.0).build();
    /// assert!(matches!(bad, Err(SphError::InvalidParameter { field: "surface_tension", .. })));
    /// # Ok::<(), SphError>(())
    /// ```
    pub fn surface_tension(mut self, gamma: Real) -> Self {
        self.params.surface_tension = gamma;
        self.sigma = None;
        self
    }
    /// Surface tension as an SI `σ` (N/m; water 0.072): [`Self::build`] sets the `γ` that
    /// gives it at the fluid's rest density and smoothing length,
    /// `γ = σ/(0.00675·ρ0²·h²)` (see [`FluidParams::surface_tension_sigma`] for the
    /// measurement, about ±40 %, and its range). Replaces an earlier [`Self::surface_tension`].
    ///
    /// # Examples
    ///
    /// ```
    /// use rapier_sph::{FluidParamsBuilder, SphError};
    /// let p = FluidParamsBuilder::water(0.01).surface_tension_sigma(0.072).build()?;
    /// assert!((p.surface_tension_sigma() - 0.072).abs() < 1e-6);
    /// let bad = FluidParamsBuilder::water(0.01).surface_tension_sigma(-1.0).build();
    /// assert!(matches!(bad, Err(SphError::InvalidParameter { field: "surface_tension", .. })));
    /// # Ok::<(), SphError>(())
    /// ```
    pub fn surface_tension_sigma(mut self, sigma: Real) -> Self {
        self.sigma = Some(sigma);
        self
    }
    /// Adhesion `β` to colliders (see [`FluidParams::adhesion`]); 0 (the default): none.
    pub fn adhesion(mut self, beta: Real) -> Self {
        self.params.adhesion = beta;
        self
    }
    /// Density kernel.
    pub fn density_kernel(mut self, k: KernelKind) -> Self {
        self.params.density_kernel = k;
        self
    }
    /// Pressure-gradient kernel.
    pub fn pressure_kernel(mut self, k: KernelKind) -> Self {
        self.params.pressure_kernel = k;
        self
    }
    /// Contact restitution in `[0, 1]`.
    pub fn restitution(mut self, v: Real) -> Self {
        self.params.restitution = v;
        self
    }
    /// Contact friction `μ ≥ 0`.
    pub fn friction(mut self, v: Real) -> Self {
        self.params.friction = v;
        self
    }
    /// Collision groups against rapier colliders.
    pub fn collision_groups(mut self, g: InteractionGroups) -> Self {
        self.params.collision_groups = g;
        self
    }
    /// Which fluids of the same set this one interacts with ([`FluidParams::fluid_groups`]);
    /// `InteractionGroups::all()` interacts with every fluid that says the same.
    pub fn fluid_groups(mut self, g: InteractionGroups) -> Self {
        self.params.fluid_groups = g;
        self
    }

    /// Phases mixed in every particle ([`FluidParams::mixture`], see [`crate::mixture`]);
    /// sets the fluid's viscosity to the largest phase's (the solvers' explicit limit; each
    /// particle's is its phases').
    pub fn mixture(mut self, m: crate::mixture::Mixture) -> Self {
        self.params.viscosity = m.max_viscosity();
        self.params.mixture = Some(m);
        self
    }

    /// Validates and returns the parameters (the particle mass follows the spacing unless set).
    ///
    /// # Errors
    ///
    /// [`SphError::InvalidParameter`] naming the first bad field (see
    /// [`FluidParams::validate`]).
    pub fn build(mut self) -> SphResult<FluidParams> {
        if !self.mass_given {
            let s = self.params.particle_spacing;
            self.params.particle_mass = self.params.rest_density * s * s * s;
        }
        if let Some(sigma) = self.sigma {
            let p = &self.params;
            self.params.surface_tension = crate::forces::surface_tension::gamma_for_sigma(
                sigma,
                p.rest_density,
                p.smoothing_length,
            );
        }
        self.params.validate()?;
        Ok(self.params)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field_of(r: SphResult<FluidParams>) -> &'static str {
        match r {
            Err(SphError::InvalidParameter { field, .. }) => field,
            other => panic!("expected an invalid parameter, got {other:?}"),
        }
    }

    /// The water preset is DFSPH with wall density, and keeps it with any solver, Clavet
    /// included; an explicit choice always holds (Clavet can meet walls by contact only).
    /// The paper preset stays WCSPH without wall density.
    #[test]
    fn wall_density_follows_the_preset_unless_set() {
        let w = FluidParamsBuilder::water(0.05).build().unwrap();
        assert!(matches!(w.solver, Solver::Dfsph(_)) && w.wall_density);
        let c = FluidParamsBuilder::water(0.05).solver(Solver::clavet());
        assert!(c.clone().build().unwrap().wall_density);
        assert!(!c.wall_density(false).build().unwrap().wall_density);
        let p = FluidParamsBuilder::water(0.05).solver(Solver::pbf());
        assert!(p.clone().build().unwrap().wall_density);
        assert!(!p.wall_density(false).build().unwrap().wall_density);
        let paper = FluidParamsBuilder::paper().build().unwrap();
        assert!(paper.solver == Solver::Wcsph && !paper.wall_density);
        let paper_df = FluidParamsBuilder::paper().solver(Solver::dfsph()).build();
        assert!(!paper_df.unwrap().wall_density);
    }

    #[test]
    fn wall_viscosity_is_checked_and_needs_wall_density() {
        let b = || FluidParamsBuilder::water(0.05);
        assert!(b().wall_viscosity(0.5).build().is_ok());
        assert_eq!(field_of(b().wall_viscosity(-1.0).build()), "wall_viscosity");
        assert_eq!(
            field_of(b().wall_viscosity(Real::NAN).build()),
            "wall_viscosity"
        );
        let no_walls = b().wall_density(false).wall_viscosity(0.5).build();
        assert_eq!(field_of(no_walls), "wall_viscosity");
        let clavet = b().solver(Solver::clavet()).wall_density(true);
        assert!(clavet.clone().build().is_ok());
        assert_eq!(
            field_of(clavet.wall_viscosity(0.5).build()),
            "wall_viscosity"
        );
    }

    #[test]
    fn presets_are_valid() {
        let w = FluidParamsBuilder::water(0.05).build().unwrap();
        assert!((w.particle_mass - 0.125).abs() < 1e-6);
        let p = FluidParamsBuilder::paper().build().unwrap();
        assert_eq!(p.particle_mass, 1.0);
        assert_eq!(p.rest_density, 8.0);
        assert_eq!(p.smoothing_length, 0.4);
    }

    #[test]
    fn bad_values_name_their_field() {
        assert_eq!(
            field_of(FluidParamsBuilder::water(Real::NAN).build()),
            "particle_spacing"
        );
        assert_eq!(
            field_of(FluidParamsBuilder::water(-0.1).build()),
            "particle_spacing"
        );
        assert_eq!(
            field_of(FluidParamsBuilder::water(0.0).build()),
            "particle_spacing"
        );
        assert_eq!(
            field_of(FluidParamsBuilder::water(Real::INFINITY).build()),
            "particle_spacing"
        );
        assert_eq!(
            field_of(FluidParamsBuilder::water(0.1).particle_mass(0.0).build()),
            "particle_mass"
        );
        assert_eq!(
            field_of(
                FluidParamsBuilder::water(0.1)
                    .particle_mass(Real::NAN)
                    .build()
            ),
            "particle_mass"
        );
        assert_eq!(
            field_of(FluidParamsBuilder::water(0.1).rest_density(-1.0).build()),
            "rest_density"
        );
        assert_eq!(
            field_of(
                FluidParamsBuilder::water(0.1)
                    .smoothing_length(0.05)
                    .build()
            ),
            "smoothing_length"
        );
        assert_eq!(
            field_of(FluidParamsBuilder::water(0.1).smoothing_length(1.0).build()),
            "smoothing_length"
        );
        assert_eq!(
            field_of(FluidParamsBuilder::water(0.1).stiffness(0.0).build()),
            "stiffness"
        );
        assert_eq!(
            field_of(FluidParamsBuilder::water(0.1).viscosity(-1.0).build()),
            "viscosity"
        );
        assert_eq!(
            field_of(FluidParamsBuilder::water(0.1).restitution(1.5).build()),
            "restitution"
        );
        assert_eq!(
            field_of(FluidParamsBuilder::water(0.1).friction(Real::NAN).build()),
            "friction"
        );
        assert_eq!(
            field_of(FluidParamsBuilder::water(0.1).particle_radius(0.0).build()),
            "particle_radius"
        );
        let tait = EquationOfState::Tait {
            speed_of_sound: 10.0,
            exponent: 0.5,
        };
        assert_eq!(
            field_of(
                FluidParamsBuilder::water(0.1)
                    .equation_of_state(tait)
                    .build()
            ),
            "exponent"
        );
    }
}
