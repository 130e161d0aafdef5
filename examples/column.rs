//! A column of water at rest in a closed tank: how quiet it stays and how hydrostatic its
//! pressure is, layer by layer.
//!
//! ```text
//! cargo run --release --example column                         # default solver, 10×20×10 at 2 cm, 3 s
//! cargo run --release --example column -- --solver wcsph --spacing 0.01 --seconds 5
//! cargo run --release --example column -- --solver dfsph --hydrostatic-walls --warm-start 0.5
//! cargo run --release --example column -- --solver dfsph --validation 6,8,12   # the report's scene
//! ```
//!
//! The tank is [`rapier_sph::scenes::HydrostaticTank`] (`n × 2n × n` particles on a lattice
//! at rest density, released without pressure), stepped in frames of 1/60 s (adaptive
//! substeps). Every 0.25 s it prints the kinetic energy and the largest speed; over the last
//! quarter of the run it averages, per layer one spacing thick, the pressure over
//! `ρ0·g·depth` (depth from the free surface of the fluid's rest volume), separately for the
//! particles next to a side wall (centre within one spacing of it) and for the interior ones
//! (at least 3 spacings from every side wall), and the layer's mean density; and the kinetic
//! energy split between the bulk and the top two layers, next to a side wall or not.
//!
//! `--validation 6,8,12` instead runs the report's hydrostatic scene
//! (`rapier_sph::validation::hydrostatic`, adaptive steps) with the chosen settings at those
//! resolutions and prints its errors, as the `hydrostatic_bottom_pressure_within_2_percent`
//! test reads them.

use rapier_sph::math::Real;
use rapier_sph::scenes::HydrostaticTank;
use rapier_sph::{FluidParamsBuilder, Solver};

fn main() {
    let (mut n, mut s, mut seconds): (usize, Real, Real) = (10, 0.02, 3.0);
    let mut solver = "default".to_string();
    let mut hydrostatic_walls: Option<bool> = None;
    let mut warm: Option<Real> = None;
    let mut min_iterations: Option<u32> = None;
    let mut max_density_error: Option<Real> = None;
    let mut threads = 0usize;
    let mut validation: Vec<usize> = Vec::new();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let value = args.get(i + 1).cloned().unwrap_or_default();
        let mut step = 2;
        match args[i].as_str() {
            "--n" => n = parse(&value, "--n"),
            "--spacing" => s = parse(&value, "--spacing"),
            "--seconds" => seconds = parse(&value, "--seconds"),
            "--solver" => solver = value,
            "--warm-start" => warm = Some(parse(&value, "--warm-start")),
            "--threads" => threads = parse(&value, "--threads"),
            "--validation" => {
                validation = value.split(',').map(|v| parse(v, "--validation")).collect()
            }
            "--min-iterations" => min_iterations = Some(parse(&value, "--min-iterations")),
            "--max-density-error" => max_density_error = Some(parse(&value, "--max-density-error")),
            "--hydrostatic-walls" => {
                hydrostatic_walls = Some(true);
                step = 1;
            }
            "--no-hydrostatic-walls" => {
                hydrostatic_walls = Some(false);
                step = 1;
            }
            other => exit(&format!(
                "unknown argument {other} (--n, --spacing, --seconds, --solver default|wcsph|dfsph|pbf, \
                 --warm-start, --[no-]hydrostatic-walls, --threads)"
            )),
        }
        i += step;
    }
    if n < 4 || !(s.is_finite() && s > 0.0) || !(seconds.is_finite() && seconds > 0.0) {
        exit("--n must be at least 4, --spacing and --seconds positive");
    }
    if threads > 0 {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .unwrap_or_else(|e| exit(&e.to_string()));
    }
    let mut b = FluidParamsBuilder::water(s);
    match solver.as_str() {
        "default" => {}
        "wcsph" => b = b.solver(Solver::Wcsph).wall_density(false),
        "dfsph" => b = b.solver(Solver::dfsph()).wall_density(true),
        "pbf" => b = b.solver(Solver::pbf()).wall_density(true),
        other => exit(&format!("unknown solver {other}")),
    }
    let mut params = b.build().unwrap_or_else(|e| exit(&e.to_string()));
    if let Solver::Dfsph(d) = &mut params.solver {
        if let Some(on) = hydrostatic_walls {
            d.hydrostatic_walls = on;
        }
        if let Some(w) = warm {
            d.warm_start = w;
        }
        if let Some(m) = min_iterations {
            d.min_iterations = m;
        }
        if let Some(e) = max_density_error {
            d.max_density_error = e;
        }
    } else if hydrostatic_walls.is_some() || warm.is_some() || min_iterations.is_some() {
        exit("--warm-start and --[no-]hydrostatic-walls are DFSPH settings");
    }
    if !validation.is_empty() {
        // The validation scene (`rapier_sph::validation::hydrostatic`), adaptive steps.
        use rapier_sph::validation::{Method, Scene, TimePolicy};
        let method = Method {
            name: "probe",
            solver: params.solver,
            wall_density: params.wall_density,
        };
        for res in validation {
            let r = Scene::Hydrostatic
                .run(&method, res, TimePolicy::Adaptive, &mut |_| {})
                .unwrap_or_else(|e| exit(&e.to_string()));
            println!(
                "hydrostatic scene N = {res} adaptive: bottom {:+.4}, RMS {:.4}, mean compression {:.5}, stable {}, escaped {}, {:.1} s",
                r.error("bottom_pressure").unwrap_or(f64::NAN),
                r.error("pressure_rms").unwrap_or(f64::NAN),
                r.error("mean_density_error").unwrap_or(f64::NAN),
                r.stable,
                r.escaped,
                r.wall_seconds
            );
        }
        return;
    }
    println!(
        "solver {:?}, wall density {}, {n}x{}x{n} at {s} m, {seconds} s in 1/60 s frames",
        params.solver,
        params.wall_density,
        2 * n
    );
    let rho0 = params.rest_density;
    let mut tank =
        HydrostaticTank::new(params, [n, 2 * n, n]).unwrap_or_else(|e| exit(&e.to_string()));
    let frame = 1.0 / 60.0;
    tank.world.physics.integration_parameters.dt = frame;
    let g = tank.world.physics.gravity.length();
    let height = tank.fluid_height;
    let width = n as Real * s;
    let frames = (seconds / frame).round() as usize;
    let settle = frames - frames / 4;
    let layers = 2 * n;
    // (pressure sum, expected sum, count) per layer: wall column, interior; density sum, count.
    let mut wall = vec![(0.0f64, 0.0f64); layers];
    let mut inner = vec![(0.0f64, 0.0f64); layers];
    let mut dens = vec![(0.0f64, 0usize); layers];
    let (mut ke_late, mut vmax_late, mut samples) = (0.0f64, Real::default(), 0usize);
    let (mut substeps, mut iterations, mut div_iterations) = (0u64, 0u64, 0u64);
    let mut bottom = 0.0f64;
    // Kinetic energy over the last quarter: below the top two layers / in them, away from /
    // next to a side wall.
    let mut regions = [0.0f64; 4];
    let t0 = std::time::Instant::now();
    let mut ke_window = 0.0f64;
    let mut v_window: Real = 0.0;
    for f in 1..=frames {
        let r = tank.world.step().unwrap_or_else(|e| exit(&e.to_string()));
        substeps += r.substeps as u64;
        iterations += r.solver_iterations as u64;
        div_iterations += r.divergence_iterations as u64;
        let fl = &tank.world.fluids[tank.fluid];
        let m = fl.params().particle_mass as f64;
        let ke: f64 = fl
            .velocities()
            .iter()
            .map(|v| 0.5 * m * v.length_squared() as f64)
            .sum();
        let vmax = fl
            .velocities()
            .iter()
            .map(|v| v.length())
            .fold(0.0, Real::max);
        ke_window = ke_window.max(ke);
        v_window = v_window.max(vmax);
        if f % 15 == 0 {
            println!(
                "t = {:5.2} s: max kinetic energy {ke_window:.3e} J, max speed {v_window:.4} m/s",
                f as Real * frame
            );
            ke_window = 0.0;
            v_window = 0.0;
        }
        if f > settle {
            samples += 1;
            ke_late += ke;
            vmax_late = vmax_late.max(vmax);
            bottom +=
                HydrostaticTank::bottom_pressure_error_of(&tank.world, tank.fluid, height) as f64;
            for (((x, &p), &rho), v) in fl
                .positions()
                .iter()
                .zip(fl.pressures())
                .zip(fl.densities())
                .zip(fl.velocities())
            {
                let side = x.x.min(width - x.x).min(x.z).min(width - x.z);
                let e = 0.5 * m * v.length_squared() as f64;
                let top = x.y > height - 2.0 * s;
                regions[(top as usize) * 2 + (side < s) as usize] += e;
                let k = (x.y / s).floor();
                if !(k >= 0.0 && (k as usize) < layers) {
                    continue;
                }
                let k = k as usize;
                let expected = (rho0 * g * (height - x.y)) as f64;
                if side < s {
                    wall[k].0 += p as f64;
                    wall[k].1 += expected;
                } else if side >= 3.0 * s {
                    inner[k].0 += p as f64;
                    inner[k].1 += expected;
                }
                dens[k].0 += rho as f64;
                dens[k].1 += 1;
            }
        }
    }
    let r = |k: usize| regions[k] / samples as f64;
    println!(
        "last quarter: mean kinetic energy below the top 2 layers {:.2e} J (interior) + {:.2e} J \
         (next to a side wall); top 2 layers {:.2e} + {:.2e} J",
        r(0),
        r(1),
        r(2),
        r(3)
    );
    let ratio = |e: (f64, f64)| if e.1 > 0.0 { e.0 / e.1 } else { f64::NAN };
    println!(
        "last quarter: layer (from the floor), p / rho0 g depth (wall column, interior), mean density"
    );
    for k in 0..layers {
        println!(
            "  {k:2}: {:6.3} {:6.3}  {:8.2}",
            ratio(wall[k]),
            ratio(inner[k]),
            dens[k].0 / dens[k].1.max(1) as f64
        );
    }
    println!(
        "bottom error (scene measure) {:+.4}, mean kinetic energy {:.3e} J, max speed {:.4} m/s; \
         {:.2} substeps/frame, {:.2} density + {:.2} divergence iterations per substep; {:.1} s",
        bottom / samples as f64,
        ke_late / samples as f64,
        vmax_late,
        substeps as f64 / frames as f64,
        iterations as f64 / substeps as f64,
        div_iterations as f64 / substeps as f64,
        t0.elapsed().as_secs_f64()
    );
}

fn parse<T: std::str::FromStr>(v: &str, flag: &str) -> T {
    v.parse()
        .unwrap_or_else(|_| exit(&format!("{flag}: not a number: {v:?}")))
}

fn exit(msg: &str) -> ! {
    eprintln!("{msg}");
    std::process::exit(2)
}
