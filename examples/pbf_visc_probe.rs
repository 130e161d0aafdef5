//! PBF's kinetic energy in a block at rest at short substeps: the scene of
//! `tests/abuse.rs::extreme_viscosity_never_explodes` (a 0.6×0.3×0.6 m block of 5 cm
//! particles in a closed 0.6 m box), per frame: kinetic energy over the block's potential
//! energy over the floor (PE0), the substeps and the longest one, PBF's iterations and the
//! compression left, the particles the viscosity limited, and the fastest particle with
//! where it is.
//!
//! ```text
//! cargo run --release --example pbf_visc_probe -- [VISCOSITY] [COURANT] [FRAMES] [K] [unscaled]
//! ```
//! `VISCOSITY` in Pa·s (default 10⁴), `COURANT` the adaptive time stepping's number (default
//! 0.4; a small one forces the 256-substep cap without viscosity), `K` the artificial pressure
//! (default 0.1; 0 switches it off), `unscaled` turns `Pbf::artificial_pressure_dt_scaling`
//! off. Measured (2026-11-27; 256 substeps of 65 µs a frame at 10⁴ Pa·s, the cap):
//!
//! ```text
//! -- 1e4 0.4 8                     KE/PE0 at most 1.2e-3 (frame 0), 0.08 m/s
//! -- 1e4 0.4 6 0.1 unscaled        13.1 at frame 0 (9.5 m/s), 8.9, 0.74, 1.57 (3.7 m/s), 0.47
//! -- 0 0.0015 4 0.1 unscaled       no viscosity, same cap: 73.5 at frame 0 (34 m/s), 11.9
//! -- 1e4 0.4 5 0                   no artificial pressure: at most 1.5e-3
//! ```
//! The energy comes from the artificial pressure at a fixed strength, a position correction of
//! fixed size in every iteration turned into velocity `Δx/dt` (`solver/pbf/step.rs`), not from
//! the viscosity (which damps it); its default `dt²` scaling holds the block at rest.
use rapier_sph::math::{Real, Vector};
use rapier_sph::scenes::add_closed_box;
use rapier_sph::{Fluid, FluidParamsBuilder, FluidWorld, Pbf, Solver, TimeStepping};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let mu: Real = a.get(1).and_then(|s| s.parse().ok()).unwrap_or(1e4);
    let courant: Real = a.get(2).and_then(|s| s.parse().ok()).unwrap_or(0.4);
    let frames: usize = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(10);
    let ap: Real = a.get(4).and_then(|s| s.parse().ok()).unwrap_or(0.1);
    let scaling = a.get(5).is_none_or(|s| s != "unscaled");
    let s = 0.05;
    let pbf = Pbf {
        artificial_pressure: ap,
        artificial_pressure_dt_scaling: scaling,
        ..Pbf::default()
    };
    let params = FluidParamsBuilder::water(s)
        .solver(Solver::Pbf(pbf))
        .viscosity(mu)
        .build()
        .unwrap();
    let mut world = FluidWorld::new();
    let max = Vector::new(0.6, 0.6, 0.6);
    add_closed_box(&mut world, Vector::ZERO, max, 0.1);
    world.physics.step();
    world.pipeline.time_stepping = TimeStepping::Adaptive {
        courant,
        max_substeps: 256,
    };
    let h = world.fluids.insert(Fluid::new(params).unwrap());
    world.fluids[h]
        .add_block(Vector::ZERO, Vector::new(0.6, 0.3, 0.6))
        .unwrap();
    let f = &world.fluids[h];
    let m = f.params().particle_mass as f64;
    let pe0: f64 = f.positions().iter().map(|x| m * 9.81 * x.y as f64).sum();
    println!("n {} pe0 {pe0:.3}", f.len());
    for frame in 0..frames {
        let r = world.step().unwrap().clone();
        let f = &world.fluids[h];
        let (mut vmax, mut imax) = (0.0, 0);
        for (i, v) in f.velocities().iter().enumerate() {
            if v.length() > vmax {
                vmax = v.length();
                imax = i;
            }
        }
        let x = f.positions()[imax];
        println!(
            "frame {frame}: KE/PE0 {:.3e} substeps {} dt {:.2e} it {} err {:.2e} maxerr {:.2e} vlim {} vmax {vmax:.3} at ({:.3},{:.3},{:.3}) halvings {}",
            f.kinetic_energy() / pe0,
            r.substeps,
            r.max_substep,
            r.solver_iterations,
            r.solver_density_error,
            r.max_density_error,
            r.viscosity_limited,
            x.x,
            x.y,
            x.z,
            r.solver_relaxation_halvings
        );
    }
}
