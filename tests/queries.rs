//! Game queries: amount of fluid in regions (box, ball, sensor collider), SPH samples at
//! points against a brute-force sum, and enter/leave counts.

mod common;

use common::*;
use rapier_sph::kernel::{CubicSpline, Kernel};
use rapier_sph::rapier3d::prelude::*;
use rapier_sph::{Fluid, FluidSampler, FluidWorld, Region, RegionTracker};

const S: Real = 0.05;

/// A 10×10×10 lattice at spacing 5 cm from (0.025, 0.025, 0.025), moving at `v`.
fn block(v: Vector) -> Fluid {
    let mut f = Fluid::new(water(S)).unwrap();
    let pts = rapier_sph::fluid::lattice(Vector::splat(0.5 * S), 10, 10, 10, S);
    let vel = vec![v; pts.len()];
    f.add_particles_with_velocities(&pts, Some(&vel)).unwrap();
    f
}

#[test]
fn amount_in_boxes_balls_and_sensors() {
    let f = block(Vector::ZERO);
    let mut colliders = ColliderSet::new();
    // A sensor box covering lattice x-indices 0..5 (x < 0.25), all y, z: 500 particles.
    let sensor = colliders.insert(
        ColliderBuilder::cuboid(0.125, 1.0, 1.0)
            .translation(Vector::new(0.125, 0.25, 0.25))
            .sensor(true),
    );
    let a = f.amount_in(&Region::Collider(sensor), &colliders);
    assert_eq!(a.particles, 500);
    // Volume at rest density: 500 particles of m/ρ0 = s³ each.
    assert!((a.volume - 500.0 * S * S * S).abs() < 1e-6);
    let b = f.amount_in(
        &Region::Aabb {
            min: Vector::ZERO,
            max: Vector::new(0.1, 0.1, 0.1),
        },
        &colliders,
    );
    assert_eq!(b.particles, 8);
    // A ball of radius 1.01 spacings around a lattice point: it and its 6 face neighbours.
    let c = f.amount_in(
        &Region::Ball {
            center: Vector::splat(0.225),
            radius: 1.01 * S,
        },
        &colliders,
    );
    assert_eq!(c.particles, 7);
}

#[test]
fn samples_match_a_brute_force_sum() {
    let v = Vector::new(0.3, -0.2, 0.1);
    let f = block(v);
    let sampler = FluidSampler::new(&f);
    let h = f.params().smoothing_length;
    let m = f.params().particle_mass;
    let k = CubicSpline::new(h);
    let mut rng = rng(5);
    use rand::Rng;
    let mut inside = 0;
    for _ in 0..200 {
        let x = Vector::new(
            rng.random_range(-0.2..0.7),
            rng.random_range(-0.2..0.7),
            rng.random_range(-0.2..0.7),
        );
        let brute: Real = f
            .positions()
            .iter()
            .map(|p| (x - *p).length())
            .filter(|d| *d < h)
            .map(|d| m * k.w(d))
            .sum();
        match sampler.sample(x) {
            None => assert_eq!(brute, 0.0, "missed particles near {x}"),
            Some(s) => {
                inside += 1;
                // Same terms, summed in another order: f32 round-off of ~30 terms.
                assert!(
                    (s.density - brute).abs() <= 1e-4 * brute.max(1.0),
                    "{x}: {} vs {brute}",
                    s.density
                );
                // A uniform flow is returned exactly up to round-off (Shepard normalisation).
                assert!((s.velocity - v).length() < 1e-5, "{x}: {}", s.velocity);
            }
        }
    }
    assert!(inside > 50);
    // Deep inside, the interpolated density is the lattice's: ρ0 within the cubic spline's
    // lattice-sum error at h = 2s (the same figure the density stage computes there).
    let center = sampler.sample(Vector::splat(0.225)).unwrap();
    assert!(
        (center.density - 1000.0).abs() < 0.05 * 1000.0,
        "{}",
        center.density
    );
}

#[test]
fn enter_and_leave_counts() {
    // A block flying along +x at 2 m/s through a box region 0.3 m wide, no gravity: after
    // 1 s it has passed entirely, so every particle entered once and left once.
    let mut world = FluidWorld::new();
    world.physics.gravity = Vector::ZERO;
    let fluid = world.fluids.insert(block(Vector::new(2.0, 0.0, 0.0)));
    let mut tracker = RegionTracker::new(Region::Aabb {
        min: Vector::new(0.8, -1.0, -1.0),
        max: Vector::new(1.1, 2.0, 2.0),
    });
    let (mut entered, mut left, mut peak) = (0, 0, 0);
    for _ in 0..60 {
        step_fluid(&mut world, Vector::ZERO, 1.0 / 60.0);
        let e = tracker.update(&world.fluids[fluid], &world.physics.colliders);
        entered += e.entered;
        left += e.left;
        peak = peak.max(e.inside);
        assert_eq!(entered - left, e.inside);
    }
    let n = world.fluids[fluid].len();
    // The block spreads a little as it flies (free surface in zero gravity): its rear has
    // left the region after 1 s (it started 0.8 m before it and moves 2 m).
    assert_eq!(entered, n);
    assert_eq!(left, n);
    assert!(peak > 0);
}

/// The water's surface and depth over a pool at rest on its lattice: the fill height
/// everywhere over it (exact: the top layer's centers plus half a spacing), nothing beside it,
/// and a typed error for a non-finite coordinate.
#[test]
fn surface_height_and_depth_over_a_pool() {
    let f = block(Vector::ZERO); // 0.5 m cube of water from the origin
    let surface = rapier_sph::WaterSurface::new(&f);
    for (x, z) in [(0.25, 0.25), (0.01, 0.49), (0.37, 0.12), (0.5, 0.5)] {
        let c = surface.column(x, z).unwrap().unwrap();
        assert!(
            (c.surface - 0.5).abs() < 1e-5,
            "surface {} at ({x}, {z})",
            c.surface
        );
        assert!(c.bottom.abs() < 1e-5 && (c.depth() - 0.5).abs() < 1e-5);
    }
    let d = surface
        .depth_below_surface(Vector::new(0.2, 0.35, 0.2))
        .unwrap()
        .unwrap();
    assert!((d - 0.15).abs() < 1e-5);
    let above = surface
        .depth_below_surface(Vector::new(0.2, 0.8, 0.2))
        .unwrap()
        .unwrap();
    assert!((above + 0.3).abs() < 1e-5);
    // Beyond one kernel support of the water: no column.
    assert!(surface.column(0.8, 0.25).unwrap().is_none());
    assert!(surface.height(-0.5, 0.25).unwrap().is_none());
    for bad in [Real::NAN, Real::INFINITY] {
        assert!(matches!(
            surface.column(bad, 0.0),
            Err(rapier_sph::SphError::InvalidParameter { field: "x", .. })
        ));
        assert!(matches!(
            surface.height(0.0, bad),
            Err(rapier_sph::SphError::InvalidParameter { field: "z", .. })
        ));
        assert!(matches!(
            surface.depth_below_surface(Vector::new(0.0, bad, 0.0)),
            Err(rapier_sph::SphError::InvalidParameter { field: "point", .. })
        ));
    }
}

/// A box's submerged volume under a flat surface is its footprint times its chord under the
/// water: exact for an axis-aligned box, whatever its height; a removed collider is a typed
/// error.
#[test]
fn submerged_volume_of_a_box_is_exact_under_a_flat_surface() {
    let f = block(Vector::ZERO);
    let surface = rapier_sph::WaterSurface::new(&f);
    let mut colliders = ColliderSet::new();
    let (hx, hy, hz) = (0.1, 0.05, 0.08);
    for (y, under) in [
        (0.8, 0.0),
        (0.5, hy),
        (0.47, hy + 0.03),
        (0.3, 2.0 * hy),
        (0.0, hy),
    ] {
        let h = colliders
            .insert(ColliderBuilder::cuboid(hx, hy, hz).translation(Vector::new(0.25, y, 0.25)));
        let v = surface.submerged_volume(h, &colliders).unwrap();
        let expected = 4.0 * hx * hz * under;
        assert!(
            (v - expected).abs() < 1e-6,
            "at y = {y}: {v} m³, expected {expected}"
        );
    }
    let gone = colliders.insert(ColliderBuilder::ball(0.1));
    colliders.remove(
        gone,
        &mut IslandManager::new(),
        &mut RigidBodySet::new(),
        &mut SoftBodySet::new(),
        true,
    );
    assert!(matches!(
        surface.submerged_volume(gone, &colliders),
        Err(rapier_sph::SphError::UnknownHandle {
            argument: "collider",
            ..
        })
    ));
}

/// The surface of water settled in a tank by the solver reads its fill height at rest density
/// within half a spacing (the top layer's jitter), and the fluid's velocity there is still.
#[test]
fn surface_of_settled_water_reads_its_fill_height() {
    let s = 0.05;
    let floor = ColliderBuilder::cuboid(1.0, 0.1, 1.0).translation(Vector::new(0.0, -0.1, 0.0));
    let wall = |x: Real, z: Real, hx: Real, hz: Real| {
        ColliderBuilder::cuboid(hx, 0.5, hz).translation(Vector::new(x, 0.5, z))
    };
    let (mut world, fluid, _) = world_with(
        water(s),
        vec![
            floor,
            wall(-0.35, 0.0, 0.05, 0.4),
            wall(0.35, 0.0, 0.05, 0.4),
            wall(0.0, -0.35, 0.4, 0.05),
            wall(0.0, 0.35, 0.4, 0.05),
        ],
    );
    world.fluids[fluid]
        .add_block(Vector::new(-0.3, 0.0, -0.3), Vector::new(0.6, 0.3, 0.6))
        .unwrap();
    for _ in 0..60 {
        world.step().unwrap();
    }
    let f = &world.fluids[fluid];
    let surface = rapier_sph::WaterSurface::new(f);
    let sampler = FluidSampler::new(f);
    for (x, z) in [(0.0, 0.0), (0.1, -0.2), (-0.2, 0.15)] {
        let h = surface.height(x, z).unwrap().unwrap();
        assert!((h - 0.3).abs() < 0.5 * s, "surface {h} at ({x}, {z})");
        let v = sampler
            .velocity_at(Vector::new(x, 0.15, z))
            .unwrap()
            .unwrap();
        assert!(v.length() < 0.05, "velocity {v:?} in water at rest");
    }
}

/// Queries and sinks take the same regions: `NearCollider` counts what is within its reach of
/// the collider's surface (one spacing by default), `Collider` only what is inside.
#[test]
fn near_collider_regions_reach_past_the_surface() {
    let f = block(Vector::ZERO); // x from 0.025 to 0.475 in steps of 0.05
    let mut colliders = ColliderSet::new();
    // A plate whose face is at x = 0.1: the lattice's columns at 0.125 (0.025 off) and
    // 0.175 (0.075 off) are outside it.
    let plate = colliders
        .insert(ColliderBuilder::cuboid(0.05, 1.0, 1.0).translation(Vector::new(0.05, 0.25, 0.25)));
    let inside = f.amount_in(&Region::Collider(plate), &colliders).particles;
    let near = |reach| {
        f.amount_in(
            &Region::NearCollider {
                handle: plate,
                reach,
            },
            &colliders,
        )
        .particles
    };
    assert_eq!(inside, 200); // columns at x = 0.025 and 0.075
    assert_eq!(near(None), 300); // + the column 0.025 off (within one spacing, 0.05)
    assert_eq!(near(Some(0.1)), 400); // + the column 0.075 off
    assert!(
        Region::NearCollider {
            handle: plate,
            reach: Some(-1.0)
        }
        .validate()
        .is_err()
    );
}
