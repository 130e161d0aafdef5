//! Clavet's relaxation in the report's hydrostatic tank (`validation::hydrostatic`, water at
//! spacing 0.1/N, `N × 2N × N` particles), step by step: the kinetic and potential energy
//! after every step, the highest particle over the top row, and the six fastest particles
//! (their lattice cell, velocity, displacement in spacings, density over ρ0, pressure). First
//! it prints the spawn lattice's cohesion energy with contact-only walls,
//! `m·Σ k_c·c²·(ρ − ρ_t)²/(8ρ0)` over the particles under the cohesion threshold (the
//! relaxation's potential energy, `src/solver/clavet/mod.rs`, "Walls"; c = 30 m/s, k_c = 1).
//!
//! ```text
//! cargo run --release --example clavet_probe -- N DT_FACTOR STEPS [walls] [adaptive] [quiet]
//! cargo run --release --example clavet_probe -- 6 0.5 4            # dt_ref/2, contact-only walls
//! cargo run --release --example clavet_probe -- 6 0.5 94 walls quiet
//! ```
//!
//! `DT_FACTOR` times the report's `dt_ref` is the step (`TimeStepping::Fixed`), or with
//! `adaptive` the frame (adaptive substeps inside it); `walls`: walls in Clavet's densities;
//! `quiet`: one line every 20 steps and the last.
use rapier_sph::math::{Real, Vector};
use rapier_sph::scenes::HydrostaticTank;
use rapier_sph::{FluidParamsBuilder, Solver, TimeStepping};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let n: usize = a.get(1).map_or(6, |x| x.parse().unwrap());
    let factor: Real = a.get(2).map_or(0.5, |x| x.parse().unwrap());
    let steps: usize = a.get(3).map_or(5, |x| x.parse().unwrap());
    let walls = a.iter().any(|x| x == "walls");
    let adaptive = a.iter().any(|x| x == "adaptive");
    let quiet = a.iter().any(|x| x == "quiet");
    let width = 0.1;
    let params = FluidParamsBuilder::water(width / n as Real)
        .solver(Solver::clavet())
        .wall_density(walls)
        .build()
        .unwrap();
    let mut tank = HydrostaticTank::new(params.clone(), [n, 2 * n, n]).unwrap();
    let g = 9.81;
    let v = (g * tank.fluid_height).sqrt();
    let dt_ref = rapier_sph::validation::reference_step(&params, v, g);
    let dt = factor * dt_ref;
    let world = &mut tank.world;
    if adaptive {
        world.physics.integration_parameters.dt = dt;
    } else {
        world.pipeline.time_stepping = TimeStepping::Fixed;
        world.physics.integration_parameters.dt = dt;
    }
    let s = params.particle_spacing;
    let m = params.particle_mass as f64;
    let energy = |f: &rapier_sph::Fluid| {
        let pe: f64 = f
            .positions()
            .iter()
            .map(|p| m * g as f64 * p.y as f64)
            .sum();
        (f.kinetic_energy(), pe)
    };
    let (_, pe0) = energy(&world.fluids[tank.fluid]);
    let top0 = world.fluids[tank.fluid]
        .positions()
        .iter()
        .map(|p| p.y)
        .fold(Real::MIN, Real::max);
    let x0: Vec<Vector> = world.fluids[tank.fluid].positions().to_vec();
    let ids0: Vec<u32> = world.fluids[tank.fluid].ids().to_vec();
    println!(
        "N = {n}, s = {s}, h = {}, dt = {dt:.3e} (dt_ref {dt_ref:.3e}), E0 = {pe0:.4} J, walls {walls}",
        params.smoothing_length
    );
    {
        // The cohesion's potential energy of the spawn lattice (contact-only walls):
        // m·Σ k_c·c²·(ρ − ρ_t)²/(8ρ0) over the particles under ρ_t (module docs, "Walls").
        use rapier_sph::solver::clavet::{cohesion_threshold, lattice_rest_density};
        let h = params.smoothing_length;
        let rho0 = lattice_rest_density(h, s) as f64;
        let rho_t = cohesion_threshold(h, s) as f64 * rho0;
        let c2 = 900.0f64;
        let mut e = 0.0;
        let mut under = 0;
        for i in 0..x0.len() {
            let mut rho = 0.0f64;
            for j in 0..x0.len() {
                let d = (x0[i] - x0[j]).length() as f64;
                if i != j && d < h as f64 {
                    rho += (1.0 - d / h as f64).powi(2);
                }
            }
            if rho < rho_t {
                under += 1;
                e += m * c2 * (rho - rho_t).powi(2) / (8.0 * rho0);
            }
        }
        println!(
            "cohesion energy of the spawn lattice (contact-only walls): {e:.4} J = {:.3} E0, {under} particles under rho_t",
            e / pe0
        );
    }
    let mut t = 0.0;
    let mut emax: f64 = 0.0;
    let mut hmax: Real = 1.0;
    for step in 0..steps {
        let rep = world.step_fluids().unwrap().clone();
        t += dt;
        let f = &world.fluids[tank.fluid];
        let (ke, pe) = energy(f);
        emax = emax.max((ke + pe) / pe0 - 1.0);
        let top = f.positions().iter().map(|p| p.y).fold(Real::MIN, Real::max);
        hmax = hmax.max(top / top0);
        if quiet && step + 1 != steps && (step + 1) % 20 != 0 {
            continue;
        }
        println!(
            "step {step} t {t:.5} substeps {} KE {ke:.4e} PE-PE0 {:+.4e} (KE+PE)/E0-1 {:+.4e} max E excess {emax:+.4} top/top0 {:.4} max {hmax:.4} contacts {}",
            rep.substeps,
            pe - pe0,
            (ke + pe) / pe0 - 1.0,
            top / top0,
            rep.contacts
        );
        if quiet {
            continue;
        }
        // fastest particles
        let mut idx: Vec<usize> = (0..f.len()).collect();
        idx.sort_by(|&i, &j| {
            f.velocities()[j]
                .length()
                .partial_cmp(&f.velocities()[i].length())
                .unwrap()
        });
        for &i in idx.iter().take(6) {
            let p = f.positions()[i];
            let id = f.ids()[i];
            let k0 = ids0.iter().position(|&q| q == id).unwrap();
            let p0 = x0[k0];
            // lattice cell and distances from walls in spacings
            let cell = ((p0 / s) - Vector::splat(0.5)).round();
            println!(
                "   id {id} cell ({},{},{}) |v| {:.3} v ({:+.3},{:+.3},{:+.3}) moved ({:+.3},{:+.3},{:+.3})s rho/rho0 {:.3} p {:.1}",
                cell.x,
                cell.y,
                cell.z,
                f.velocities()[i].length(),
                f.velocities()[i].x,
                f.velocities()[i].y,
                f.velocities()[i].z,
                (p - p0).x / s,
                (p - p0).y / s,
                (p - p0).z / s,
                f.densities()[i] / params.rest_density,
                f.pressures()[i]
            );
        }
    }
}
