//! Thick liquids: a viscous column spreading on a floor (Huppert 1982's axisymmetric viscous
//! gravity current, `rapier_sph::validation::spreading`), stepped in 1/60 s frames with the
//! implicit viscosity solve (Weiler et al. 2018) or the explicit force. Prints the front
//! `r_N(t)` against Huppert's law, the fit `r_N⁸ = a (t − t0)` over the late half of the run,
//! and the cost.
//!
//! ```text
//! cargo run --release --example honey                          # implicit, ν = 1 m²/s, DFSPH
//! cargo run --release --example honey -- --explicit            # the explicit force
//! cargo run --release --example honey -- --solver pbf --seconds 4
//! ```

use clap::{Parser, ValueEnum};
use rapier_sph::validation::spreading::{
    HUPPERT_ETA, SpreadingConfig, fit_line, front, huppert_rate, spreading,
};
use rapier_sph::{ImplicitViscosity, Solver, Stage, StageTimings};
use std::time::Instant;

#[derive(Copy, Clone, Debug, ValueEnum)]
enum SolverArg {
    Wcsph,
    Dfsph,
    Pbf,
    Clavet,
}

#[derive(Parser, Debug)]
#[command(about = "A viscous column spreading on a floor against Huppert (1982)")]
struct Args {
    /// Pressure solver.
    #[arg(long, value_enum, default_value = "dfsph")]
    solver: SolverArg,
    /// Explicit viscosity (Müller's force, its viscous time-step limit) instead of the
    /// implicit solve.
    #[arg(long)]
    explicit: bool,
    /// Particle spacing (m).
    #[arg(long, default_value_t = 0.01)]
    spacing: f32,
    /// Column radius (m).
    #[arg(long, default_value_t = 0.08)]
    radius: f32,
    /// Column height (m).
    #[arg(long, default_value_t = 0.12)]
    height: f32,
    /// Dynamic viscosity (Pa·s).
    #[arg(long, default_value_t = 1400.0)]
    viscosity: f32,
    /// Rest density (kg/m³).
    #[arg(long, default_value_t = 1400.0)]
    density: f32,
    /// Seconds simulated.
    #[arg(long, default_value_t = 8.0)]
    seconds: f32,
    /// DFSPH's density error target (its default: 1e-3).
    #[arg(long, default_value_t = 1e-3)]
    density_error: f32,
    /// Tolerance of the implicit solve.
    #[arg(long, default_value_t = 1e-3)]
    tolerance: f32,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a = Args::parse();
    let solver = match a.solver {
        SolverArg::Wcsph => Solver::Wcsph,
        SolverArg::Dfsph => Solver::Dfsph(rapier_sph::Dfsph {
            max_density_error: a.density_error,
            ..Default::default()
        }),
        SolverArg::Pbf => Solver::pbf(),
        SolverArg::Clavet => Solver::clavet(),
    };
    let config = SpreadingConfig {
        spacing: a.spacing,
        radius: a.radius,
        height: a.height,
        rest_density: a.density,
        viscosity: a.viscosity,
        solver,
        implicit: (!a.explicit).then_some(ImplicitViscosity {
            tolerance: a.tolerance,
            ..ImplicitViscosity::default()
        }),
    };
    let mut s = spreading(&config)?;
    let n = s.world.fluids[s.fluid].len();
    let rate = huppert_rate(9.81, s.volume, s.nu);
    println!(
        "{n} particles, V = {:.4e} m³, ν = {:.3e} m²/s, {} viscosity, {}",
        s.volume,
        s.nu,
        if a.explicit { "explicit" } else { "implicit" },
        solver.name()
    );
    let frames = (a.seconds * 60.0).round() as usize;
    let (mut ts, mut rs) = (Vec::new(), Vec::new());
    let mut timings = StageTimings::default();
    let (mut substeps, mut iterations, mut limited) = (0usize, 0usize, 0usize);
    let mut energy_max: f64 = 0.0;
    let t0 = Instant::now();
    for frame in 1..=frames {
        let rep = s.world.step()?;
        timings.accumulate(&rep.timings);
        substeps += rep.substeps as usize;
        iterations += rep.viscosity_iterations;
        limited += rep.viscosity_limited;
        let f = &s.world.fluids[s.fluid];
        energy_max = energy_max.max(f.kinetic_energy());
        let t = frame as f64 / 60.0;
        let r = front(f.positions());
        ts.push(t);
        rs.push(r);
        if frame % 30 == 0 {
            let huppert = HUPPERT_ETA * (9.81 * s.volume.powi(3) * t / (3.0 * s.nu)).powf(0.125);
            println!(
                "t {t:5.2} s  r_N {r:.4} m  Huppert (t0 = 0) {huppert:.4} m  lost {}",
                n - f.len()
            );
        }
    }
    let wall = t0.elapsed().as_secs_f64();
    let half = ts.len() / 2;
    let r8: Vec<f64> = rs[half..].iter().map(|r| r.powi(8)).collect();
    let (slope, b) = fit_line(&ts[half..], &r8);
    let worst = ts[half..]
        .iter()
        .zip(&r8)
        .map(|(t, y)| ((slope * t + b) - y).abs() / y)
        .fold(0.0, f64::max);
    println!(
        "fit over t in [{:.2}, {:.2}] s: r_N^8 = a (t - t0), a = {slope:.4e} (Huppert {rate:.4e}, \
         ratio {:.3}, eta_N measured {:.4}), t0 = {:.3} s, worst misfit of r^8 {:.2} %",
        ts[half],
        ts[ts.len() - 1],
        slope / rate,
        HUPPERT_ETA * (slope / rate).powf(0.125),
        -b / slope,
        100.0 * worst
    );
    println!(
        "{frames} frames, {substeps} substeps, {iterations} CG iterations, {limited} limited, \
         wall {wall:.2} s ({:.2} ms/frame); viscosity solve {:.3} s, viscosity force {:.3} s; \
         largest KE {energy_max:.3e} J",
        1e3 * wall / frames as f64,
        timings.get(Stage::ViscositySolve).as_secs_f64(),
        timings.get(Stage::ViscosityForce).as_secs_f64(),
    );
    Ok(())
}
