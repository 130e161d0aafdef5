//! Buoyancy (issue 5): boxes of density 250, 500 and 750 kg/m³ float in water with
//! 25 %, 50 % and 75 % of their height submerged (within 5 % of the height once settled),
//! a box of 2000 kg/m³ sinks and rests on the floor.
//!
//! **Ignored: this does not pass yet.** Run `cargo test --release --test buoyancy --
//! --ignored --nocapture` for the measured figures (README, "Two-way coupling").

mod common;

use common::*;
use rapier_sph::rapier3d::prelude::*;
use rapier_sph::{Fluid, FluidWorld};

const S: Real = 0.025;

/// A 0.5 × 0.5 m tank with 0.2 m of water and a 0.16 m cube of `density` dropped in at the
/// surface; after `seconds`, returns (submerged fraction, cube's vertical speed, water
/// surface height).
fn float(density: Real, wall_density: bool, seconds: Real) -> (Real, Real, Real) {
    let mut world = FluidWorld::new();
    world.physics.integration_parameters.dt = 1.0 / 60.0;
    let (lx, lz, depth) = (0.5, 0.5, 0.2);
    rapier_sph::scenes::add_closed_box(&mut world, Vector::ZERO, Vector::new(lx, 0.6, lz), 0.05);
    let params = rapier_sph::FluidParamsBuilder::water(S)
        .wall_density(wall_density)
        .build()
        .unwrap();
    let mut fluid = Fluid::new(params).unwrap();
    let half = 0.08;
    let centre = Vector::new(
        0.25,
        depth + half * (1.0 - 2.0 * density.min(1000.0) / 1000.0),
        0.25,
    );
    let pts: Vec<Vector> = rapier_sph::fluid::lattice(
        Vector::splat(0.5 * S),
        (lx / S) as usize,
        (depth / S) as usize,
        (lz / S) as usize,
        S,
    )
    .into_iter()
    .filter(|p| ((*p - centre).abs() - Vector::splat(half + 0.5 * S)).max_element() > 0.0)
    .collect();
    fluid.add_particles(&pts).unwrap();
    let fluid = world.fluids.insert(fluid);
    let cube = world
        .physics
        .insert_body(RigidBodyBuilder::dynamic().translation(centre));
    world.physics.insert_collider(
        ColliderBuilder::cuboid(half, half, half).density(density),
        Some(cube),
    );
    world.physics.step();
    let frames = (seconds * 60.0) as usize;
    for _ in 0..frames {
        world.step().unwrap();
    }
    let f = &world.fluids[fluid];
    // Water surface: mean height of the topmost particles away from the cube (its centre
    // is half a spacing under the surface).
    let mut top: Vec<Real> = f
        .positions()
        .iter()
        .filter(|p| (p.x - 0.25).abs() > 0.15 || (p.z - 0.25).abs() > 0.15)
        .map(|p| p.y)
        .collect();
    top.sort_by(|a, b| b.total_cmp(a));
    let n = (top.len() / 20).max(1);
    let surface = top[..n].iter().sum::<Real>() / n as Real + 0.5 * S;
    let b = &world.physics.bodies[cube];
    let bottom = b.translation().y - half;
    (
        ((surface - bottom) / (2.0 * half)).clamp(0.0, 1.0),
        b.linvel().y,
        surface,
    )
}

#[test]
#[ignore = "buoyancy is not within 5 % yet: see the README for the measured figures"]
fn boxes_float_at_the_right_depth() {
    for wall_density in [false, true] {
        for density in [250.0, 500.0, 750.0] {
            let (frac, vy, surface) = float(density, wall_density, 3.0);
            let expected = density / 1000.0;
            eprintln!(
                "wall_density {wall_density}: density {density}: submerged {frac:.3} (expected {expected:.2}), \
                 vertical speed {vy:.3} m/s, surface at {surface:.3} m"
            );
        }
        let (frac, vy, _) = float(2000.0, wall_density, 3.0);
        eprintln!(
            "wall_density {wall_density}: density 2000: submerged {frac:.3}, vertical speed {vy:.3} m/s"
        );
    }
    for density in [250.0, 500.0, 750.0] {
        let (frac, _, _) = float(density, false, 3.0);
        assert!(
            (frac - density / 1000.0).abs() < 0.05,
            "density {density}: {frac}"
        );
    }
}
