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
//! ## Position-based solvers
//!
//! PBF (Macklin & Müller 2013) keeps its density constraint, which in the number form is the
//! same for every fluid, `C_i = V·δ_i − 1` (unilateral, as with one fluid), and weights the
//! position corrections by inverse mass as position-based dynamics does for unequal masses
//! (Müller et al. 2007, "Position based dynamics", eqs. 2–3; Bender, Müller & Macklin 2017,
//! "A survey on position based dynamics", section 3): with `w_k = 1/m_k = r_k/m_ref`,
//!
//! ```text
//! λ_i  = −C_i / ( Σ_k w_k |∇_k C_i|² + ε )      Δx_k = w_k λ_i ∇_k C_i   (every constraint i)
//! ```
//!
//! so particle `i` gathers `Δx_i = r_i/ρ_ref · Σ_j m_ref (λ_i + λ_j + s_corr) ∇W_ij`, the
//! single-fluid correction times `r_i`, and its own constraint's denominator weighs each
//! neighbour's gradient by its `r_j` (`r_i` on its own, walls weightless: they do not move).
//! Every pair's corrections then carry equal and opposite momenta, `m_i·r_i = m_ref`. The
//! artificial pressure `s_corr` (eq. 13) is a pair term of the same sum, so it is weighted
//! the same way (a fluid-independent repulsion that conserves momentum); the pressure the
//! corrections stand for, `−Σλ·ρ²/(ρ_ref·dt²)` with the reference-unit densities, is then
//! each particle's physical pressure (a light particle's `λ` gradient is `r_i` times smaller
//! for the same push), and is reported as is. Hydrostatic walls add each particle's own
//! `λ`-weighted wall term, times `r_i` too; their hydrostatic part is already per unit of the
//! particle's own rest density.
//!
//! Clavet's double-density relaxation (Clavet et al. 2005) moves both particles of a pair by
//! half the pair's displacement `D`. With unequal masses the split is by inverse mass,
//! `r_i/(r_i + r_j)·D` to `i` (momentum-conserving; equal masses give the halves), and its
//! densities `Σ(1 − q)²`, `Σ(1 − q)³` count neighbours, not their masses: they are already
//! number densities, so a particle at the interface is not read as compressed or stretched
//! by its neighbours' masses (no spurious tension). Its pressures `P = k(ρ − ρ0)` are
//! accelerations (stiffnesses in `c²/(h·ρ0)`), the same for every fluid at the same
//! compression: a fluid's pressure in Pa is `ρ0_i/ρ_ref` times the reference's, as WCSPH's,
//! and that is what is reported. With a physical pressure `p` on both sides of an interface,
//! the split pair force `m_ref/(r_i + r_j)·(P_i + P_j)` is `p` (`P_k ∝ p/m_k`): a uniform
//! pressure holds both liquids at rest. Its walls' term is per particle and left as is. Its
//! viscoelastic springs are refused in a group (their displacements are split in halves).
//!
//! The explicit viscosity of both (the step's last pass, the role XSPH plays in Macklin &
//! Müller) is the same pair term as WCSPH's: `√(ε_k·ε_l)` between fluids `k` and `l`, each
//! particle's velocity change divided by its own mass, so its momentum exchange stays
//! antisymmetric. XSPH's own form `Σ_j (m_j/ρ̄_ij)(v_j − v_i)W_ij` would need the pair's
//! mass weighting to conserve momentum (with volumes `V` in place of `m_j/ρ̄_ij` it does
//! not); the explicit viscosity was kept as the single-fluid solvers use it.
//!
//! # What must match
//!
//! Interacting fluids must share everything the combined step reads once for all of them:
//! particle spacing, particle volume (mass / rest density), smoothing length, contact
//! radius, kernels, domain, the solver (PBF's and Clavet's settings equal; Clavet without
//! springs), its boolean settings, the explicit viscosity (the implicit
//! `viscosity_solve` returns an error: not supported yet), WCSPH's and Clavet's equation of
//! state (Clavet's stiffnesses are in units of its speed of sound), the wall, contact and
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
//!   this tank (the paper's pressure force is half the pressure gradient), and +0.27 % with
//!   `WcsphPressure::Adami`;
//! - oil and water side by side (a lock exchange) stratify within 2 s; the interface settles
//!   at 0.108 m for 0.100 with DFSPH (0.136 m with WCSPH). What is left are single particles of
//!   one liquid caught in the other, and a mix at the particle scale does not separate (see
//!   below);
//! - two blobs (1000 and 100 kg/m³) thrown at each other in open space: the total momentum
//!   changed by 1.4·10⁻⁸ (DFSPH), 7·10⁻⁸ (WCSPH), 7.3·10⁻⁵ (PBF) and 2.0·10⁻⁵ (Clavet) of
//!   `Σ m_i|v_i|` over 30 frames (two waters, the position-based solvers' single-fluid
//!   round-off: 3.6·10⁻⁶ and 2.2·10⁻⁵; without the inverse-mass weights 1.4 and 1.5 of it);
//! - PBF and Clavet (`cargo test --release --test interaction pbf_and_clavet --
//!   --nocapture`) carry their own one-liquid error into the layers: the bottom pressure
//!   against `ρ_oil·g·h_oil + ρ_water·g·h_water`, mean ± standard deviation of five runs
//!   perturbed at round-off (the average over the second second depends on how the bottom
//!   layer settles), one liquid (two waters) → oil on water: PBF +19.9 ± 1.1 % → +19.3 ±
//!   0.4 %, PBF with hydrostatic walls −2.7 ± 1.5 % → −3.8 ± 2.1 %, Clavet without cohesion
//!   (walls in its densities) +65.7 ± 2.9 % → +61.6 ± 4.2 % (not a pressure in Pa); the
//!   interface within 0.21 spacing of the poured volumes. Water under a liquid of 100 kg/m³:
//!   +17.6 %, −3.4 % and +67.3 %, the largest total energy 0.993, 1.0002 and 0.997 of the
//!   initial. With Clavet's default cohesion the tank's spawn lattice is thrown, with one
//!   liquid as with two (the stability suite's case 18 fails for it on energy).
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
//!
//! # Why a fine mix stays mixed
//!
//! Oil and water mixed at the scale of a few particles stall instead of stratifying. In the
//! tank above with DFSPH (`cargo run --release --example layered_probe -- --start checker
//! --k K --viscosity ε --seconds 6`), the interface height (0.200 m mixed, 0.100 m
//! separated) after 6 s, oil particles more than a spacing below 0.100 m of 512:
//!
//! | start | ε = 0.5 (water preset) | ε = 0.05 | ε = 0 |
//! |---|---|---|---|
//! | checkerboard of single particles | 0.195 m (224) | 0.190 m (217) | 0.182 m (212) |
//! | of 2 × 2 × 2 cubes | 0.193 m (228) | 0.183 m (217) | 0.134 m (107), still moving |
//! | of 4 × 4 × 4 cubes | 0.174 m (208) | 0.133 m (104) | 0.126 m (87) |
//!
//! (WCSPH at ε = 0.05: 0.174 m with 2 × 2 × 2 cubes, 0.150 m with 4 × 4 × 4.) Measured causes:
//! - **Not the viscosity's size.** The explicit force gives the viscosity set: a shear wave's
//!   decay at this spacing (`--start shear`) reads `μ_eff` = 0.979 ε at ε = 0.5, 0.976 at
//!   0.05, 0.975 at 0.005, and no decay at 0. Stokes' rise speed `2/9·Δρ·g·r²/μ` of one oil
//!   particle in water (`r` = 0.62 s, the sphere of a particle's volume; Δρ = 200 kg/m³) is
//!   5.2 cm/s at the preset's 0.5 Pa·s, of a 2 × 2 × 2 blob 21 cm/s. Measured
//!   (`--start blob --k K --at L`): one oil particle set into the water moves up at most 0.4
//!   spacing within 0.5 s and stays there, at ε = 0.5, 0.05 and 0 alike, mid-column or on
//!   the floor, under 2 to 16 layers of water (`--layers`); a 2 × 2 × 2 blob on the floor rises 2.3 mm
//!   in 3 s at ε = 0.5 (5.5 mm at ε = 0); a 4 × 4 × 4 blob stops after 3 mm at ε = 0.5 and
//!   rises 5.6 cm in 3 s at ε = 0.05. A smaller viscosity helps blobs, not single particles.
//! - **The constant-density solve.** A particle passes its neighbours only through
//!   configurations whose density is off by more than DFSPH's 0.1 % allows: with
//!   `max_density_error` 0.03 (`--eta 0.03`, ε = 0.05) the lone oil particle reaches the
//!   interface in 2.5 s and a checkerboard of single particles settles at 0.106 m in 8 s (19
//!   of 512 below; at 0.01: 0.186 m). But the looser solve stirs the liquids: the settled
//!   two-layer tank at rest then runs at an RMS speed of 0.14–0.18 m/s over 6 s (0.02–0.04 m/s
//!   at 0.001) and had mixed 14 oil particles into the water after 2 s.
//! - **Particle shifting does not cure it.** Lind et al. 2012's shift `δr = −D·V·Σ_j ∇W_ij`
//!   after each substep of the group (particles with a full kernel support only): with
//!   Skillen et al. 2013's `D = A·(h/2)·|v|·dt` at A = 2 and 6 (the range DualSPHysics and
//!   Chrono::FSI use) the 2 × 2 × 2 checkerboard at ε = 0.05 read 0.184 and 0.188 m after
//!   4 s (0.183 m without): a liquid at rest has no speed to scale the shift. A fixed
//!   `D = 0.5·h²` per substep, each shift capped at 0.1 s, brought it to 0.104 m in 10 s
//!   (3 of 512 below), single particles to 0.105 m (11 below), but it too works by
//!   stirring: the settled tank's RMS speed rose to 0.16–0.19 m/s; uncapped it threw
//!   particles at 6 m/s (D = 0.25·h²) or barely helped (0.1·h²: 0.173 m in 6 s). No option is offered: each
//!   separates a mix only by heating the liquids.
//!
//! So the mix is held by the pressure solve's incompressibility at the particle scale, not by
//! a wrong interface term: the pressure force is Solenthaler & Pajarola's symmetric
//! `(p_i/δ_i² + p_j/δ_j²)` (checked above), and the layers, the lock exchange and the
//! bottom pressure come out right. A mixture ([`crate::mixture`]) separates such a mix: its
//! phases move through the particles instead (the checkerboard of single particles reaches
//! 0.101 m in 2.75 s there).

use super::{Fluid, FluidSet};
use crate::error::{SphError, SphResult};
use crate::math::Real;
use crate::params::FluidParams;
use crate::solver::Solver;
use rapier3d::geometry::InteractionGroups;

/// The largest ratio of rest densities interacting fluids may have (heaviest / lightest).
/// Water under a liquid of 100 kg/m³ runs stable with DFSPH, WCSPH, PBF and Clavet without
/// cohesion (the stability suite's case "18 layers 1:10", tests/interaction.rs); larger
/// ratios were not measured.
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
    if let Solver::Clavet(c) = f.params().solver
        && c.springs.is_some()
    {
        return Err(invalid(
            "springs",
            0.0,
            "interacting Clavet fluids: the viscoelastic springs are not supported",
        ));
    }
    if !matches!(f.params().viscosity_solve, crate::ViscositySolve::Explicit) {
        return Err(invalid(
            "viscosity_solve",
            0.0,
            "interacting fluids: the explicit viscosity only (the implicit solve is not supported yet)",
        ));
    }
    if f.params().mixture.is_some() {
        return Err(invalid(
            "mixture",
            0.0,
            "a fluid with a mixture does not interact with other fluids yet",
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
        ("wcsph_pressure", a.wcsph_pressure == b.wcsph_pressure),
        ("wcsph_density", a.wcsph_density == b.wcsph_density),
        ("solver", merge_solver(a.solver, b.solver).is_some()),
    ];
    for (field, ok) in shared {
        if !ok {
            return Err(invalid(field, 0.0, "interacting fluids must share it"));
        }
    }
    if a.solver == Solver::Wcsph && a.wcsph_density != crate::WcsphDensity::Summation {
        return Err(invalid(
            "wcsph_density",
            0.0,
            "the continuity density (δ-SPH) does not take interacting fluids",
        ));
    }
    if matches!(a.solver, Solver::Wcsph | Solver::Clavet(_))
        && a.equation_of_state != b.equation_of_state
    {
        return Err(invalid(
            "equation_of_state",
            0.0,
            "interacting WCSPH and Clavet fluids must share it (their pressures scale with rest density)",
        ));
    }
    Ok(())
}

/// The solver settings two interacting fluids are solved with: the same solver, DFSPH's
/// boolean and warm-start settings equal, its tolerances the tightest of the two; PBF's and
/// Clavet's settings equal. `None` when they cannot be merged.
fn merge_solver(a: Solver, b: Solver) -> Option<Solver> {
    match (a, b) {
        (Solver::Wcsph, Solver::Wcsph) => Some(Solver::Wcsph),
        (Solver::Pbf(x), Solver::Pbf(y)) => (x == y).then_some(a),
        (Solver::Clavet(x), Solver::Clavet(y)) => (x == y).then_some(a),
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
