use rapier_sph::scenes::HydrostaticTank;
use rapier_sph::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let solver = args.get(1).map(|s| s.as_str()).unwrap_or("dfsph");
    let dt: f32 = args
        .get(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0 / 60.0);
    let secs: f32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(3.0);
    let n: usize = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(10);
    let s = 0.02;
    let walls = std::env::var("WALLS").map(|v| v == "1").unwrap_or(true);
    let mut b = FluidParamsBuilder::water(s).wall_density(walls);
    if let Ok(r) = std::env::var("RADIUS") {
        b = b.particle_radius(r.parse::<f32>().unwrap() * s);
    }
    if solver == "dfsph" {
        b = b.solver(Solver::dfsph());
    }
    let params = b.build().unwrap();
    let mut tank = HydrostaticTank::new(params, [n, 2 * n, n]).unwrap();
    tank.world.pipeline.time_stepping = TimeStepping::Adaptive {
        courant: 0.4,
        max_substeps: 256,
    };
    let frames = (secs / dt).round() as usize;
    let t0 = std::time::Instant::now();
    let (mut it, mut sub) = (0u64, 0u64);
    for f in 0..frames {
        tank.world.physics.integration_parameters.dt = dt;
        let r = tank.world.step().unwrap().clone();
        it += r.solver_iterations as u64;
        sub += r.substeps as u64;
        if f < 12 || (f + 1) % ((0.5 / dt).round() as usize) == 0 {
            let fl = &tank.world.fluids[tank.fluid];
            let (mut k, mut best) = (0, 0.0f32);
            for (i, v) in fl.velocities().iter().enumerate() {
                if v.length() > best {
                    best = v.length();
                    k = i;
                }
            }
            let x = fl.positions()[k];
            let fast = fl
                .velocities()
                .iter()
                .filter(|v| v.length() > 0.3 * best)
                .count();
            println!(
                "   fastest at {:?} v {:?} rho {:.1}; {} particles above 30% of it",
                x,
                fl.velocities()[k],
                fl.densities()[k],
                fast
            );
            println!(
                "t {:5.2} KE {:.3e} vmax {:.3} bottom {:+.2}% rms {:.2}% mean_err {:.3}% max_err {:.2}% it/sub {:.2} sub/frame {:.1}",
                (f + 1) as f32 * dt,
                fl.kinetic_energy(),
                r.max_speed,
                100.0 * tank.bottom_pressure_error(),
                100.0 * tank.pressure_profile_rms(),
                100.0 * r.mean_density_error,
                100.0 * r.max_density_error,
                it as f64 / sub as f64,
                sub as f64 / (f + 1) as f64
            );
        }
    }
    let fl = &tank.world.fluids[tank.fluid];
    let layers = 2 * n;
    let mut sums = vec![(0.0f64, 0usize); layers];
    for (x, pr) in fl.positions().iter().zip(fl.pressures()) {
        let k = (x.y / s).floor() as usize;
        if k < layers {
            sums[k].0 += *pr as f64;
            sums[k].1 += 1;
        }
    }
    for (k, (sp, c)) in sums.iter().enumerate() {
        let y = (k as f32 + 0.5) * s;
        let exp = 1000.0 * 9.81 * (tank.fluid_height - y);
        if *c > 0 {
            print!("{}:{:.2} ", k, sp / *c as f64 / exp as f64);
        }
    }
    println!();
    println!("wall {:.2} s", t0.elapsed().as_secs_f64());
}
