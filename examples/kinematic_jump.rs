//! A 0.4 m open bucket of water on a kinematic body whose target jumps sideways in one frame
//! (or which is teleported with `set_position`): the fastest particle, the fraction of the
//! water left in the bucket 1 s later, whether the substep cap was hit.
//!
//! `cargo run --release --example kinematic_jump -- <jump m> <solver: dfsph|wcsph|pbf|clavet> [teleport]`

use rapier_sph::rapier3d::prelude::*;
use rapier_sph::{Fluid, FluidParamsBuilder, FluidWorld, Solver};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let jump: Real = args.get(1).map_or(0.1, |s| s.parse().unwrap());
    let solver = match args.get(2).map_or("dfsph", |s| s.as_str()) {
        "wcsph" => Solver::Wcsph,
        "pbf" => Solver::pbf(),
        "clavet" => Solver::clavet(),
        _ => Solver::dfsph(),
    };
    let teleport = args.get(3).is_some_and(|s| s == "teleport");
    let mark = args.get(3).is_some_and(|s| s == "mark");
    let spacing = 0.03;
    let mut world = FluidWorld::new();
    let body = world
        .physics
        .insert_body(RigidBodyBuilder::kinematic_position_based());
    let (inner, wall, floor_y) = (0.2, 0.02, 0.0);
    let height = 0.4;
    // Floor and four walls around the 0.4 m square interior.
    let parts = [
        (
            Vector::new(0.0, floor_y - wall, 0.0),
            Vector::new(inner + 2.0 * wall, wall, inner + 2.0 * wall),
        ),
        (
            Vector::new(inner + wall, height * 0.5, 0.0),
            Vector::new(wall, height * 0.5, inner + 2.0 * wall),
        ),
        (
            Vector::new(-inner - wall, height * 0.5, 0.0),
            Vector::new(wall, height * 0.5, inner + 2.0 * wall),
        ),
        (
            Vector::new(0.0, height * 0.5, inner + wall),
            Vector::new(inner, height * 0.5, wall),
        ),
        (
            Vector::new(0.0, height * 0.5, -inner - wall),
            Vector::new(inner, height * 0.5, wall),
        ),
    ];
    for (c, h) in parts {
        world.physics.insert_collider(
            ColliderBuilder::cuboid(h.x, h.y, h.z).translation(c),
            Some(body),
        );
    }
    world.physics.step();
    let params = FluidParamsBuilder::water(spacing)
        .solver(solver)
        .build()
        .unwrap();
    let mut fluid = Fluid::new(params).unwrap();
    let r = spacing * 0.5;
    fluid
        .add_block(
            Vector::new(-inner + r, floor_y + r, -inner + r),
            Vector::new(13.0 * spacing, 8.0 * spacing, 13.0 * spacing),
        )
        .unwrap();
    let h = world.fluids.insert(fluid);
    let n0 = world.fluids[h].len();
    for _ in 0..60 {
        world.step().unwrap();
    }
    let vmax_rest = world.fluids[h]
        .velocities()
        .iter()
        .map(|v| v.length())
        .fold(0.0, Real::max);
    let e0 = energy(&world, h);
    let t0 = std::time::Instant::now();
    let mut cap = false;
    let mut vmax: Real = 0.0;
    let mut substeps = 0;
    for frame in 0..61 {
        if frame == 0 {
            if teleport {
                let b = &mut world.physics.bodies[body];
                b.set_position(Pose::from_translation(Vector::new(jump, 0.0, 0.0)), true);
            } else {
                world.physics.bodies[body]
                    .set_next_kinematic_translation(Vector::new(jump, 0.0, 0.0));
                if mark {
                    world.pipeline.mark_teleport(body);
                }
            }
        }
        let rep = world.step().unwrap().clone();
        cap |= rep.substep_cap_hit;
        if rep.substep_cap_hit {
            eprintln!(
                "cap hit at frame {frame}: substeps {} vmax {}",
                rep.substeps, rep.max_speed
            );
        }
        substeps += rep.substeps;
        let v = world.fluids[h]
            .velocities()
            .iter()
            .map(|v| v.length())
            .fold(0.0, Real::max);
        vmax = vmax.max(v);
        if frame == 0 {
            let f = &world.fluids[h];
            let mut idx: Vec<usize> = (0..f.len()).collect();
            idx.sort_by(|&a, &b| {
                f.velocities()[b]
                    .length()
                    .partial_cmp(&f.velocities()[a].length())
                    .unwrap()
            });
            for &i in idx.iter().take(6) {
                eprintln!("  x {:?} v {:?}", f.positions()[i], f.velocities()[i]);
            }
        }
        if frame < 3 {
            eprintln!(
                "frame {frame}: substeps {} vmax {v:.2} body {:?}",
                rep.substeps,
                world.physics.bodies[body].translation()
            );
        }
    }
    let f = &world.fluids[h];
    let inside = f
        .positions()
        .iter()
        .filter(|p| {
            (p.x - jump).abs() < inner && p.z.abs() < inner && p.y > floor_y && p.y < height
        })
        .count();
    println!(
        "jump {jump} teleport {teleport}: n {} of {n0}, rest vmax {vmax_rest:.3}, fastest {vmax:.2} m/s, left in bucket {:.1} %, cap hit {cap}, substeps {substeps}, energy gain {:.2} J, {:.1} s",
        f.len(),
        100.0 * inside as f64 / n0 as f64,
        energy(&world, h) - e0,
        t0.elapsed().as_secs_f64()
    );
}

fn energy(world: &FluidWorld, h: rapier_sph::FluidHandle) -> f64 {
    let f = &world.fluids[h];
    let m = f.params().particle_mass as f64;
    f.positions()
        .iter()
        .zip(f.velocities())
        .map(|(p, v)| m * (0.5 * v.length_squared() as f64 + 9.81 * p.y as f64))
        .sum()
}
