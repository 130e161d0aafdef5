//! Buoyancy (issue 5): boxes of density 250, 500 and 750 kg/m³ float in water with
//! 25 %, 50 % and 75 % of their height submerged (within 5 % of the height once settled),
//! a box of 2000 kg/m³ sinks and rests on the floor.
//!
//! Walls count in the density (`wall_density(true)`, WCSPH), so the water's pressure pushes
//! the body (contact alone transmits too little: the boxes float 5–12 % too deep).
//!
//! **Ignored**: about 2.5 minutes on two cores (a 2.5 cm resolution is needed for a 16 cm
//! box), too long for the suite. It passes the depth criterion, but the issue's "nothing
//! jitters" does not hold yet: the boxes' vertical velocity still jumps by up to 0.13 m/s from
//! frame to frame (their depth varies by only ±1 mm), which this test reports but does not
//! check. Run `cargo test --release --test buoyancy -- --ignored --nocapture` for the
//! figures (README, "Two-way coupling").

use rapier_sph::rapier3d::prelude::*;
use rapier_sph::{Fluid, FluidWorld};

const S: Real = 0.025;

/// A 0.5 × 0.5 m tank with 0.2 m of water and a 0.16 m cube of `density` placed at its
/// expected floating depth; runs `seconds` and returns the submerged fraction's mean, min and
/// max over the last second, and the largest vertical speed of the cube then.
fn float(density: Real, seconds: Real) -> (Real, Real, Real, Real) {
    let mut world = FluidWorld::new();
    world.physics.integration_parameters.dt = 1.0 / 60.0;
    let (lx, lz, depth) = (0.5, 0.5, 0.2);
    rapier_sph::scenes::add_closed_box(&mut world, Vector::ZERO, Vector::new(lx, 0.6, lz), 0.05);
    let params = rapier_sph::FluidParamsBuilder::water(S)
        .wall_density(true)
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
    let (mut sum, mut lo, mut hi, mut vmax, mut count) = (0.0, Real::MAX, Real::MIN, 0.0, 0);
    for frame in 0..frames {
        world.step().unwrap();
        if frame + 60 < frames {
            continue;
        }
        let f = &world.fluids[fluid];
        // Water surface: mean height of the topmost 5 % of the particles away from the cube
        // (particle centres sit half a spacing under the surface).
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
        let frac = ((surface - (b.translation().y - half)) / (2.0 * half)).clamp(0.0, 1.0);
        sum += frac;
        count += 1;
        lo = lo.min(frac);
        hi = hi.max(frac);
        vmax = b.linvel().y.abs().max(vmax);
    }
    (sum / count as Real, lo, hi, vmax)
}

#[test]
#[ignore = "2.5 minutes on two cores; see the module docs"]
fn boxes_float_at_the_right_depth() {
    let mut failures = Vec::new();
    for density in [250.0, 500.0, 750.0] {
        let (mean, lo, hi, v) = float(density, 4.0);
        let expected = density / 1000.0;
        eprintln!(
            "density {density}: submerged {mean:.3} (expected {expected:.2}; {lo:.3} to {hi:.3} \
             over the last second), vertical speed up to {v:.3} m/s"
        );
        // The criterion: within 5 % of the box's height, once settled.
        if (mean - expected).abs() > 0.05 {
            failures.push(format!("density {density}: {mean:.3} vs {expected}"));
        }
    }
    let (mean, _, _, v) = float(2000.0, 4.0);
    eprintln!("density 2000: submerged {mean:.3}, vertical speed up to {v:.3} m/s");
    assert!(mean > 0.99, "the heavy box floats");
    assert!(failures.is_empty(), "{failures:?}");
}
