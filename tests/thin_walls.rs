//! Thin walls hit fast: a 1 mm thick cuboid plate and a zero-thickness trimesh sheet, hit at
//! 50 m/s (5.3 cm per step at the acoustic time step, 53 times the plate's thickness), and
//! a continuous 30 m/s jet onto the sheet. No particle may end on the far side.

mod common;

use common::*;
use rand::Rng;
use rapier_sph::rapier3d::prelude::*;

const SPACING: Real = 0.04;

/// The plate/sheet: footprint |x|, |z| ≤ 2 m in the plane y = 0 of `P` (large, so that
/// particles sliding along it for the 0.1 s of the run stay over it).
const HALF: Real = 2.0;

fn plate_pose() -> Pose {
    Pose::new(Vector::new(0.0, 0.3, 0.0), Vector::new(0.3, 0.0, -0.2))
}

fn sheet(p: Pose) -> ColliderBuilder {
    let v = vec![
        Vector::new(-HALF, 0.0, -HALF),
        Vector::new(HALF, 0.0, -HALF),
        Vector::new(HALF, 0.0, HALF),
        Vector::new(-HALF, 0.0, HALF),
    ];
    ColliderBuilder::trimesh(v, vec![[0, 1, 2], [0, 2, 3]])
        .expect("sheet")
        .position(p)
}

/// Streams and clouds at 50 m/s from both faces, straight and oblique.
fn shots(p: Pose, seed: u64) -> Vec<Shot> {
    let mut rng = rng(seed);
    let mut s = Vec::new();
    for k in 0..8 {
        let sign: Real = if k % 2 == 0 { -1.0 } else { 1.0 };
        let mut d = random_unit(&mut rng);
        d.y = sign * d.y.abs().max(0.5);
        if k < 2 {
            d = Vector::new(0.0, sign, 0.0);
        }
        let t = Vector::new(
            rng.random_range(-0.5..0.5),
            0.0,
            rng.random_range(-0.5..0.5),
        );
        s.push(Shot {
            dir: p.rotation.mul_vec3(d.normalize()),
            target: p.transform_point(t),
            cloud: k < 4,
        });
    }
    s
}

fn throw(name: &str, collider: ColliderBuilder, thick: bool, seed: u64) {
    let params = water(SPACING);
    let p = plate_pose();
    for gravity in [Vector::ZERO, Vector::new(0.0, -9.81, 0.0)] {
        let throw = Throw {
            label: format!("{name}, gravity {gravity}"),
            speed: 50.0,
            gravity,
            shots: shots(p, seed),
            duration: 0.1,
            stream_len: 8,
        };
        let tracker = run_throw(
            &params,
            vec![collider.clone()],
            |_, h| {
                let mut r = vec![Region::Sheet {
                    pose: p,
                    hx: HALF,
                    hz: HALF,
                }];
                if thick {
                    r.push(Region::Solid(h[0]));
                }
                r
            },
            &throw,
            seed,
        );
        assert!(tracker.contacts > 50, "{}: too few contacts", throw.label);
        tracker.assert_clearance(&throw.label);
    }
}

#[test]
fn plate_1mm_at_50_m_s() {
    throw(
        "1 mm cuboid plate at 50 m/s",
        ColliderBuilder::cuboid(HALF, 0.0005, HALF).position(plate_pose()),
        true,
        21,
    );
}

#[test]
fn zero_thickness_trimesh_at_50_m_s() {
    throw(
        "zero-thickness trimesh at 50 m/s",
        sheet(plate_pose()),
        false,
        22,
    );
}

/// A 30 m/s jet, 3 × 3 particles wide, fed every step for 0.1 s, straight down onto the
/// sheet from 20 cm, under gravity. The jet is dense (a new layer every 3.2 cm for particles
/// at 4 cm spacing), so it also splashes.
#[test]
fn zero_thickness_trimesh_jet_at_30_m_s() {
    let params = water(SPACING);
    let p = plate_pose();
    let (mut world, fluid, handles) = world_with(params.clone(), vec![sheet(p)]);
    let regions = vec![Region::Sheet {
        pose: p,
        hx: HALF,
        hz: HALF,
    }];
    let down = p.rotation.mul_vec3(Vector::NEG_Y);
    let mut tracker = Tracker::new();
    let dt = params.acoustic_time_step();
    let steps = (0.1 / dt).ceil() as usize;
    let mut total = 0;
    for _ in 0..steps {
        let nozzle: Vec<Vector> = (0..9)
            .map(|k| {
                let l = Vector::new(
                    (k % 3) as Real * SPACING - SPACING,
                    0.2,
                    (k / 3) as Real * SPACING - SPACING,
                );
                p.transform_point(l)
            })
            .collect();
        let vel = vec![down * 30.0; nozzle.len()];
        let ids = world.fluids[fluid]
            .add_particles_with_velocities(&nozzle, Some(&vel))
            .unwrap();
        tracker.spawn(ids, &nozzle, &regions);
        total += nozzle.len();
        let report = step_fluid(&mut world, Vector::new(0.0, -9.81, 0.0), dt);
        tracker.check(
            "30 m/s jet",
            &world,
            fluid,
            total,
            &regions,
            &handles,
            &report,
        );
    }
    assert!(tracker.contacts > 100, "the jet did not reach the sheet");
    // (The tracker asserted after every step that no particle crossed the sheet and that
    // every particle that stayed over it is still on the nozzle's side.)
    tracker.assert_clearance("30 m/s jet");
}
