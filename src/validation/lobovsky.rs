//! Lobovský et al. (2014): impact pressure of a dam break on the downstream wall, H = 0.3 m,
//! against the experiment's sensor 2 (15 mm above the floor): median and 2.5–97.5 % band of
//! the repeated runs (`lobovsky_2014/sensor2_percentiles.csv`), `p/(ρ g H)` against
//! `T = t·sqrt(g/H)`.
//!
//! ## Set-up (as the data's README gives it)
//!
//! Tank 1.610 m long and 0.6 m tall (AQUAgpusph's 2D case), a water column 0.600 m long and
//! H = 0.300 m high against the back wall, released at `t = 0`. Quasi-2D like the other dam
//! breaks: a slab of [`super::dam_break::LAYERS`] particle layers between two walls. Water
//! preset at spacing `H / resolution`, the run's solver. Runs to T = 4.5: the first impact
//! (T ≈ 2.4–3) and the run-up that follows, before the reflected wave returns.
//!
//! ## Measurement
//!
//! The pressure at a sensor is what the wall is told: the fluid's pressure extrapolated to the
//! sensor's point on the wall as Adami et al. (2012) give their walls' pressure
//! ([`WallSensor`]: the Shepard average of the pressures of the particles within the kernel
//! support, plus `ρ_f·g·(x_w − x_f)` for each, the weight of the fluid between a particle and
//! the wall; zero when no particle is there: the sensor is dry). The array read is each
//! solver's own: WCSPH's equation of state, DFSPH's sum of both solves' pressures over the
//! step (all the pressure the step applied), PBF's `λ` as a pressure, Clavet's linear
//! equation of state (an estimate, not its relaxation's force). The data's README gives no
//! diameter for the sensors' faces; [`WallSensor::radius`] averages over one, the report
//! reads the point (a face smaller than the kernel's support, `h` = 40 mm at N = 15, changes
//! a kernel-smoothed field little; `examples/impact_probe.rs` measures the reading against the
//! force the wall receives).
//!
//! Errors over the first impact, `2.0 ≤ T ≤ 4.5`:
//! - `band_rms`: RMS of `(p_sim − p_median)` at the data's times, over the median's peak;
//! - `peak`: relative error of the first peak's height, `(max p_sim − max p_median)/max p_median`;
//! - `peak_time`: `T` of the simulated peak minus `T` of the median's peak;
//! - `peak_filtered`: relative error of the first peak after the same moving average is
//!   applied to the simulated curve and to the median (see [`filter_width`]);
//! - `impulse`: relative error of the pressure impulse `∫ p dT` over [`IMPACT`].
//!
//! ## What a raw peak is made of, and why the filtered peak and the impulse
//!
//! A sample of the raw curve is one instant of the fluid next to the wall. The layer that meets
//! the wall is stopped within a few steps; an incompressible solver (DFSPH, PBF) stops it
//! within one, with a pressure of order `ρ·U·s/dt` that grows without bound as `dt → 0`: in
//! incompressible theory the impact pressure is a delta and only the *pressure impulse* is
//! defined (Cooker & Peregrine 1995, J. Fluid Mech. 297, 193–214). A weakly compressible
//! solver rings at its own speed of sound instead (water hammer `ρ·c·U`, here `c` = 30 m/s).
//! Either way the raw maximum is one sample of a spike whose height depends on `dt` and on
//! the phase of the sampling, not on the flow. A sensor whose support is `h` wide cannot
//! resolve times shorter than the flow takes to cross it, `h/U`; [`filter_width`] is that
//! time with Ritter's front speed `U = 2·sqrt(g·H)`, and the same moving average is applied
//! to the experiment's median before the peaks are compared (the filter lowers the median's
//! own peak by a few per cent, so a real peak survives it).

use super::data::{Curve, read_curve};
use super::{
    DriveSpec, Method, RunRecord, RunSetup, SimCurve, TimePolicy, drive, inside_box, interpolate,
    metrics, potential_energy,
};
use crate::error::{SphError, SphResult};
use crate::fluid::{Fluid, FluidHandle, try_lattice};
use crate::kernel::KernelKind;
use crate::math::{Real, Vector};
use crate::params::{FluidParams, FluidParamsBuilder};
use crate::scenes::add_closed_box;
use crate::world::FluidWorld;

/// Water height H (m).
pub const H: Real = 0.3;
/// Tank length, back wall to the downstream wall (m).
pub const TANK_LENGTH: Real = 1.61;
/// Column length (m).
pub const COLUMN_LENGTH: Real = 0.6;
/// Tank height (m).
pub const TANK_HEIGHT: Real = 0.6;
/// Heights of sensors 1–4 above the floor on the downstream wall (m).
pub const SENSOR_HEIGHTS: [Real; 4] = [0.003, 0.015, 0.030, 0.080];
/// The first impact: `T` range of the errors.
pub const WINDOW: (f64, f64) = (2.0, 4.5);
/// The `T` range of the pressure impulse: the first impact, from before the water arrives
/// (the experiment's median rises at T ≈ 2.45) to the end of the median's decay (0.9 at T = 3).
pub const IMPACT: (f64, f64) = (2.0, 3.0);

/// Width in `T` of the moving average behind the `peak_filtered` error, for a run
/// with `resolution` particles across H: the time the flow at Ritter's front speed
/// `2·sqrt(g·H)` takes to cross the sensor's support `h = 2s = 2H/resolution`, i.e.
/// `h/(2H)` in units of `sqrt(H/g)`.
pub fn filter_width(resolution: usize) -> f64 {
    1.0 / resolution.max(1) as f64
}

/// Centred moving average of width `width` (in x) of `points` (sorted by x): each point
/// replaced by the mean of the points within `width/2` of it.
pub fn moving_average(points: &[(f64, f64)], width: f64) -> Vec<(f64, f64)> {
    let (mut lo, mut hi, mut sum) = (0usize, 0usize, 0.0f64);
    points
        .iter()
        .map(|&(x, _)| {
            while hi < points.len() && points[hi].0 <= x + 0.5 * width {
                sum += points[hi].1;
                hi += 1;
            }
            while points[lo].0 < x - 0.5 * width {
                sum -= points[lo].1;
                lo += 1;
            }
            (x, sum / (hi - lo) as f64)
        })
        .collect()
}

/// `∫ p dT` of `points` over `range` (trapezoids, the curve linearly interpolated at the
/// range's ends).
pub fn impulse(points: &[(f64, f64)], range: (f64, f64)) -> f64 {
    let mut inside: Vec<(f64, f64)> = Vec::new();
    if let Some(p) = interpolate(points, range.0) {
        inside.push((range.0, p));
    }
    inside.extend(
        points
            .iter()
            .copied()
            .filter(|p| p.0 > range.0 && p.0 < range.1),
    );
    if let Some(p) = interpolate(points, range.1) {
        inside.push((range.1, p));
    }
    inside
        .windows(2)
        .map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0))
        .sum()
}

const G: Real = 9.81;

/// Sensor 2's data: median and the 2.5 % and 97.5 % percentiles, `p/(ρ g H)` against T.
#[derive(Clone, Debug)]
pub struct Sensor2 {
    /// Median of the repeated runs.
    pub median: Curve,
    /// 2.5th percentile.
    pub low: Curve,
    /// 97.5th percentile.
    pub high: Curve,
}

impl Sensor2 {
    /// Reads `lobovsky_2014/sensor2_percentiles.csv`.
    pub fn load() -> SphResult<Self> {
        let read = |col: &str, label: &str| {
            read_curve(
                "lobovsky_2014",
                "sensor2_percentiles.csv",
                "T_t_sqrt_g_over_H",
                col,
                None,
                label,
            )
        };
        Ok(Self {
            median: read(
                "p_over_rho_g_H_median",
                "Lobovský et al. 2014, sensor 2, median",
            )?,
            low: read("p_over_rho_g_H_p2.5", "2.5 %")?,
            high: read("p_over_rho_g_H_p97.5", "97.5 %")?,
        })
    }

    /// `(T, p)` of the median's highest point inside [`WINDOW`].
    pub fn peak(&self) -> (f64, f64) {
        window_peak(&self.median.points)
    }
}

/// `(T, p)` of the highest of `points` inside [`WINDOW`] (the first of equal heights;
/// `(0, f64::MIN)` when none is inside).
fn window_peak(points: &[(f64, f64)]) -> (f64, f64) {
    points
        .iter()
        .copied()
        .filter(|p| p.0 >= WINDOW.0 && p.0 <= WINDOW.1)
        .fold((0.0, f64::MIN), |a, p| if p.1 > a.1 { p } else { a })
}

/// The pressure at `point` read from `fluid` (Shepard average over the kernel support; 0 when
/// no particle is within it).
pub fn probe(fluid: &Fluid, point: Vector) -> Real {
    let h = fluid.params().smoothing_length;
    let (mut pw, mut w) = (0.0f64, 0.0f64);
    for (x, p) in fluid.positions().iter().zip(fluid.pressures()) {
        let d = (*x - point).length();
        if d < h {
            let k = KernelKind::CubicSpline.w(d, h) as f64;
            pw += k * *p as f64;
            w += k;
        }
    }
    if w > 0.0 { (pw / w) as Real } else { 0.0 }
}

/// The sensor at height `y` (m) on the downstream wall, on the slab's centre plane (`depth`
/// the slab's depth along z): the wall pressure at that point ([`WallSensor`], radius 0; the
/// data's README gives no diameter for the sensors' faces, see the module's doc).
pub fn downstream_sensor(y: Real, depth: Real) -> WallSensor {
    WallSensor {
        center: Vector::new(TANK_LENGTH, y, 0.5 * depth),
        normal: -Vector::X,
        radius: 0.0,
    }
}

/// A pressure sensor on a wall: what the wall is told, read from the fluid next to it.
///
/// The reading is the fluid's pressure *extrapolated to the wall* as Adami, Hu & Adams (2012,
/// J. Comput. Phys. 231, 7057–7075, eq. 27) give their wall particles' pressure,
///
/// `p_w(x_w) = (Σ_f p_f W(x_w − x_f) + (g − a_w)·Σ_f ρ_f (x_w − x_f) W(x_w − x_f)) / Σ_f W(x_w − x_f)`,
///
/// a Shepard (kernel-weighted) average of the pressures of the particles `f` within the kernel
/// support `h` of the wall point, plus the pressure the fluid's weight and the wall's
/// acceleration `a_w` put between a particle and the wall (the wall is that much deeper than
/// the particle: a settled column's side wall reads `ρ0·g·depth` at its own depth, not at the
/// particles' mean depth). The kernel is the cubic spline of support `h`. A physical sensor
/// has a face of finite area and reads the mean pressure over it: the reading is averaged
/// over the disc of [`WallSensor::radius`] around [`WallSensor::center`] in the wall's plane
/// (equal-area quadrature, 24 points; one point when the radius is 0). Zero when no particle
/// is within `h` of any point of the face: the sensor is dry.
///
/// # Examples
/// ```
/// use rapier_sph::math::Vector;
/// use rapier_sph::validation::lobovsky::WallSensor;
/// use rapier_sph::{Fluid, FluidParamsBuilder};
/// // One particle at rest density with a pressure of 100 Pa, 1 cm in front of a wall at x = 0.
/// let params = FluidParamsBuilder::water(0.02).build().unwrap();
/// let mut fluid = Fluid::new(params).unwrap();
/// fluid.add_particles(&[Vector::new(0.01, 0.5, 0.0)]).unwrap();
/// let sensor = WallSensor { center: Vector::new(0.0, 0.5, 0.0), normal: Vector::X, radius: 0.0 };
/// // A dry sensor reads 0, whatever the gravity.
/// let far = WallSensor { center: Vector::new(0.0, 5.0, 0.0), ..sensor };
/// assert_eq!(far.read(&fluid, Vector::new(0.0, -9.81, 0.0), Vector::ZERO), 0.0);
/// // A particle level with the sensor adds nothing under gravity along y: the sensor reads
/// // the particle's own pressure (0 before the fluid stepped).
/// assert_eq!(sensor.read(&fluid, Vector::new(0.0, -9.81, 0.0), Vector::ZERO), 0.0);
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct WallSensor {
    /// The centre of the sensor's face, on the wall's surface (m).
    pub center: Vector,
    /// The wall's unit normal, pointing into the fluid.
    pub normal: Vector,
    /// The radius of the sensor's face (m); 0 reads the wall at [`WallSensor::center`] only.
    pub radius: Real,
}

impl WallSensor {
    /// The mean wall pressure over the sensor's face (Pa), `gravity` the world's (m/s²) and
    /// `wall_acceleration` the wall's (zero for a fixed wall); see the type's doc.
    pub fn read(&self, fluid: &Fluid, gravity: Vector, wall_acceleration: Vector) -> Real {
        const RINGS: usize = 3;
        const ANGLES: usize = 8;
        let n = self.normal.normalize_or_zero();
        let e = if n.x.abs() < 0.9 {
            Vector::X
        } else {
            Vector::Y
        };
        let t1 = n.cross(e).normalize_or_zero();
        let t2 = n.cross(t1);
        let mut points = Vec::with_capacity(RINGS * ANGLES);
        if self.radius > 0.0 {
            for k in 0..RINGS {
                // Equal-area rings: the k-th holds the area between radii sqrt(k/RINGS)·R and
                // sqrt((k + 1)/RINGS)·R, sampled at its area's midpoint.
                let r = self.radius * ((k as Real + 0.5) / RINGS as Real).sqrt();
                for j in 0..ANGLES {
                    let a = std::f32::consts::TAU as Real * (j as Real + 0.5 * (k % 2) as Real)
                        / ANGLES as Real;
                    points.push(self.center + r * (a.cos() * t1 + a.sin() * t2));
                }
            }
        } else {
            points.push(self.center);
        }
        let h = fluid.params().smoothing_length;
        let accel = gravity - wall_acceleration;
        let (mut sum, mut wet) = (0.0f64, 0usize);
        for &xw in &points {
            let (mut pw, mut w) = (0.0f64, 0.0f64);
            for ((x, p), rho) in fluid
                .positions()
                .iter()
                .zip(fluid.pressures())
                .zip(fluid.densities())
            {
                let r = xw - *x;
                let d = r.length();
                if d < h {
                    let k = KernelKind::CubicSpline.w(d, h) as f64;
                    pw += k * (*p as f64 + *rho as f64 * accel.dot(r) as f64);
                    w += k;
                }
            }
            if w > 0.0 {
                sum += pw / w;
                wet += 1;
            }
        }
        // A dry point of a partly wet face reads 0, as a dry patch of a real face presses
        // nothing.
        if wet > 0 {
            (sum / points.len() as f64) as Real
        } else {
            0.0
        }
    }
}

/// Runs the scene once (see [`super::Scene::run`]). `resolution` is the number of particles
/// across H.
pub fn run(
    method: &Method,
    resolution: usize,
    policy: TimePolicy,
    progress: &mut dyn FnMut(Real),
) -> SphResult<RunRecord> {
    if resolution < 2 {
        return Err(SphError::InvalidParameter {
            field: "resolution",
            value: resolution as f64,
            reason: "at least 2 particles across the water height",
        });
    }
    let data = Sensor2::load()?;
    let mut tank = Tank::new(method, resolution)?;
    let params = &tank.params;
    let dt_ref = super::reference_step(params, 2.0 * (G * H).sqrt(), G);
    let scale = (G as f64 / H as f64).sqrt();
    let duration = (WINDOW.1 / scale) as Real;
    let p_ref = params.rest_density as f64 * G as f64 * H as f64;
    let tank_max = tank.max;
    let inside = inside_box(tank_max, 1e-4 * tank_max.max_element());
    let mut sensors: Vec<Vec<(f64, f64)>> = vec![Vec::new(); SENSOR_HEIGHTS.len()];
    let sensor = |y: Real| downstream_sensor(y, tank_max.z);
    let fluid = tank.fluid;
    let driven = drive(
        &mut tank.world,
        fluid,
        &DriveSpec {
            duration,
            sample_dt: duration / 400.0,
            dt_ref,
            policy,
            energy_bound: tank.energy_bound,
            gravity: G,
            inside: &inside,
        },
        &mut |t, world| {
            let f = &world.fluids[fluid];
            let gravity = world.physics.gravity;
            for (k, &y) in SENSOR_HEIGHTS.iter().enumerate() {
                let p = sensor(y).read(f, gravity, Vector::ZERO);
                sensors[k].push((t as f64 * scale, p as f64 / p_ref));
            }
        },
        progress,
    )?;
    let [band_rms, peak, peak_time, peak_filtered, impulse] =
        first_impact_errors(&sensors[1], &data, filter_width(resolution));
    let setup = RunSetup {
        scene: super::Scene::Lobovsky.name(),
        method: method.name,
        resolution,
        spacing: tank.params.particle_spacing,
        particles: tank.particles,
        policy,
        dt_ref,
        duration,
    };
    let names = ["sensor_1", "sensor_2", "sensor_3", "sensor_4"];
    Ok(setup.record(
        driven,
        metrics([
            ("band_rms", band_rms),
            ("peak", peak),
            ("peak_time", peak_time),
            ("peak_filtered", peak_filtered),
            ("impulse", impulse),
        ]),
        sensors
            .into_iter()
            .zip(names)
            .map(|(points, name)| SimCurve { name, points })
            .collect(),
    ))
}

/// The tank at the start of a run: the closed box (its walls rapier colliders), the water
/// column on a lattice at rest against the back wall.
struct Tank {
    world: FluidWorld,
    fluid: FluidHandle,
    params: FluidParams,
    /// The box's far corner (its near corner is the origin).
    max: Vector,
    particles: usize,
    /// The column's potential energy (J), see [`super::DriveSpec`].
    energy_bound: f64,
}

impl Tank {
    /// The tank for `method` at `resolution` particles across H: the water preset at spacing
    /// `H / resolution`, the box [`super::dam_break::LAYERS`] spacings deep.
    fn new(method: &Method, resolution: usize) -> SphResult<Self> {
        let params = FluidParamsBuilder::water(H / resolution as Real)
            .solver(method.solver)
            .wall_density(method.wall_density)
            .wcsph_pressure(method.wcsph_pressure)
            .wcsph_density(method.wcsph_density)
            .build()?;
        let s = params.particle_spacing;
        let layers = super::dam_break::LAYERS;
        let max = Vector::new(TANK_LENGTH, TANK_HEIGHT, layers as Real * s);
        let mut world = FluidWorld::new();
        add_closed_box(&mut world, Vector::ZERO, max, (4.0 * s).max(0.05));
        world.physics.step();
        let mut fluid = Fluid::new(params.clone())?;
        let nx = (COLUMN_LENGTH / s).round() as usize;
        fluid.add_particles(&try_lattice(
            Vector::splat(0.5 * s),
            nx,
            resolution,
            layers,
            s,
        )?)?;
        let particles = fluid.len();
        let energy_bound = potential_energy(&fluid, params.particle_mass, G);
        let fluid = world.fluids.insert(fluid);
        Ok(Self {
            world,
            fluid,
            params,
            max,
            particles,
            energy_bound,
        })
    }
}

/// `[band_rms, peak, peak_time, peak_filtered, impulse]` of sensor 2's simulated curve `sim`
/// against the median of `data` over [`WINDOW`] (the impulse over [`IMPACT`]; the filtered
/// peak with a moving average `width` wide in T; see the module's doc); NaN when the run
/// stopped before its end.
fn first_impact_errors(sim: &[(f64, f64)], data: &Sensor2, width: f64) -> [f64; 5] {
    let (t_peak_ref, p_peak_ref) = data.peak();
    let reached = sim.last().is_some_and(|p| p.0 >= WINDOW.1 - 1e-6);
    if !reached {
        return [f64::NAN; 5];
    }
    let mut sum = 0.0;
    let mut n = 0usize;
    for &(t, p) in &data.median.points {
        if t < WINDOW.0 || t > WINDOW.1 {
            continue;
        }
        if let Some(v) = interpolate(sim, t) {
            sum += (v - p).powi(2);
            n += 1;
        }
    }
    let (t_sim, p_sim) = window_peak(sim);
    let filtered_ref = window_peak(&moving_average(&data.median.points, width)).1;
    let filtered_sim = window_peak(&moving_average(sim, width)).1;
    let impulse_ref = impulse(&data.median.points, IMPACT);
    [
        (sum / n.max(1) as f64).sqrt() / p_peak_ref,
        (p_sim - p_peak_ref) / p_peak_ref,
        t_sim - t_peak_ref,
        (filtered_sim - filtered_ref) / filtered_ref,
        (impulse(sim, IMPACT) - impulse_ref) / impulse_ref,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moving_average_and_impulse() {
        let pts: Vec<(f64, f64)> = (0..=10).map(|i| (i as f64, (i % 2) as f64)).collect();
        let avg = moving_average(&pts, 2.0);
        // Interior points average three samples: (0 + 1 + 0)/3 at odd T, (1 + 0 + 1)/3 at even.
        assert!((avg[5].1 - 1.0 / 3.0).abs() < 1e-12);
        assert!((avg[4].1 - 2.0 / 3.0).abs() < 1e-12);
        // The end points average two.
        assert!((avg[0].1 - 0.5).abs() < 1e-12);
        // ∫ of the line p = T over [0.5, 2.5] is (2.5² − 0.5²)/2 = 3.
        let line: Vec<(f64, f64)> = (0..=4).map(|i| (i as f64, i as f64)).collect();
        assert!((impulse(&line, (0.5, 2.5)) - 3.0).abs() < 1e-12);
    }
}
