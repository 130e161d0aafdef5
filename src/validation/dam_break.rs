//! Quasi-2D dam breaks against experiments: Martin & Moyce (1952), square column (n² = 1) and
//! column twice as tall as wide (n² = 2), and Koshizuka & Oka (1996).
//!
//! ## Set-up
//!
//! A column of water `a` wide (x) and `n²·a` tall (y, up), against the back wall `x = 0` of a
//! closed tank of rapier cuboids, released at `t = 0` onto the dry floor. Plane flow in 3D: the
//! column spans the tank's full width in z, a thin slab of [`LAYERS`] particle layers between
//! two walls. The fluid is the [`crate::FluidParamsBuilder::water`] preset at spacing
//! `a / resolution` with the run's solver; nothing else is changed.
//!
//! ## Measurements
//!
//! - **Front** `x_front`: the largest `x + s/2` over particles that have at least
//!   [`MIN_NEIGHBOURS`] other particles within the kernel support `h` (s the spacing; `s/2` is
//!   the particle's half-width, so the column's face starts at exactly `x = a`). A droplet or
//!   a spray cluster of up to `MIN_NEIGHBOURS` particles ahead of the surge does not move it,
//!   while the thin tongue of the surge (one particle tall across the slab has about nine
//!   neighbours within `h = 2s`) still counts. A percentile of x would not do: the share of
//!   particles in the tongue shrinks with resolution, so the percentile's bias would change
//!   with the spacing.
//! - **Residual height** `h`: the largest `y + s/2` over particles with centers within one
//!   spacing of the back wall that pass the same neighbour test.
//!
//! Errors: RMS of the relative deviation from every measured point over the measured range
//! (`front_rms`, `height_rms`), the same over `T ≤ 3` (`front_rms_t3`), and the largest excess
//! of the front over Ritter's shallow-water bound, `max(Z − (1 + 2T))` over the samples after
//! release (`ritter_excess`; the bound holds when it is ≤ 0).
//!
//! ## What the front converges to
//!
//! The model is an instant release on a free-slip floor. Its front, measured with
//! `examples/dam_front.rs`, converges at first order and runs ahead of both experiments by
//! about 0.2 in T once converged (Koshizuka & Oka's own MPS solution agrees with it to 1 %
//! RMS at N = 48, not with their experiment), so the error against the data grows with N once
//! the discretisation's too-slow front stops hiding that lead. Without wall density the front
//! is slower by an amount that does not vanish with the spacing: the slab's two outer layers
//! (of [`LAYERS`]) miss 15 % of their density next to the side walls at every N. See the
//! docs/validation.md, "Convergence of the dam-break front".

use super::data::{Curve, read_curve};
use super::{
    DriveSpec, Method, Metric, RunRecord, RunSetup, SimCurve, TimePolicy, drive, inside_box,
    metrics, potential_energy, rms_relative,
};
use crate::error::{SphError, SphResult};
use crate::fluid::{Fluid, try_lattice};
use crate::math::{Real, Vector};
use crate::params::{FluidParams, FluidParamsBuilder};
use crate::scenes::add_closed_box;
use crate::world::FluidWorld;
use std::collections::HashMap;

/// Particle layers across the slab (z).
pub const LAYERS: usize = 4;

/// A particle counts as liquid for the front and height measurements when it has at least
/// this many other particles within the kernel support.
pub const MIN_NEIGHBOURS: usize = 5;

/// Gravity (m/s², rapier's default).
const G: Real = 9.81;

/// One dam-break experiment: geometry, scalings and data.
#[derive(Clone, Debug)]
pub struct Case {
    /// Scene name.
    pub name: &'static str,
    /// Column width `a` (m).
    pub width: Real,
    /// Column height over width, `n²` (an integer here).
    pub n2: usize,
    /// Tank length over the column width.
    pub tank_length: Real,
    /// Front data: `Z = x/a` against `T = n·t·sqrt(g/a)`.
    pub front: Curve,
    /// Residual-height data: `h/(height_scale·a)` against `t·sqrt(g/a)·height_time_factor`.
    pub height: Option<Curve>,
    /// `T = front_time_factor · t·sqrt(g/a)` for the front (`n`).
    pub front_time_factor: Real,
    /// Time factor of the height data.
    pub height_time_factor: Real,
    /// The height data are `h / (height_scale · a)`.
    pub height_scale: Real,
    /// Simulated duration (s).
    pub duration: Real,
}

impl Case {
    /// Martin & Moyce (1952), square column, a = 2¼ in = 0.05715 m; front and height against
    /// T = t·sqrt(g/a) (`martin_moyce_1952_square/`: the jax-sph series, the README's primary
    /// one). Runs to T = 6.5 (the last height point is at 6.29). Tank 15a long (as the
    /// OpenFOAM re-run the README cites).
    pub fn martin_moyce_square() -> SphResult<Self> {
        let a = 0.05715;
        let folder = "martin_moyce_1952_square";
        Ok(Self {
            name: "martin_moyce_n2_1",
            width: a,
            n2: 1,
            tank_length: 15.0,
            front: read_curve(
                folder,
                "data.csv",
                "T_t_sqrt_g_over_a",
                "Z_x_front_over_a",
                Some(("source", "jax-sph")),
                "Martin & Moyce 1952, n² = 1, front",
            )?,
            height: Some(read_curve(
                folder,
                "height.csv",
                "T_t_sqrt_g_over_a",
                "H_h_residual_over_a",
                None,
                "Martin & Moyce 1952, n² = 1, height",
            )?),
            front_time_factor: 1.0,
            height_time_factor: 1.0,
            height_scale: 1.0,
            duration: 6.5 / (G / a).sqrt(),
        })
    }

    /// Martin & Moyce (1952), column 2a tall, a = 2¼ in: front from Table 2 against
    /// T = t·sqrt(2g/a), height from Table 6 as h/(2a) against τ = t·sqrt(g/a)
    /// (`martin_moyce_1952_n2_2/`). Runs to τ = 7.6 (the last height point is at 7.4).
    /// Tank 25a long, so the front (Ritter: Z ≤ 1 + 2T ≤ 23) never reaches the far wall.
    pub fn martin_moyce_n2() -> SphResult<Self> {
        let a = 0.05715;
        let folder = "martin_moyce_1952_n2_2";
        Ok(Self {
            name: "martin_moyce_n2_2",
            width: a,
            n2: 2,
            tank_length: 25.0,
            front: read_curve(
                folder,
                "data.csv",
                "T_n_t_sqrt_g_over_a",
                "Z_x_front_over_a",
                Some(("source", "Table 2 via Ocellaris")),
                "Martin & Moyce 1952, n² = 2, front (Table 2)",
            )?,
            height: Some(read_curve(
                folder,
                "height.csv",
                "tau_t_sqrt_g_over_a",
                "H_h_residual_over_n2_a",
                None,
                "Martin & Moyce 1952, n² = 2, height (Table 6)",
            )?),
            front_time_factor: 2.0f32.sqrt(),
            height_time_factor: 1.0,
            height_scale: 2.0,
            duration: 7.6 / (G / a).sqrt(),
        })
    }

    /// Koshizuka & Oka (1996), experiment: Z = x/L against T = t·sqrt(2g/L)
    /// (`koshizuka_oka_1996/`). The data give no size; the geometry is PySPH's (column L wide,
    /// 2L tall, tank 4L long) with L = 0.146 m, the width usually quoted for this experiment
    /// (not checked against the paper). Runs to T = 3.3 (last point 3.10); the front reaches
    /// the far wall at Z = 4.
    pub fn koshizuka_oka() -> SphResult<Self> {
        let l = 0.146;
        Ok(Self {
            name: "koshizuka_oka",
            width: l,
            n2: 2,
            tank_length: 4.0,
            front: read_curve(
                "koshizuka_oka_1996",
                "data.csv",
                "T_t_sqrt_2g_over_L",
                "Z_x_front_over_L",
                Some(("kind", "experiment")),
                "Koshizuka & Oka 1996, experiment, front",
            )?,
            height: None,
            front_time_factor: 2.0f32.sqrt(),
            height_time_factor: 1.0,
            height_scale: 2.0,
            duration: 3.3 / (2.0 * G / l).sqrt(),
        })
    }

    /// Koshizuka & Oka's own MPS simulation of their experiment as the reference
    /// (`koshizuka_oka_1996/`, rows `kind = MPS simulation`, digitised by PySPH to 1–3 %),
    /// same geometry and scaling as [`Self::koshizuka_oka`]: a numerical solution of the
    /// model this crate solves (an instant release onto a free-slip floor), not a
    /// measurement, so the error against it isolates the discretisation from what the
    /// experiment has and the model has not (docs/validation.md, "Convergence of the dam-break
    /// front": it is 12 % ahead of the experiment on average). Runs to T = 3.0 (last point
    /// 2.94).
    pub fn koshizuka_oka_mps() -> SphResult<Self> {
        let mut case = Self::koshizuka_oka()?;
        case.name = "koshizuka_oka_mps";
        case.front = read_curve(
            "koshizuka_oka_1996",
            "data.csv",
            "T_t_sqrt_2g_over_L",
            "Z_x_front_over_L",
            Some(("kind", "MPS simulation")),
            "Koshizuka & Oka 1996, MPS simulation, front",
        )?;
        case.duration = 3.0 / (2.0 * G / case.width).sqrt();
        Ok(case)
    }

    /// Ritter's front speed `2·sqrt(g·n²·a)` (m/s), the fastest the flow can go.
    pub fn ritter_speed(&self) -> Real {
        2.0 * (G * self.n2 as Real * self.width).sqrt()
    }

    /// The fluid parameters for `method` at `resolution` particles across the column.
    pub fn params(&self, method: &Method, resolution: usize) -> SphResult<FluidParams> {
        if resolution < 2 {
            return Err(SphError::InvalidParameter {
                field: "resolution",
                value: resolution as f64,
                reason: "at least 2 particles across the column",
            });
        }
        FluidParamsBuilder::water(self.width / resolution as Real)
            .solver(method.solver)
            .wall_density(method.wall_density)
            .wcsph_pressure(method.wcsph_pressure)
            .wcsph_density(method.wcsph_density)
            .build()
    }
}

/// A built dam break.
pub struct DamBreak2d {
    /// Tank colliders and the fluid; rapier has stepped once (its broad-phase is filled).
    pub world: FluidWorld,
    /// The fluid.
    pub fluid: crate::FluidHandle,
    /// Interior of the tank: `[0, max]`.
    pub tank_max: Vector,
    /// Column width `a` (m).
    pub width: Real,
}

impl DamBreak2d {
    /// Builds `case` with `params` (spacing `a / resolution`).
    pub fn new(case: &Case, params: FluidParams) -> SphResult<Self> {
        let s = params.particle_spacing;
        let nx = (case.width / s).round() as usize;
        let ny = nx * case.n2;
        let column_height = ny as Real * s;
        let tank_max = Vector::new(
            case.tank_length * case.width,
            2.0 * column_height,
            LAYERS as Real * s,
        );
        let mut world = FluidWorld::new();
        add_closed_box(&mut world, Vector::ZERO, tank_max, (4.0 * s).max(0.05));
        world.physics.step();
        let mut fluid = Fluid::new(params)?;
        fluid.add_particles(&try_lattice(Vector::splat(0.5 * s), nx, ny, LAYERS, s)?)?;
        let fluid = world.fluids.insert(fluid);
        Ok(Self {
            world,
            fluid,
            tank_max,
            width: case.width,
        })
    }

    /// `(front x, residual height at the back wall)` in metres (see the module docs).
    pub fn measure(&self) -> (Real, Real) {
        measure(&self.world.fluids[self.fluid])
    }
}

/// `(front x, height at x = 0)` of `fluid` (see the module docs).
pub fn measure(fluid: &Fluid) -> (Real, Real) {
    let p = fluid.params();
    let (s, h) = (p.particle_spacing, p.smoothing_length);
    let pos = fluid.positions();
    let key = |x: Vector| {
        let c = (x / h).floor();
        (c.x as i32, c.y as i32, c.z as i32)
    };
    let mut cells: HashMap<(i32, i32, i32), Vec<u32>> = HashMap::new();
    for (i, &x) in pos.iter().enumerate() {
        cells.entry(key(x)).or_default().push(i as u32);
    }
    let liquid = |i: usize| {
        let x = pos[i];
        let (cx, cy, cz) = key(x);
        let mut n = 0;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = cells.get(&(cx + dx, cy + dy, cz + dz)) {
                        for &j in list {
                            if j as usize != i && (pos[j as usize] - x).length_squared() < h * h {
                                n += 1;
                                if n >= MIN_NEIGHBOURS {
                                    return true;
                                }
                            }
                        }
                    }
                }
            }
        }
        false
    };
    let mut order: Vec<usize> = (0..pos.len()).collect();
    order.sort_by(|&a, &b| pos[b].x.total_cmp(&pos[a].x));
    let front = order
        .iter()
        .find(|&&i| liquid(i))
        .map_or(0.0, |&i| pos[i].x + 0.5 * s);
    let mut back: Vec<usize> = (0..pos.len()).filter(|&i| pos[i].x < s).collect();
    back.sort_by(|&a, &b| pos[b].y.total_cmp(&pos[a].y));
    let height = back
        .iter()
        .find(|&&i| liquid(i))
        .map_or(0.0, |&i| pos[i].y + 0.5 * s);
    (front, height)
}

/// Runs `case` once (see [`super::Scene::run`]).
pub fn run(
    case: &Case,
    method: &Method,
    resolution: usize,
    policy: TimePolicy,
    progress: &mut dyn FnMut(Real),
) -> SphResult<RunRecord> {
    let params = case.params(method, resolution)?;
    let mut scene = DamBreak2d::new(case, params.clone())?;
    let f = &scene.world.fluids[scene.fluid];
    let particles = f.len();
    let energy_bound = potential_energy(f, params.particle_mass, G);
    let dt_ref = super::reference_step(&params, case.ritter_speed(), G);
    let a = case.width as f64;
    let scale = (G as f64 / a).sqrt();
    let mut front = Vec::new();
    let mut height = Vec::new();
    let tank_max = scene.tank_max;
    let inside = inside_box(tank_max, 1e-4 * tank_max.max_element());
    let fluid = scene.fluid;
    let driven = drive(
        &mut scene.world,
        fluid,
        &DriveSpec {
            duration: case.duration,
            sample_dt: case.duration / 250.0,
            dt_ref,
            policy,
            energy_bound,
            gravity: G,
            inside: &inside,
        },
        &mut |t, world| {
            let (x, hgt) = measure(&world.fluids[fluid]);
            let tau = t as f64 * scale;
            front.push((tau * case.front_time_factor as f64, x as f64 / a));
            height.push((
                tau * case.height_time_factor as f64,
                hgt as f64 / (case.height_scale as f64 * a),
            ));
        },
        progress,
    )?;
    let errors = errors(case, &front, &height);
    let mut curves = vec![SimCurve {
        name: "front",
        points: front,
    }];
    if case.height.is_some() {
        curves.push(SimCurve {
            name: "height",
            points: height,
        });
    }
    let setup = RunSetup {
        scene: case.name,
        method: method.name,
        resolution,
        spacing: params.particle_spacing,
        particles,
        policy,
        dt_ref,
        duration: case.duration,
    };
    Ok(setup.record(driven, errors, curves))
}

/// The errors of the simulated `front` and `height` curves (scaled as `case`'s data) against
/// `case`'s data (see the module docs): the front's RMS over the run and to T = 3, the
/// height's RMS when the case has height data, and the front's largest excess over Ritter's
/// bound `Z = 1 + 2T`.
fn errors(case: &Case, front: &[(f64, f64)], height: &[(f64, f64)]) -> Vec<Metric> {
    let front_range = (0.0, f64::MAX);
    let mut errors = metrics([
        ("front_rms", rms_relative(front, &case.front, front_range)),
        ("front_rms_t3", rms_relative(front, &case.front, (0.0, 3.0))),
    ]);
    if let Some(h) = &case.height {
        errors.push(Metric {
            name: "height_rms",
            value: rms_relative(height, h, (0.0, f64::MAX)),
        });
    }
    errors.push(Metric {
        name: "ritter_excess",
        // Samples after release: at T = 0 the front sits on the bound by construction.
        value: front
            .iter()
            .filter(|&&(t, _)| t > 0.0)
            .map(|&(t, z)| z - (1.0 + 2.0 * t))
            .fold(f64::NEG_INFINITY, f64::max),
    });
    errors
}
