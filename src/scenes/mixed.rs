//! A closed tank of one fluid whose particles carry a mixture's fractions
//! (`crate::mixture`): an emulsion that separates into layers.

use crate::error::{SphError, SphResult};
use crate::fluid::{Fluid, FluidHandle, try_lattice};
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use crate::world::FluidWorld;

/// How the phases start in a [`MixedTank`].
#[derive(Clone, Debug, PartialEq)]
pub enum Start {
    /// Every particle at these fractions (one per phase).
    Uniform(Vec<Real>),
    /// Pure particles of phases 0 and 1 in a checkerboard of single particles.
    Checker,
}

/// A closed box `nx·s` wide, `nz·s` deep and twice as tall as the fluid, holding one fluid
/// with a mixture ([`FluidParams::mixture`]) of `nx × ny × nz` particles at spacing `s`.
/// Gravity −9.81 m/s² along y.
pub struct MixedTank {
    /// The world.
    pub world: FluidWorld,
    /// The fluid.
    pub fluid: FluidHandle,
    /// Height of the free surface at rest (m).
    pub surface_height: Real,
    /// The floor's area (m²).
    pub floor_area: Real,
}

impl MixedTank {
    /// Builds the tank.
    ///
    /// # Errors
    /// The parameters' and the particles' errors; [`SphError::InvalidParameter`] naming
    /// `mixture` when the parameters have none, and [`Fluid::set_fractions`]' errors.
    pub fn new(params: FluidParams, [nx, ny, nz]: [usize; 3], start: Start) -> SphResult<Self> {
        if params.mixture.is_none() {
            return Err(SphError::InvalidParameter {
                field: "mixture",
                value: 0.0,
                reason: "a mixed tank needs a mixture",
            });
        }
        let s = params.particle_spacing;
        let size = Vector::new(nx as Real, ny as Real, nz as Real) * s;
        let mut world = super::hydrostatic_world(size, s);
        let mut fluid = Fluid::new(params)?;
        fluid.add_particles(&try_lattice(Vector::splat(0.5 * s), nx, ny, nz, s)?)?;
        match start {
            Start::Uniform(f) => fluid.set_fractions(&f)?,
            Start::Checker => {
                // `try_lattice` runs z outermost, then y, then x.
                let odd = |k: usize| (k % nx + (k / nx) % ny + k / (nx * ny)) % 2 == 1;
                let ones: Vec<Real> = (0..fluid.len()).map(|k| Real::from(odd(k))).collect();
                for (a, &o) in fluid.fractions_mut(1).into_iter().flatten().zip(&ones) {
                    *a = o;
                }
                for (a, &o) in fluid.fractions_mut(0).into_iter().flatten().zip(&ones) {
                    *a = 1.0 - o;
                }
            }
        }
        let fluid = world.fluids.insert(fluid);
        Ok(Self {
            world,
            fluid,
            surface_height: size.y,
            floor_area: size.x * size.z,
        })
    }

    /// The fluid.
    pub fn fluid(&self) -> &Fluid {
        &self.world.fluids[self.fluid]
    }

    /// Phase `k`'s volume, `V·Σ_i α_k,i` (m³), summed in f64.
    pub fn phase_volume(&self, k: usize) -> f64 {
        let f = self.fluid();
        let v = (f.params().particle_mass / f.params().rest_density) as f64;
        f.fractions(k)
            .map_or(0.0, |a| a.iter().map(|&x| x as f64).sum::<f64>() * v)
    }

    /// The height of the interface at rest from the volumes: phase `heavy`'s volume over
    /// the floor's area (m) (the heavy phase settled under the others).
    pub fn volume_interface(&self, heavy: usize) -> Real {
        (self.phase_volume(heavy) / self.floor_area as f64) as Real
    }

    /// Phase `k`'s mean fraction in horizontal slabs one spacing thick, from the floor up to
    /// the surface at rest.
    pub fn profile(&self, k: usize) -> Vec<Real> {
        let f = self.fluid();
        let s = f.params().particle_spacing;
        let bins = (self.surface_height / s).round() as usize;
        let (mut sum, mut count) = (vec![0.0f64; bins], vec![0usize; bins]);
        if let Some(a) = f.fractions(k) {
            for (x, &a) in f.positions().iter().zip(a) {
                let b = ((x.y / s).floor().max(0.0) as usize).min(bins - 1);
                sum[b] += a as f64;
                count[b] += 1;
            }
        }
        sum.iter()
            .zip(&count)
            .map(|(s, &c)| if c > 0 { (s / c as f64) as Real } else { 0.0 })
            .collect()
    }

    /// The height (m) where phase `k`'s slab profile ([`Self::profile`]) first rises through
    /// `level` from the floor up (linear between slab centres); `None` if it never does.
    pub fn crossing(&self, k: usize, level: Real) -> Option<Real> {
        let s = self.fluid().params().particle_spacing;
        let p = self.profile(k);
        if p.first().is_some_and(|&a| a >= level) {
            return Some(0.5 * s);
        }
        p.windows(2).enumerate().find_map(|(b, w)| {
            (w[0] < level && w[1] >= level).then(|| {
                let t = (level - w[0]) / (w[1] - w[0]);
                (b as Real + 0.5 + t) * s
            })
        })
    }

    /// The interface's thickness (m): between the heights where phase `k`'s profile rises
    /// through 0.1 and through 0.9; `None` if it does not rise through both.
    pub fn interface_thickness(&self, k: usize) -> Option<Real> {
        Some(self.crossing(k, 0.9)? - self.crossing(k, 0.1)?)
    }

    /// Relative error of the mean pressure of the particles in the bottom layer (centres
    /// within one spacing of the floor) against the settled layers' weight,
    /// `Σ_k ρ_k·g·h_k` from the surface down to each particle (the phases in layers by
    /// density, each `h_k` its volume over the floor's area).
    pub fn bottom_pressure_error(&self) -> Real {
        let f = self.fluid();
        let Some(m) = f.params().mixture.as_ref() else {
            return Real::INFINITY;
        };
        let g = self.world.physics.gravity.length() as f64;
        let area = self.floor_area as f64;
        let mut layers: Vec<(f64, f64)> = (0..m.len())
            .map(|k| {
                let rho = m.phases[k].rest_density as f64;
                (rho, self.phase_volume(k) / area)
            })
            .collect();
        layers.sort_by(|a, b| b.0.total_cmp(&a.0));
        let weight = |y: f64| -> f64 {
            let mut bottom = 0.0;
            let mut p = 0.0;
            for &(rho, h) in &layers {
                let top = bottom + h;
                p += rho * g * (top - y.max(bottom)).max(0.0);
                bottom = top;
            }
            p
        };
        let s = f.params().particle_spacing;
        let (mut measured, mut expected) = (0.0f64, 0.0f64);
        for (x, pr) in f.positions().iter().zip(f.pressures()) {
            if x.y < s {
                measured += *pr as f64;
                expected += weight(x.y as f64);
            }
        }
        if expected == 0.0 {
            return Real::INFINITY;
        }
        ((measured - expected) / expected) as Real
    }
}
