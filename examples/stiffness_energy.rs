//! Energy budget of the stability suite's case 1 (the paper's tower at a chosen stiffness):
//! kinetic, potential and the equation of state's internal energy `Σ m·u(ρ)`, with
//! `u(ρ) = (k/2)(ln(ρ/ρ0) + ρ0/ρ − 1)` for the linear `p = k(ρ − ρ0)` (the energy whose
//! gradient Müller's symmetric force is in a uniform fluid: `u' = p/(2ρ²)`).
//!
//! The suite's case 1 bounds the total (kinetic + potential + internal) against its initial
//! value; the paper preset's tower starts compressed, so this shows how much of the motion is
//! stored compression released and how much is energy the integrator made. The densities are
//! interpolated at the particles' positions at the end of each frame (as at t = 0).
//!
//! ```text
//! cargo run --release --example stiffness_energy -- 3000 240   # k, frames of 1/60 s
//! cargo run --release --example stiffness_energy -- 3000 240 cubic   # both kernels cubic spline
//! ```
//!
//! The third argument, `cubic`, gives density and pressure force the same kernel (the cubic
//! spline) instead of the paper's pair (tuned poly6 for density, spiky for the force): only
//! with one kernel is the pressure force the gradient of the internal energy above, so only
//! then can the integrator conserve the total.

use rapier_sph::FluidParamsBuilder;
use rapier_sph::query::FluidSampler;
use rapier_sph::scenes::{DamBreakConfig, dam_break};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let k: f32 = args.next().map_or(Ok(3000.0), |s| s.parse())?;
    let frames: usize = args.next().map_or(Ok(240), |s| s.parse())?;
    let mut builder = FluidParamsBuilder::paper().stiffness(k);
    match args.next().as_deref() {
        None | Some("paper") => {}
        Some("cubic") => {
            builder = builder
                .density_kernel(rapier_sph::KernelKind::CubicSpline)
                .pressure_kernel(rapier_sph::KernelKind::CubicSpline)
        }
        Some(other) => return Err(format!("unknown kernels {other} (paper, cubic)").into()),
    }
    let params = builder.build()?;
    let (rho0, m) = (params.rest_density as f64, params.particle_mass as f64);
    let mut d = dam_break(&DamBreakConfig::tower(params, 1.0))?;
    d.world.physics.integration_parameters.dt = 1.0 / 60.0;
    let floor = d.tank_min.y as f64;
    let g = d.world.physics.gravity.length() as f64;
    let u = |rho: f64| {
        if rho > 0.0 {
            0.5 * k as f64 * ((rho / rho0).ln() + rho0 / rho - 1.0)
        } else {
            0.0
        }
    };
    let energies = |f: &rapier_sph::Fluid, rhos: &[f64]| {
        let ke = f.kinetic_energy();
        let pe: f64 = f
            .positions()
            .iter()
            .map(|x| m * g * (x.y as f64 - floor))
            .sum();
        let ie: f64 = rhos.iter().map(|&r| m * u(r)).sum();
        (ke, pe, ie)
    };

    // At t = 0 the fluid has no densities yet: interpolate them at the particles.
    let f = &d.world.fluids[d.fluid];
    let sampler = FluidSampler::new(f);
    let rhos: Vec<f64> = f
        .positions()
        .iter()
        .map(|&x| sampler.sample(x).map_or(0.0, |s| s.density as f64))
        .collect();
    let mean = rhos.iter().sum::<f64>() / rhos.len().max(1) as f64;
    let (ke0, pe0, ie0) = energies(f, &rhos);
    println!(
        "k = {k}: mean density at t = 0 {:.2} ρ0; kinetic {ke0:.4e} J, potential {pe0:.4e} J, \
         internal {ie0:.4e} J",
        mean / rho0
    );
    let (mut max_verdict, mut max_total, mut max_energy) = (0.0f64, 0.0f64, 0.0f64);
    for frame in 0..frames {
        let substeps = d.world.step()?.substeps;
        let f = &d.world.fluids[d.fluid];
        // The densities at the frame's end positions, as at t = 0 (the stability suite's
        // case 1 counts the same: `stability::eos_internal_energy`).
        let sampler = FluidSampler::new(f);
        let rhos: Vec<f64> = f
            .positions()
            .iter()
            .map(|&x| sampler.sample(x).map_or(0.0, |s| s.density as f64))
            .collect();
        let (ke, pe, ie) = energies(f, &rhos);
        max_verdict = max_verdict.max(ke / (pe0 + ke0));
        max_total = max_total.max(ke / (pe0 + ke0 + ie0));
        max_energy = max_energy.max((ke + pe + ie) / (pe0 + ke0 + ie0));
        if frame < 3 || frame % 30 == 0 || frame + 1 == frames {
            println!(
                "frame {frame:4} ({substeps:3} substeps): kinetic {ke:.4e}  potential {pe:.4e}  \
                 internal {ie:.4e}  total {:.4e} J",
                ke + pe + ie
            );
        }
    }
    println!(
        "largest kinetic energy / initial (kinetic + potential): {max_verdict:.3}; \
         / initial (kinetic + potential + internal): {max_total:.3}; largest total / initial \
         total: {max_energy:.3} (case 1's verdict, at most 1.05)"
    );
    Ok(())
}
