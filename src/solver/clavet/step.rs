//! The double-density relaxation's substep as the pipeline calls it (Clavet et al. 2005,
//! Alg. 1): the pipeline has added gravity and predicted the positions; this applies the
//! viscoelastic springs (if any) and the relaxation to them, then the velocity update and
//! viscosity. Its state: the relaxation's buffers, the springs (keyed by particle id, so they
//! survive re-sorts and removals), and the fluid's stiffest rest mode for the substep limit.

use super::{Clavet, ClavetBuffers, ClavetContext};
use crate::diagnostics::Stage;
use crate::domain::Separation;
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use crate::solver::context::{Outcome, StepContext};
use crate::solver::springs::{self, SpringBuffers, SpringContext, SpringSet};
use crate::solver::{PressureSolver, WallReaction, WallRequest};

/// Bound of the relaxation's `θ = λ·dt²` per squared Courant number: 1.2 at the default
/// Courant number 0.4, 90 % of the linear stability bound 4/3.
const THETA_PER_COURANT2: Real = 7.5;

/// The relaxation's buffers, the springs, and the stiffest rest mode.
#[derive(Clone, Debug, Default)]
pub(crate) struct ClavetState {
    /// `(P, P_near)`, displacements, partial sums.
    pub buffers: ClavetBuffers,
    /// The viscoelastic springs (empty with springs off).
    pub springs: SpringSet,
    /// Scratch of the spring stage.
    pub spring_buffers: SpringBuffers,
    /// The stiffest rest mode (1/s²) and the parameters it was computed for (support,
    /// spacing, speed of sound, settings); see [`super::stiffest_rest_mode`].
    pub stiffest: Option<(Real, Real, Real, Clavet, Real)>,
}

impl PressureSolver for ClavetState {
    type Settings = Clavet;
    const PREDICTS_POSITIONS: bool = true;
    // Dynamic bodies are left out of its wall densities (contact only): its wall term has no
    // share of theirs to react (`wall_impulse_scale` is 0).
    const WALL_REACTION: WallReaction = WallReaction::Impulse { added_mass: true };

    fn walls(_: &Clavet, params: &FluidParams) -> WallRequest {
        WallRequest {
            force_kernel: params.density_kernel,
            hydrostatic: false,
            double_density: true,
            planes: false,
        }
    }

    fn step<S: Separation>(
        &mut self,
        settings: &Clavet,
        ctx: &mut StepContext<'_>,
        sep: S,
    ) -> Outcome {
        let p = ctx.params;
        let (h, c, dt) = (
            p.smoothing_length,
            p.equation_of_state.speed_of_sound(),
            ctx.dt,
        );
        let relax = ClavetContext {
            neighbors: ctx.neighbors,
            h,
            spacing: p.particle_spacing,
            speed_of_sound: c,
            dt,
            wall: ctx.wall,
            hold: ctx.hold,
            ratio: ctx.phases.map(|ph| ph.ratio),
        };
        // Springs (if any) first, on the predicted positions (the paper's Alg. 1 order); timed
        // with the relaxation.
        let (ids, neighbors) = (ctx.ids, ctx.neighbors);
        let error = ctx.report.timed(Stage::DensitySolve, || {
            if let Some(s) = &settings.springs {
                let sctx = SpringContext {
                    neighbors,
                    ids,
                    h,
                    speed_of_sound: c,
                    expected_neighbours: p.expected_neighbours(),
                    dt,
                };
                springs::apply_in(
                    &sctx,
                    s,
                    &mut self.springs,
                    &mut self.spring_buffers,
                    ctx.positions,
                    sep,
                );
            } else if !self.springs.is_empty() {
                // Springs switched off: forget them.
                self.springs = Default::default();
            }
            super::relax_in(
                &relax,
                settings,
                &mut self.buffers,
                ctx.positions,
                ctx.densities,
                sep,
            )
        });
        ctx.report.solver_iterations += 1;
        ctx.report.solver_density_error = ctx.report.solver_density_error.max(error);
        // Densities: the relative density times ρ0; pressures: the relaxation's pressure as a
        // linear equation of state with the fluid's speed of sound (the acceleration the
        // relaxation applies): the stiffness above ρ0, none between the cohesion threshold and
        // ρ0, the cohesion below the threshold. The method's densities do not count the
        // particle itself: a particle whose only neighbour sits at the support's edge has a
        // density near 0, and `1/ρ` (the particle's volume in the viscosity term) near 10^38,
        // which turned the viscosity into NaN (20–50 m/s at 0.2–0.4 m spacing: up to 118 of
        // 512 particles quarantined). `1/ρ` counts the particle's own kernel `(1 − 0)² = 1`,
        // as an SPH density does: at most `ρ0_lattice/ρ0` with `ρ0_lattice` the lattice's
        // `Σ(1 − q)²`.
        let self_density = p.rest_density / super::lattice_rest_density(h, p.particle_spacing);
        let threshold = super::cohesion_threshold(h, p.particle_spacing);
        for ((rho, pr), inv) in ctx
            .densities
            .iter_mut()
            .zip(ctx.pressures.iter_mut())
            .zip(ctx.inv_densities.iter_mut())
        {
            let rel = *rho;
            *rho = rel * p.rest_density;
            *inv = 1.0 / rho.max(self_density);
            let excess = if rel >= 1.0 {
                settings.stiffness * (rel - 1.0)
            } else {
                settings.cohesion * (rel - threshold).min(0.0)
            };
            // Clamped to the largest finite `f32`: at the fastest accepted speed of sound
            // `c²·ρ0` overflows (c = 10¹⁸ m/s gave −∞).
            *pr = (excess * p.rest_density * c * c).clamp(-Real::MAX, Real::MAX);
        }
        // Interacting fluids: each particle's own fluid's pressure, `ρ0_i/ρ_ref` times the
        // reference's at the same relative density (`crate::fluid::interaction`).
        if let Some(ph) = ctx.phases {
            for (pr, &r) in ctx.pressures.iter_mut().zip(ph.ratio) {
                *pr /= r;
            }
        }
        crate::solver::finish_position_step(ctx, sep)
    }

    /// Zero: dynamic bodies do not count in Clavet's wall densities (they meet its water
    /// through contact only, `boundary::wall::WallWorkspace::update_clavet`), so its wall term
    /// gives them nothing to react to.
    fn wall_impulse_scale(&self, _: &Clavet, _: &StepContext<'_>, _: usize) -> Real {
        0.0
    }

    /// The relaxation pushes like an equation of state whose speed of sound is `c·√k` (its
    /// stiffnesses are in units of `c²/(h·ρ0)`, its springs' in `c²/(h²·N)`). Linear
    /// stability: with the forces taken at the predicted positions, a mode of stiffness λ (per
    /// unit mass) evolves as `x' = (1 − θ)(x + dt·v)`, `θ = λ·dt²`, bounded iff θ ≤ 4/3. The
    /// stiffest mode of the lattice (power iteration on a periodic lattice 0.1 % compressed,
    /// where both pressures act) has λ ≈ 4.1·k·c²/h² at `h = 2s`, so θ ≈ 4.1·courant² = 0.66
    /// at the default Courant number 0.4. It grows faster than c²/h² with the support in
    /// spacings (λ·h²/c² = 4.1, 6.9, 11.1 at h/s = 2, 2.5, 3; the paper's pressures, whose
    /// tension and near pressure were on at rest, had 6.6, 12.1, 21.1), so the fluid's own
    /// stiffest mode, computed once per parameter set, also bounds the substep:
    /// θ ≤ [`THETA_PER_COURANT2`]·courant².
    fn time_step_limit(
        &mut self,
        settings: &Clavet,
        params: &FluidParams,
        speed: Real,
        _: Vector,
        courant: Real,
    ) -> Real {
        let c = params.equation_of_state.speed_of_sound()
            * settings
                .stiffness
                .max(settings.cohesion)
                .max(settings.near_stiffness.unwrap_or(settings.stiffness))
                .max(settings.springs.map_or(0.0, |s| s.stiffness))
                .max(1e-6)
                .sqrt();
        let mut limit = courant * params.smoothing_length / (c + speed);
        let lambda = self.stiffest_rest_mode(settings, params);
        if lambda > 0.0 {
            limit = limit.min(courant * (THETA_PER_COURANT2 / lambda).sqrt());
        }
        limit
    }

    fn heap_bytes(&self) -> usize {
        self.buffers.heap_bytes() + self.springs.heap_bytes() + self.spring_buffers.heap_bytes()
    }
}

impl ClavetState {
    /// The fluid's stiffest rest mode, recomputed only when its parameters changed.
    fn stiffest_rest_mode(&mut self, settings: &Clavet, params: &FluidParams) -> Real {
        let (h, s) = (params.smoothing_length, params.particle_spacing);
        let c = params.equation_of_state.speed_of_sound();
        if let Some((h0, s0, c0, k0, lambda)) = self.stiffest
            && (h0, s0, c0, k0) == (h, s, c, *settings)
        {
            return lambda;
        }
        let lambda = super::stiffest_rest_mode(settings, h, s, c);
        self.stiffest = Some((h, s, c, *settings, lambda));
        lambda
    }
}
