//! The walls' viscosity (see [`crate::boundary::wall`]): `dv_i/dt = ε_w/ρ_i·Σ_k L_k (v_k −
//! v_i)`, integrated implicitly over the substep against the walls' velocities at its start,
//! `v_i' = (v_i + α_i v̄_i)/(1 + α_i)` with `α_i = dt·ε_w·L_i/ρ_i` and `v̄_i` the walls'
//! `L`-weighted velocity: the particle tends to the wall's velocity and never overshoots it,
//! at any substep. Each dynamic body's share of a particle's velocity change goes back to the
//! body as the opposite impulse (explicit: the body's velocity is the substep start's, as for
//! contact without the added-mass solve), applied at the particle's position: the force is
//! tangential, so only there does the torque the body takes equal the angular momentum the
//! particle gains.

use crate::boundary::WallWorkspace;
use crate::boundary::bodies::ImpulseRecord;
use crate::math::{Real, Vector};
use crate::par;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// The constants of one application.
#[derive(Copy, Clone)]
pub(crate) struct WallViscosity<'a> {
    /// The walls' viscosity `ε_w`.
    pub epsilon: Real,
    /// Each particle's mass.
    pub mass: crate::boundary::bodies::ParticleMass<'a>,
    /// The substep.
    pub dt: Real,
    /// The walls' viscous sums (`viscous`, `viscous_velocity`, `coupled`).
    pub wall: &'a WallWorkspace,
}

/// Applies the walls' viscosity to `velocities`, recording each dynamic body's share as an
/// impulse in `records` (in particle order).
pub(crate) fn apply(
    c: WallViscosity<'_>,
    positions: &[Vector],
    inv_densities: &[Real],
    velocities: &mut [Vector],
    records: &mut Vec<ImpulseRecord>,
) {
    let wall = c.wall;
    let factor = |i: usize| c.dt * c.epsilon * inv_densities[i];
    if wall.coupled_any {
        for (i, cw) in wall.coupled.iter().enumerate() {
            if cw.entry == u32::MAX || cw.viscous <= 0.0 {
                continue;
            }
            let f = factor(i);
            let alpha = f * wall.viscous[i];
            // The body's share of `v_i' − v_i = f·(Σ L_k v_k − L v_i)/(1 + α)`.
            let dv = (cw.viscous_velocity - velocities[i] * cw.viscous) * (f / (1.0 + alpha));
            records.push(ImpulseRecord {
                entry: cw.entry,
                particle: i as u32,
                normal: Vector::ZERO,
                impulse: -dv * c.mass.of(i),
                point: positions[i],
                moment: Vector::ZERO,
                held: None,
            });
        }
    }
    crate::par_chunks_mut!(velocities, par::CHUNK)
        .enumerate()
        .for_each(|(k, out)| {
            let base = k * par::CHUNK;
            for (j, v) in out.iter_mut().enumerate() {
                let i = base + j;
                let l = wall.viscous[i];
                if l > 0.0 {
                    let f = factor(i);
                    *v = (*v + wall.viscous_velocity[i] * f) / (1.0 + f * l);
                }
            }
        });
}
