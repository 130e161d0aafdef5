//! Bitwise parity across thread counts, and between the parallel and the serial build.
//!
//! The crate promises (src/par.rs) that the result of a step does not depend on the number
//! of threads, nor on the `parallel` feature: every per-particle loop is a gather over
//! fixed-size chunks and no float is accumulated across threads. So the comparison is
//! bitwise (`to_bits`), with no tolerance.
//!
//! Serial vs parallel build: the serial build (`--no-default-features`) is compared by
//! running this same test binary twice with `RAPIER_SPH_PARITY_FILE` pointing at the same
//! file, once per build (the CI script does this):
//!
//! ```text
//! rm -f /tmp/parity.txt
//! RAPIER_SPH_PARITY_FILE=/tmp/parity.txt cargo test --release --test parallel_parity
//! RAPIER_SPH_PARITY_FILE=/tmp/parity.txt cargo test --release --no-default-features --test parallel_parity
//! ```
//!
//! The first run writes the hash of the final state, the second compares its own with it.

mod common;

use common::on_threads;
use rapier_sph::math::{Real, Vector};
use rapier_sph::scenes::{DamBreakConfig, dam_break};
use rapier_sph::{FluidParamsBuilder, StepReport};

const STEPS: usize = 100;

/// Final positions, velocities and ids after `STEPS` steps of a small dam break
/// (8 × 20 × 8 = 1,280 particles, five 256-particle chunks), and the last report.
fn run() -> (Vec<Vector>, Vec<Vector>, Vec<u32>, StepReport) {
    let params = FluidParamsBuilder::water(0.04).build().unwrap();
    let dt = params.acoustic_time_step();
    let mut scene = dam_break(&DamBreakConfig::tower(params, 0.8)).unwrap();
    scene.world.physics.integration_parameters.dt = dt;
    let mut report = StepReport::default();
    for _ in 0..STEPS {
        report = scene.world.step().unwrap().clone();
    }
    let f = &scene.world.fluids[scene.fluid];
    assert_eq!(f.len(), 1280);
    (
        f.positions().to_vec(),
        f.velocities().to_vec(),
        f.ids().to_vec(),
        report,
    )
}

fn bits(v: &[Vector]) -> Vec<[u32; 3]> {
    v.iter()
        .map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
        .collect()
}

/// 64-bit FNV-1a over the bits of ids, positions and velocities, in order.
fn fnv(pos: &[Vector], vel: &[Vector], ids: &[u32]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |w: u32| {
        for b in w.to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for ((p, v), &id) in pos.iter().zip(vel).zip(ids) {
        eat(id);
        for c in [p.x, p.y, p.z, v.x, v.y, v.z] {
            eat(Real::to_bits(c));
        }
    }
    h
}

/// Serial vs parallel build: with `RAPIER_SPH_PARITY_FILE` set (path + `suffix`), the first
/// build to run writes `hash` there and the second must find the same (see the module docs).
fn check_parity_file(suffix: &str, what: &str, hash: u64) {
    let build = if cfg!(feature = "parallel") {
        "parallel"
    } else {
        "serial"
    };
    let Some(path) = std::env::var_os("RAPIER_SPH_PARITY_FILE") else {
        return;
    };
    let mut path = std::path::PathBuf::from(path).into_os_string();
    path.push(suffix);
    match std::fs::read_to_string(&path) {
        Ok(text) => {
            let mut parts = text.split_whitespace();
            let recorded = parts.next().expect("empty parity file");
            let recorded_by = parts.next().unwrap_or("?");
            assert_eq!(
                recorded,
                format!("{hash:016x}"),
                "the {build} build's {what} differs from the {recorded_by} build's \
                 (recorded in {path:?})"
            );
            eprintln!(
                "parity: {build} build's {what} matches the {recorded_by} build ({hash:016x})"
            );
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            std::fs::write(&path, format!("{hash:016x} {build}\n")).unwrap();
            eprintln!("parity: {build} build wrote its {what}, {hash:016x}, to {path:?}");
        }
        Err(e) => panic!("cannot read {path:?}: {e}"),
    }
}

#[test]
fn thread_counts_give_bitwise_identical_results() {
    let results = [1, 2, 3].map(|threads| (threads, on_threads(threads, run)));
    let (_, (p1, v1, i1, r1)) = &results[0];
    // The run did something: particles moved and touched the tank.
    assert!(r1.max_speed > 0.1 && r1.contacts > 0, "{r1:?}");
    for (threads, (p, v, i, r)) in &results[1..] {
        assert_eq!(
            i, i1,
            "{threads} threads: particle order differs from 1 thread"
        );
        assert!(
            bits(p) == bits(p1),
            "{threads} threads: positions differ from 1 thread"
        );
        assert!(
            bits(v) == bits(v1),
            "{threads} threads: velocities differ from 1 thread"
        );
        // Counts and reductions of the report too (timings excluded).
        assert_eq!(
            (
                r.particles,
                r.neighbour_pairs,
                r.contacts,
                r.contact_fallbacks
            ),
            (
                r1.particles,
                r1.neighbour_pairs,
                r1.contacts,
                r1.contact_fallbacks
            ),
            "{threads} threads: report counts differ"
        );
        assert_eq!(r.max_speed.to_bits(), r1.max_speed.to_bits());
        assert_eq!(
            r.max_density_error.to_bits(),
            r1.max_density_error.to_bits()
        );
        assert_eq!(
            r.mean_density_error.to_bits(),
            r1.mean_density_error.to_bits()
        );
    }

    // Serial vs parallel build, through a file shared by two runs (see the module docs).
    check_parity_file("", "final state", fnv(p1, v1, i1));
}

/// The obstacle course for 2 s at 5 cm: emitters, sinks, a kinematic wheel and dynamic
/// crates pushed by the fluid (moving-frame contact, impulses summed per chunk). Returns
/// the fluid's final state and the crates' positions and velocities. (The water reaches the
/// crates after about 1.5 s; 2 s gives some twenty pushes, where 1.5 s gave one or none.)
fn run_coupled() -> (Vec<Vector>, Vec<Vector>, Vec<u32>, Vec<Vector>) {
    use rapier_sph::scenes::{ObstacleCourseConfig, obstacle_course};
    let params = FluidParamsBuilder::water(0.05).build().unwrap();
    let mut course = obstacle_course(&ObstacleCourseConfig::new(params)).unwrap();
    let mut pushed = 0;
    for _ in 0..120 {
        pushed += course.world.step().unwrap().coupled_bodies;
    }
    assert!(pushed > 0, "no body was pushed by the fluid");
    let f = &course.world.fluids[course.fluid];
    let bodies: Vec<Vector> = course
        .crates
        .iter()
        .flat_map(|&b| {
            let b = &course.world.physics.bodies[b];
            [b.translation(), b.linvel(), b.angvel()]
        })
        .collect();
    (
        f.positions().to_vec(),
        f.velocities().to_vec(),
        f.ids().to_vec(),
        bodies,
    )
}

#[test]
fn coupled_scene_is_bitwise_identical_across_thread_counts_and_builds() {
    let results = [1, 2, 3].map(|threads| (threads, on_threads(threads, run_coupled)));
    let (_, (p1, v1, i1, b1)) = &results[0];
    for (threads, (p, v, i, b)) in &results[1..] {
        assert_eq!(i, i1, "{threads} threads: particle order differs");
        assert!(bits(p) == bits(p1), "{threads} threads: positions differ");
        assert!(bits(v) == bits(v1), "{threads} threads: velocities differ");
        assert!(bits(b) == bits(b1), "{threads} threads: crates differ");
    }
    let hash = fnv(p1, v1, i1) ^ fnv(b1, b1, &vec![0; b1.len()]).rotate_left(1);
    check_parity_file(".coupled", "coupled scene", hash);
}

/// DFSPH with walls in the density (the salva comparison's setup, small): the solves' pair
/// passes, the stored gradients and Laplacians, and the warm start pushed by the density
/// pass give bitwise the same state on 1, 2 and 3 threads, and in the serial build.
#[test]
fn dfsph_with_wall_density_is_bitwise_identical_across_thread_counts_and_builds() {
    let (p1, v1, i1) = dfsph_on_1_2_3_threads(rapier_sph::solver::Dfsph::default());
    check_parity_file(".dfsph", "DFSPH run", fnv(&p1, &v1, &i1));
}

/// DFSPH with the carried error and Chebyshev acceleration (opt-in): the same scene gives
/// bitwise the same state on 1, 2 and 3 threads.
#[test]
fn dfsph_with_chebyshev_is_bitwise_identical_across_thread_counts() {
    dfsph_on_1_2_3_threads(rapier_sph::solver::Dfsph {
        full_warm_start: true,
        carry_density_error: true,
        chebyshev: Some(0.8),
        ..Default::default()
    });
}

/// The DFSPH dam break of the tests above with `dfsph`, run on 1, 2 and 3 threads: asserts
/// the density solve iterated and the runs are bitwise equal; returns the 1-thread state.
fn dfsph_on_1_2_3_threads(
    dfsph: rapier_sph::solver::Dfsph,
) -> (Vec<Vector>, Vec<Vector>, Vec<u32>) {
    let run = || {
        let params = FluidParamsBuilder::water(0.04)
            .solver(rapier_sph::Solver::Dfsph(dfsph))
            .wall_density(true)
            .build()
            .unwrap();
        let mut scene = dam_break(&DamBreakConfig::tower(params, 0.8)).unwrap();
        scene.world.physics.integration_parameters.dt = 1.0 / 60.0;
        let mut iterations = 0;
        for _ in 0..60 {
            iterations += scene.world.step().unwrap().solver_iterations;
        }
        let f = &scene.world.fluids[scene.fluid];
        (
            f.positions().to_vec(),
            f.velocities().to_vec(),
            f.ids().to_vec(),
            iterations,
        )
    };
    let mut results: Vec<_> = [1, 2, 3]
        .into_iter()
        .map(|threads| (threads, on_threads(threads, run)))
        .collect();
    let (_, (p1, v1, i1, it1)) = results.remove(0);
    // The solver did work: the density solve iterated.
    assert!(it1 > 60, "{it1} density iterations over 60 frames");
    for (threads, (p, v, i, it)) in &results {
        assert_eq!(*i, i1, "{threads} threads: particle order differs");
        assert_eq!(*it, it1, "{threads} threads: iteration counts differ");
        assert!(bits(p) == bits(&p1), "{threads} threads: positions differ");
        assert!(bits(v) == bits(&v1), "{threads} threads: velocities differ");
    }
    (p1, v1, i1)
}
