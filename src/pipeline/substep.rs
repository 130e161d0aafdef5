//! One substep of one fluid: the ordered list of stages (ARCHITECTURE.md). Each stage is a
//! call into the module that owns it, timed into the report under its [`Stage`]; a stage the
//! scene does not use is skipped by one check.

use super::contact::{Scene, collider_contact};
use super::workspace::{FluidRuntime, Workspace};
use crate::boundary::Coupling;
use crate::boundary::bodies::ImpulseRecord;
use crate::boundary::forces::{FluidForces, WallTerms, Watch};
use crate::boundary::wall::WallQuery;
use crate::diagnostics::{Stage, StepReport};
use crate::fluid::{Fluid, ParticlesMut};
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use crate::solver::context::StepContext;
use crate::solver::{SolverState, WallReaction};
use crate::{density, forces, integrate};
use rapier3d::geometry::ColliderSet;

/// What the frame hands each substep.
#[derive(Copy, Clone)]
pub(crate) struct SubstepInput<'a> {
    /// Gravity (m/s²).
    pub gravity: Vector,
    /// The substep (s).
    pub dt: Real,
    /// The colliders, when the scene has any.
    pub scene: Option<Scene<'a>>,
    /// Seconds from the substep's start and end to the frame's end (moving bodies stand at
    /// their end-of-frame poses; see `boundary::bodies`).
    pub back: (Real, Real),
}

/// What a substep measured.
#[derive(Copy, Clone, Debug, Default)]
pub(crate) struct SubstepResult {
    /// Mean relative density error.
    pub mean_error: Real,
    /// Particles that became non-finite (quarantined by the frame).
    pub non_finite: usize,
}

/// One substep of one fluid.
pub(crate) fn substep(
    fluid: &mut Fluid,
    rt: &mut FluidRuntime,
    input: &SubstepInput<'_>,
    coupling: &mut Coupling,
    report: &mut StepReport,
) -> SubstepResult {
    if fluid.is_empty() {
        return SubstepResult::default();
    }
    wrap_periodic(fluid, report);
    relax_if_needed(fluid, rt, input, coupling, report);
    let mut coupling = begin_coupling(fluid, &rt.ws, input, coupling, report);
    if let Some(c) = coupling.as_deref() {
        rt.ws.bodies_near = rt.ws.bodies_near.merge(c.table_surface_speeds());
    }
    let depenetrate = fluid.needs_depenetration;
    let hold = rt.relax.held(fluid.relax_pending);
    let (params, mut particles) = fluid.split_mut();
    let held;
    let params = if hold > 1.0 {
        held = held_params(params, hold);
        &held
    } else {
        params
    };
    let ws = &mut rt.ws;
    let predicts = rt.solver.predicts_positions();
    if predicts {
        predict(&mut particles, ws, input.gravity, input.dt, report);
    }
    search_neighbours(params, &mut particles, ws, predicts, report);
    let query = wall_query(params, &rt.solver, input, coupling.as_deref());
    walls(query.as_ref(), particles.positions, ws, report);
    wall_shares(query.as_ref(), ws);
    let (outcome, mean_error) = solve(
        (params, hold),
        particles,
        rt,
        input,
        coupling.as_deref_mut(),
        report,
    );
    let contacts_before = report.contacts;
    let depenetrated = collider_contact(
        fluid,
        &mut rt.ws,
        input.scene,
        depenetrate,
        (coupling, true),
        report,
    );
    let non_finite = outcome.non_finite + contact_non_finite(fluid, report, contacts_before);
    continuity_density(fluid, &rt.ws, input, report);
    let max_speed = limit_near_kinematic(fluid, &rt.ws, outcome.max_speed, report);
    diffuse_scalars(fluid, &mut rt.ws, input.dt, report);
    // Particles pushed out of a solid land on its surface, on top of each other: the next
    // substep relaxes them (and checks for more) before giving them dynamics.
    fluid.needs_depenetration = depenetrated > 0;
    wrap_periodic(fluid, report);
    rt.ws.max_speed = max_speed;
    report.non_finite += non_finite;
    report.max_speed = report.max_speed.max(max_speed);
    SubstepResult {
        mean_error,
        non_finite,
    }
}

/// Particles the contact stage left non-finite (counted only when it touched any): a
/// finite but absurd speed (the fuzz's 5·10¹⁴ m/s) can overflow the reflection or the body
/// exchange, and the frame's quarantine must see it before the next substep's sums do.
fn contact_non_finite(fluid: &Fluid, report: &mut StepReport, contacts_before: usize) -> usize {
    if report.contacts == contacts_before {
        return 0;
    }
    report.timed(Stage::Contact, || {
        integrate::scan(fluid.positions(), fluid.velocities()).0
    })
}

/// WCSPH's continuity density (`crate::delta_sph`, `WcsphDensity::Continuity`): advanced
/// after contact, so every move of the substep counts; skipped for other densities.
fn continuity_density(
    fluid: &mut Fluid,
    ws: &Workspace,
    input: &SubstepInput<'_>,
    report: &mut StepReport,
) {
    let (params, particles) = fluid.split_mut();
    let crate::WcsphDensity::Continuity { delta } = params.wcsph_density else {
        return;
    };
    if params.solver != crate::Solver::Wcsph {
        return;
    }
    let motion = crate::delta_sph::Motion {
        start: &ws.previous_positions,
        neighbors: &ws.search.lists,
        inv_densities: &ws.inv_densities,
        gravity: input.gravity,
        dt: input.dt,
    };
    let moved = (&particles.positions[..], &particles.densities[..]);
    report.timed(Stage::Density, || {
        crate::with_kernel!(params.density_kernel, K => crate::with_separation!(params.domain, S, sep =>
            crate::delta_sph::advance::<K, S>(params, moved, particles.attributes, &motion, delta, sep)))
    });
}

/// The overlap relaxation (pipeline/relax.rs) when particles were added or pushed out of a
/// solid, within what is left of the frame's budget. Kinematic bodies near the fluid stand
/// at their pose of the substep's start throughout (see [`relax_coupling`]).
fn relax_if_needed(
    fluid: &mut Fluid,
    rt: &mut FluidRuntime,
    input: &SubstepInput<'_>,
    coupling: &mut Coupling,
    report: &mut StepReport,
) {
    if (fluid.needs_depenetration || fluid.relax_pending) && rt.relax.left > 0 {
        let bodies = relax_coupling(fluid, input, rt.relax.left, coupling, report);
        let (ws, budget) = (&mut rt.ws, &mut rt.relax);
        fluid.relax_pending =
            !super::relax::relax_overlaps(fluid, ws, input.scene, bodies, budget, report);
        report.relax_unfinished |= fluid.relax_pending;
    }
}

/// The coupling table the overlap relaxation sees, if a kinematic body is near the fluid:
/// every kinematic body stands at its pose of the substep's start (the table's start and stop poses
/// both there), where the particles are; contact reflects velocities against its surface
/// velocity, as the substep's contact does, and moves no body. Without it the relaxation met
/// a moving body as if at rest at rapier's pose of the frame's end: water spawned twice over
/// into a closed tank translating at 2 m/s and spinning at 5 rad/s was relaxed against
/// walls 3.3 cm and 0.083 rad ahead of those it was spawned in (DFSPH: 122 of 800 particles
/// beyond the inner faces of the spawn pose's walls after the first substep's relaxation),
/// and the substep's contact, at the start pose, pushed 57 of them out through the walls
/// (`tests/moving_container.rs`). Kinematic bodies only: the relaxation moves no body, and
/// a contact with a dynamic one whose impulse it does not hand over would break the balance
/// of the fluid's momentum with the forces reported on the bodies (`tests/collider_forces.rs`
/// checks it every frame), so dynamic bodies stand at rapier's pose of the frame's end, at
/// rest, as before. `None` when no kinematic body is near: the relaxation's contact is then
/// that of a scene at rest.
fn relax_coupling<'c>(
    fluid: &Fluid,
    input: &SubstepInput<'_>,
    rounds: u32,
    coupling: &'c mut Coupling,
    report: &mut StepReport,
) -> Option<&'c mut Coupling> {
    let scene = input.scene?;
    if coupling.is_off() {
        return None;
    }
    let back = input.back.0;
    // Every body the relaxation's rounds can reach: each moves a particle at most
    // `RELAX_MAX_MOVE` spacings.
    let reach = rounds as Real * super::relax::RELAX_MAX_MOVE * fluid.params().particle_spacing;
    report.timed(Stage::Contact, || {
        coupling_near(fluid, scene.colliders, reach, (back, back), coupling);
        coupling.keep_kinematic();
    });
    (!coupling.table().is_empty()).then_some(coupling)
}

/// Starts `coupling`'s substep with the bodies within `reach` of the fluid's box, grown by
/// the support and the contact radius: the bodies a particle can meet in the substep.
fn coupling_near(
    fluid: &Fluid,
    colliders: &ColliderSet,
    reach: Real,
    (back0, back1): (Real, Real),
    coupling: &mut Coupling,
) {
    let p = fluid.params();
    let (lo, hi) = integrate::bounds(fluid.positions());
    let margin = p.smoothing_length + p.particle_radius + reach;
    let fluid_box = parry3d::bounding_volume::Aabb::new(lo, hi);
    coupling.begin_substep(colliders, &fluid_box, margin, back0, back1);
}

/// The neighbour search (sort, cells, lists); a solver that predicts positions has its
/// substep-start positions re-sorted with the particles.
fn search_neighbours(
    params: &FluidParams,
    particles: &mut ParticlesMut<'_>,
    ws: &mut Workspace,
    predicts: bool,
    report: &mut StepReport,
) {
    let previous = predicts.then_some(&mut ws.previous_positions);
    report.timed(Stage::NeighbourSearch, || {
        ws.search.search(
            particles,
            previous,
            params.smoothing_length,
            params.domain.minimum_image(),
        )
    });
    report.neighbour_pairs += ws.search.lists.total_pairs();
}

/// The scalars the particles carry diffuse over the substep (`crate::scalars`), on the
/// substep's neighbour lists; nothing runs for a fluid without a diffusing scalar.
fn diffuse_scalars(fluid: &mut Fluid, ws: &mut Workspace, dt: Real, report: &mut StepReport) {
    if fluid.scalars.iter().all(|s| s.diffusivity <= 0.0) {
        return;
    }
    let p = fluid.params();
    let (mass, h, rho0, domain) = (
        p.particle_mass,
        p.smoothing_length,
        p.rest_density,
        p.domain,
    );
    let n = fluid.len();
    let limited = report.timed(Stage::ScalarDiffusion, || {
        let mut limited = 0;
        for spec in &fluid.scalars {
            // `Fluid::add_scalar` created the values; appends and removals keep them sized.
            let Some(k) = fluid
                .attributes
                .index_of(crate::scalars::PREFIX, &spec.name)
            else {
                continue;
            };
            let values = fluid.attributes.vec_mut(k);
            debug_assert_eq!(values.len(), n);
            let scratch = (&mut ws.scalar_scratch.0, &mut ws.scalar_scratch.1);
            limited += crate::with_separation!(domain, S, sep => {
                let pairs = crate::neighbors::Pairs {
                    positions: &fluid.positions,
                    neighbors: &ws.search.lists,
                    mass,
                    h,
                    sep,
                };
                crate::scalars::diffuse(&pairs, rho0, (spec.diffusivity, dt), values, scratch)
            });
        }
        limited
    });
    report.scalar_limited += limited;
}

/// Near a kinematic body, the speed limit of [`limit_near_bodies`]; returns the fluid's
/// fastest speed after it.
fn limit_near_kinematic(
    fluid: &mut Fluid,
    ws: &Workspace,
    max_speed: Real,
    report: &mut StepReport,
) -> Real {
    match ws.bodies_near.kinematic {
        Some(kinematic) => {
            let cap = ws.frame_speed + 2.0 * kinematic;
            let velocities = fluid.split_mut().1.velocities; // (not the game's edit: no wake)
            report.speed_limited += limit_near_bodies(velocities, cap, report);
            max_speed.min(cap)
        }
        None => max_speed,
    }
}

/// The parameters the solver holds a fluid at while its overlap relaxation is unfinished:
/// the rest density times `hold` (see `relax::RelaxBudget::held`).
fn held_params(params: &FluidParams, hold: Real) -> FluidParams {
    FluidParams {
        rest_density: params.rest_density * hold,
        ..params.clone()
    }
}

/// The speed a kinematic body can give the water: a wall moving at `V` reflects a particle
/// that meets it at `v` to at most `v + 2V` (elastic reflection in the wall's frame), and
/// gravity adds `|g|·dt` over the frame; so no particle leaves faster than the fluid's
/// fastest at the frame's start (`frame_speed`, gravity's share included) plus twice the
/// fastest surface speed of a kinematic body near it. Dynamic bodies are left alone: they
/// exchange momentum with the water, which a limit would break. The pressure the pushed water
/// builds can exceed it on the discrete fluid: an impulsively moved wall drives SPH
/// particles next to it at the free surface up to 3 times `V` (the bucket of
/// `tests/kinematic_jumps.rs`), which this limit takes off. Returns how many particles it
/// limited (`cap`: the fluid workspace's `frame_speed` plus twice its fastest kinematic body).
fn limit_near_bodies(velocities: &mut [Vector], cap: Real, report: &mut StepReport) -> usize {
    report.timed(Stage::ParticleUpdate, || {
        integrate::limit_speeds(velocities, cap)
    })
}

/// Periodic box: particles outside it (added there, or moved there by the caller or the
/// substep) re-enter through the opposite face.
fn wrap_periodic(fluid: &mut Fluid, report: &mut StepReport) {
    if let Some(d) = fluid.params().domain.minimum_image() {
        report.timed(Stage::ParticleUpdate, || {
            integrate::wrap_positions(&d, &mut fluid.positions)
        });
    }
}

/// The moving bodies near this fluid during this substep (`None`: no moving body in the
/// scene, nothing more is done for them).
fn begin_coupling<'c>(
    fluid: &Fluid,
    ws: &Workspace,
    input: &SubstepInput<'_>,
    coupling: &'c mut Coupling,
    report: &mut StepReport,
) -> Option<&'c mut Coupling> {
    let scene = input.scene?;
    if coupling.is_off() {
        return None;
    }
    let (dt, back) = (input.dt, input.back);
    let v = ws.max_speed + input.gravity.length() * dt;
    report.timed(Stage::Contact, || {
        coupling_near(fluid, scene.colliders, 2.0 * v * dt, back, coupling)
    });
    Some(coupling)
}

/// Position-based solvers (PBF, Clavet) first add gravity and predict the positions, then
/// search neighbours at the predicted positions (Macklin & Müller 2013, Alg. 1 lines 2–4;
/// Clavet et al. 2005, Alg. 1).
fn predict(
    particles: &mut ParticlesMut<'_>,
    ws: &mut Workspace,
    gravity: Vector,
    dt: Real,
    report: &mut StepReport,
) {
    ws.previous_positions
        .resize(particles.positions.len(), Vector::ZERO);
    if gravity != Vector::ZERO {
        report.timed(Stage::ExternalForces, || {
            particles.accelerations.fill(gravity);
            integrate::add_accelerations(dt, particles.accelerations, particles.velocities);
        });
    }
    report.timed(Stage::ParticleUpdate, || {
        integrate::predict_positions(
            dt,
            particles.velocities,
            particles.positions,
            &mut ws.previous_positions,
        )
    });
}

/// What the wall stage reads, as the solver asks for it, when walls count in the density and
/// the scene has colliders; with whether the solver asks for Clavet's two densities too.
fn wall_query<'a>(
    params: &'a FluidParams,
    solver: &SolverState,
    input: &SubstepInput<'a>,
    coupling: Option<&'a Coupling>,
) -> Option<(WallQuery<'a>, bool)> {
    let scene = input.scene.filter(|_| params.wall_density)?;
    let request = solver.walls(params);
    let query = WallQuery {
        params,
        force_kernel: request.force_kernel,
        scene: (scene.bvh, scene.colliders, scene.bodies),
        coupling,
        hydrostatic: request.hydrostatic.then_some(input.gravity),
        viscous: params.wall_viscosity > 0.0,
        // Position-based solvers predicted the positions to the substep's end: the moving
        // bodies are taken there too.
        predicted: solver.predicts_positions(),
        watch: Some(scene.watch).filter(|w| w.any_forces),
        planes: request.planes,
    };
    Some((query, request.double_density))
}

/// The walls' density and pressure-gradient tables (and Clavet's densities when
/// `double_density`) for the sorted `positions`; none without a query.
fn walls(
    query: Option<&(WallQuery<'_>, bool)>,
    positions: &[Vector],
    ws: &mut Workspace,
    report: &mut StepReport,
) {
    let Some((query, double_density)) = query else {
        ws.wall.clear();
        return;
    };
    let near = report.timed(Stage::WallDensity, || {
        ws.wall.update(&ws.search, positions, query)
    });
    if query.params.adhesion > 0.0 {
        report.timed(Stage::SurfaceTension, || {
            ws.wall.update_adhesion(&ws.search.grid, positions, query)
        });
    }
    if *double_density {
        report.timed(Stage::WallDensity, || {
            ws.wall.update_clavet(&ws.search.grid, positions, query)
        });
    }
    report.particles_near_walls += near;
}

/// The watched colliders' shares of the wall terms just computed (`boundary::forces`; none
/// when no collider's forces are watched).
fn wall_shares(query: Option<&(WallQuery<'_>, bool)>, ws: &mut Workspace) {
    ws.forces.shares.clear();
    if query.is_some_and(|(q, _)| q.watch.is_some()) {
        for chunk in &ws.wall.share_chunks {
            ws.forces.shares.extend_from_slice(chunk);
        }
    }
}

/// The solver's substep on the step context (`params` with the rest density the solver
/// holds the fluid at, `hold` times the fluid's), then the walls' viscosity and their reaction
/// on dynamic bodies, then the report's density error. Returns the solver's outcome and the
/// mean density error.
fn solve(
    (params, hold): (&FluidParams, Real),
    mut particles: ParticlesMut<'_>,
    rt: &mut FluidRuntime,
    input: &SubstepInput<'_>,
    coupling: Option<&mut Coupling>,
    report: &mut StepReport,
) -> (crate::solver::context::Outcome, Real) {
    let n = particles.positions.len();
    let ws = &mut rt.ws;
    // Taken out of the workspace for the solver stages (a move, no copy), put back below.
    let wall_ws = std::mem::take(&mut ws.wall);
    ws.inv_densities.resize(n, 0.0);
    ws.previous_positions.resize(n, Vector::ZERO);
    // Interacting fluids stepped together: their per-particle factors, taken out of the
    // attributes (a move) while the context borrows those, put back below.
    // A mixture writes its particles' factors where the phases below are read.
    super::mixture::before_solve(params, hold, &mut particles, &mut ws.mixture);
    let phases = super::interaction::take_phases(particles.attributes);
    let mut ctx = StepContext {
        params,
        gravity: input.gravity,
        dt: input.dt,
        positions: particles.positions,
        velocities: particles.velocities,
        accelerations: particles.accelerations,
        densities: particles.densities,
        pressures: particles.pressures,
        ids: particles.ids,
        attributes: &mut *particles.attributes,
        inv_densities: &mut ws.inv_densities,
        previous_positions: &mut ws.previous_positions,
        neighbors: &ws.search.lists,
        wall: wall_ws.any().then_some(&wall_ws),
        hold,
        report,
        phases: super::interaction::phases(&phases),
    };
    let outcome = rt.solver.step(&mut ctx);
    implicit_viscosity(&mut ctx, outcome.non_finite, &mut ws.viscosity);
    let watch = input.scene.map(|s| s.watch);
    if let Some(watch) = watch.filter(|_| !ws.forces.shares.is_empty()) {
        wall_impulses(&ctx, &rt.solver, &wall_ws, watch, &mut ws.forces);
    }
    let mut viscous = std::mem::take(&mut ws.wall_viscous_impulses);
    viscous.clear();
    wall_viscosity(&mut ctx, &mut viscous);
    surface_tension(&mut ctx, &mut ws.surface_normals);
    if let Some(c) = coupling {
        let watch = watch.filter(|w| w.any_dynamic_forces);
        if let Some(w) = watch {
            ws.forces.snapshot(w, ctx.velocities);
        }
        let records = &mut ws.wall_impulses;
        let exchanged = wall_reaction(&mut ctx, &rt.solver, records, &mut viscous, c);
        if let Some(w) = watch.filter(|_| exchanged) {
            let m = (ctx.masses(), false);
            ws.forces
                .after_exchange(w, c.table(), records, ctx.velocities, m);
        }
    }
    let (_, mean_error) = measure_density_error(&mut ctx, &mut ws.partials);
    super::mixture::after_solve(&mut ctx, &mut ws.mixture);
    super::interaction::put_back_phases(particles.attributes, phases);
    ws.wall_viscous_impulses = viscous;
    ws.wall = wall_ws;
    (outcome, mean_error)
}

/// The watched colliders' wall impulses of the substep, after the solver and before the
/// walls' viscosity (see `boundary::forces`).
fn wall_impulses(
    ctx: &StepContext<'_>,
    solver: &SolverState,
    wall: &crate::boundary::WallWorkspace,
    watch: &Watch,
    forces: &mut FluidForces,
) {
    let p = ctx.params;
    let terms = WallTerms {
        unit: wall.gradient_unit(p.rest_density),
        mass: ctx.masses(),
        dt: ctx.dt,
        epsilon: if wall.viscous.len() == ctx.velocities.len() {
            p.wall_viscosity
        } else {
            0.0
        },
        velocities: ctx.velocities,
        inv_densities: ctx.inv_densities,
        viscous_total: &wall.viscous,
    };
    let scale = |i| solver.wall_impulse_scale(ctx, i);
    forces.wall_impulses(watch, terms, scale);
}

/// The implicit viscosity solve (`forces::viscosity_implicit`), after the solver, on the
/// velocities it left; skipped unless the fluid asks for it, and in a substep whose solver
/// left a non-finite particle (the solve's dot products would spread it to every particle;
/// the frame quarantines it first).
fn implicit_viscosity(
    ctx: &mut StepContext<'_>,
    non_finite: usize,
    scratch: &mut forces::viscosity_implicit::Scratch,
) {
    let p = ctx.params;
    let (settings, stress) = match p.viscosity_solve {
        crate::ViscositySolve::Implicit(s) => (s, false),
        crate::ViscositySolve::Stress(s) => (s, true),
        crate::ViscositySolve::Explicit => return,
    };
    if p.viscosity <= 0.0 || non_finite > 0 {
        return;
    }
    let c = forces::viscosity_implicit::Implicit {
        viscosity: p.viscosity,
        dt: ctx.dt,
        settings,
    };
    let (positions, neighbors, inv) = (&*ctx.positions, ctx.neighbors, &*ctx.inv_densities);
    let (attributes, velocities) = (&mut *ctx.attributes, &mut *ctx.velocities);
    let stats = ctx.report.timed(Stage::ViscositySolve, || {
        crate::with_separation!(p.domain, S, sep => {
            let pairs = crate::neighbors::Pairs {
                positions,
                neighbors,
                mass: p.particle_mass,
                h: p.smoothing_length,
                sep,
            };
            if stress {
                let s = &mut scratch.stress;
                forces::viscosity_stress::solve(c, &pairs, inv, attributes, velocities, s)
            } else {
                forces::viscosity_implicit::solve(c, &pairs, inv, attributes, velocities, scratch)
            }
        })
    });
    ctx.report.viscosity_iterations += stats.iterations;
    ctx.report.viscosity_residual = ctx.report.viscosity_residual.max(stats.residual);
}

/// The walls' viscosity (`wall_viscosity` > 0), after the solver, on the velocities it left.
fn wall_viscosity(ctx: &mut StepContext<'_>, records: &mut Vec<ImpulseRecord>) {
    let p = ctx.params;
    let Some(w) = ctx.wall.filter(|_| p.wall_viscosity > 0.0) else {
        return;
    };
    if w.viscous.len() != ctx.velocities.len() {
        return;
    }
    let mass = ctx.masses();
    ctx.report.timed(Stage::ViscosityForce, || {
        forces::wall_viscosity::apply(
            forces::wall_viscosity::WallViscosity {
                epsilon: p.wall_viscosity,
                mass,
                dt: ctx.dt,
                wall: w,
            },
            ctx.positions,
            ctx.inv_densities,
            ctx.velocities,
            records,
        )
    });
}

/// Surface tension and adhesion (`forces::surface_tension`), after the solver and the walls'
/// viscosity, on the velocities they left; skipped when the fluid has neither (adhesion
/// counts only with a wall near).
fn surface_tension(ctx: &mut StepContext<'_>, normals: &mut Vec<Vector>) {
    let p = ctx.params;
    let adhesion = ctx.wall.map_or(&[][..], |w| &w.adhesion[..]);
    if p.surface_tension <= 0.0 && adhesion.is_empty() {
        return;
    }
    let st = forces::surface_tension::SurfaceTension {
        gamma: p.surface_tension,
        beta_rest: p.adhesion * p.rest_density,
        rest_density: p.rest_density,
        dt: ctx.dt,
        adhesion,
    };
    let (positions, neighbors) = (&*ctx.positions, ctx.neighbors);
    let (densities, inv) = (&*ctx.densities, &*ctx.inv_densities);
    let velocities = &mut *ctx.velocities;
    ctx.report.timed(Stage::SurfaceTension, || {
        crate::with_separation!(p.domain, S, sep => {
            let pairs = crate::neighbors::Pairs {
                positions,
                neighbors,
                mass: p.particle_mass,
                h: p.smoothing_length,
                sep,
            };
            crate::with_kernel!(p.density_kernel, K =>
                forces::surface_tension::apply::<K, S>(
                    &st, &pairs, (densities, inv), normals, velocities))
        })
    });
}

/// Fluid → body through the walls: each particle's wall term from dynamic bodies pushes those
/// bodies back (Newton's third law; see `boundary::bodies`), with the solver's share of the
/// impulse its wall term gave the particle; the walls' viscous impulses go with them.
/// Returns whether it exchanged them.
fn wall_reaction(
    ctx: &mut StepContext<'_>,
    solver: &SolverState,
    records: &mut Vec<Vec<ImpulseRecord>>,
    viscous: &mut Vec<ImpulseRecord>,
    coupling: &mut Coupling,
) -> bool {
    let WallReaction::Impulse { added_mass } = solver.wall_reaction();
    let Some(w) = ctx.wall.filter(|w| w.coupled_any) else {
        return false;
    };
    let t0 = std::time::Instant::now();
    let (m, dt) = (ctx.masses(), ctx.dt);
    records.resize_with(1, Vec::new);
    records[0].clear();
    let impulse = |i, gradient_c| solver.wall_impulse(ctx, i, gradient_c);
    w.reaction(
        impulse,
        (added_mass, m, dt),
        ctx.previous_positions,
        &mut records[0],
    );
    records[0].append(viscous);
    let with_rapier = !matches!(solver, SolverState::Wcsph(_));
    coupling.exchange(records, ctx.positions, ctx.velocities, m, with_rapier);
    ctx.report.timings.add(Stage::Contact, t0.elapsed());
    true
}

/// The report's density error (counted with the density stage, whose output it reads).
fn measure_density_error(
    ctx: &mut StepContext<'_>,
    partials: &mut Vec<(f64, Real)>,
) -> (Real, Real) {
    // Against the fluid's own rest density, also while the solver holds it compressed.
    let rest = ctx.params.rest_density / ctx.hold;
    let densities = &*ctx.densities;
    let (max_err, mean_err) = ctx.report.timed(Stage::Density, || {
        density::density_error(densities, rest, partials)
    });
    ctx.report.max_density_error = ctx.report.max_density_error.max(max_err);
    (max_err, mean_err)
}
