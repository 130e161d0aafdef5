//! One dam-break front against the experiment: Z(T) of one scene × solver × resolution ×
//! time step, with the fluid's settings overridable, for convergence studies (docs/validation.md's
//! "Convergence of the dam-break front" notes were measured with it). Prints the errors the
//! report prints (`front_rms_t3`: RMS relative deviation from the measured points with
//! T ≤ 3), Z at T = 0.5, 1, 2, 3, and the time shift δ that best aligns the simulated front
//! with the data (`Z_sim(T − δ)` against `Z(T)`, scanned in steps of 0.005, with the RMS left
//! after the shift); then, unless `--quiet`, the front at every data point and every sample.
//!
//! ```sh
//! cargo run --release --example dam_front -- --scene n2_2 --solver dfsph --n 12
//! cargo run --release --example dam_front -- --scene n2_1 --solver wcsph --n 16 --dt 2e-5
//! cargo run --release --example dam_front -- --scene n2_2 --solver wcsph --wall-density on
//! ```
//!
//! Flags: `--scene n2_1|n2_2|ko` (Martin & Moyce square column, n² = 2, Koshizuka & Oka),
//! `--solver wcsph|dfsph|pbf`, `--n N` (particles across the column, default 12), `--dt S`
//! (fixed step in seconds; default: adaptive), `--courant C`, `--viscosity E` (Pa·s),
//! `--friction F`, `--wall-viscosity E` (Pa·s, needs wall density), `--density-error X`, `--divergence-error X`, `--warm-start W`,
//! `--hydrostatic-walls` / `--no-hydrostatic-walls` (DFSPH's default: on), `--no-divergence-solve` (DFSPH), `--gate V` (the column held by a gate at x = a that rises at
//! V m/s from t = 0, instead of an instant release),
//! `--sound C` (WCSPH's Tait speed of sound, m/s), `--wall-density on|off` (default: as
//! `validation::methods()` runs the solver), `--periodic-z L` (no side walls: L ≥ 6 layers
//! across a slab periodic in z, floor and end walls only), `--t-end T` (front time, default
//! 3.05), `--every T` (sampling interval in front time, default 0.05), `--quiet`.

use rapier_sph::FluidParams;
use rapier_sph::math::Real;
use rapier_sph::pipeline::TimeStepping;
use rapier_sph::solver::{Dfsph, Solver};
use rapier_sph::validation::dam_break::{Case, DamBreak2d};
use rapier_sph::validation::{Method, interpolate, methods, rms_relative};

fn main() {
    let mut scene = "n2_2".to_string();
    let mut solver = "dfsph".to_string();
    let mut n = 12usize;
    let mut dt: Option<Real> = None;
    let mut courant: Real = 0.4;
    let mut viscosity: Option<Real> = None;
    let mut friction: Option<Real> = None;
    let mut wall_viscosity: Option<Real> = None;
    let mut density_error: Option<Real> = None;
    let mut divergence_error: Option<Real> = None;
    let mut warm: Option<Real> = None;
    let mut wall_density: Option<bool> = None;
    let mut t_end: Option<f64> = None;
    let mut every = 0.05f64;
    let mut quiet = false;
    let mut sound: Option<Real> = None;
    let mut periodic_z: Option<usize> = None;
    let mut hydrostatic_walls: Option<bool> = None;
    let mut no_divergence = false;
    let mut gate: Option<Real> = None;
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut val = || it.next().unwrap_or_else(|| panic!("{a} needs a value"));
        match a.as_str() {
            "--scene" => scene = val(),
            "--solver" => solver = val(),
            "--n" => n = val().parse().unwrap(),
            "--dt" => dt = Some(val().parse().unwrap()),
            "--courant" => courant = val().parse().unwrap(),
            "--viscosity" => viscosity = Some(val().parse().unwrap()),
            "--friction" => friction = Some(val().parse().unwrap()),
            "--wall-viscosity" => wall_viscosity = Some(val().parse().unwrap()),
            "--density-error" => density_error = Some(val().parse().unwrap()),
            "--divergence-error" => divergence_error = Some(val().parse().unwrap()),
            "--warm-start" => warm = Some(val().parse().unwrap()),
            "--wall-density" => wall_density = Some(val() == "on"),
            "--t-end" => t_end = Some(val().parse().unwrap()),
            "--every" => every = val().parse().unwrap(),
            "--quiet" => quiet = true,
            "--sound" => sound = Some(val().parse().unwrap()),
            "--periodic-z" => periodic_z = Some(val().parse().unwrap()),
            "--hydrostatic-walls" => hydrostatic_walls = Some(true),
            "--no-hydrostatic-walls" => hydrostatic_walls = Some(false),
            "--no-divergence-solve" => no_divergence = true,
            "--gate" => gate = Some(val().parse().unwrap()),
            other => panic!("unknown argument {other}"),
        }
    }
    let case = match scene.as_str() {
        "n2_1" => Case::martin_moyce_square(),
        "n2_2" => Case::martin_moyce_n2(),
        "ko" => Case::koshizuka_oka(),
        s => panic!("unknown scene {s}"),
    }
    .unwrap();
    let mut method: Method = methods()
        .into_iter()
        .find(|m| m.name.eq_ignore_ascii_case(&solver))
        .unwrap_or_else(|| panic!("unknown solver {solver}"));
    if let Some(w) = wall_density {
        method.wall_density = w;
    }
    if let Solver::Dfsph(d) = &mut method.solver {
        let mut dd: Dfsph = *d;
        if let Some(x) = density_error {
            dd.max_density_error = x;
        }
        if let Some(x) = divergence_error {
            dd.max_divergence_error = x;
        }
        if let Some(x) = warm {
            dd.warm_start = x;
        }
        if let Some(on) = hydrostatic_walls {
            dd.hydrostatic_walls = on;
        }
        dd.divergence_solve = !no_divergence;
        *d = dd;
    }
    let mut params: FluidParams = case.params(&method, n).unwrap();
    if let Some(v) = viscosity {
        params.viscosity = v;
    }
    if let Some(c) = sound {
        params.equation_of_state = rapier_sph::EquationOfState::Tait {
            speed_of_sound: c,
            exponent: 7.0,
        };
    }
    if let Some(f) = friction {
        params.friction = f;
    }
    if let Some(e) = wall_viscosity {
        params.wall_viscosity = e;
    }
    let mut db = match periodic_z {
        None => DamBreak2d::new(&case, params.clone()).unwrap(),
        Some(layers) => periodic_slab(&case, params.clone(), layers),
    };
    let g = 9.81f64;
    let a = case.width as f64;
    let tf = case.front_time_factor as f64 * (g / a).sqrt();
    let t_end = t_end.unwrap_or(3.05);
    let duration = t_end / tf;
    let frame = every / tf;
    let (step, stepping, frames_per_sample) = match dt {
        Some(d) => {
            let k = (frame / d as f64).round().max(1.0) as usize;
            ((frame / k as f64) as Real, TimeStepping::Fixed, k)
        }
        None => (
            frame as Real,
            TimeStepping::Adaptive {
                courant,
                // As good as no cap: the CFL limits alone set the substeps.
                max_substeps: rapier_sph::pipeline::MAX_SUBSTEPS,
            },
            1,
        ),
    };
    if let Some(v) = gate {
        add_gate(&mut db, &params, v);
    }
    db.world.pipeline.time_stepping = stepping;
    db.world.physics.integration_parameters.dt = step;
    let mut front = vec![(0.0f64, db.measure().0 as f64 / a)];
    let mut t = 0.0f64;
    let mut substeps = 0u64;
    let mut k = 0usize;
    let wall = std::time::Instant::now();
    while t < duration - 1e-9 {
        let r = if gate.is_some() {
            db.world.step().unwrap()
        } else {
            db.world.step_fluids().unwrap()
        };
        substeps += r.substeps as u64;
        assert_eq!(r.non_finite, 0, "non-finite particles");
        t += step as f64;
        k += 1;
        if k.is_multiple_of(frames_per_sample) {
            front.push((t * tf, db.measure().0 as f64 / a));
        }
    }
    let e_all = rms_relative(&front, &case.front, (0.0, f64::MAX));
    let e3 = rms_relative(&front, &case.front, (0.0, 3.0));
    let ritter = front
        .iter()
        .filter(|p| p.0 > 0.0)
        .map(|&(t, z)| z - (1.0 + 2.0 * t))
        .fold(f64::NEG_INFINITY, f64::max);
    println!(
        "# {} {} N={n} s={:.5} visc={} wall_visc={} friction={} dt={} mean_dt={:.3e} substeps={substeps} wall={:.1}s",
        case.name,
        method.name,
        params.particle_spacing,
        params.viscosity,
        params.wall_viscosity,
        params.friction,
        dt.map_or("adaptive".to_string(), |d| format!("{d:e}")),
        t / substeps.max(1) as f64,
        wall.elapsed().as_secs_f64()
    );
    let z = |t: f64| interpolate(&front, t).unwrap_or(f64::NAN);
    println!(
        "# front_rms={e_all:.4} front_rms_t3={e3:.4} ritter_excess={ritter:.4} Z(0.5)={:.3} Z(1)={:.3} Z(2)={:.3} Z(3)={:.3}",
        z(0.5),
        z(1.0),
        z(2.0),
        z(3.0)
    );
    // The time shift δ that best aligns the simulated front with the data: the RMS of
    // (Z_sim(T − δ) − Z)/Z over the data points, δ scanned in steps of 0.005.
    let (mut best, mut best_rms) = (0.0, f64::INFINITY);
    for k in -40..=100 {
        let d = k as f64 * 0.005;
        let shifted: Vec<(f64, f64)> = front.iter().map(|&(t, z)| (t + d, z)).collect();
        let e = rms_relative(&shifted, &case.front, (d.max(0.0), 3.0));
        if e < best_rms {
            (best, best_rms) = (d, e);
        }
    }
    println!("# best time shift over T <= 3: delta={best:+.3} rms={best_rms:.4}");
    if quiet {
        return;
    }
    println!("# at the data points: T Z_data Z_sim rel");
    for &(tx, zx) in &case.front.points {
        if let Some(z) = interpolate(&front, tx) {
            println!("D {tx:.3} {zx:.3} {z:.3} {:+.3}", (z - zx) / zx);
        }
    }
    println!("# samples: T Z ritter");
    for &(tt, z) in &front {
        println!("S {tt:.3} {z:.3} {:.3}", 1.0 + 2.0 * tt);
    }
}

/// The dam break without side walls: floor, back wall, far wall and lid as rapier cuboids
/// that reach well past the slab, and a box periodic across the slab (z) only in effect (the
/// box is larger than the tank in x and y, so nothing wraps there).
fn periodic_slab(case: &Case, mut params: FluidParams, layers: usize) -> DamBreak2d {
    use rapier_sph::math::Vector;
    use rapier_sph::rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};
    let s = params.particle_spacing;
    let nx = (case.width / s).round() as usize;
    let ny = nx * case.n2;
    let tank_max = Vector::new(
        case.tank_length * case.width,
        2.0 * ny as Real * s,
        layers as Real * s,
    );
    let margin = 4.0 * params.smoothing_length;
    params.domain = rapier_sph::Domain::Periodic {
        min: Vector::new(-margin, -margin, 0.0),
        max: Vector::new(tank_max.x + margin, tank_max.y + margin, tank_max.z),
    };
    let mut world = rapier_sph::FluidWorld::new();
    let body = world.physics.insert_body(RigidBodyBuilder::fixed());
    let t = 0.5 * (4.0 * s).max(0.05);
    let (cx, cy, hz) = (0.5 * tank_max.x, 0.5 * tank_max.y, 1.0);
    for (c, he) in [
        (Vector::new(cx, -t, 0.0), Vector::new(cx + 2.0 * t, t, hz)),
        (
            Vector::new(cx, tank_max.y + t, 0.0),
            Vector::new(cx + 2.0 * t, t, hz),
        ),
        (Vector::new(-t, cy, 0.0), Vector::new(t, cy + 2.0 * t, hz)),
        (
            Vector::new(tank_max.x + t, cy, 0.0),
            Vector::new(t, cy + 2.0 * t, hz),
        ),
    ] {
        world.physics.insert_collider(
            ColliderBuilder::cuboid(he.x, he.y, he.z).translation(c),
            Some(body),
        );
    }
    world.physics.step();
    let mut fluid = rapier_sph::Fluid::new(params).unwrap();
    fluid
        .add_particles(&rapier_sph::fluid::lattice(
            Vector::splat(0.5 * s),
            nx,
            ny,
            layers,
            s,
        ))
        .unwrap();
    let fluid = world.fluids.insert(fluid);
    DamBreak2d {
        world,
        fluid,
        tank_max,
        width: case.width,
    }
}

/// A gate two spacings thick against the column's face (x = a), a little taller than the
/// column, rising at `speed` (m/s) from t = 0: a kinematic rapier body, so the world must be
/// stepped with rapier (`FluidWorld::step`).
fn add_gate(db: &mut DamBreak2d, params: &FluidParams, speed: Real) {
    use rapier_sph::math::Vector;
    use rapier_sph::rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};
    let s = params.particle_spacing;
    let half = Vector::new(s, 0.3 * db.tank_max.y, db.tank_max.z);
    let body = db.world.physics.insert_body(
        RigidBodyBuilder::kinematic_velocity_based()
            .translation(Vector::new(db.width + half.x, half.y, 0.5 * db.tank_max.z))
            .linvel(Vector::new(0.0, speed, 0.0)),
    );
    db.world
        .physics
        .insert_collider(ColliderBuilder::cuboid(half.x, half.y, half.z), Some(body));
}
