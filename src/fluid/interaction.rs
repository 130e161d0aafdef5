//! Fluids that interact: oil on water, a light liquid over a heavy one.
//!
//! Fluids of one [`FluidSet`] interact when their [`FluidParams::fluid_groups`] say so
//! (rapier's `InteractionGroups::test`, as for colliders; default: no fluid interacts). Each
//! group of interacting fluids is stepped as one set of particles: one neighbour search, one
//! pressure solve, in which every particle keeps its own fluid's rest density, particle mass
//! and viscosity. Two liquids that interact keep an interface (they are immiscible: nothing
//! but pressure and viscosity passes between them).
//!
//! # The formulation
//!
//! Solenthaler & Pajarola 2008, "Density contrast SPH interfaces" (SCA 2008), number-density
//! form: with one particle volume `V = m_k/ρ0_k` for every fluid `k` (equal spacings), the
//! number density `δ_i = Σ_j W_ij` gives each particle's density `ρ_i = m_i·δ_i` from its
//! own mass only, so the density of a particle next to the interface is not smeared by its
//! neighbours' masses (the standard `Σ m_j W_ij` puts a water particle next to oil at 0.9 of
//! its rest density, a spurious tension that mixes the layers). The incompressibility
//! condition `ρ_i/ρ0_i = V·δ_i` is then the same for every fluid; only the accelerations
//! differ: the pressure force `F_i = −Σ_j (p_i/δ_i² + p_j/δ_j²) ∇W_ij` (Solenthaler &
//! Pajarola's eq. 6; WCSPH's symmetric `(p_i + p_j)/(2δ_iδ_j)` form) is the same
//! antisymmetric pair force for all fluids, divided by each particle's own mass.
//!
//! The solvers run on the group as if every particle had the first fluid's (the reference's)
//! mass `m_ref` and rest density `ρ_ref`, in which units `m_ref·Σ W_ij` is `ρ_ref·V·δ_i`,
//! and multiply every pair acceleration of particle `i` by `r_i = m_ref/m_i = ρ_ref/ρ0_i`
//! (`StepContext::phases`): DFSPH's pressure pushes and its factors `α_i` (the diagonal of
//! the Jacobi solve, whose pushes are `r_i` times stronger, divided by `r_i`), WCSPH's
//! pressure and viscosity accelerations; WCSPH's equation of state gives particle `i` its
//! own fluid's pressure, `ρ0_i/ρ_ref` times the reference's. Each pair force `m_ref·a` stays
//! antisymmetric, so momentum is conserved across the fluids. Viscosity between fluids `k`
//! and `l` uses `√(ε_k·ε_l)` (the geometric mean keeps the pair term a product of
//! per-particle factors: `ε_k` within fluid `k`, and zero against an inviscid fluid). The
//! walls' hydrostatic term (DFSPH) is already per unit of the particle's own rest density and
//! is left as is. The densities written back are each fluid's physical ones (`ρ0_i·V·δ_i`).
//!
//! # What must match
//!
//! Interacting fluids must share everything the combined step reads once for all of them:
//! particle spacing, particle volume (mass / rest density), smoothing length, contact
//! radius, kernels, domain, the solver (DFSPH or WCSPH; PBF and Clavet return an error: not
//! supported yet), its boolean settings, the explicit viscosity (the implicit
//! `viscosity_solve` returns an error: not supported yet), WCSPH's equation of state, the wall, contact and
//! surface settings and the collision groups; a density ratio of at most
//! [`MAX_DENSITY_RATIO`]; no diffusing scalar (scalar diffusion across fluids is not done
//! yet); and interaction must hold between every two fluids of a group (`a`–`b` and `b`–`c`
//! interacting need `a`–`c` too). Anything else is a [`SphError::InvalidParameter`] naming
//! the field, returned by the step before anything changes. DFSPH's tolerances may differ:
//! the group is solved to the tightest of its fluids' (smallest errors, most iterations).
//!
//! # Measured
//!
//! In a closed tank 0.1 m wide, 8 × 8 × 8 particles of each liquid at 1.25 cm
//! (`scenes::LayeredTank`, feature `validation`; `cargo test --release --test interaction`):
//! - oil (800) on water, DFSPH: the layers stay, the bottom pressure averaged over the second
//!   second is +1.1 % off `ρ_oil·g·h_oil + ρ_water·g·h_water` (two waters: −0.6 %); water under
//!   a liquid of 100 kg/m³: −0.7 %. WCSPH reads +117 % there, as it does with one fluid in
//!   this tank (its walls mirror the particle's own pressure);
//! - oil and water side by side (a lock exchange) stratify within 2 s; the interface settles
//!   at 0.108 m for 0.100 with DFSPH (0.136 m with WCSPH). What is left are single particles of
//!   one liquid caught in the other: a lone particle is held by its neighbours' lattice under
//!   a pressure `ρ·g·depth` far above its buoyancy `Δρ·g·s`, so a mix at the particle scale
//!   barely separates (a checkerboard of 2 × 2 × 2-particle cubes went from 0.200 to 0.183 m
//!   in 5 s, one of 4 × 4 × 4 to 0.133 m, at a viscosity of 0.05; with the water preset's 0.5
//!   the 4 × 4 × 4 one stalled at 0.174 m);
//! - two blobs (1000 and 100 kg/m³) thrown at each other in open space: the total momentum
//!   changed by 1.4·10⁻⁸ (DFSPH) and 7·10⁻⁸ (WCSPH) of `Σ m_i|v_i|` over 30 frames.
//!
//! Bodies and watched colliders see each particle at its own mass `m_ref/r_i`
//! (`boundary::bodies::ParticleMass`): collider contact's impulses on dynamic bodies and
//! their added-mass exchange, the walls' hydrostatic and viscous reaction, and the watched
//! colliders' records. The walls' pressure reaction needs no change: the solver's wall push
//! on particle `i` is `r_i` times the reference's, so `m_ref` times the reference push is
//! the particle's own momentum change. A blob of a liquid of 100 kg/m³ grouped with water,
//! thrown at 2 m/s at a free cube in zero gravity (`cargo test --release --test interaction
//! a_light_liquid -- --nocapture`): the cube gains the 0.1068 kg·m/s the blob loses, the
//! total drifts by at most 3·10⁻⁷ of it (DFSPH and WCSPH) and the cube's reported force
//! balances the fluids' loss to 8·10⁻⁸; counted at the water's mass, the cube gained
//! 0.255 kg·m/s for the blob's 0.060 (DFSPH).
//!
//! What the combined step does not do per fluid yet: the overlap relaxation and surface
//! tension act as within one fluid.

use super::{Fluid, FluidSet};
use crate::error::{SphError, SphResult};
use crate::math::Real;
use crate::params::FluidParams;
use crate::solver::Solver;
use rapier3d::geometry::InteractionGroups;

/// The largest ratio of rest densities interacting fluids may have (heaviest / lightest).
/// Water under a liquid of 100 kg/m³ runs stable with DFSPH and WCSPH (the stability suite's
/// case "18 layers 1:10", tests/interaction.rs); larger ratios were not measured.
pub const MAX_DENSITY_RATIO: Real = 10.0;

/// Relative tolerance of the equalities between interacting fluids' sizes.
const SAME: Real = 1e-5;

/// Default of [`FluidParams::fluid_groups`]: no interaction.
pub(crate) fn no_groups() -> InteractionGroups {
    InteractionGroups::none()
}

/// `true` when fluids with parameters `a` and `b` interact.
pub(crate) fn interact(a: &FluidParams, b: &FluidParams) -> bool {
    a.fluid_groups.test(b.fluid_groups)
}

/// The groups of interacting fluids of `fluids` (at least two each), as indices in the
/// set's order, checked (see the module's docs); empty, and without allocating, when no
/// fluid asks for interaction.
///
/// # Errors
/// [`SphError::InvalidParameter`] naming the first mismatched field.
pub(crate) fn groups(fluids: &FluidSet, out: &mut Vec<Vec<usize>>) -> SphResult<()> {
    out.clear();
    let none = no_groups();
    if fluids.iter().all(|(_, f)| f.params().fluid_groups == none) {
        return Ok(());
    }
    let list: Vec<&Fluid> = fluids.iter().map(|(_, f)| f).collect();
    let mut group_of: Vec<Option<usize>> = vec![None; list.len()];
    for a in 0..list.len() {
        for b in a + 1..list.len() {
            if !interact(list[a].params(), list[b].params()) {
                continue;
            }
            match (group_of[a], group_of[b]) {
                (Some(g), None) => group_of[b] = Some(g),
                (None, Some(g)) => group_of[a] = Some(g),
                (None, None) => {
                    group_of[a] = Some(out.len());
                    group_of[b] = Some(out.len());
                    out.push(Vec::new());
                }
                (Some(g), Some(h)) if g != h => return Err(not_transitive()),
                _ => {}
            }
        }
    }
    for (k, g) in group_of.iter().enumerate() {
        if let Some(g) = g {
            out[*g].push(k);
        }
    }
    for group in out.iter() {
        check_group(group.iter().map(|&k| list[k]))?;
    }
    Ok(())
}

fn not_transitive() -> SphError {
    invalid(
        "fluid_groups",
        0.0,
        "fluids that interact with a common fluid must interact with each other",
    )
}

fn invalid(field: &'static str, value: Real, reason: &'static str) -> SphError {
    SphError::InvalidParameter {
        field,
        value: value as f64,
        reason,
    }
}

/// Whether two sizes are equal within [`SAME`].
fn same(a: Real, b: Real) -> bool {
    (a - b).abs() <= SAME * a.abs().max(b.abs())
}

/// The checks of one group (see the module's docs).
fn check_group<'a>(mut members: impl Iterator<Item = &'a Fluid>) -> SphResult<()> {
    let first = members.next().expect("a group has members");
    let (mut lo, mut hi) = (first.params().rest_density, first.params().rest_density);
    check_fluid(first)?;
    for f in members {
        let q = f.params();
        if !interact(first.params(), q) {
            return Err(not_transitive());
        }
        check_pair(first.params(), q)?;
        check_fluid(f)?;
        lo = lo.min(q.rest_density);
        hi = hi.max(q.rest_density);
    }
    if hi > MAX_DENSITY_RATIO * lo {
        return Err(invalid(
            "rest_density",
            hi / lo,
            "interacting fluids' rest densities differ by more than MAX_DENSITY_RATIO (10)",
        ));
    }
    Ok(())
}

/// What one member must satisfy on its own.
fn check_fluid(f: &Fluid) -> SphResult<()> {
    if !matches!(f.params().solver, Solver::Dfsph(_) | Solver::Wcsph) {
        return Err(invalid(
            "solver",
            0.0,
            "interacting fluids: DFSPH and WCSPH only (PBF and Clavet not supported yet)",
        ));
    }
    if !matches!(f.params().viscosity_solve, crate::ViscositySolve::Explicit) {
        return Err(invalid(
            "viscosity_solve",
            0.0,
            "interacting fluids: the explicit viscosity only (the implicit solve is not supported yet)",
        ));
    }
    if f.scalars.iter().any(|s| s.diffusivity > 0.0) {
        return Err(invalid(
            "diffusivity",
            0.0,
            "scalar diffusion in interacting fluids is not supported yet",
        ));
    }
    Ok(())
}

/// What two members must share.
fn check_pair(a: &FluidParams, b: &FluidParams) -> SphResult<()> {
    let sizes = [
        ("particle_spacing", a.particle_spacing, b.particle_spacing),
        ("smoothing_length", a.smoothing_length, b.smoothing_length),
        ("particle_radius", a.particle_radius, b.particle_radius),
        (
            "particle_mass",
            a.particle_mass / a.rest_density,
            b.particle_mass / b.rest_density,
        ),
        ("wall_viscosity", a.wall_viscosity, b.wall_viscosity),
        ("surface_tension", a.surface_tension, b.surface_tension),
        ("adhesion", a.adhesion, b.adhesion),
        ("restitution", a.restitution, b.restitution),
        ("friction", a.friction, b.friction),
    ];
    for (field, x, y) in sizes {
        if !same(x, y) {
            return Err(invalid(field, y, "interacting fluids must share it"));
        }
    }
    let shared = [
        ("density_kernel", a.density_kernel == b.density_kernel),
        ("pressure_kernel", a.pressure_kernel == b.pressure_kernel),
        ("domain", a.domain == b.domain),
        ("wall_density", a.wall_density == b.wall_density),
        ("collision_groups", a.collision_groups == b.collision_groups),
        (
            "clamp_negative_pressure",
            a.clamp_negative_pressure == b.clamp_negative_pressure,
        ),
        ("solver", merge_solver(a.solver, b.solver).is_some()),
    ];
    for (field, ok) in shared {
        if !ok {
            return Err(invalid(field, 0.0, "interacting fluids must share it"));
        }
    }
    if matches!(a.solver, Solver::Wcsph) && a.equation_of_state != b.equation_of_state {
        return Err(invalid(
            "equation_of_state",
            0.0,
            "interacting WCSPH fluids must share it (their pressures scale with rest density)",
        ));
    }
    Ok(())
}

/// The solver settings two interacting fluids are solved with: the same solver, DFSPH's
/// boolean and warm-start settings equal, its tolerances the tightest of the two. `None`
/// when they cannot be merged.
fn merge_solver(a: Solver, b: Solver) -> Option<Solver> {
    match (a, b) {
        (Solver::Wcsph, Solver::Wcsph) => Some(Solver::Wcsph),
        (Solver::Dfsph(x), Solver::Dfsph(y)) => {
            let tight = crate::Dfsph {
                max_density_error: x.max_density_error.min(y.max_density_error),
                max_divergence_error: x.max_divergence_error.min(y.max_divergence_error),
                min_iterations: x.min_iterations.max(y.min_iterations),
                min_divergence_iterations: x
                    .min_divergence_iterations
                    .max(y.min_divergence_iterations),
                max_iterations: x.max_iterations.max(y.max_iterations),
                ..x
            };
            let y_tight = crate::Dfsph { ..tight };
            let y_own = crate::Dfsph {
                max_density_error: tight.max_density_error,
                max_divergence_error: tight.max_divergence_error,
                min_iterations: tight.min_iterations,
                min_divergence_iterations: tight.min_divergence_iterations,
                max_iterations: tight.max_iterations,
                ..y
            };
            (y_own == y_tight).then_some(Solver::Dfsph(tight))
        }
        _ => None,
    }
}

/// The parameters a group is stepped with: the first member's (the reference: its rest
/// density and mass), the largest viscosity of the members (each particle's own is restored
/// by the per-particle weights, see the module's docs) and the merged solver settings.
/// `members` must have passed [`groups`]' checks.
pub(crate) fn group_params<'a>(mut members: impl Iterator<Item = &'a FluidParams>) -> FluidParams {
    let first = members.next().expect("a group has members");
    let mut p = first.clone();
    for q in members {
        p.viscosity = p.viscosity.max(q.viscosity);
        p.solver = merge_solver(p.solver, q.solver).expect("checked by `groups`");
    }
    p
}
