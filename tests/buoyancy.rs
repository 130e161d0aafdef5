//! Buoyancy (issue 5): boxes of density 250, 500 and 750 kg/m³ float in water with 25 %,
//! 50 % and 75 % of their height submerged (within 5 % of the height once settled), without
//! jitter; a box of 2000 kg/m³ sinks and rests on the floor.
//!
//! Walls count in the density (`wall_density(true)`, WCSPH), so the water's pressure pushes
//! the body (contact alone transmits too little: the boxes float 5–12 % too deep).
//!
//! The suite's test is lean (4 cm particles, a box 5 particles tall, ~1 800 particles, a few
//! seconds each). The boxes are 1.5 times as wide as they are tall: such a box floats upright
//! at all three densities (metacentric height `GM = sH/2 + W²/(12sH) − H/2 > 0` for
//! `s = 0.25, 0.5, 0.75`), whereas a cube of relative density 0.21–0.79 floats tilted (a
//! cube's upright position is unstable there): a cube would rotate for real while settling,
//! and rotation would not be jitter.
//!
//! **Ignored**: the finer measurement with cubes (2.5 cm particles), about 2.5 minutes on two
//! cores. Run `cargo test --release --test buoyancy -- --ignored --nocapture` for its
//! figures (README, "Two-way coupling").

use rapier_sph::rapier3d::prelude::*;
use rapier_sph::{Fluid, FluidWorld};

/// What a settled floating box did over the last second of a run.
struct Floating {
    /// Mean submerged fraction of the volume (water surface measured away from the box).
    submerged: Real,
    /// Lowest and highest submerged fraction.
    range: (Real, Real),
    /// RMS acceleration of the box's corners (m/s²), from its poses frame to frame:
    /// translation plus rotation (`α × r`).
    shaking: Real,
    /// RMS speed of the box's corners (m/s), from its poses frame to frame.
    speed: Real,
    /// RMS speed of the water within two spacings of the box (m/s).
    water: Real,
    /// Height of the box's lowest corner at the end (m; the tank's floor is at 0).
    bottom: Real,
}

/// Fraction of the volume of the box of half extents `half` at `pose` below the height
/// `surface`: the box cut into 32 × 32 columns along its own y axis, each column's fraction
/// below the surface exact (height is linear along it). Exact for an upright box, and right
/// for a tilted one too.
fn submerged_fraction(pose: &Pose, half: Vector, surface: Real) -> Real {
    const N: usize = 32;
    let mut sum = 0.0;
    for i in 0..N {
        for k in 0..N {
            let u = (i as Real + 0.5) / N as Real * 2.0 - 1.0;
            let w = (k as Real + 0.5) / N as Real * 2.0 - 1.0;
            let y0 = pose
                .transform_point(Vector::new(u * half.x, -half.y, w * half.z))
                .y;
            let y1 = pose
                .transform_point(Vector::new(u * half.x, half.y, w * half.z))
                .y;
            let (lo, hi) = (y0.min(y1), y0.max(y1));
            sum += if hi - lo < 1e-9 {
                (lo < surface) as u8 as Real
            } else {
                ((surface - lo) / (hi - lo)).clamp(0.0, 1.0)
            };
        }
    }
    sum / (N * N) as Real
}

/// A tank `tank` wide holding `depth` of water at spacing `s`, and a box of half extents
/// (`hw`, `hh`, `hw`) and `density` placed at its expected floating depth; runs `seconds` at
/// 60 Hz and measures the last second.
fn float(
    s: Real,
    tank: Real,
    depth: Real,
    hw: Real,
    hh: Real,
    density: Real,
    seconds: Real,
) -> Floating {
    let mut world = FluidWorld::new();
    world.physics.integration_parameters.dt = 1.0 / 60.0;
    let top = depth + 2.0 * hh + 0.1;
    rapier_sph::scenes::add_closed_box(
        &mut world,
        Vector::ZERO,
        Vector::new(tank, top, tank),
        0.05,
    );
    let params = rapier_sph::FluidParamsBuilder::water(s)
        .wall_density(true)
        .build()
        .unwrap();
    let mut fluid = Fluid::new(params).unwrap();
    let c = 0.5 * tank;
    let half = Vector::new(hw, hh, hw);
    let centre = Vector::new(
        c,
        depth + hh * (1.0 - 2.0 * density.min(1000.0) / 1000.0),
        c,
    );
    let n = (tank / s) as usize;
    let pts: Vec<Vector> =
        rapier_sph::fluid::lattice(Vector::splat(0.5 * s), n, (depth / s) as usize, n, s)
            .into_iter()
            .filter(|p| ((*p - centre).abs() - half - Vector::splat(0.5 * s)).max_element() > 0.0)
            .collect();
    fluid.add_particles(&pts).unwrap();
    let fluid = world.fluids.insert(fluid);
    let body = world
        .physics
        .insert_body(RigidBodyBuilder::dynamic().translation(centre));
    world.physics.insert_collider(
        ColliderBuilder::cuboid(hw, hh, hw).density(density),
        Some(body),
    );
    world.physics.step();
    let n0 = world.fluids[fluid].len();
    let frames = (seconds * 60.0) as usize;
    let dt = 1.0 / 60.0;
    let corner = half.length();
    let (mut sum, mut lo, mut hi, mut count) = (0.0, Real::MAX, Real::MIN, 0);
    let mut poses = Vec::new();
    let mut water = 0.0f64;
    for frame in 0..frames {
        world.step().unwrap();
        assert_eq!(world.fluids[fluid].len(), n0, "particles lost");
        if frame + 62 < frames {
            continue;
        }
        let b = &world.physics.bodies[body];
        poses.push(*b.position());
        if frame + 60 < frames {
            continue;
        }
        let f = &world.fluids[fluid];
        let pose = b.position();
        let (mut w2, mut wn) = (0.0f64, 0usize);
        for (x, v) in f.positions().iter().zip(f.velocities()) {
            let l = pose.inverse_transform_point(*x).abs() - half;
            if l.max_element() < 2.0 * s {
                w2 += v.length_squared() as f64;
                wn += 1;
            }
        }
        water += w2 / wn.max(1) as f64;
        // Water surface: mean height of the topmost 5 % of the particles more than two
        // spacings away from the box (particle centres sit half a spacing under it).
        let mut tops: Vec<Real> = f
            .positions()
            .iter()
            .filter(|p| (p.x - c).abs() > hw + 2.0 * s || (p.z - c).abs() > hw + 2.0 * s)
            .map(|p| p.y)
            .collect();
        tops.sort_by(|a, b| b.total_cmp(a));
        let k = (tops.len() / 20).max(1);
        let surface = tops[..k].iter().sum::<Real>() / k as Real + 0.5 * s;
        let frac = submerged_fraction(pose, half, surface);
        sum += frac;
        count += 1;
        lo = lo.min(frac);
        hi = hi.max(frac);
    }
    // Frame-to-frame velocities (linear, angular) from the poses, then accelerations.
    let vel: Vec<(Vector, Vector)> = poses
        .windows(2)
        .map(|w| {
            (
                (w[1].translation - w[0].translation) / dt,
                (w[1].rotation * w[0].rotation.inverse()).to_scaled_axis() / dt,
            )
        })
        .collect();
    let (mut a2, mut v2) = (0.0f64, 0.0f64);
    for w in vel.windows(2) {
        let a = (w[1].0 - w[0].0).length() / dt;
        let alpha = (w[1].1 - w[0].1).length() / dt;
        a2 += ((a + alpha * corner) as f64).powi(2);
    }
    for (v, w) in &vel {
        v2 += ((v.length() + w.length() * corner) as f64).powi(2);
    }
    Floating {
        submerged: sum / count as Real,
        range: (lo, hi),
        shaking: (a2 / (vel.len() - 1) as f64).sqrt() as Real,
        speed: (v2 / vel.len() as f64).sqrt() as Real,
        water: (water / count as f64).sqrt() as Real,
        bottom: {
            let pose = world.physics.bodies[body].position();
            let mut low = Real::MAX;
            for c in 0..8 {
                let sign = |b: usize| if c & b == 0 { -1.0 } else { 1.0 };
                let corner = Vector::new(sign(1) * hw, sign(2) * hh, sign(4) * hw);
                low = low.min(pose.transform_point(corner).y);
            }
            low
        },
    }
}

#[test]
fn boxes_float_at_the_right_depth_without_jitter() {
    let s = 0.04;
    let mut failures = Vec::new();
    for density in [250.0, 500.0, 750.0] {
        let f = float(s, 0.72, 0.3, 0.15, 0.1, density, 3.0);
        let expected = density / 1000.0;
        eprintln!(
            "density {density}: submerged {:.3} (expected {expected:.2}; {:.3} to {:.3}), \
             corners: RMS acceleration {:.3} g, RMS speed {:.4} m/s (water next to it {:.4})",
            f.submerged,
            f.range.0,
            f.range.1,
            f.shaking / 9.81,
            f.speed,
            f.water,
        );
        // The criterion: within 5 % of the box's height (here 8 mm, a fifth of a
        // spacing), once settled.
        if (f.submerged - expected).abs() > 0.05 {
            failures.push(format!("density {density}: submerged {:.3}", f.submerged));
        }
        // Jitter. At rest the water's force balances the weight; what is left accelerates
        // the box. A coupling that flickers (support on in one frame, off in the next: the
        // failure of explicit coupling) shakes it at the order of g: measured 0.55–1.06 g
        // RMS at the corners when the fluid's impulses reached the body once per frame. The
        // water's own noise (WCSPH at 4 cm: particles next to the box move at 0.10–0.17 m/s
        // RMS even at rest) still shakes it at 0.11–0.19 g. Bound: 0.3 g, the net force
        // and torque fluctuate by less than a third of the weight (the box is never close to
        // being lifted off or dropped).
        if f.shaking > 0.3 * 9.81 {
            failures.push(format!(
                "density {density}: corners shaken at {:.3} g",
                f.shaking / 9.81
            ));
        }
        // Gaining energy at rest: a body driven by the coupling rather than by the water
        // would move faster than the water it floats in.
        if f.speed > f.water {
            failures.push(format!(
                "density {density}: corners at {:.4} m/s, faster than the water ({:.4})",
                f.speed, f.water
            ));
        }
    }
    // A box of 2000 kg/m³ sinks and rests on the floor: fully submerged, at rest (slower
    // than the water next to it, as above), and down. Not on the floor itself: the last
    // layer of particles under it cannot be squeezed out (a particle between two walls one
    // spacing apart sits one contact radius from each, pushed equally by both; the film
    // cannot thin below one particle), so the box rests on that layer, its lowest corner one
    // spacing up (measured 0.0397 m). Bound: one spacing and a quarter (a box still sinking
    // or held up by two layers would be higher).
    let f = float(s, 0.72, 0.3, 0.15, 0.1, 2000.0, 2.5);
    eprintln!(
        "density 2000: submerged {:.3}, lowest corner at {:.4} m, corners' RMS speed {:.4} m/s \
         (water next to it {:.4})",
        f.submerged, f.bottom, f.speed, f.water
    );
    if f.submerged < 0.999 || f.bottom > 1.25 * s || f.speed > f.water {
        failures.push(format!(
            "density 2000: submerged {:.3}, bottom at {:.4} m, speed {:.4} m/s",
            f.submerged, f.bottom, f.speed
        ));
    }
    assert!(failures.is_empty(), "{failures:?}");
}

#[test]
#[ignore = "2.5 minutes on two cores; see the module docs"]
fn cubes_float_at_the_right_depth() {
    // Cubes of 16 cm at 2.5 cm resolution in a 0.5 m tank. Cubes of these densities float
    // tilted (see the module docs): the submerged fraction is that of the volume, whatever
    // the tilt (Archimedes).
    let s = 0.025;
    let mut failures = Vec::new();
    for density in [250.0, 500.0, 750.0] {
        let f = float(s, 0.5, 0.2, 0.08, 0.08, density, 4.0);
        let expected = density / 1000.0;
        eprintln!(
            "density {density}: submerged {:.3} (expected {expected:.2}; {:.3} to {:.3} over \
             the last second), corners: RMS acceleration {:.3} g, RMS speed {:.4} m/s",
            f.submerged,
            f.range.0,
            f.range.1,
            f.shaking / 9.81,
            f.speed
        );
        if (f.submerged - expected).abs() > 0.05 {
            failures.push(format!(
                "density {density}: {:.3} vs {expected}",
                f.submerged
            ));
        }
    }
    let f = float(s, 0.5, 0.2, 0.08, 0.08, 2000.0, 4.0);
    eprintln!(
        "density 2000: submerged {:.3}, corners: RMS speed {:.4} m/s",
        f.submerged, f.speed
    );
    assert!(f.submerged > 0.99, "the heavy box floats");
    assert!(failures.is_empty(), "{failures:?}");
}
