//! The still game pool's energy budget, frame by frame: the water's kinetic and potential
//! energy, the hull's, their sum, and what keeps the pool from falling asleep (the sleep
//! test's drift, here over the `--every` frames between lines, the hull's speed and turn
//! rate, the water's center of mass, the hull's draft, and how far the first particle layer
//! stands from the floor and from the hull's bottom, in spacings: 0.5 for a lattice whose
//! volume ends at the surface). At the end it prints the open water's particle layers (their
//! heights and the spacing between them) and the water's level.
//!
//! ```text
//! cargo run --release --example pool_energy -- --particles 2500 --seconds 30
//! cargo run --release --example pool_energy -- --hull fixed --every 60
//! cargo run --release --example pool_energy -- --hull none --every 60
//! cargo run --release --example pool_energy -- --wall-density false --every 60
//! cargo run --release --example pool_energy -- --preset game --particles 10000 --hull none --where
//! cargo run --release --example pool_energy -- --preset game --hull none --seconds 4 --every 60 --full-warm-start true
//! ```
//!
//! `--preset water|game` (default water), `--particles N` (2500), `--seconds S` (30),
//! `--every F` frames between lines (30), `--fps F` frames per second (60),
//! `--hull-density D` (500 kg/m³), `--hull dynamic|fixed|none` (dynamic: the hull
//! floats; fixed: it is held where it starts; none: no hull, the water fills its place),
//! `--viscosity E`, `--wall-viscosity E`, `--wall-density true|false`, `--warm-start W`,
//! `--min-iterations N`, `--hydrostatic-walls true|false`, `--max-density-error E`,
//! `--full-warm-start true|false`, `--divergence-solve true|false` change
//! the preset, `--sleep` lets the water fall asleep with `Sleep::default()`, `--where` adds
//! a line after each saying where the particles that moved are (near the floor, the walls,
//! the paddle, the hull, the surface, or inside) and how far the water moved, the drift
//! averaged over cells of one and two kernel supports (what the sleep test's
//! `Sleep::mean_drift` reads is the first). The last column is the fluid's relaxation
//! halvings (`StepReport::solver_relaxation_halvings`).
//!
//! Energies are in J, the potential ones (`Σ m g y`) and the total relative to the first
//! frame's. The paddle stands still, so nothing does work on the pool: once the start's
//! settling is over its total energy can only fall (viscosity, the pressure solve's
//! projection), and its kinetic energy fall to the jitter of water at rest, unless
//! something in the step feeds it. What it showed (docs/performance.md, "Sleeping water"):
//! with the floating hull the water's kinetic energy stopped falling at about 2 J (2,556
//! particles) and the water never stopped moving, until the coupling's exchange stopped
//! feeding it (`Coupling::exchange`); it now falls (0.49 J at 12 s) and the pool falls
//! asleep with `--sleep` (docs/performance.md, "Sleeping water", has when).

use rapier_sph::prelude::*;
use rapier_sph::rapier3d::prelude::RigidBodyType;
use rapier_sph::scenes::{WavePool, WavePoolConfig};
use std::collections::HashMap;

/// Per-run options from the command line.
struct Options {
    particles: usize,
    seconds: Real,
    every: usize,
    hull: String,
    sleep: bool,
    /// Print where the particles that moved are (`--where`).
    breakdown: bool,
    /// Frame length (s).
    dt: Real,
}

fn main() -> SphResult<()> {
    let argv: Vec<String> = std::env::args().collect();
    let value = |name: &str| argv.windows(2).find(|w| w[0] == name).map(|w| w[1].clone());
    let o = Options {
        particles: value("--particles")
            .and_then(|v| v.parse().ok())
            .unwrap_or(2500),
        seconds: value("--seconds")
            .and_then(|v| v.parse().ok())
            .unwrap_or(30.0),
        every: value("--every").and_then(|v| v.parse().ok()).unwrap_or(30),
        hull: value("--hull").unwrap_or_else(|| "dynamic".into()),
        sleep: argv.iter().any(|a| a == "--sleep"),
        breakdown: argv.iter().any(|a| a == "--where"),
        dt: 1.0
            / value("--fps")
                .and_then(|v| v.parse::<Real>().ok())
                .unwrap_or(60.0),
    };
    let game = value("--preset").as_deref() == Some("game");
    let config = WavePoolConfig {
        particles: o.particles,
        params: if game { game_params } else { water_params },
        paddle: (0.0, 1.5),
        hull_density: value("--hull-density")
            .and_then(|v| v.parse().ok())
            .unwrap_or(500.0),
        ..Default::default()
    };
    let mut pool = WavePool::new(config)?;
    setup_hull(&mut pool, &o.hull)?;
    run(&mut pool, &o)
}

fn water_params(s: Real) -> SphResult<FluidParams> {
    edited(FluidParamsBuilder::water(s).build()?)
}

fn game_params(s: Real) -> SphResult<FluidParams> {
    edited(FluidParamsBuilder::game_water(s).build()?)
}

/// The preset with the command line's changes.
fn edited(mut p: FluidParams) -> SphResult<FluidParams> {
    let argv: Vec<String> = std::env::args().collect();
    let value = |name: &str| argv.windows(2).find(|w| w[0] == name).map(|w| w[1].clone());
    let f = |name: &str| value(name).and_then(|v| v.parse::<Real>().ok());
    if let Some(v) = f("--viscosity") {
        p.viscosity = v;
    }
    if let Some(v) = f("--wall-viscosity") {
        p.wall_viscosity = v;
    }
    if let Some(v) = value("--wall-density").and_then(|v| v.parse().ok()) {
        p.wall_density = v;
    }
    if let Solver::Dfsph(d) = &mut p.solver {
        if let Some(v) = f("--warm-start") {
            d.warm_start = v;
        }
        if let Some(v) = f("--max-density-error") {
            d.max_density_error = v;
        }
        if let Some(v) = value("--min-iterations").and_then(|v| v.parse().ok()) {
            d.min_iterations = v;
        }
        if let Some(v) = value("--hydrostatic-walls").and_then(|v| v.parse().ok()) {
            d.hydrostatic_walls = v;
        }
        if let Some(v) = value("--full-warm-start").and_then(|v| v.parse().ok()) {
            d.full_warm_start = v;
        }
        if let Some(v) = value("--divergence-solve").and_then(|v| v.parse().ok()) {
            d.divergence_solve = v;
        }
    }
    if argv.iter().any(|a| a == "--sleep") {
        p.sleep = Some(Sleep::default());
    }
    p.validate()?;
    Ok(p)
}

/// `dynamic` leaves the hull floating, `fixed` holds it, `none` removes it and fills its
/// place with water on the pool's lattice.
fn setup_hull(pool: &mut WavePool, hull: &str) -> SphResult<()> {
    match hull {
        "fixed" => {
            pool.world.physics.bodies[pool.hull].set_body_type(RigidBodyType::Fixed, true);
        }
        "none" => pool.remove_hull()?,
        _ => {}
    }
    Ok(())
}

/// The mean height of each particle layer of the open water (away from the hull and the
/// paddle), from the floor up (m), and the spacing between them.
fn layers(pool: &WavePool) {
    let s = pool.spacing;
    let f = &pool.world.fluids[pool.water];
    let mut sums: Vec<(f64, usize)> = vec![(0.0, 0); 20];
    for x in f.positions() {
        if x.x < 0.5 || (x.x > 0.9 && x.x < 1.75) {
            continue;
        }
        let k = ((x.y / s).floor() as usize).min(19);
        sums[k].0 += x.y as f64;
        sums[k].1 += 1;
    }
    let mut prev: Option<f64> = None;
    for (k, (y, n)) in sums.iter().enumerate() {
        if *n == 0 {
            continue;
        }
        let y = y / *n as f64;
        println!(
            "layer {k}: {n} particles at {:.4} m ({:.3} spacings; {:.3} above the one below)",
            y,
            y / s as f64,
            prev.map_or(f64::NAN, |p| (y - p) / s as f64)
        );
        prev = Some(y);
    }
    if pool.world.physics.bodies.get(pool.hull).is_some() {
        println!("water level {:.4} m", pool.water_level());
    }
}

/// The pool's energies (J): water kinetic, water potential, hull kinetic, hull potential.
fn energies(pool: &WavePool) -> [f64; 4] {
    let f = &pool.world.fluids[pool.water];
    let g = 9.81f64;
    let m = f.params().particle_mass as f64;
    let pe: f64 = f.positions().iter().map(|x| m * g * x.y as f64).sum();
    let (hk, hp) = match pool.world.physics.bodies.get(pool.hull) {
        Some(b) if b.is_dynamic() => (
            b.kinetic_energy() as f64,
            b.mass() as f64 * g * b.center_of_mass().y as f64,
        ),
        _ => (0.0, 0.0),
    };
    [f.kinetic_energy(), pe, hk, hp]
}

/// The mean distance (in spacings) from the floor to the particles of its first layer, and
/// from the hull's bottom to the particles of the first layer under it (both `0.5` for a
/// lattice whose volume ends at the surface; more: the particles stand off).
fn gaps(pool: &WavePool) -> (Real, Real) {
    let s = pool.spacing;
    let f = &pool.world.fluids[pool.water];
    let mean = |v: Vec<Real>| v.iter().sum::<Real>() / v.len().max(1) as Real / s;
    let floor = mean(
        f.positions()
            .iter()
            .map(|x| x.y)
            .filter(|y| *y < s)
            .collect(),
    );
    let Some(b) = pool.world.physics.bodies.get(pool.hull) else {
        return (floor, Real::NAN);
    };
    let h = WavePool::HULL_HALF;
    let under = f
        .positions()
        .iter()
        .map(|x| b.position().inverse_transform_point(*x))
        .filter(|l| l.x.abs() < h.x - s && l.z.abs() < h.z - s)
        .map(|l| -h.y - l.y)
        .filter(|d| *d > 0.0 && *d < s)
        .collect();
    (floor, mean(under))
}

/// Where the particles that moved since the last line are (`--where`): the pool split
/// into the particles within two spacings of the floor, of a side wall (the far end, the
/// two sides, the paddle), of the free surface (the top two spacings under the water's
/// level: the highest particle's top), and the rest (the interior); for each, its count, its root-mean-square drift
/// (spacings) and its share of the sum of squared drifts; then where the 1 % farthest
/// movers are.
fn breakdown(pool: &WavePool, anchor: &HashMap<u32, Vector>) {
    let s = pool.spacing;
    let f = &pool.world.fluids[pool.water];
    // The highest particle's top (the pool's surface at rest is flat to a spacing).
    let level = f.positions().iter().map(|x| x.y).fold(0.0, Real::max) + 0.5 * s;
    let x0 = WavePool::PADDLE_X + 0.02;
    let size = WavePool::SIZE;
    let near_hull = |x: &Vector| match pool.world.physics.bodies.get(pool.hull) {
        Some(b) => {
            let l = b.position().inverse_transform_point(*x);
            let h = WavePool::HULL_HALF;
            l.x.abs() < h.x + 2.0 * s && l.z.abs() < h.z + 2.0 * s && l.y > -h.y - 2.0 * s
        }
        None => false,
    };
    let class = |x: &Vector| {
        if near_hull(x) {
            0
        } else if x.y > level - 2.0 * s {
            1
        } else if x.y < 2.0 * s {
            2
        } else if x.x < x0 + 2.0 * s {
            3
        } else if x.x > size.x - 2.0 * s || x.z < 2.0 * s || x.z > size.z - 2.0 * s {
            4
        } else {
            5
        }
    };
    const NAMES: [&str; 6] = ["hull", "surface", "floor", "paddle", "walls", "interior"];
    let mut sums = [(0usize, 0.0f64); 6];
    let mut all: Vec<(Real, usize)> = Vec::new();
    for (id, x) in f.ids().iter().zip(f.positions()) {
        let Some(a) = anchor.get(id) else { continue };
        let d = (*x - *a).length() / s;
        let c = class(x);
        sums[c].0 += 1;
        sums[c].1 += (d * d) as f64;
        all.push((d, c));
    }
    let total: f64 = sums.iter().map(|s| s.1).sum();
    let mut line = String::from("  where:");
    for (k, (n, ss)) in sums.iter().enumerate() {
        if *n == 0 {
            continue;
        }
        line += &format!(
            " {} {} rms {:.3} ({:.0} %);",
            NAMES[k],
            n,
            (ss / *n as f64).sqrt(),
            100.0 * ss / total.max(1e-30)
        );
    }
    // The displacement averaged over cubic cells (by the particles' window-start
    // positions) of one and two smoothing lengths: what of the drift is coherent (a current,
    // a slosh) and not each particle's own jitter, which averages out.
    for cells in [1.0, 2.0] {
        let edge = cells * f.params().smoothing_length;
        let mut bins: HashMap<(i32, i32, i32), (Vector, usize)> = HashMap::new();
        for (id, x) in f.ids().iter().zip(f.positions()) {
            let Some(a) = anchor.get(id) else { continue };
            let key = (*a / edge).floor();
            let e = bins
                .entry((key.x as i32, key.y as i32, key.z as i32))
                .or_insert((Vector::ZERO, 0));
            e.0 += *x - *a;
            e.1 += 1;
        }
        let (mut ss, mut n) = (0.0f64, 0usize);
        for (d, k) in bins.values() {
            let mean = *d / *k as Real / s;
            ss += (mean.length_squared() * *k as Real) as f64;
            n += k;
        }
        line += &format!(
            " cells of {cells} h: rms {:.3};",
            (ss / n.max(1) as f64).sqrt()
        );
    }
    all.sort_by(|a, b| b.0.total_cmp(&a.0));
    let top = (all.len() / 100).max(1);
    let mut counts = [0usize; 6];
    for (_, c) in &all[..top.min(all.len())] {
        counts[*c] += 1;
    }
    line += &format!(
        " top 1 % ({top}, from {:.3}):",
        all.get(top - 1).map_or(0.0, |a| a.0)
    );
    for (k, n) in counts.iter().enumerate() {
        if *n > 0 {
            line += &format!(" {} {n}", NAMES[k]);
        }
    }
    println!("{line}");
}

fn run(pool: &mut WavePool, o: &Options) -> SphResult<()> {
    let s = pool.spacing;
    println!(
        "{} particles at {:.1} mm, hull {}, sleep {}",
        pool.world.fluids[pool.water].len(),
        s * 1e3,
        o.hull,
        o.sleep
    );
    println!(
        "t (s) | water KE | water PE | hull KE | hull PE | total (J, from frame 0) | 0.5 s drift rms / max (spacings) | hull |v| (m/s), |ω| (rad/s) | water COM x, z (mm from frame 0) | mean density error | substeps, iterations | hull draft / expected | gap floor, hull (spacings) | asleep | relaxation halvings"
    );
    let e0 = energies(pool);
    let com = |pool: &WavePool| {
        let f = &pool.world.fluids[pool.water];
        let n = f.len().max(1) as f64;
        let sum = f.positions().iter().fold((0.0f64, 0.0f64), |a, x| {
            (a.0 + x.x as f64, a.1 + x.z as f64)
        });
        (sum.0 / n, sum.1 / n)
    };
    let c0 = com(pool);
    let mut anchor: HashMap<u32, Vector> = HashMap::new();
    let frames = (o.seconds / o.dt).round() as usize;
    let (mut substeps, mut iterations) = (0usize, 0usize);
    for frame in 1..=frames {
        pool.world.physics.integration_parameters.dt = o.dt;
        pool.world.physics.step();
        pool.world.step_fluids()?;
        let report = pool.world.pipeline.report();
        substeps += report.substeps as usize;
        iterations += report.solver_iterations as usize;
        if frame % o.every != 0 {
            continue;
        }
        let e = energies(pool);
        let d: Vec<f64> = (0..4).map(|k| e[k] - e0[k]).collect();
        let f = &pool.world.fluids[pool.water];
        let drift: Vec<Real> = f
            .ids()
            .iter()
            .zip(f.positions())
            .filter_map(|(id, x)| Some((*x - *anchor.get(id)?).length() / s))
            .collect();
        let rms = (drift.iter().map(|d| d * d).sum::<Real>() / drift.len().max(1) as Real).sqrt();
        let max = drift.iter().copied().fold(0.0, Real::max);
        let (v, w) = match pool.world.physics.bodies.get(pool.hull) {
            Some(b) => (b.linvel().length(), b.angvel().length()),
            None => (0.0, 0.0),
        };
        let c = com(pool);
        println!(
            "{:5.1} | {:.4} | {:+.4} | {:.4} | {:+.4} | {:+.4} | {:.3} / {:.3} | {:.4}, {:.4} | {:+.2}, {:+.2} | {:.3} % | {:.2}, {:.2} | {:.3} | {:.3}, {:.3} | {} | {}",
            frame as Real * o.dt,
            e[0],
            d[1],
            e[2],
            d[3],
            d.iter().sum::<f64>(),
            rms,
            max,
            v,
            w,
            (c.0 - c0.0) * 1e3,
            (c.1 - c0.1) * 1e3,
            100.0 * report.mean_density_error,
            substeps as f64 / o.every as f64,
            iterations as f64 / substeps.max(1) as f64,
            if o.hull == "dynamic" {
                pool.draft_ratio()
            } else {
                Real::NAN
            },
            gaps(pool).0,
            gaps(pool).1,
            if f.is_sleeping() { "asleep" } else { "awake" },
            report.solver_relaxation_halvings,
        );
        (substeps, iterations) = (0, 0);
        if o.breakdown {
            breakdown(pool, &anchor);
        }
        let f = &pool.world.fluids[pool.water];
        anchor = f
            .ids()
            .iter()
            .copied()
            .zip(f.positions().iter().copied())
            .collect();
    }
    layers(pool);
    Ok(())
}
