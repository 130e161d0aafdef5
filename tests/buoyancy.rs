//! Buoyancy: boxes of density 250, 500 and 750 kg/m³ float in water with 25 %,
//! 50 % and 75 % of their height submerged (within 5 % of the height once settled), without
//! jitter; a box of 2000 kg/m³ sinks and rests on the floor.
//!
//! Walls count in the density (`wall_density(true)`; WCSPH and DFSPH, the water preset's
//! default), so the water's pressure pushes the body (contact alone transmits too little: the
//! boxes float 5–12 % too deep). Measured (4 cm, the 3rd second): WCSPH 0.241 / 0.502 /
//! 0.726, corners 0.050 / 0.040 / 0.043 g; DFSPH (hydrostatic walls) 0.216 / 0.461 / 0.709
//! (a fifth of a spacing high: docs/coupling.md, "Buoyancy"), corners 0.029–0.047 g; the
//! 2000 kg/m³ box's lowest corner 0.0400 m up with both (it
//! rests on the last particle layer, held against the floor by contact: `contact::hold`).
//!
//! The suite's test is lean (4 cm particles, a box 5 particles tall, ~1 800 particles, a few
//! seconds each). The boxes are 1.5 times as wide as they are tall: such a box floats upright
//! at all three densities (metacentric height `GM = sH/2 + W²/(12sH) − H/2 > 0` for
//! `s = 0.25, 0.5, 0.75`), whereas a cube of relative density 0.21–0.79 floats tilted (a
//! cube's upright position is unstable there): a cube would rotate for real while settling,
//! and rotation would not be jitter.
//!
//! `pbf_boxes_float_within_5_percent_of_archimedes` reads the criterion strictly (the
//! fraction within 5 % of itself) for PBF at 2.5 cm, the solver whose boxes float closest.
//!
//! `cubes_float_at_the_right_depth` (3 s runs, the 3rd second measured): the finer measurement
//! with 16 cm cubes (2.5 cm particles) in 0.3 m of water: the tilted 750 kg/m³ cube's lowest
//! edge floats 0.146 m deep, so shallower water would leave it within the floor's kernel
//! reach. Measured: 0.236 / 0.486 / 0.734 for 250 / 500 / 750 kg/m³ over the 3rd second,
//! 0.235 / 0.485 / 0.733 over the 4th (`cargo run --release --example buoyancy -- --cubes`).
//! `dense_boxes_land_and_rest_without_gaining_energy` (~15 s): boxes of 5,000 and 7,850 kg/m³
//! land on the floor and rest, with WCSPH, DFSPH and PBF, the total energy never above its
//! start (pinched particles are left out of the solves).
//! `cargo test --release --test buoyancy -- --nocapture` prints every figure
//! (docs/coupling.md).

use rapier_sph::math::Real;
use rapier_sph::scenes::{Floating, FloatingBox, FloatingBoxConfig};

const WCSPH: rapier_sph::Solver = rapier_sph::Solver::Wcsph;

/// A tank `tank` wide holding `depth` of water at spacing `s` with `solver` (walls counting in the
/// density), and a box of half extents (`hw`, `hh`, `hw`) and `density` placed at its expected
/// floating depth ([`FloatingBox`]); runs `seconds` at 60 Hz, checking after every frame that
/// no particle was lost, and measures the last second.
#[allow(clippy::too_many_arguments)]
fn float(
    solver: rapier_sph::Solver,
    s: Real,
    tank: Real,
    depth: Real,
    hw: Real,
    hh: Real,
    density: Real,
    seconds: Real,
) -> Floating {
    let mut scene = FloatingBox::new(FloatingBoxConfig {
        spacing: s,
        tank,
        depth,
        half_width: hw,
        half_height: hh,
        density,
        solver,
    })
    .unwrap();
    let fluid = scene.fluid;
    let n0 = scene.world.fluids[fluid].len();
    scene
        .run(seconds, |_, world| {
            assert_eq!(world.fluids[fluid].len(), n0, "particles lost");
            Ok(())
        })
        .unwrap()
}

/// WCSPH and the water preset's default solver, DFSPH (both with walls counting in the
/// density), one test each so that the two run on the test harness's two threads side by side
/// (`cargo test --release --test buoyancy boxes_float_at_the_right_depth` runs both).
mod boxes_float_at_the_right_depth_without_jitter {
    #[test]
    fn wcsph() {
        super::boxes_float(super::WCSPH);
    }

    #[test]
    fn dfsph() {
        super::boxes_float(rapier_sph::Solver::dfsph());
    }
}

fn boxes_float(solver: rapier_sph::Solver) {
    let mut failures = Vec::new();
    let s = 0.04;
    let name = solver.name();
    for density in [250.0, 500.0, 750.0] {
        let f = float(solver, s, 0.72, 0.3, 0.15, 0.1, density, 3.0);
        let expected = density / 1000.0;
        eprintln!(
            "{name}, density {density}: submerged {:.3} (expected {expected:.2}; {:.3} to {:.3}), \
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
            failures.push(format!(
                "{name}, density {density}: submerged {:.3}",
                f.submerged
            ));
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
                "{name}, density {density}: corners shaken at {:.3} g",
                f.shaking / 9.81
            ));
        }
        // Gaining energy at rest: a body driven by the coupling rather than by the water
        // would move faster than the water it floats in.
        if f.speed > f.water {
            failures.push(format!(
                "{name}, density {density}: corners at {:.4} m/s, faster than the water ({:.4})",
                f.speed, f.water
            ));
        }
    }
    // A box of 2000 kg/m³ sinks and rests on the floor: fully submerged, at rest (slower
    // than the water next to it, as above), and down. Not on the floor itself: the last
    // layer of particles under it cannot be squeezed out (a particle between two walls one
    // spacing apart sits one contact radius from each, pushed equally by both; the film
    // cannot thin below one particle), so the box rests on that layer, its lowest corner one
    // spacing up (measured 0.0400 m). Bound: one spacing and a quarter (a box still sinking
    // or held up by two layers would be higher).
    let f = float(solver, s, 0.72, 0.3, 0.15, 0.1, 2000.0, 2.5);
    eprintln!(
        "{name}, density 2000: submerged {:.3}, lowest corner at {:.4} m, corners' RMS speed {:.4} m/s \
         (water next to it {:.4})",
        f.submerged, f.bottom, f.speed, f.water
    );
    if f.submerged < 0.999 || f.bottom > 1.25 * s || f.speed > f.water {
        failures.push(format!(
            "{name}, density 2000: submerged {:.3}, bottom at {:.4} m, speed {:.4} m/s",
            f.submerged, f.bottom, f.speed
        ));
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// The criterion read strictly: the submerged *fraction* within 5 % of its own value
/// (Archimedes: density / 1000), at 2.5 cm (the box 8 particles tall), with PBF, whose
/// boxes float closest (WCSPH and DFSPH float the light box a few % too high, see
/// docs/coupling.md). Same jitter and energy bounds as above, measured "once settled": over
/// the 5th second for the 250 box, over the 4th for the 500 and 750 boxes. The box is placed
/// at its expected depth in a lattice cut out around it, and the start excites a slosh of the
/// whole tank (period about 1 s) that the light box rides: its sway decays from 0.05 m/s at
/// 0.7 s to 0.02 at 2.5 s and 0.003 at 5.5 s. Over the 3rd second the 250 box still sways at
/// 0.0350 m/s against the water's 0.0278, a start-up transient the relative-speed bound is
/// not meant to judge; over the 4th, 0.0222 against 0.0221. The heavier boxes settle sooner:
/// over the 4th second their corners move at 0.0163 and 0.0178 m/s (the water 0.0227 and
/// 0.0253) and their fractions read 0.4977 and 0.7518, within 0.0010 of the 5th second's
/// (0.4967, 0.7508: the same runs carried on to 5 s; a 25th of the tolerance or less).
/// One test a box, so that they run side by side on the test harness's two threads.
mod pbf_boxes_float_within_5_percent_of_archimedes {
    #[test]
    fn density_250() {
        super::pbf_box_floats(250.0, 5.0);
    }

    #[test]
    fn density_500() {
        super::pbf_box_floats(500.0, 4.0);
    }

    #[test]
    fn density_750() {
        super::pbf_box_floats(750.0, 4.0);
    }
}

/// A box of `density` in PBF at 2.5 cm, run `seconds` and measured over the last second
/// ([`pbf_boxes_float_within_5_percent_of_archimedes`]).
fn pbf_box_floats(density: Real, seconds: Real) {
    let s = 0.025;
    let mut failures = Vec::new();
    let f = float(
        rapier_sph::Solver::pbf(),
        s,
        0.72,
        0.3,
        0.15,
        0.1,
        density,
        seconds,
    );
    let expected = density / 1000.0;
    eprintln!(
        "PBF, density {density}: submerged {:.3} (expected {expected:.2}), corners: RMS \
         acceleration {:.3} g, RMS speed {:.4} m/s (water next to it {:.4})",
        f.submerged,
        f.shaking / 9.81,
        f.speed,
        f.water,
    );
    if (f.submerged - expected).abs() > 0.05 * expected {
        failures.push(format!("density {density}: submerged {:.3}", f.submerged));
    }
    if f.shaking > 0.3 * 9.81 || f.speed > f.water {
        failures.push(format!(
            "density {density}: corners at {:.3} g, {:.4} m/s (water {:.4})",
            f.shaking / 9.81,
            f.speed,
            f.water
        ));
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// Each cube runs 3 s, measured over the 3rd second: 0.236 / 0.486 / 0.734 for 250 / 500 /
/// 750 kg/m³. Settled: over the 4th second the same runs read 0.235 / 0.485 / 0.733 (the
/// example's 4 s, `cargo run --release --example buoyancy -- --cubes`), within 0.002 of the
/// 3rd second's, a 25th of the 0.05 tolerance (over the 2nd second the 750 cube, still
/// tilting, read 0.742). The 2,000 kg/m³ cube lies on the floor, fully submerged, from the
/// 2nd second on. One test a cube, so that they run side by side on the test harness's two
/// threads.
mod cubes_float_at_the_right_depth {
    #[test]
    fn density_250() {
        super::cube_floats(250.0);
    }

    #[test]
    fn density_500() {
        super::cube_floats(500.0);
    }

    #[test]
    fn density_750() {
        super::cube_floats(750.0);
    }

    #[test]
    fn density_2000() {
        super::cube_sinks(2000.0);
    }
}

/// A cube of `density` (250, 500 or 750 kg/m³) floats at the depth Archimedes gives
/// ([`cubes_float_at_the_right_depth`]).
fn cube_floats(density: Real) {
    // Cubes of 16 cm at 2.5 cm resolution in a 0.5 m tank holding 0.3 m of water. Cubes of
    // these densities float tilted (see the module docs): the submerged fraction is that of
    // the volume, whatever the tilt (Archimedes). Tilted, the 750 kg/m³ cube reaches deep: edge
    // down at 45°, its lowest edge floats a·√2 − a/2 = 0.146 m under the surface (a = 0.16),
    // so the water must be deep enough to leave more than the kernel's reach (h = 5 cm) under
    // it; in 0.2 m it would be 5.4 cm, and the floor's wall term holds the cube (measured:
    // it sinks to 0.855).
    let s = 0.025;
    let mut failures = Vec::new();
    let f = float(WCSPH, s, 0.5, 0.3, 0.08, 0.08, density, 3.0);
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
    assert!(failures.is_empty(), "{failures:?}");
}

/// A cube of `density` (2,000 kg/m³) sinks: fully submerged over the 3rd second
/// ([`cubes_float_at_the_right_depth`]).
fn cube_sinks(density: Real) {
    let f = float(WCSPH, 0.025, 0.5, 0.3, 0.08, 0.08, density, 3.0);
    eprintln!(
        "density {density}: submerged {:.3}, corners: RMS speed {:.4} m/s",
        f.submerged, f.speed
    );
    assert!(f.submerged > 0.99, "the heavy box floats");
}

/// Dense bodies (5,000 kg/m³; 7,850, steel) dropped in water sink, land on the floor and
/// rest there, with every solver that has walls counting in the density, and the water and
/// the box together never gain energy on the way (mechanical energy, kinetic plus potential
/// from the floor, against its value at the start).
///
/// A landing box squeezes a layer of particles thinner than the fluid's spacing against the
/// floor. If DFSPH and PBF raised those particles' pressure without bound (no motion of theirs
/// can lower their density), the pressure would throw the box: a 5,000 kg/m³ box reached
/// 100 m (DFSPH; PBF from 3,000 kg/m³), total energy 339 J → 263,000 J in one frame. Such
/// particles are left out of the solves (`WallWorkspace::pinched`). Figures: the eprintln
/// lines (`-- --nocapture`). One test a solver, so that they run side by side on the test
/// harness's two threads.
mod dense_boxes_land_and_rest_without_gaining_energy {
    #[test]
    fn wcsph() {
        super::dense_boxes_land(super::WCSPH);
    }

    #[test]
    fn dfsph() {
        super::dense_boxes_land(rapier_sph::Solver::dfsph());
    }

    #[test]
    fn pbf() {
        super::dense_boxes_land(rapier_sph::Solver::pbf());
    }
}

/// [`dense_boxes_land_and_rest_without_gaining_energy`] with `solver`.
fn dense_boxes_land(solver: rapier_sph::Solver) {
    let s = 0.04;
    let mut failures = Vec::new();
    for density in [5000.0, 7850.0] {
        let name = solver.name();
        let mut scene = FloatingBox::new(FloatingBoxConfig {
            spacing: s,
            tank: 0.72,
            depth: 0.3,
            half_width: 0.15,
            half_height: 0.1,
            density,
            solver,
        })
        .unwrap();
        let (fluid, body) = (scene.fluid, scene.body);
        let n0 = scene.world.fluids[fluid].len();
        let energy = |world: &rapier_sph::FluidWorld| {
            let b = &world.physics.bodies[body];
            let w = &world.fluids[fluid];
            let g = world.physics.gravity.length() as f64;
            let m = w.params().particle_mass as f64;
            let water: f64 = w.positions().iter().map(|x| m * g * x.y as f64).sum();
            w.kinetic_energy() as f64
                + water
                + b.kinetic_energy() as f64
                + b.mass() as f64 * g * b.center_of_mass().y as f64
        };
        let e0 = energy(&scene.world);
        let mut e_max = e0;
        let f = scene
            .run(2.5, |_, world| {
                assert_eq!(world.fluids[fluid].len(), n0, "particles lost");
                e_max = e_max.max(energy(world));
                Ok(())
            })
            .unwrap();
        eprintln!(
            "{name}, density {density}: lowest corner at {:.4} m, submerged {:.3}, corners' \
             RMS speed {:.4} m/s (water next to it {:.4}); energy at most {:.2} J against \
             {:.2} J at the start",
            f.bottom, f.submerged, f.speed, f.water, e_max, e0
        );
        // At rest on the floor: as for the 2,000 kg/m³ box above (at most one layer of
        // particles under it, slower than the water next to it).
        if f.submerged < 0.999 || f.bottom > 1.25 * s || f.speed > f.water {
            failures.push(format!(
                "{name}, density {density}: submerged {:.3}, bottom at {:.4} m, speed {:.4} \
                 m/s",
                f.submerged, f.bottom, f.speed
            ));
        }
        // Nothing drives the water or the box: the energy can only fall. Allowance: 1 %
        // of the start's (the lattice the water starts from settles, and its small
        // compression returns some energy; the floating boxes above gain at most 0.4 %).
        if e_max > 1.01 * e0 {
            failures.push(format!(
                "{name}, density {density}: energy rose to {e_max:.2} J from {e0:.2} J"
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// A floating box teleported by a game's marked move (`mark_teleport` with `set_position`)
/// and launched at 2 m/s upward (`set_linvel`), placed so that rapier's step of the frame
/// brings it back to about where it floated, is seen at rest by the water during that frame
/// (`boundary::teleport`). PBF's walls stand a body at its substep's end and add rapier's
/// share of its velocity change over the frame to the added-mass solve
/// (`Coupling::exchange`, `with_rapier`); for a body seen at rest that share is none of the
/// motion the water met, and it may not reach the water. Bound: with the body at rest, the
/// water's fastest particle gains at most one frame's gravity `g·dt` over its fastest before
/// the jump (contact and the walls only push it back). Measured: 0.196 m/s before, 0.237
/// after (bound 0.360); with rapier's share left in, 0.729. The water is left behind
/// (`set_teleport_carry(false)`): carried, the water around the box moves with it by the
/// 1.4 mm rapier's gravity left between the two poses, against the water beyond, and PBF's
/// position solve turns that into 0.77 m/s (`boundary::teleport`).
#[test]
fn pbf_floating_box_teleported_does_not_kick_the_water() {
    use rapier_sph::math::{Pose, Vector};
    let config = FloatingBoxConfig {
        spacing: 0.04,
        tank: 0.6,
        depth: 0.24,
        half_width: 0.08,
        half_height: 0.08,
        density: 500.0,
        solver: rapier_sph::Solver::pbf(),
    };
    let mut scene = FloatingBox::new(config).unwrap();
    let (fluid, body) = (scene.fluid, scene.body);
    let fastest = |scene: &FloatingBox| {
        scene.world.fluids[fluid]
            .velocities()
            .iter()
            .map(|v| v.length())
            .fold(0.0, Real::max)
    };
    for _ in 0..60 {
        scene.world.step().unwrap();
    }
    let before = fastest(&scene);
    let (launch, dt) = (2.0, 1.0 / 60.0);
    let b = &mut scene.world.physics.bodies[body];
    let target = b.translation() - Vector::new(0.0, launch * dt, 0.0);
    b.set_position(Pose::from_translation(target), true);
    b.set_linvel(Vector::new(0.0, launch, 0.0), true);
    scene.world.pipeline.mark_teleport(body);
    scene.world.pipeline.set_teleport_carry(body, false);
    scene.world.step().unwrap();
    let after = fastest(&scene);
    let bound = before + 9.81 * dt;
    println!(
        "water's fastest {before:.3} m/s before the jump, {after:.3} m/s after (bound {bound:.3})"
    );
    assert!(
        after <= bound,
        "water kicked to {after} m/s (bound {bound})"
    );
}
