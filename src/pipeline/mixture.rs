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
    #[cfg(test)]
    let (before, kept) = (
        record::moments(m, &taken, ctx.velocities, volume),
        ctx.velocities.to_vec(),
    );
    let velocities = &mut *ctx.velocities;
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
                mixture::transport::<K, S>(m, &t, &mut views, velocities, scratch))
        });
        scratch.effective_gravity = gravity;
    });
    #[cfg(test)]
    record::push(
        before,
        record::moments(m, &taken, ctx.velocities, volume),
        record::moments(m, &taken, &kept, volume),
    );
    for (k, values) in taken.into_iter().enumerate() {
        *ctx.attributes.vec_mut(idx[k]) = values;
    }
}

/// The lib tests' record of each substep's transport: the fluid's momentum and kinetic
/// energy just before and just after it (f64 sums, each particle at its own mass).
#[cfg(test)]
pub(crate) mod record {
    use crate::math::{Real, Vector};
    use crate::mixture::Mixture;
    use std::sync::Mutex;

    /// A fluid's motion at one moment.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Moments {
        /// Momentum (kg·m/s).
        pub p: [f64; 3],
        /// `Σ m|v|` (kg·m/s).
        pub abs: f64,
        /// Kinetic energy (J).
        pub ke: f64,
        /// The largest speed (m/s).
        pub v_max: f64,
        /// The particles.
        pub n: usize,
    }

    /// Each substep: before, after, and after with the velocities kept (the fractions
    /// moved, the velocities not: what the transport did before it carried momentum).
    /// `Some` while a test records (one test at a time: such a test holds [`GUARD`]).
    pub(crate) static RECORDS: Mutex<Option<Vec<[Moments; 3]>>> = Mutex::new(None);
    /// Held by a recording test.
    pub(crate) static GUARD: Mutex<()> = Mutex::new(());

    pub(crate) fn moments(
        m: &Mixture,
        fractions: &[Vec<Real>],
        v: &[Vector],
        volume: Real,
    ) -> Moments {
        let mut out = Moments {
            p: [0.0; 3],
            abs: 0.0,
            ke: 0.0,
            v_max: 0.0,
            n: v.len(),
        };
        for (i, v) in v.iter().enumerate() {
            let mass: f64 = m
                .phases
                .iter()
                .zip(fractions)
                .map(|(ph, a)| ph.rest_density as f64 * a[i] as f64)
                .sum::<f64>()
                * volume as f64;
            let v = [v.x as f64, v.y as f64, v.z as f64];
            for (p, vc) in out.p.iter_mut().zip(v) {
                *p += mass * vc;
            }
            let s2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
            out.abs += mass * s2.sqrt();
            out.ke += 0.5 * mass * s2;
            out.v_max = out.v_max.max(s2.sqrt());
        }
        out
    }

    pub(crate) fn push(before: Moments, after: Moments, kept: Moments) {
        if let Some(r) = RECORDS.lock().unwrap().as_mut() {
            r.push([before, after, kept]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::record::{self, Moments};
    use crate::FluidParamsBuilder;
    use crate::math::{Real, Vector};
    use crate::mixture::Mixture;
    use crate::scenes::{MixedStart, MixedTank};

    /// Steps `tank` for `frames` frames, recording every substep's transport.
    fn recorded(tank: &mut MixedTank, frames: usize) -> Vec<[Moments; 3]> {
        *record::RECORDS.lock().unwrap() = Some(Vec::new());
        for _ in 0..frames {
            let report = tank.world.step().unwrap();
            assert_eq!(report.non_finite, 0);
        }
        record::RECORDS.lock().unwrap().take().unwrap()
    }

    /// The tank of tests/mixture.rs, 8 × `layers` × 8 particles at 1.25 cm, oil droplets of
    /// 1 mm in water.
    fn tank(layers: usize, start: MixedStart) -> MixedTank {
        let params = FluidParamsBuilder::water(0.1 / 8.0)
            .mixture(Mixture::oil_in_water(1e-6 / 18e-3, 1e-5))
            .build()
            .unwrap();
        MixedTank::new(params, [8, layers, 8], start).unwrap()
    }

    /// The most neighbours a particle of the tank's lattice can have: the lattice points
    /// within the support radius `h` of one (particles pack no closer than the lattice by
    /// more than the solver's density error, so twice that is a safe ceiling).
    fn neighbours_ceiling(tank: &MixedTank) -> f64 {
        let p = &tank.fluid().params();
        let reach = (p.smoothing_length / p.particle_spacing).ceil() as i32;
        let mut count = 0;
        for a in -reach..=reach {
            for b in -reach..=reach {
                for c in -reach..=reach {
                    let r = ((a * a + b * b + c * c) as Real).sqrt() * p.particle_spacing;
                    count += i32::from(r < p.smoothing_length);
                }
            }
        }
        2.0 * count as f64
    }

    /// The round-off bound of one substep's transport on the momentum (see the test).
    fn bound(b: &Moments, a: &Moments, k: f64, m_max: f64) -> f64 {
        let np = 2.0;
        let eps = (2.0f64).powi(-24);
        let v_max = b.v_max.max(a.v_max);
        eps * (k * np + np + 5.0) * (b.abs + 2.0 * b.n as f64 * m_max * v_max)
    }

    /// Checks every substep's transport: momentum and kinetic energy; returns the worst
    /// `|ΔP|` over its bound, with the velocities updated and with them kept.
    fn check(records: &[[Moments; 3]], k: f64, m_max: f64, what: &str) -> (f64, f64) {
        assert!(!records.is_empty(), "{what}: nothing recorded");
        let change = |x: &Moments, y: &Moments| {
            ((0..3).map(|c| (x.p[c] - y.p[c]).powi(2)).sum::<f64>()).sqrt()
        };
        let (mut worst, mut kept_worst) = (0.0f64, 0.0f64);
        for (s, [b, a, kept]) in records.iter().enumerate() {
            let bound = bound(b, a, k, m_max);
            worst = worst.max(change(a, b) / bound);
            kept_worst = kept_worst.max(change(kept, b) / bound);
            assert!(
                change(a, b) <= bound,
                "{what}, substep {s}: momentum {:?} -> {:?} (bound {bound:e})",
                b.p,
                a.p
            );
            assert!(
                a.ke - b.ke <= b.v_max.max(a.v_max) * bound,
                "{what}, substep {s}: kinetic energy {} -> {}",
                b.ke,
                a.ke
            );
        }
        (worst, kept_worst)
    }

    /// The phases' transport conserves momentum pair by pair: over every substep, the
    /// fluid's momentum changes by no more than the f32 round-off of the per-particle
    /// momentum updates, and the kinetic energy does not grow by more than that (each
    /// swapped volume leaves its donor at the donor's velocity and merges with the receiver:
    /// an inelastic exchange, so the energy can only fall). The round-off: each particle's
    /// new momentum `ρ0_i v_i + Σ_j Σ_k ρ_k φ_k v_up` sums `K·phases + 1` terms in f32 (`K`
    /// its neighbours), whose magnitudes add up to at most `ρ0_i|v_i| + 2ρ_max·v_max` (what
    /// a particle gives and receives is at most its volume), then is divided by its new
    /// density (`phases` roundings): at most `2⁻²⁴·(K·phases + phases + 5)·(m_i|v_i| +
    /// 2·m_max·v_max)` per particle, summed. Measured in a closed box without gravity (a
    /// checkerboard of pure oil and water particles thrown at a wall at 1 m/s: the drift is
    /// `−τΔρ·a`, the walls' friction off in the water preset) and in the tank that
    /// stratifies under gravity. Keeping the velocities while the fractions move (the mass
    /// moves without its momentum) exceeds the bound: that is checked too.
    #[test]
    fn the_transport_conserves_momentum() {
        let _guard = record::GUARD.lock().unwrap_or_else(|e| e.into_inner());
        let mut thrown = tank(8, MixedStart::Checker);
        assert_eq!(thrown.fluid().params().wall_viscosity, 0.0);
        thrown.world.physics.gravity = Vector::ZERO;
        for v in thrown.world.fluids[thrown.fluid].velocities_mut() {
            *v = Vector::new(1.0, 0.0, 0.0);
        }
        let mut settling = tank(16, MixedStart::Uniform(vec![0.5, 0.5]));
        let k = neighbours_ceiling(&thrown);
        // The heaviest phase's particle mass, `V·ρ_max`.
        let p = thrown.fluid().params();
        let m_max = (p.particle_mass / p.rest_density * 1000.0) as f64;
        for (t, frames, what) in [
            (&mut thrown, 30, "zero gravity, thrown"),
            (&mut settling, 60, "stratifying tank"),
        ] {
            let r = recorded(t, frames);
            let (worst, kept) = check(&r, k, m_max, what);
            eprintln!(
                "{what}: {} substeps, the largest |ΔP| {worst:.3e} of the bound; velocities kept: {kept:.3e} of it",
                r.len()
            );
            assert!(
                kept > 1.0,
                "{what}: the mass moved without momentum: {kept}"
            );
        }
    }
}
