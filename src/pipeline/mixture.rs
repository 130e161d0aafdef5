//! A mixture's substep (`crate::mixture`): before the solver, each particle's factors from
//! its fractions (the number-density form of interacting liquids, `solver::context::Phases`);
//! after it, the densities in each particle's own units, then the phases' drift and
//! diffusion. A fluid without a mixture returns at the first check.

use super::interaction::{RATIO, VISCOSITY};
use crate::diagnostics::Stage;
use crate::fluid::{Attributes, ParticlesMut};
use crate::math::Real;
use crate::mixture::{self, MAX_PHASES, Mixture, PREFIX};
use crate::params::FluidParams;
use crate::solver::context::StepContext;

/// The index of every phase's fractions in `attributes` (created, zeros, if missing: the
/// fluid makes them when the mixture is set).
fn fraction_indices(m: &Mixture, attributes: &mut Attributes, n: usize) -> [usize; MAX_PHASES] {
    let mut idx = [0; MAX_PHASES];
    for (k, slot) in idx.iter_mut().enumerate().take(m.len()) {
        *slot = match attributes.index_of(PREFIX, mixture::name(k)) {
            Some(a) => a,
            None => attributes.ensure(&format!("{PREFIX}{k}"), n),
        };
    }
    idx
}

/// Before the solver: each particle's `r_i = ρ_ref/ρ0_i` and viscosity weight `√(ε_i/ε)`
/// from its fractions, written where the solver's phases are read
/// (`pipeline::interaction::take_phases`), and the velocities at the substep's start (for
/// the acceleration). `params` are the ones the solver holds the fluid at (`hold` times
/// its rest density).
pub(super) fn before_solve(
    params: &FluidParams,
    hold: Real,
    particles: &mut ParticlesMut<'_>,
    scratch: &mut mixture::Scratch,
) {
    let Some(m) = &params.mixture else {
        return;
    };
    let n = particles.positions.len();
    let attributes = &mut *particles.attributes;
    let idx = fraction_indices(m, attributes, n);
    let (r, v) = (attributes.ensure(RATIO, n), attributes.ensure(VISCOSITY, n));
    let mut ratio = std::mem::take(attributes.vec_mut(r));
    let mut weight = std::mem::take(attributes.vec_mut(v));
    let rest = params.rest_density / hold;
    let eps = params.viscosity;
    for i in 0..n {
        let (mut rho, mut visc) = (0.0, 0.0);
        for (k, p) in m.phases.iter().enumerate() {
            let a = attributes.get(idx[k])[i];
            rho += a * p.rest_density;
            visc += a * p.viscosity;
        }
        ratio[i] = rest / rho;
        weight[i] = if eps > 0.0 {
            (visc.max(0.0) / eps).sqrt()
        } else {
            0.0
        };
    }
    *attributes.vec_mut(r) = ratio;
    *attributes.vec_mut(v) = weight;
    scratch.start_velocities.clear();
    scratch
        .start_velocities
        .extend_from_slice(particles.velocities);
}

/// After the solver and the stages on its velocities: the densities in each particle's own
/// units (`ρ0_i/ρ_ref` times the reference's), then the drift and diffusion of the phases
/// over the substep (timed with the scalar diffusion).
pub(super) fn after_solve(ctx: &mut StepContext<'_>, scratch: &mut mixture::Scratch) {
    let p = ctx.params;
    let Some(m) = &p.mixture else {
        return;
    };
    let Some(phases) = ctx.phases else {
        return;
    };
    for (d, r) in ctx.densities.iter_mut().zip(phases.ratio) {
        *d /= r;
    }
    let n = ctx.positions.len();
    if scratch.start_velocities.len() != n {
        return;
    }
    let (dt, g) = (ctx.dt, ctx.gravity);
    scratch.effective_gravity.clear();
    scratch.effective_gravity.extend(
        ctx.velocities
            .iter()
            .zip(&scratch.start_velocities)
            .map(|(v, v0)| g - (*v - *v0) / dt),
    );
    let idx = fraction_indices(m, ctx.attributes, n);
    let mut taken: Vec<Vec<Real>> = (0..m.len())
        .map(|k| std::mem::take(ctx.attributes.vec_mut(idx[k])))
        .collect();
    let (positions, neighbors) = (&*ctx.positions, ctx.neighbors);
    let volume = p.particle_mass / (p.rest_density / ctx.hold);
    ctx.report.timed(Stage::ScalarDiffusion, || {
        let gravity = std::mem::take(&mut scratch.effective_gravity);
        crate::with_separation!(p.domain, S, sep => {
            let t = mixture::Transport {
                pairs: crate::neighbors::Pairs {
                    positions,
                    neighbors,
                    mass: p.particle_mass,
                    h: p.smoothing_length,
                    sep,
                },
                volume,
                dt,
                effective_gravity: &gravity,
            };
            let mut views: Vec<&mut Vec<Real>> = taken.iter_mut().collect();
            crate::with_kernel!(p.pressure_kernel, K =>
                mixture::transport::<K, S>(m, &t, &mut views, scratch))
        });
        scratch.effective_gravity = gravity;
    });
    for (k, values) in taken.into_iter().enumerate() {
        *ctx.attributes.vec_mut(idx[k]) = values;
    }
}
