//! Surface tension and adhesion (Akinci et al. 2013; `src/forces/surface_tension.rs`).

mod common;

use rapier_sph::math::{Real, Vector};
use rapier_sph::solver::Solver;
use rapier_sph::{Fluid, FluidParamsBuilder, FluidPipeline, FluidSet};
use rapier_sph::rapier3d::prelude::{BroadPhaseBvh, ColliderSet, RigidBodySet};

/// A fluid set stepped in zero gravity without colliders.
struct Free {
    set: FluidSet,
    pipeline: FluidPipeline,
    bodies: RigidBodySet,
    colliders: ColliderSet,
    bvh: BroadPhaseBvh,
    handle: rapier_sph::FluidHandle,
}

impl Free {
    fn new(fluid: Fluid) -> Self {
        let mut set = FluidSet::new();
        let handle = set.insert(fluid);
        Self {
            set,
            pipeline: FluidPipeline::new(),
            bodies: RigidBodySet::new(),
            colliders: ColliderSet::new(),
            bvh: BroadPhaseBvh::new(),
            handle,
        }
    }
    fn step(&mut self, dt: Real) {
        self.pipeline
            .step(Vector::ZERO, dt, &mut self.set, &mut self.bodies, &self.colliders, &self.bvh)
            .expect("step");
    }
    fn fluid(&self) -> &Fluid {
        &self.set[self.handle]
    }
}

fn centre(x: &[Vector]) -> Vector {
    x.iter().fold(Vector::ZERO, |a, b| a + *b) / x.len() as Real
}

/// `(r_max/R_eq, std(r of the outer shell)/R_eq)`.
fn shape(x: &[Vector], spacing: Real) -> (Real, Real, Real) {
    let c = centre(x);
    let r: Vec<Real> = x.iter().map(|p| (*p - c).length()).collect();
    let req = (3.0 * x.len() as Real / (4.0 * std::f32::consts::PI)).cbrt() * spacing;
    let rmax = r.iter().cloned().fold(0.0, Real::max);
    let shell: Vec<Real> = r.iter().cloned().filter(|d| *d > rmax - 1.5 * spacing).collect();
    let m = shell.iter().sum::<Real>() / shell.len() as Real;
    let var = shell.iter().map(|d| (d - m) * (d - m)).sum::<Real>() / shell.len() as Real;
    (rmax / req, var.sqrt() / req, req)
}

#[test]
fn explore_cube() {
    let s = 0.01;
    for (solver, gamma) in [(Solver::dfsph(), 1.0), (Solver::dfsph(), 4.0)] {
        let p = FluidParamsBuilder::water(s).solver(solver.clone()).surface_tension(gamma).viscosity(0.05).build().unwrap();
        let mut f = Fluid::new(p).unwrap();
        f.add_block(Vector::ZERO, Vector::splat(10.0 * s)).unwrap();
        let mut w = Free::new(f);
        println!("{:?} gamma {gamma} start {:?}", solver, shape(w.fluid().positions(), s));
        for k in 0..400 {
            w.step(1e-3);
            if k % 20 == 19 {
                let x = w.fluid().positions();
                let c = centre(x);
                let q: Real = x.iter().map(|p| { let d = *p - c; d.z * d.z - 0.5 * (d.x * d.x + d.y * d.y) }).sum::<Real>() / x.len() as Real;
                let pr: Vec<Real> = x.iter().zip(w.fluid().pressures()).filter(|(p, _)| (**p - c).length() < 3.0 * s).map(|(_, p)| *p).collect();
                let pm = pr.iter().sum::<Real>() / pr.len().max(1) as Real;
                println!("t {:.3} shape {:?} q {q:.3e} KE {:.3e} pcore {pm:.2}", (k + 1) as f32 * 1e-3, shape(x, s), w.fluid().kinetic_energy());
            }
        }
    }
}
