//! An oil-in-water emulsion separating in the closed tank of `scenes::MixedTank` (8 × 16 × 8
//! particles at 1.25 cm, DFSPH, the mixture model of `rapier_sph::mixture`): the figures
//! reported in `docs/solvers.md` ("A mixture of liquids") and tests/mixture.rs.
//!
//! Each line printed: time (s), the height where the oil fraction's slab profile rises
//! through 0.5 (m; `-` if it does not), the height from the volumes (m), the interface's
//! thickness between the profile's 0.1 and 0.9 crossings (m), the bottom pressure's error
//! against `ρ_oil·g·h_oil + ρ_water·g·h_water`, each phase's volume's relative change, the
//! smallest fraction and the largest `|Σ_k α_k − 1|`, the RMS particle speed (m/s); at the
//! end, the time the phases' transport took against the whole step's.
//!
//! `cargo run --release --example mixture_probe -- --start uniform --drift 5.6e-5`
//! `cargo run --release --example mixture_probe -- --start checker --drift 0` (no drift)

use clap::Parser;
use rapier_sph::mixture::{Mixture, Phase};
use rapier_sph::prelude::*;
use rapier_sph::scenes::{MixedStart, MixedTank};

#[derive(Parser)]
struct Args {
    /// uniform (every particle at 0.5) or checker (pure particles in a checkerboard).
    #[arg(long, default_value = "uniform")]
    start: String,
    /// The mobility τ (m³·s/kg).
    #[arg(long, default_value_t = 5.6e-5)]
    drift: Real,
    /// The diffusivity D (m²/s).
    #[arg(long, default_value_t = 1e-5)]
    diffusivity: Real,
    /// Both phases' viscosity ε (Pa·s).
    #[arg(long, default_value_t = 0.5)]
    viscosity: Real,
    /// The light phase's rest density (kg/m³; the heavy one's is 1000).
    #[arg(long, default_value_t = 800.0)]
    light: Real,
    /// Simulated time (s), at 60 frames per second.
    #[arg(long, default_value_t = 4.0)]
    seconds: Real,
    /// Print every this many seconds.
    #[arg(long, default_value_t = 0.25)]
    every: Real,
    /// Layers of particles (the tank is 8 × LAYERS × 8).
    #[arg(long, default_value_t = 16)]
    layers: usize,
}

fn main() {
    let a = Args::parse();
    let mixture = Mixture {
        phases: vec![
            Phase {
                rest_density: 1000.0,
                viscosity: a.viscosity,
            },
            Phase {
                rest_density: a.light,
                viscosity: a.viscosity,
            },
        ],
        drift: a.drift,
        diffusivity: a.diffusivity,
    };
    let params = FluidParamsBuilder::water(0.1 / 8.0)
        .mixture(mixture)
        .build()
        .unwrap();
    let start = match a.start.as_str() {
        "checker" => MixedStart::Checker,
        _ => MixedStart::Uniform(vec![0.5, 0.5]),
    };
    let mut t = MixedTank::new(params, [8, a.layers, 8], start).unwrap();
    let v0 = [t.phase_volume(0), t.phase_volume(1)];
    let w = a.drift * (1000.0 - a.light) * 9.81;
    println!(
        "# drift speed τΔρg = {w:.4} m/s, H/w = {:.2} s, volume interface {:.4} m",
        t.surface_height / w,
        t.volume_interface(0)
    );
    let frames = (a.seconds * 60.0).round() as usize;
    let every = ((a.every * 60.0).round() as usize).max(1);
    let mut timings = rapier_sph::StageTimings::default();
    for k in 1..=frames {
        timings.accumulate(&t.world.step().unwrap().timings);
        if k % every != 0 {
            continue;
        }
        let f = t.fluid();
        let (w0, o) = (f.fractions(0).unwrap(), f.fractions(1).unwrap());
        let min = w0.iter().chain(o).fold(1.0 as Real, |m, &x| m.min(x));
        let sum = w0
            .iter()
            .zip(o)
            .map(|(a, b)| (a + b - 1.0).abs())
            .fold(0.0 as Real, Real::max);
        let rms = (f.kinetic_energy() * 2.0 / f.total_mass() as f64).sqrt();
        let cross = t
            .crossing(1, 0.5)
            .map_or("-".to_string(), |c| format!("{c:.4}"));
        let thick = t
            .interface_thickness(1)
            .map_or("-".to_string(), |c| format!("{c:.4}"));
        println!(
            "{:.2} {cross} {:.4} {thick} {:+.4} {:+.2e} {:+.2e} {min:.2e} {sum:.2e} {rms:.4}",
            k as Real / 60.0,
            t.volume_interface(0),
            t.bottom_pressure_error(),
            t.phase_volume(0) / v0[0] - 1.0,
            t.phase_volume(1) / v0[1] - 1.0,
        );
    }
    let stage = timings
        .get(rapier_sph::Stage::ScalarDiffusion)
        .as_secs_f64();
    println!(
        "# the phases' drift and diffusion (timed as scalar diffusion): {:.3} s of {:.3} s stepping ({:.1} %)",
        stage,
        timings.total().as_secs_f64(),
        100.0 * stage / timings.total().as_secs_f64()
    );
    let p: Vec<String> = t.profile(1).iter().map(|x| format!("{x:.2}")).collect();
    println!("# oil profile, floor up: {}", p.join(" "));
}
