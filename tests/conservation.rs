//! Conservation: mass (particle count × mass) in the walled dam break, linear momentum of an
//! isolated blob under the particle forces alone, and a column at rest in a closed box that
//! stays in the box for 1.5 s.

mod common;

use common::*;
use rand::Rng;
use rapier_sph::kernel::{CubicSpline, Kernel, ViscosityLaplacian};
use rapier_sph::math::{Real, Vector};
use rapier_sph::rapier3d::prelude::{BroadPhaseBvh, ColliderSet, RigidBodySet};
use rapier_sph::scenes::{DamBreakConfig, add_closed_box, dam_break};
use rapier_sph::{Fluid, FluidParams, FluidPipeline, FluidSet, FluidWorld, KernelKind};

/// Checks that every particle is inside the box interior `[min, max]` kept one contact radius
/// off each wall (minus the clearance tolerance, see `common::clearance_tolerance`).
fn assert_in_box(f: &Fluid, min: Vector, max: Vector, label: &str) {
    let r = f.params().particle_radius;
    let keep = r - clearance_tolerance(r);
    for (p, id) in f.positions().iter().zip(f.ids()) {
        assert!(p.is_finite(), "{label}: particle {id} not finite");
        assert!(
            p.cmpge(min + Vector::splat(keep)).all() && p.cmple(max - Vector::splat(keep)).all(),
            "{label}: particle {id} at {p} is not inside the box [{min}, {max}] kept {keep} off the walls"
        );
    }
}

#[test]
fn mass_is_exactly_conserved_in_the_dam_break() {
    let params = water(0.04);
    let mut scene = dam_break(&DamBreakConfig::tower(params.clone(), 0.6)).unwrap();
    let dt = params.acoustic_time_step();
    scene.world.physics.integration_parameters.dt = dt;
    let f = &scene.world.fluids[scene.fluid];
    let n0 = f.len();
    let m0 = f.total_mass();
    assert_eq!(n0, 6 * 15 * 6);
    // Mass is count × particle mass: nothing may create or destroy particles.
    assert_eq!(m0, n0 as Real * params.particle_mass);
    let mut ids0: Vec<u32> = f.ids().to_vec();
    ids0.sort_unstable();
    let steps = (0.5 / dt).ceil() as usize;
    for step in 0..steps {
        let report = scene.world.step().unwrap().clone();
        assert_eq!(report.non_finite, 0, "step {step}");
        let f = &scene.world.fluids[scene.fluid];
        assert_eq!(f.len(), n0, "step {step}: particle count changed");
        assert_eq!(
            f.total_mass().to_bits(),
            m0.to_bits(),
            "step {step}: mass changed"
        );
        assert_eq!(
            scene.escaped(),
            0,
            "step {step}: particles escaped the tank"
        );
        assert_in_box(
            f,
            scene.tank_min,
            scene.tank_max,
            &format!("dam break step {step}"),
        );
    }
    // The same particles (ids) at the end, each once.
    let mut ids: Vec<u32> = scene.world.fluids[scene.fluid].ids().to_vec();
    ids.sort_unstable();
    assert_eq!(ids, ids0);
    // The column did collapse (the run tested something): the front moved past the column.
    assert!(
        scene.front() > 1.5 * scene.column_width,
        "front at {} for a column {} wide",
        scene.front(),
        scene.column_width
    );
}

/// Per-pair force magnitudes of the step that was just taken, in f64, for the round-off
/// bound of the momentum test. `x0`, `v0` are the start-of-step positions and velocities by
/// particle id; densities, pressures and neighbour lists are the step's own (current order).
///
/// Returns `(Σ_i Σ_j m·|a_ij|·dt, largest neighbour count)`.
fn pair_impulses(
    f: &Fluid,
    lists: &rapier_sph::neighbors::NeighborLists,
    x0: &[Vector],
    v0: &[Vector],
    dt: Real,
) -> (f64, usize) {
    let p: &FluidParams = f.params();
    assert_eq!(p.pressure_kernel, KernelKind::CubicSpline);
    let h = p.smoothing_length;
    let grad = CubicSpline::new(h);
    let lap = ViscosityLaplacian::new(h);
    let m = p.particle_mass as f64;
    let (rho, pr, ids) = (f.densities(), f.pressures(), f.ids());
    let mut sum = 0.0f64;
    let mut max_deg = 0;
    for i in 0..f.len() {
        let (xi, vi) = (x0[ids[i] as usize], v0[ids[i] as usize]);
        let nb = lists.of(i);
        max_deg = max_deg.max(nb.len());
        for &j in nb {
            let j = j as usize;
            let (xj, vj) = (x0[ids[j] as usize], v0[ids[j] as usize]);
            let d = (xi - xj).length();
            let rr = rho[i] as f64 * rho[j] as f64;
            // Pressure: (m/2)·(p_i + p_j)/(ρ_i ρ_j)·|∇W|, viscosity: ε m |v_j − v_i| ∇²W/(ρ_i ρ_j).
            let a_p = 0.5 * m * (pr[i] as f64 + pr[j] as f64).abs() / rr * grad.dw(d).abs() as f64;
            let a_v =
                p.viscosity as f64 * m * (vj - vi).length() as f64 * lap.laplacian(d) as f64 / rr;
            sum += m * (a_p + a_v) * dt as f64;
        }
    }
    (sum, max_deg)
}

/// An isolated blob (no collider, no gravity) with random velocities: the pressure and
/// viscosity forces are pair-wise antisymmetric, so the total momentum may change only by
/// f32 round-off.
///
/// Round-off bound, per step and per component (u = 2⁻²⁴):
/// - The pair term `a_ij` and its mirror `a_ji` are computed with the same `r`, `d` and
///   kernel value (exactly antisymmetric), then scaled by `(p_i+p_j)/ρ_j · m/(2ρ_i)` vs
///   `(p_i+p_j)/ρ_i · m/(2ρ_j)` (or the viscous equivalent): about 6 roundings each, so
///   `|m a_ij + m a_ji| ≤ 12 u (m|a_ij| + m|a_ji|)`.
/// - Summing up to `k` terms into `a_i` adds at most `(k−1) u Σ_j |a_ij|`.
/// - `v += a·dt` rounds twice: `u (|a_i dt| + |v_i|)`, and `|a_i dt| ≤ Σ_j |a_ij| dt`.
///
/// So `|ΔP| ≤ (14 + k) u · Σ_i Σ_j m |a_ij| dt + u · Σ_i m |v_i|`, accumulated over the steps
/// (with |v| summed after each step). The f64 sum in `linear_momentum` is exact to 1e-16
/// relative, negligible. A bug that breaks the antisymmetry (e.g. dividing by ρ_i² instead
/// of ρ_iρ_j) errs by the density variation, ~1e-2 of the pair terms: 100× over the bound.
#[test]
fn linear_momentum_of_an_isolated_blob_is_conserved() {
    let params = water(0.05);
    let mut fluid = Fluid::new(params.clone()).unwrap();
    let mut r = rng(11);
    let pos = rapier_sph::fluid::lattice(Vector::new(-0.2, 0.1, -0.3), 8, 8, 8, 0.05);
    // Random velocities of up to 2 m/s plus a drift, so that P ≠ 0 and particles collide.
    let vel: Vec<Vector> = pos
        .iter()
        .map(|_| {
            Vector::new(0.3, -0.2, 0.1)
                + Vector::new(
                    r.random_range(-1.0..1.0),
                    r.random_range(-1.0..1.0),
                    r.random_range(-1.0..1.0),
                ) * 2.0
        })
        .collect();
    fluid
        .add_particles_with_velocities(&pos, Some(&vel))
        .unwrap();
    let n = fluid.len();
    let m = params.particle_mass as f64;
    let mut fluids = FluidSet::new();
    let h = fluids.insert(fluid);
    let mut pipeline = FluidPipeline::new();
    let (mut bodies, colliders, broad_phase) = (
        RigidBodySet::new(),
        ColliderSet::new(),
        BroadPhaseBvh::new(),
    );
    let dt = params.acoustic_time_step();
    let p0 = fluids[h].linear_momentum();
    let mut bound = 0.0f64;
    let mut total_exchange = 0.0f64;
    let mut x0 = vec![Vector::ZERO; n];
    let mut v0 = vec![Vector::ZERO; n];
    for step in 0..200 {
        {
            let f = &fluids[h];
            for ((&x, &v), &id) in f.positions().iter().zip(f.velocities()).zip(f.ids()) {
                x0[id as usize] = x;
                v0[id as usize] = v;
            }
        }
        let report = pipeline
            .step(
                Vector::ZERO,
                dt,
                &mut fluids,
                &mut bodies,
                &colliders,
                &broad_phase,
            )
            .unwrap();
        assert_eq!(report.non_finite, 0);
        let f = &fluids[h];
        assert_eq!(f.len(), n);
        let lists = pipeline.neighbor_lists(h).unwrap();
        let (exchange, k) = pair_impulses(f, lists, &x0, &v0, dt);
        let speeds: f64 = f.velocities().iter().map(|v| m * v.length() as f64).sum();
        bound += (14.0 + k as f64) * U32 * exchange + U32 * speeds;
        total_exchange += exchange;
        let p = f.linear_momentum();
        for c in 0..3 {
            assert!(
                (p[c] - p0[c]).abs() <= bound,
                "step {step}: momentum component {c} drifted by {:e} (from {:e} to {:e}), \
                 round-off bound {bound:e}",
                p[c] - p0[c],
                p0[c],
                p[c]
            );
        }
    }
    let p = fluids[h].linear_momentum();
    eprintln!(
        "momentum drift {:e} {:e} {:e}, bound {bound:e}, pair impulses {total_exchange:e}, |P0| {:?}",
        p[0] - p0[0],
        p[1] - p0[1],
        p[2] - p0[2],
        p0
    );
    // The forces did exchange momentum between particles, far more than the bound: the test
    // would see a non-antisymmetric force.
    assert!(
        total_exchange > 1e3 * bound,
        "pair impulses {total_exchange:e} not ≫ bound {bound:e}"
    );
}

/// A 0.5 m cube of water at rest on the floor of a closed 0.5 × 1 × 0.5 m box (its walls
/// touch the column's sides), water preset at 5 cm spacing, stepped at the acoustic time
/// step for 1.5 s (~1,100 steps): no particle lost, none leaves the box interior, none NaN.
#[test]
fn column_at_rest_in_a_closed_box_stays_in() {
    let params = water(0.05);
    let dt = params.acoustic_time_step();
    let mut world = FluidWorld::new();
    let (min, max) = (Vector::ZERO, Vector::new(0.5, 1.0, 0.5));
    add_closed_box(&mut world, min, max, 0.1);
    world.physics.integration_parameters.dt = dt;
    let mut fluid = Fluid::new(params.clone()).unwrap();
    fluid.add_block(min, Vector::new(0.5, 0.5, 0.5)).unwrap();
    let n = fluid.len();
    assert_eq!(n, 1000);
    let handle = world.fluids.insert(fluid);
    let steps = (1.5 / dt).ceil() as usize;
    for step in 0..steps {
        let report = world.step().unwrap().clone();
        assert_eq!(report.non_finite, 0, "step {step}");
        let f = &world.fluids[handle];
        assert_eq!(f.len(), n, "step {step}");
        assert_in_box(f, min, max, &format!("column step {step}"));
    }
}
