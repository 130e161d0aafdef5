//! Validation scenes against experiments and analytic solutions, and the runner that measures
//! their error and their cost. One place, used by `examples/error_vs_runtime.rs` (the report),
//! by `tests/validation.rs` and by anyone who wants to know how much accuracy a second of
//! compute buys.
//!
//! | scene | reference | errors |
//! |---|---|---|
//! | [`Scene::Hydrostatic`] | `p = ρ0·g·depth` | bottom pressure, RMS over depth, mean and max density error |
//! | [`Scene::MartinMoyceSquare`] | Martin & Moyce 1952, square column (n² = 1) | surge front Z(T), residual height H(T), Ritter bound |
//! | [`Scene::MartinMoyceN2`] | Martin & Moyce 1952, column 2a tall (n² = 2) | surge front Z(T), residual height H(τ), Ritter bound |
//! | [`Scene::KoshizukaOka`] | Koshizuka & Oka 1996, experiment | surge front Z(T), Ritter bound |
//! | [`Scene::Lobovsky`] | Lobovský et al. 2014, sensor 2 median and band | impact pressure: RMS against the median, first peak's height and time |
//! | [`Scene::TaylorGreen`] | 3D Taylor–Green vortex, Re = 100, periodic box (JAX-Fluids 64³ via jax-sph) | kinetic-energy decay: RMS relative error, initial dissipation rate, final energy |
//!
//! Every scene is built with the public API (the same [`crate::FluidWorld`],
//! [`crate::FluidParamsBuilder::water`] preset and rapier colliders a user would use) and is
//! deterministic. A run is one [`Method`] (solver) × one resolution × one [`TimePolicy`]; it
//! returns a [`RunRecord`] with the wall time, the particle-steps, every error and whether it
//! stayed stable. Reference data are read from `../shared/validation/` (see [`data`]).

#![cfg_attr(docsrs, doc(cfg(feature = "validation")))]

pub mod dam_break;
pub mod data;
pub mod hydrostatic;
pub mod lobovsky;
pub mod spreading;
pub mod taylor_green;

use crate::fluid::FluidHandle;
use crate::math::{Real, Vector};
use crate::pipeline::TimeStepping;
use crate::solver::Solver;
use crate::world::FluidWorld;
use crate::{SphResult, StepReport};
use std::time::Instant;

pub use data::Curve;

/// A pressure solver as the validation runs it: the solver and whether walls count in the
/// density (DFSPH, PBF and Clavet with walls; WCSPH, the paper's method, without).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Method {
    /// Name printed in reports (the solver's name).
    pub name: &'static str,
    /// The solver.
    pub solver: Solver,
    /// [`crate::FluidParams::wall_density`].
    pub wall_density: bool,
    /// [`crate::FluidParams::wcsph_pressure`] (WCSPH only).
    pub wcsph_pressure: crate::WcsphPressure,
    /// [`crate::FluidParams::wcsph_density`] (WCSPH only).
    pub wcsph_density: crate::WcsphDensity,
}

/// Every solver the crate has, as the report sweeps them. A new solver is one line here.
pub fn methods() -> Vec<Method> {
    vec![
        Method {
            name: Solver::Wcsph.name(),
            solver: Solver::Wcsph,
            wall_density: false,
            wcsph_pressure: crate::WcsphPressure::Paper,
            wcsph_density: crate::WcsphDensity::Summation,
        },
        Method {
            name: Solver::dfsph().name(),
            solver: Solver::dfsph(),
            wall_density: true,
            wcsph_pressure: crate::WcsphPressure::Paper,
            wcsph_density: crate::WcsphDensity::Summation,
        },
        Method {
            name: Solver::pbf().name(),
            solver: Solver::pbf(),
            wall_density: true,
            wcsph_pressure: crate::WcsphPressure::Paper,
            wcsph_density: crate::WcsphDensity::Summation,
        },
        // Clavet with walls in its densities: contact-only walls are non-wetting for its
        // cohesion, whose surface energy at the tank's corners and edges (2–3 times the
        // column's potential energy in the hydrostatic tank) turns into kinetic energy at any
        // step (docs/solvers.md, "Clavet's cohesion and its spawn lattice").
        Method {
            name: Solver::clavet().name(),
            solver: Solver::clavet(),
            wall_density: true,
            wcsph_pressure: crate::WcsphPressure::Paper,
            wcsph_density: crate::WcsphDensity::Summation,
        },
    ]
}

/// How a validation run chooses its time step. `dt_ref` is the step the adaptive policy
/// takes at the scene's characteristic speed (see [`RunRecord::dt_ref`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum TimePolicy {
    /// [`TimeStepping::Fixed`] at `dt_ref / 2`.
    FixedSmall,
    /// [`TimeStepping::Fixed`] at `2·dt_ref`: beyond the stability limits on purpose, to show
    /// what a too-large step costs in accuracy (or stability).
    FixedLarge,
    /// [`TimeStepping::Adaptive`] (Courant 0.4, the default), frames of one sampling interval.
    Adaptive,
}

impl TimePolicy {
    /// All policies, in report order.
    pub const ALL: [TimePolicy; 3] = [
        TimePolicy::FixedSmall,
        TimePolicy::FixedLarge,
        TimePolicy::Adaptive,
    ];

    /// Name printed in reports.
    pub fn name(self) -> &'static str {
        match self {
            TimePolicy::FixedSmall => "fixed dt/2",
            TimePolicy::FixedLarge => "fixed 2dt",
            TimePolicy::Adaptive => "adaptive",
        }
    }
}

/// A named error of a run against its reference (dimensionless; relative errors are
/// fractions, not per cent).
#[derive(Clone, Debug, PartialEq)]
pub struct Metric {
    /// Short name, e.g. `"front_rms"`.
    pub name: &'static str,
    /// Value (NaN when it could not be measured, e.g. the run stopped early).
    pub value: f64,
}

/// One simulated curve (same scaling as the reference it is compared with), for plots.
#[derive(Clone, Debug, PartialEq)]
pub struct SimCurve {
    /// What it is (`"front"`, `"height"`, `"bottom_pressure"`).
    pub name: &'static str,
    /// `(x, y)` points.
    pub points: Vec<(f64, f64)>,
}

/// Everything measured in one validation run.
#[derive(Clone, Debug)]
pub struct RunRecord {
    /// Scene name.
    pub scene: &'static str,
    /// Solver name.
    pub method: &'static str,
    /// Resolution: particles across the scene's reference length (see [`Scene::resolutions`]).
    pub resolution: usize,
    /// Particle spacing (m).
    pub spacing: Real,
    /// Particles at the start.
    pub particles: usize,
    /// Particles at the end (equal to `particles` unless something was lost).
    pub particles_end: usize,
    /// Particles outside the tank at the end.
    pub escaped: usize,
    /// Time-step policy.
    pub policy: TimePolicy,
    /// The scene's reference step (s): the adaptive policy's step at the characteristic speed.
    pub dt_ref: Real,
    /// Mean step actually taken (s): simulated time / substeps.
    pub dt_mean: Real,
    /// Simulated time reached (s).
    pub simulated: Real,
    /// Simulated time asked for (s).
    pub duration: Real,
    /// Wall time of the fluid steps (s), measurement and set-up excluded.
    pub wall_seconds: f64,
    /// Substeps taken.
    pub substeps: u64,
    /// Σ particles × substeps.
    pub particle_steps: u64,
    /// Errors against the reference; the first is the scene's primary error.
    pub errors: Vec<Metric>,
    /// Largest relative density error `(ρ − ρ0)/ρ0` over every particle and step.
    pub max_density_error: Real,
    /// The run reached its duration with no NaN, no lost or escaped particle and no energy
    /// created (kinetic energy above the initial potential energy).
    pub stable: bool,
    /// Why it is not stable (empty when stable).
    pub note: String,
    /// Simulated curves (for plots).
    pub curves: Vec<SimCurve>,
}

impl RunRecord {
    /// Particle-steps per second of wall time.
    pub fn particle_steps_per_second(&self) -> f64 {
        self.particle_steps as f64 / self.wall_seconds.max(1e-12)
    }

    /// The error named `name`, if measured.
    pub fn error(&self, name: &str) -> Option<f64> {
        self.errors.iter().find(|m| m.name == name).map(|m| m.value)
    }

    /// The magnitude of the scene's primary error (the first), NaN if the run was not stable.
    pub fn primary_error(&self) -> f64 {
        if !self.stable {
            return f64::NAN;
        }
        self.errors.first().map_or(f64::NAN, |m| m.value.abs())
    }
}

/// The validation scenes.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Scene {
    /// A column of water settling in a closed box ([`crate::scenes::HydrostaticTank`]).
    Hydrostatic,
    /// Martin & Moyce 1952, square column (n² = 1), quasi-2D.
    MartinMoyceSquare,
    /// Martin & Moyce 1952, column twice as tall as wide (n² = 2), quasi-2D.
    MartinMoyceN2,
    /// Koshizuka & Oka 1996 dam-break front, quasi-2D.
    KoshizukaOka,
    /// Lobovský et al. 2014 impact pressure on the downstream wall, quasi-2D.
    Lobovsky,
    /// The 3D Taylor–Green vortex at Re = 100 in a periodic box ([`taylor_green`]).
    TaylorGreen,
}

/// How thorough a sweep is: which resolutions each scene runs at.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Depth {
    /// A smoke run (the report's `--quick`).
    Quick,
    /// The report's default.
    Default,
    /// The report's `--full`.
    Full,
}

impl Scene {
    /// All scenes, in report order.
    pub const ALL: [Scene; 6] = [
        Scene::Hydrostatic,
        Scene::MartinMoyceSquare,
        Scene::MartinMoyceN2,
        Scene::KoshizukaOka,
        Scene::Lobovsky,
        Scene::TaylorGreen,
    ];

    /// Name printed in reports.
    pub fn name(self) -> &'static str {
        match self {
            Scene::Hydrostatic => "hydrostatic",
            Scene::MartinMoyceSquare => "martin_moyce_n2_1",
            Scene::MartinMoyceN2 => "martin_moyce_n2_2",
            Scene::KoshizukaOka => "koshizuka_oka",
            Scene::Lobovsky => "lobovsky",
            Scene::TaylorGreen => "taylor_green",
        }
    }

    /// The resolutions (particles across the reference length: the tank's width for the
    /// hydrostatic tank, the column's width for the dam breaks, the water height for
    /// Lobovský's) swept at `depth`, coarsest first.
    pub fn resolutions(self, depth: Depth) -> Vec<usize> {
        match (self, depth) {
            (Scene::Hydrostatic, Depth::Quick) => vec![3, 4, 5],
            (Scene::Hydrostatic, Depth::Default) => vec![6, 8, 12],
            (Scene::Hydrostatic, Depth::Full) => vec![6, 8, 12, 16],
            (Scene::Lobovsky, Depth::Quick) => vec![6, 8, 10],
            (Scene::Lobovsky, Depth::Default) => vec![10, 15, 20],
            (Scene::Lobovsky, Depth::Full) => vec![10, 15, 20, 30, 40],
            (Scene::TaylorGreen, Depth::Quick) => vec![8, 9, 10],
            (Scene::TaylorGreen, Depth::Default) => vec![12, 16, 20],
            (Scene::TaylorGreen, Depth::Full) => vec![12, 16, 20, 32],
            (_, Depth::Quick) => vec![4, 5, 6],
            (_, Depth::Default) => vec![8, 12, 16],
            (_, Depth::Full) => vec![8, 12, 16, 24, 32],
        }
    }

    /// The resolution the tests call "default" (the middle of the default sweep).
    pub fn default_resolution(self) -> usize {
        self.resolutions(Depth::Default)[1]
    }

    /// Name of the primary error (the first of [`RunRecord::errors`]).
    pub fn primary_error_name(self) -> &'static str {
        match self {
            Scene::Hydrostatic => "bottom_pressure",
            Scene::Lobovsky => "band_rms",
            Scene::TaylorGreen => "ekin_rms",
            _ => "front_rms",
        }
    }

    /// Runs the scene once. `progress` is called with the fraction of simulated time done.
    pub fn run(
        self,
        method: &Method,
        resolution: usize,
        policy: TimePolicy,
        progress: &mut dyn FnMut(Real),
    ) -> SphResult<RunRecord> {
        match self {
            Scene::Hydrostatic => hydrostatic::run(method, resolution, policy, progress),
            Scene::MartinMoyceSquare => dam_break::run(
                &dam_break::Case::martin_moyce_square()?,
                method,
                resolution,
                policy,
                progress,
            ),
            Scene::MartinMoyceN2 => dam_break::run(
                &dam_break::Case::martin_moyce_n2()?,
                method,
                resolution,
                policy,
                progress,
            ),
            Scene::KoshizukaOka => dam_break::run(
                &dam_break::Case::koshizuka_oka()?,
                method,
                resolution,
                policy,
                progress,
            ),
            Scene::Lobovsky => lobovsky::run(method, resolution, policy, progress),
            Scene::TaylorGreen => taylor_green::run(method, resolution, policy, progress),
        }
    }
}

/// The step the adaptive policy takes for `params` at speed `v` under gravity `g`
/// (the same limits as [`TimeStepping::Adaptive`] with Courant 0.4; keep in step with
/// the pipeline's `stable_time_step`).
pub fn reference_step(params: &crate::FluidParams, v: Real, g: Real) -> Real {
    let courant = 0.4;
    let cs = courant * params.particle_spacing;
    let mut dt = 2.0 * cs / (v + (v * v + 4.0 * g * cs).sqrt());
    if params.viscosity > 0.0 {
        let h = params.smoothing_length;
        dt = dt.min(params.rest_density * h * h / (30.0 * params.viscosity));
    }
    match params.solver {
        Solver::Wcsph => {
            let c = params.equation_of_state.speed_of_sound();
            dt = dt.min(courant * params.smoothing_length / (c + v));
        }
        Solver::Clavet(cl) => {
            let c = params.equation_of_state.speed_of_sound()
                * cl.stiffness
                    .max(cl.cohesion)
                    .max(cl.near_stiffness.unwrap_or(cl.stiffness))
                    .max(cl.springs.map_or(0.0, |s| s.stiffness))
                    .max(1e-6)
                    .sqrt();
            dt = dt.min(courant * params.smoothing_length / (c + v));
        }
        Solver::Dfsph(d) if g > 0.0 => {
            dt = dt.min((5.0 * d.max_density_error * params.particle_spacing / g).sqrt());
        }
        _ => {}
    }
    dt
}

/// What [`drive`] needs to know about a run.
pub(crate) struct DriveSpec<'a> {
    pub duration: Real,
    pub sample_dt: Real,
    pub dt_ref: Real,
    pub policy: TimePolicy,
    /// Kinetic energy above this means the run created energy (J). With gravity, the
    /// fluid's initial potential energy above the floor (the column starts at rest).
    pub energy_bound: f64,
    /// Gravity's magnitude (m/s², along −y; 0 for a scene without gravity): with it `drive`
    /// follows the mechanical energy `E_kin + Σ m·g·y` and the highest particle.
    pub gravity: Real,
    /// Is a position inside the container?
    pub inside: &'a dyn Fn(Vector) -> bool,
}

/// What [`drive`] measured.
pub(crate) struct Driven {
    pub wall_seconds: f64,
    pub substeps: u64,
    pub particle_steps: u64,
    pub simulated: Real,
    pub max_density_error: Real,
    pub note: String,
    pub particles_end: usize,
    pub escaped: usize,
    /// Largest `(E_kin + E_pot)/E_0 − 1` over the substeps (NaN without gravity).
    pub energy_excess: f64,
    /// Highest particle center over the substeps over the highest at the start (NaN without
    /// gravity).
    pub max_height: f64,
}

/// [`drive`]'s energy check, sampled after every substep: a fixed step is one substep, an
/// adaptive frame is sampled through the pipeline's [`crate::pipeline::SubstepProbe`], so a
/// transient between two frames is seen.
struct EnergyWatch {
    /// [`DriveSpec::energy_bound`] (J).
    energy_bound: f64,
    /// [`DriveSpec::gravity`] (m/s²).
    gravity: Real,
    /// The highest particle at the start (m).
    top0: f64,
    /// Largest `(E_kin + E_pot)/E_0 − 1` so far (NaN without gravity).
    excess: f64,
    /// Highest particle so far over `top0` (NaN without gravity).
    height: f64,
    /// The first sample whose kinetic energy passed [`DriveSpec::energy_bound`]: its time
    /// (s) and kinetic energy (J).
    over: Option<(f64, f64)>,
}

impl EnergyWatch {
    fn new(spec: &DriveSpec, f: &crate::Fluid) -> Self {
        let gravity = spec.gravity > 0.0;
        Self {
            energy_bound: spec.energy_bound,
            gravity: spec.gravity,
            top0: top(f) as f64,
            excess: if gravity { -1.0 } else { f64::NAN },
            height: if gravity { 1.0 } else { f64::NAN },
            over: None,
        }
    }

    /// One sample of `f` at time `t` (s).
    fn sample(&mut self, f: &crate::Fluid, t: f64) {
        let ke = f.kinetic_energy();
        if self.over.is_none() && ke > self.energy_bound {
            self.over = Some((t, ke));
        }
        if self.gravity > 0.0 {
            let mass = f.params().particle_mass;
            let e = ke + potential_energy(f, mass, self.gravity);
            self.excess = self.excess.max(e / self.energy_bound - 1.0);
            self.height = self.height.max(top(f) as f64 / self.top0);
        }
    }
}

/// The highest particle center's height (m).
fn top(f: &crate::Fluid) -> Real {
    f.positions().iter().map(|p| p.y).fold(Real::MIN, Real::max)
}

/// Steps `world` (rapier is not stepped: the containers are fixed; its broad-phase must be
/// filled) for `spec.duration` under `spec.policy`, calling `sample(t, world)` at `t = 0` and
/// then once per sampling interval. Stops early when the run becomes unstable: particles not
/// finite, lost or outside the container (checked after every step, a 5 ms frame at the
/// adaptive policy), or a kinetic energy above `spec.energy_bound` (checked, with the
/// mechanical energy and the highest particle, after every substep; the time the probe takes
/// is left out of the wall time).
pub(crate) fn drive(
    world: &mut FluidWorld,
    fluid: FluidHandle,
    spec: &DriveSpec,
    sample: &mut dyn FnMut(Real, &FluidWorld),
    progress: &mut dyn FnMut(Real),
) -> SphResult<Driven> {
    let (dt, stepping) = match spec.policy {
        TimePolicy::FixedSmall => (0.5 * spec.dt_ref, TimeStepping::Fixed),
        TimePolicy::FixedLarge => (2.0 * spec.dt_ref, TimeStepping::Fixed),
        TimePolicy::Adaptive => (spec.sample_dt, TimeStepping::default()),
    };
    world.pipeline.time_stepping = stepping;
    world.physics.integration_parameters.dt = dt;
    let n0 = world.fluids[fluid].len();
    let mut out = Driven {
        wall_seconds: 0.0,
        substeps: 0,
        particle_steps: 0,
        simulated: 0.0,
        max_density_error: 0.0,
        note: String::new(),
        particles_end: n0,
        escaped: 0,
        energy_excess: f64::NAN,
        max_height: f64::NAN,
    };
    let mut watch = EnergyWatch::new(spec, &world.fluids[fluid]);
    // A fixed step is one substep: sampled after it, outside the timed step.
    let per_substep = matches!(stepping, TimeStepping::Adaptive { .. });
    sample(0.0, world);
    let mut next_sample = spec.sample_dt as f64;
    let mut t = 0.0f64;
    let end = spec.duration as f64;
    while t < end - 1e-9 {
        let t0 = Instant::now();
        let mut probing = 0.0;
        let report: StepReport = if per_substep {
            let mut probe = |elapsed: Real, fluids: &crate::FluidSet| {
                let p0 = Instant::now();
                watch.sample(&fluids[fluid], t + elapsed as f64);
                probing += p0.elapsed().as_secs_f64();
            };
            let w = &mut *world;
            let p = &mut w.physics;
            w.pipeline
                .step_with_parameters_probed(
                    p.gravity,
                    &p.integration_parameters,
                    &mut w.fluids,
                    (&mut p.bodies, &p.colliders, &p.broad_phase),
                    Some(&mut probe),
                )?
                .clone()
        } else {
            world.step_fluids()?.clone()
        };
        out.wall_seconds += t0.elapsed().as_secs_f64() - probing;
        t += dt as f64;
        out.substeps += report.substeps as u64;
        out.particle_steps += report.substeps as u64 * n0 as u64;
        out.max_density_error = out.max_density_error.max(report.max_density_error);
        let f = &world.fluids[fluid];
        if !per_substep {
            watch.sample(f, t);
        }
        out.particles_end = f.len();
        if report.non_finite > 0 || report.quarantined > 0 {
            out.note = format!("{} non-finite particles at t = {t:.4} s", report.non_finite);
        } else if f.len() != n0 {
            out.note = format!("{} particles lost at t = {t:.4} s", n0 - f.len());
        } else {
            out.escaped = f.positions().iter().filter(|&&p| !(spec.inside)(p)).count();
            if out.escaped > 0 {
                out.note = format!("{} particles escaped at t = {t:.4} s", out.escaped);
            } else if let Some((at, ke)) = watch.over {
                out.note = format!(
                    "kinetic energy {ke:.3e} J above the initial potential energy {:.3e} J at t = {at:.4} s",
                    spec.energy_bound
                );
            }
        }
        (out.energy_excess, out.max_height) = (watch.excess, watch.height);
        if !out.note.is_empty() {
            out.simulated = t as Real;
            return Ok(out);
        }
        if t >= next_sample - 1e-9 {
            sample(t as Real, world);
            progress((t / end) as Real);
            next_sample += spec.sample_dt as f64;
        }
    }
    out.simulated = t as Real;
    Ok(out)
}

/// What a run's [`RunRecord`] states about its set-up, known before it is driven; every
/// scene fills one and [`RunSetup::record`] adds what [`drive`] measured.
pub(crate) struct RunSetup {
    pub scene: &'static str,
    pub method: &'static str,
    pub resolution: usize,
    /// Particle spacing (m).
    pub spacing: Real,
    /// Particles at the start.
    pub particles: usize,
    pub policy: TimePolicy,
    pub dt_ref: Real,
    /// Simulated time asked for (s).
    pub duration: Real,
}

impl RunSetup {
    /// The run's record: this set-up, what `driven` measured, and the scene's `errors`
    /// (primary first) and `curves`.
    pub(crate) fn record(
        self,
        driven: Driven,
        mut errors: Vec<Metric>,
        curves: Vec<SimCurve>,
    ) -> RunRecord {
        errors.extend(metrics([
            ("energy_excess", driven.energy_excess),
            ("max_height", driven.max_height),
        ]));
        RunRecord {
            scene: self.scene,
            method: self.method,
            resolution: self.resolution,
            spacing: self.spacing,
            particles: self.particles,
            particles_end: driven.particles_end,
            escaped: driven.escaped,
            policy: self.policy,
            dt_ref: self.dt_ref,
            dt_mean: driven.simulated / driven.substeps.max(1) as Real,
            simulated: driven.simulated,
            duration: self.duration,
            wall_seconds: driven.wall_seconds,
            substeps: driven.substeps,
            particle_steps: driven.particle_steps,
            errors,
            max_density_error: driven.max_density_error,
            stable: driven.note.is_empty(),
            note: driven.note,
            curves,
        }
    }
}

/// `Σ m·g·y` over `fluid`'s particles of mass `mass` (J): their potential energy above the
/// floor `y = 0`, the most kinetic energy a falling column can gain ([`DriveSpec::energy_bound`]).
pub(crate) fn potential_energy(fluid: &crate::Fluid, mass: Real, g: Real) -> f64 {
    fluid
        .positions()
        .iter()
        .map(|p| (mass * g * p.y) as f64)
        .sum()
}

/// Is a position inside the box from the origin to `max`, widened by `eps` on every side
/// (the round-off of particles resting on a wall)? For [`DriveSpec::inside`].
pub(crate) fn inside_box(max: Vector, eps: Real) -> impl Fn(Vector) -> bool {
    move |p: Vector| p.cmpge(Vector::splat(-eps)).all() && p.cmple(max + Vector::splat(eps)).all()
}

/// The named errors of a run, in the order given (the primary error first).
pub(crate) fn metrics<const N: usize>(named: [(&'static str, f64); N]) -> Vec<Metric> {
    named
        .into_iter()
        .map(|(name, value)| Metric { name, value })
        .collect()
}

/// Linear interpolation of `samples` (sorted by x) at `x`; `None` outside their range.
pub fn interpolate(samples: &[(f64, f64)], x: f64) -> Option<f64> {
    let k = samples.partition_point(|s| s.0 < x);
    if k == 0 {
        return (samples.first()?.0 == x).then(|| samples[0].1);
    }
    let b = *samples.get(k)?;
    let a = samples[k - 1];
    if b.0 == a.0 {
        return Some(b.1);
    }
    Some(a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0))
}

/// RMS of the relative deviation `(sim − ref)/ref` of `sim` (interpolated) from every point
/// of `reference` whose x lies in `x_range` and within the simulated range. NaN if a point in
/// `x_range` lies beyond the simulated range (the run stopped early) or none is left.
pub fn rms_relative(sim: &[(f64, f64)], reference: &Curve, x_range: (f64, f64)) -> f64 {
    let mut sum = 0.0;
    let mut n = 0usize;
    for &(x, y) in &reference.points {
        if x < x_range.0 || x > x_range.1 {
            continue;
        }
        match interpolate(sim, x) {
            Some(s) => {
                sum += ((s - y) / y).powi(2);
                n += 1;
            }
            None => return f64::NAN,
        }
    }
    if n == 0 {
        return f64::NAN;
    }
    (sum / n as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_and_rms() {
        let sim = [(0.0, 1.0), (1.0, 2.0), (2.0, 4.0)];
        assert_eq!(interpolate(&sim, 0.5), Some(1.5));
        assert_eq!(interpolate(&sim, 2.0), Some(4.0));
        assert_eq!(interpolate(&sim, 0.0), Some(1.0));
        assert_eq!(interpolate(&sim, 2.5), None);
        let reference = Curve {
            label: "r".into(),
            points: vec![(0.5, 1.5), (1.5, 2.0)],
        };
        // Deviations 0 and (3 − 2)/2 = 0.5: RMS = sqrt(0.25/2).
        let e = rms_relative(&sim, &reference, (0.0, 10.0));
        assert!((e - (0.125f64).sqrt()).abs() < 1e-12);
        assert_eq!(rms_relative(&sim, &reference, (0.0, 1.0)), 0.0);
        // A point beyond the simulated range (the run stopped early) gives NaN.
        let late = Curve {
            label: "r".into(),
            points: vec![(3.0, 1.0)],
        };
        assert!(rms_relative(&sim, &late, (0.0, 10.0)).is_nan());
    }

    #[test]
    fn missing_data_is_a_typed_error_naming_the_path() {
        let dir = std::path::Path::new("/nonexistent/validation");
        let source = data::CurveSource {
            folder: "x",
            file: "y.csv",
            x_col: "a",
            y_col: "b",
            filter: None,
            label: "l",
        };
        let err = data::read_curve_in(dir, &source).unwrap_err();
        match err {
            crate::SphError::ReferenceData { path, .. } => assert!(path.contains("nonexistent")),
            e => panic!("{e:?}"),
        }
    }

    #[test]
    fn reference_data_load_with_the_documented_scalings() {
        let c = dam_break::Case::martin_moyce_n2().unwrap();
        assert_eq!(c.front.points.len(), 15); // Table 2 via Ocellaris
        assert_eq!(c.front.points[0], (0.41, 1.11));
        assert_eq!(c.height.as_ref().unwrap().points.len(), 17);
        let s = dam_break::Case::martin_moyce_square().unwrap();
        assert_eq!(s.front.points.len(), 20); // jax-sph only
        assert_eq!(s.height.as_ref().unwrap().points.len(), 8); // (0, 1) dropped
        let k = dam_break::Case::koshizuka_oka().unwrap();
        assert_eq!(k.front.points.len(), 8); // experiment, (0, 1) dropped
        let m = dam_break::Case::koshizuka_oka_mps().unwrap();
        assert_eq!(m.front.points.len(), 17); // MPS, (0, 1.002) dropped
        assert_eq!(m.front.points[16], (2.943, 3.997));
    }
}
