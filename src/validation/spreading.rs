//! A viscous column spreading on a floor: the constant-volume axisymmetric viscous gravity
//! current of Huppert (1982), "The propagation of two-dimensional and axisymmetric viscous
//! gravity currents over a rigid horizontal surface", J. Fluid Mech. 121, 43–58.
//!
//! In the lubrication limit (the current thin, inertia negligible, no slip on the floor) a
//! volume `V` of liquid of kinematic viscosity `ν` spreads with the self-similar front
//! (Huppert's eq. 2.18 with his `η_N = 0.894`)
//!
//! `r_N(t) = 0.894 (g V³ t / (3 ν))^(1/8)`,
//!
//! and the height profile `h(r) ∝ (1 − (r/r_N)²)^(1/3)` (his eq. 2.16 with the constant
//! he gives). Late in the spreading the column's own collapse is forgotten up to a time
//! shift `t0` (the virtual origin): `r_N⁸ = a (t − t0)` with `a = 0.894⁸ g V³/(3ν)`.
//!
//! **The front, measured.** The outermost particle is one particle's noise. The profile fixes
//! which share of the volume lies beyond any radius: `∫ h 2πr dr` from `ξ r_N` to `r_N` is
//! `(1 − ξ²)^(4/3)` of the whole. So the radius `r_q` that leaves the outer share `q` of the
//! particles outside gives `r_N = r_q/√(1 − q^(3/4))`; with `q` = 5 %, `r_N = 1.058 r_q`.
//!
//! The floor is a rapier cuboid whose walls count in the density and hold the liquid by
//! their viscosity ([`crate::FluidParams::wall_viscosity`] equal to the liquid's): no slip.

use crate::fluid::Fluid;
use crate::math::{Real, Vector};
use crate::params::{FluidParamsBuilder, ImplicitViscosity, ViscositySolve};
use crate::solver::Solver;
use crate::world::FluidWorld;
use crate::{FluidHandle, SphResult};
use rapier3d::prelude::{ColliderBuilder, RigidBodyBuilder};

/// Huppert's constant `η_N` of the axisymmetric current.
pub const HUPPERT_ETA: f64 = 0.894;

/// The share of particles left outside the measured radius (see the module docs).
pub const OUTER_SHARE: f64 = 0.05;

/// One spreading column.
#[derive(Copy, Clone, Debug)]
pub struct SpreadingConfig {
    /// Particle spacing (m).
    pub spacing: Real,
    /// Column radius and height (m).
    pub radius: Real,
    /// Column height (m).
    pub height: Real,
    /// Rest density (kg/m³).
    pub rest_density: Real,
    /// Dynamic viscosity (Pa·s).
    pub viscosity: Real,
    /// The pressure solver.
    pub solver: Solver,
    /// The implicit solve's settings, or `None` for the explicit viscosity.
    pub implicit: Option<ImplicitViscosity>,
}

impl Default for SpreadingConfig {
    /// A 1,900-particle column 0.08 m wide and 0.12 m tall at 1 cm spacing, 1400 kg/m³,
    /// 1400 Pa·s (`ν` = 1 m²/s), DFSPH, the implicit solve at its defaults.
    fn default() -> Self {
        Self {
            spacing: 0.01,
            radius: 0.08,
            height: 0.12,
            rest_density: 1400.0,
            viscosity: 1400.0,
            solver: Solver::dfsph(),
            implicit: Some(ImplicitViscosity::default()),
        }
    }
}

/// The scene, ready to step in the world's frames (1/60 s).
pub struct Spreading {
    /// The world: a floor (top at `y = 0`) and the column on it, centred on the y axis.
    pub world: FluidWorld,
    /// The liquid.
    pub fluid: FluidHandle,
    /// The liquid's volume (m³): particles times the spacing cubed.
    pub volume: f64,
    /// Kinematic viscosity `ν = μ/ρ0` (m²/s).
    pub nu: f64,
}

/// Builds the column on its floor.
///
/// # Errors
///
/// The parameters' errors ([`crate::SphError::InvalidParameter`]).
pub fn spreading(c: &SpreadingConfig) -> SphResult<Spreading> {
    let s = c.spacing;
    let mut b = FluidParamsBuilder::water(s)
        .rest_density(c.rest_density)
        .viscosity(c.viscosity)
        .wall_viscosity(c.viscosity)
        .solver(c.solver);
    if let Some(settings) = c.implicit {
        b = b.viscosity_solve(ViscositySolve::Implicit(settings));
    }
    let mut fluid = Fluid::new(b.build()?)?;
    let n = (2.0 * c.radius / s).ceil() as usize + 1;
    let ny = (c.height / s).round() as usize;
    let origin = Vector::new(
        -(n as Real - 1.0) * 0.5 * s,
        0.5 * s,
        -(n as Real - 1.0) * 0.5 * s,
    );
    let points: Vec<Vector> = crate::fluid::lattice(origin, n, ny, n, s)
        .into_iter()
        .filter(|p| p.x * p.x + p.z * p.z <= c.radius * c.radius)
        .collect();
    fluid.add_particles(&points)?;
    let mut world = FluidWorld::new();
    let body = world.physics.insert_body(RigidBodyBuilder::fixed());
    let half = 20.0 * c.radius;
    let floor = ColliderBuilder::cuboid(half, 0.1, half).translation(Vector::new(0.0, -0.1, 0.0));
    world.physics.insert_collider(floor, Some(body));
    let fluid = world.fluids.insert(fluid);
    Ok(Spreading {
        world,
        fluid,
        volume: points.len() as f64 * (s as f64).powi(3),
        nu: (c.viscosity / c.rest_density) as f64,
    })
}

/// The front `r_N` read from the particles (see the module docs): the radius about the y axis
/// that leaves [`OUTER_SHARE`] of them outside, over `√(1 − q^(3/4))`.
pub fn front(positions: &[Vector]) -> f64 {
    let mut r: Vec<f64> = positions
        .iter()
        .map(|p| ((p.x * p.x + p.z * p.z) as f64).sqrt())
        .collect();
    if r.is_empty() {
        return 0.0;
    }
    r.sort_by(f64::total_cmp);
    let k = ((1.0 - OUTER_SHARE) * (r.len() - 1) as f64).round() as usize;
    r[k] / (1.0 - OUTER_SHARE.powf(0.75)).sqrt()
}

/// Huppert's `a` in `r_N⁸ = a (t − t0)`: `0.894⁸ g V³/(3ν)`.
pub fn huppert_rate(g: f64, volume: f64, nu: f64) -> f64 {
    HUPPERT_ETA.powi(8) * g * volume.powi(3) / (3.0 * nu)
}

/// The least-squares line `y = a t + b` through `(t, y)`; returns `(a, b)`.
pub fn fit_line(t: &[f64], y: &[f64]) -> (f64, f64) {
    let n = t.len() as f64;
    let (mt, my) = (t.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let stt: f64 = t.iter().map(|t| (t - mt) * (t - mt)).sum();
    let sty: f64 = t.iter().zip(y).map(|(t, y)| (t - mt) * (y - my)).sum();
    let a = sty / stt;
    (a, my - a * mt)
}
