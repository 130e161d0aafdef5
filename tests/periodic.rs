//! Periodic domains: the minimum image, the periodic grid against the brute-force oracle, a
//! uniform lattice filling the box (uniform density: no boundary deficit), and a blob
//! crossing faces with momentum and particle count conserved.

mod common;

use common::{U32, on_each, rng};
use rand::Rng;
use rapier_sph::domain::{Domain, MinimumImage, Separation};
use rapier_sph::math::{Real, Vector};
use rapier_sph::neighbors::oracle::brute_force_neighbors_periodic;
use rapier_sph::neighbors::{NeighborGrid, NeighborLists};
use rapier_sph::rapier3d::prelude::{BroadPhaseBvh, ColliderSet, RigidBodySet};
use rapier_sph::{
    Fluid, FluidParamsBuilder, FluidPipeline, FluidSet, SphError, TimeStepping, solver::Solver,
};

/// The minimum image is the shortest of the 27 periodic images of `a − b` (the other images
/// are longer by at least a third of an edge here, far beyond the f32 round-off of a few
/// ulps of the edge that the comparison allows).
#[test]
fn minimum_image_is_the_shortest_image() {
    let d = MinimumImage::new(Vector::new(-1.3, 0.2, 5.0), Vector::new(-0.3, 0.97, 6.5));
    let mut r = rng(7);
    for _ in 0..2000 {
        let p = |r: &mut rand_pcg::Pcg64| {
            Vector::new(
                r.random_range(-1.3..-0.3),
                r.random_range(0.2..0.97),
                r.random_range(5.0..6.5),
            )
        };
        let (a, b) = (p(&mut r), p(&mut r));
        let got = d.sep(a, b).length();
        let mut best = Real::MAX;
        for kx in -1..=1 {
            for ky in -1..=1 {
                for kz in -1..=1 {
                    let k = Vector::new(kx as Real, ky as Real, kz as Real);
                    best = best.min((a - b + k * d.len).length());
                }
            }
        }
        assert!(
            (got - best).abs() <= 8.0 * Real::EPSILON * 6.5,
            "{got} vs {best}"
        );
        // The wrap stays in the box.
        let w = d.wrap(a + Vector::new(3.7, -2.1, 0.75));
        assert!(w.cmpge(d.min).all() && w.cmplt(d.max).all(), "{w:?}");
    }
}

/// Sorts with the periodic grid, permutes as the pipeline does, builds the lists and compares
/// them with the periodic brute force (same f32 minimum-image test: no tolerance).
fn check(
    grid: &mut NeighborGrid,
    lists: &mut NeighborLists,
    pts: &[Vector],
    h: Real,
    d: &MinimumImage,
    label: &str,
) {
    grid.sort_periodic(pts, h, d);
    assert!(grid.is_periodic());
    let sorted: Vec<Vector> = grid
        .permutation()
        .iter()
        .map(|&(_, i)| pts[i as usize])
        .collect();
    grid.build_cells();
    lists.build_periodic(grid, &sorted, h, *d);
    let oracle = brute_force_neighbors_periodic(&sorted, h, d);
    let mut pairs = 0;
    for (i, expected) in oracle.iter().enumerate() {
        assert_eq!(
            lists.of(i),
            expected.as_slice(),
            "{label}: neighbours of #{i} at {:?}",
            sorted[i]
        );
        pairs += expected.len();
    }
    assert_eq!(lists.total_pairs(), pairs, "{label}");
}

#[test]
fn periodic_grid_matches_the_oracle() {
    let mut grid = NeighborGrid::default();
    let mut lists = NeighborLists::default();
    let mut r = rng(11);
    let h: Real = 0.1;
    // Edges that the cells do not divide evenly, one of exactly 3h (3 cells: the smallest
    // allowed box) and one of 3.5h.
    for (min, len) in [
        (Vector::new(-1.3, 0.2, 5.0), Vector::new(1.0, 0.77, 1.5)),
        (Vector::new(0.0, 0.0, 0.0), Vector::new(0.3, 0.35, 0.3)),
        (Vector::new(-0.05, -7.0, 2.0), Vector::new(0.63, 0.41, 0.5)),
    ] {
        let max = min + len;
        let d = MinimumImage::new(min, max);
        let n = ((len.x * len.y * len.z) / (h * h * h) * 8.0) as usize;
        let mut pts: Vec<Vector> = (0..n)
            .map(|_| min + len * Vector::new(r.random(), r.random(), r.random()))
            .collect();
        // Particles exactly on the lower faces, edges and corner, just below the upper faces,
        // pairs straddling every face, edge and corner by less than h, and predictions a
        // little outside the box (PBF and Clavet search at predicted positions).
        let below = |x: Real| x - x.abs().max(1.0) * Real::EPSILON;
        let top = Vector::new(below(max.x), below(max.y), below(max.z));
        pts.extend([
            min,
            Vector::new(min.x, min.y + 0.5 * len.y, min.z + 0.5 * len.z),
            Vector::new(min.x, min.y, min.z + 0.3 * len.z),
            top,
            Vector::new(top.x, min.y + 0.5 * len.y, min.z + 0.5 * len.z),
            Vector::new(top.x, top.y, min.z + 0.7 * len.z),
        ]);
        for _ in 0..200 {
            let mut a = min + len * Vector::new(r.random(), r.random(), r.random());
            let mut b = a;
            for ax in 0..3 {
                if r.random_bool(0.6) {
                    a[ax] = min[ax] + r.random_range(0.0..0.5 * h);
                    b[ax] = max[ax] - r.random_range(0.0..0.5 * h);
                }
            }
            pts.push(a);
            pts.push(b);
        }
        for _ in 0..50 {
            let mut a = min + len * Vector::new(r.random(), r.random(), r.random());
            let ax = r.random_range(0..3);
            a[ax] = if r.random_bool(0.5) {
                min[ax] - r.random_range(0.0..0.3 * h)
            } else {
                max[ax] + r.random_range(0.0..0.3 * h)
            };
            pts.push(a);
        }
        check(
            &mut grid,
            &mut lists,
            &pts,
            h,
            &d,
            &format!("box {min:?} + {len:?}"),
        );
    }
}

fn no_colliders() -> (RigidBodySet, ColliderSet, BroadPhaseBvh) {
    (
        RigidBodySet::new(),
        ColliderSet::new(),
        BroadPhaseBvh::new(),
    )
}

/// A lattice filling the periodic box: every particle sees the same neighbourhood through
/// the faces, so every density is the same up to f32 round-off. The bound: each density sums
/// ~33 kernel values whose distances carry the coordinates' rounding (a few ulps of the
/// box edge, 1e-7·1.2 m on a 0.1 m spacing, ~1e-6 relative to the distance) times the
/// kernel's logarithmic slope (≤ ~4 over the support): ~4e-6 relative in the worst term,
/// so 2e-5 on the sum. A missing face would cost the face particles ~40 % of their density.
#[test]
fn lattice_filling_the_box_has_uniform_density() {
    let s: Real = 0.1;
    let n = 12;
    let len = n as Real * s;
    for solver in [Solver::Wcsph, Solver::dfsph()] {
        let params = FluidParamsBuilder::water(s)
            .solver(solver)
            .periodic(Vector::ZERO, Vector::splat(len))
            .build()
            .unwrap();
        let mut fluid = Fluid::new(params).unwrap();
        fluid.add_block(Vector::ZERO, Vector::splat(len)).unwrap();
        assert_eq!(fluid.len(), n * n * n);
        let mut fluids = FluidSet::new();
        let h = fluids.insert(fluid);
        let (mut bodies, colliders, bp) = no_colliders();
        let mut pipeline = FluidPipeline::with_time_stepping(TimeStepping::Fixed);
        pipeline
            .step(
                Vector::ZERO,
                1e-3,
                &mut fluids,
                &mut bodies,
                &colliders,
                &bp,
            )
            .unwrap();
        let rho = fluids[h].densities();
        let (lo, hi) = rho
            .iter()
            .fold((Real::MAX, Real::MIN), |(a, b), &r| (a.min(r), b.max(r)));
        assert!(
            (hi - lo) / lo < 2e-5,
            "{}: densities {lo} .. {hi}",
            solver.name()
        );
        // And it is the fluid's own rest lattice (the cubic spline at h = 2s: within 0.1 %).
        assert!((lo / 1000.0 - 1.0).abs() < 1e-3, "{lo}");
        // Every particle has the interior's neighbours (counting those clearly inside the
        // support: lattice pairs at exactly h = 2s pass or fail `d² < h²` by round-off, and
        // weigh W(h) = 0 either way).
        let f = &fluids[h];
        let d = f.params().domain.minimum_image().unwrap();
        let support = f.params().smoothing_length;
        let nb = pipeline.neighbor_lists(h).unwrap();
        let x = f.positions();
        let counts: Vec<usize> = (0..nb.len())
            .map(|i| {
                nb.of(i)
                    .iter()
                    .filter(|&&j| d.sep(x[i], x[j as usize]).length() < 0.999 * support)
                    .count()
            })
            .collect();
        assert!(
            counts.iter().all(|&c| c == counts[0]),
            "neighbour counts differ: {:?}",
            (counts.iter().min(), counts.iter().max())
        );
    }
}

/// A blob of water with random velocities drifting diagonally through the box: it crosses
/// faces, edges and corners; no particle is lost or leaves the box, and the pair forces
/// (antisymmetric, through the minimum image) conserve momentum up to round-off.
#[test]
fn blob_crossing_faces_conserves_momentum_and_count() {
    let s: Real = 0.05;
    let len: Real = 0.6;
    let min = Vector::new(-0.3, 0.1, 2.0);
    let max = min + Vector::splat(len);
    for solver in [Solver::Wcsph, Solver::dfsph()] {
        let params = FluidParamsBuilder::water(s)
            .solver(solver)
            .clamp_negative_pressure(false)
            .periodic(min, max)
            .build()
            .unwrap();
        let m = params.particle_mass;
        let dt = params.acoustic_time_step();
        let mut fluid = Fluid::new(params).unwrap();
        // A ball of 0.2 m radius near the box's upper corner (it straddles three faces
        // after a few steps).
        let mut r = rng(3);
        let center = max - Vector::splat(0.22);
        let mut pts = Vec::new();
        let mut vels = Vec::new();
        let k = (0.2 / s) as i32;
        for x in -k..=k {
            for y in -k..=k {
                for z in -k..=k {
                    let o = Vector::new(x as Real, y as Real, z as Real) * s;
                    if o.length() <= 0.2 {
                        pts.push(center + o);
                        vels.push(
                            Vector::new(3.0, 2.0, 1.5)
                                + Vector::new(
                                    r.random_range(-0.5..0.5),
                                    r.random_range(-0.5..0.5),
                                    r.random_range(-0.5..0.5),
                                ),
                        );
                    }
                }
            }
        }
        let count = pts.len();
        fluid
            .add_particles_with_velocities(&pts, Some(&vels))
            .unwrap();
        let mut fluids = FluidSet::new();
        let h = fluids.insert(fluid);
        let (mut bodies, colliders, bp) = no_colliders();
        let mut pipeline = FluidPipeline::with_time_stepping(TimeStepping::Fixed);
        let momentum = |f: &Fluid| {
            f.velocities()
                .iter()
                .fold([0.0f64; 3], |a, v| {
                    [a[0] + v.x as f64, a[1] + v.y as f64, a[2] + v.z as f64]
                })
                .map(|c| c * m as f64)
        };
        let p0 = momentum(&fluids[h]);
        // Round-off budget: every step rounds each velocity update (≤ U·|v|) and each force
        // sum (~40 pair terms, ≤ 40·U·|a|·dt); summed over particles and steps.
        let mut budget = 0.0f64;
        let mut wrapped = [false; 3];
        for _ in 0..60 {
            let before: Vec<Vector> = fluids[h].positions().to_vec();
            let ids_before: Vec<u32> = fluids[h].ids().to_vec();
            pipeline
                .step(Vector::ZERO, dt, &mut fluids, &mut bodies, &colliders, &bp)
                .unwrap();
            let f = &fluids[h];
            assert_eq!(f.len(), count, "{}: count", solver.name());
            assert!(
                f.positions()
                    .iter()
                    .all(|x| x.cmpge(min).all() && x.cmplt(max).all()),
                "{}: a particle outside the box",
                solver.name()
            );
            // A jump of more than half the box between steps is a wrap.
            let mut at = vec![Vector::ZERO; before.len()];
            for (x, &id) in before.iter().zip(&ids_before) {
                at[id as usize] = *x;
            }
            for (x, &id) in f.positions().iter().zip(f.ids()) {
                let jump = (*x - at[id as usize]).abs();
                for a in 0..3 {
                    wrapped[a] |= jump[a] > 0.5 * len;
                }
            }
            budget += f
                .velocities()
                .iter()
                .zip(f.accelerations())
                .map(|(v, a)| (v.length() + 40.0 * a.length() * dt) as f64 * m as f64)
                .sum::<f64>()
                * 2.0
                * U32;
        }
        assert!(
            wrapped.iter().all(|&w| w),
            "{}: no wrap on some axis",
            solver.name()
        );
        let p1 = momentum(&fluids[h]);
        for a in 0..3 {
            assert!(
                (p1[a] - p0[a]).abs() <= budget,
                "{}: momentum {a}: {} -> {} (budget {budget:e})",
                solver.name(),
                p0[a],
                p1[a]
            );
        }
    }
}

#[test]
fn bad_periodic_boxes_are_typed_errors() {
    let field = |r: Result<_, SphError>| match r {
        Err(SphError::InvalidParameter { field, .. }) => field,
        other => panic!("expected an error, got {other:?}"),
    };
    let b = || FluidParamsBuilder::water(0.1); // h = 0.2: edges of at least 0.6
    assert_eq!(
        field(b().periodic(Vector::ZERO, Vector::splat(0.5)).build()),
        "domain_max"
    );
    assert_eq!(
        field(
            b().periodic(Vector::ZERO, Vector::new(1.0, 1.0, -1.0))
                .build()
        ),
        "domain_max"
    );
    assert_eq!(
        field(
            b().periodic(Vector::new(Real::NAN, 0.0, 0.0), Vector::ONE)
                .build()
        ),
        "domain_min"
    );
    assert_eq!(
        field(
            b().periodic(Vector::ZERO, Vector::splat(Real::INFINITY))
                .build()
        ),
        "domain_max"
    );
    assert!(
        b().periodic(Vector::ZERO, Vector::splat(0.6))
            .build()
            .is_ok()
    );
    assert_eq!(b().build().unwrap().domain, Domain::Open);
}

/// The periodic path keeps the crate's promise: the same bits for any thread count (gather
/// loops over fixed chunks; the wrap is per particle). A blob crossing faces, every solver.
#[test]
fn periodic_runs_are_bitwise_identical_across_thread_counts() {
    let run = |solver: Solver| {
        let s: Real = 0.05;
        let min = Vector::new(-0.3, 0.1, 2.0);
        let max = min + Vector::splat(0.6);
        let params = FluidParamsBuilder::water(s)
            .solver(solver)
            .periodic(min, max)
            .build()
            .unwrap();
        let dt = params.acoustic_time_step();
        let mut fluid = Fluid::new(params).unwrap();
        let mut r = rng(5);
        let pts: Vec<Vector> = (0..1500)
            .map(|_| min + Vector::splat(0.6) * Vector::new(r.random(), r.random(), r.random()))
            .collect();
        let vels: Vec<Vector> = (0..pts.len())
            .map(|_| Vector::new(3.0, -2.0, 1.0) + Vector::splat(r.random_range(-0.5..0.5)))
            .collect();
        fluid
            .add_particles_with_velocities(&pts, Some(&vels))
            .unwrap();
        let mut fluids = FluidSet::new();
        let h = fluids.insert(fluid);
        let (mut bodies, colliders, bp) = no_colliders();
        let mut pipeline = FluidPipeline::with_time_stepping(TimeStepping::Fixed);
        for _ in 0..20 {
            pipeline
                .step(Vector::ZERO, dt, &mut fluids, &mut bodies, &colliders, &bp)
                .unwrap();
        }
        let f = &fluids[h];
        (bits(f.positions()), bits(f.velocities()), f.ids().to_vec())
    };
    for solver in [
        Solver::Wcsph,
        Solver::dfsph(),
        Solver::pbf(),
        Solver::clavet(),
    ] {
        let results = on_1_and_3_threads(|| run(solver));
        assert!(
            results[0] == results[1],
            "{}: 1 vs 3 threads differ",
            solver.name()
        );
    }
}

/// A fluid filling the periodic box takes DFSPH's closed-box path (equality solves about the
/// mean, zero-mean pressure: `solver::dfsph::SolveContext::closed`); its serial reductions keep
/// the same bits for any thread count. The Taylor–Green vortex at N = 8, 10 steps.
#[test]
fn closed_box_dfsph_is_bitwise_identical_across_thread_counts() {
    use rapier_sph::validation::{Method, taylor_green as tg};
    let m = Method {
        name: "DFSPH",
        solver: Solver::dfsph(),
        wall_density: true,
        wcsph_pressure: rapier_sph::WcsphPressure::Paper,
        wcsph_density: rapier_sph::WcsphDensity::Summation,
    };
    let run = || {
        let (mut world, h) = tg::world(&m, 8, 100).unwrap();
        world.pipeline.time_stepping = TimeStepping::Fixed;
        world.physics.integration_parameters.dt = 0.1;
        for _ in 0..10 {
            world.step_fluids().unwrap();
        }
        let f = &world.fluids[h];
        let bits = bits(f.velocities());
        let pressures: Vec<u32> = f.pressures().iter().map(|p| p.to_bits()).collect();
        // The closed path ran: its pressure has zero mean, so some is negative.
        assert!(f.pressures().iter().any(|&p| p < 0.0));
        (bits, pressures)
    };
    let results = on_1_and_3_threads(run);
    assert!(results[0] == results[1], "1 vs 3 threads differ");
}

/// The bits of every component, for exact comparisons.
fn bits(v: &[Vector]) -> Vec<[u32; 3]> {
    v.iter()
        .map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
        .collect()
}

/// `run`'s result on a pool of 1 thread, then on one of 3.
fn on_1_and_3_threads<T: Send>(run: impl Fn() -> T + Sync + Send) -> Vec<T> {
    on_each(&[1, 3], run)
}
