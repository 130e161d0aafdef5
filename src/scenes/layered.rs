//! Two interacting liquids in one closed box: the heavy one under the light one, or both
//! mixed in a checkerboard (see `crate::fluid::interaction`).

use crate::error::SphResult;
use crate::fluid::{Fluid, FluidHandle, try_lattice};
use crate::math::{Real, Vector};
use crate::params::FluidParams;
use crate::world::FluidWorld;
use rapier3d::prelude::InteractionGroups;

/// How the two liquids start in a [`LayeredTank`].
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Start {
    /// The heavy liquid under the light one (at rest).
    Layered,
    /// The light liquid under the heavy one (it overturns).
    Inverted,
    /// Side by side, the heavy liquid in the half `x < width/2` (a lock exchange: it runs
    /// under the light one).
    SideBySide,
    /// Mixed in a checkerboard of cubes of `k × k × k` particles over the whole column.
    Checker(usize),
}

/// A closed box `nx·s` wide, `nz·s` deep and twice as tall as the liquids, holding a heavy
/// and a light liquid of `nx × layers × nz` particles each, at one spacing `s` and
/// interacting ([`FluidParams::fluid_groups`] all). Gravity −9.81 m/s² along y.
pub struct LayeredTank {
    /// The world.
    pub world: FluidWorld,
    /// The heavy liquid (inserted first: the reference of the group).
    pub heavy: FluidHandle,
    /// The light liquid.
    pub light: FluidHandle,
    /// Height of the interface at rest: the heavy liquid's volume over the floor's area (m).
    pub interface_height: Real,
    /// Height of the free surface at rest (m).
    pub surface_height: Real,
}

impl LayeredTank {
    /// Builds the tank from the heavy and the light liquids' parameters (their spacing must
    /// match), placed as `start` says.
    ///
    /// # Errors
    /// The parameters' or the particles' errors; the step reports mismatched liquids.
    pub fn new(
        heavy: FluidParams,
        light: FluidParams,
        [nx, layers, nz]: [usize; 3],
        start: Start,
    ) -> SphResult<Self> {
        let s = heavy.particle_spacing;
        let height = 2.0 * layers as Real * s;
        let size = Vector::new(nx as Real * s, height, nz as Real * s);
        let mut world = super::hydrostatic_world(size, s);
        let lattice = try_lattice(Vector::splat(0.5 * s), nx, 2 * layers, nz, s)?;
        // `try_lattice` runs z outermost, then y, then x.
        let is_heavy = |k: usize| {
            let (i, j, l) = (k % nx, (k / nx) % (2 * layers), k / (nx * 2 * layers));
            match start {
                Start::Layered => j < layers,
                Start::Inverted => j >= layers,
                Start::SideBySide => 2 * i < nx,
                Start::Checker(b) => {
                    let b = b.max(1);
                    (i / b + j / b + l / b) % 2 == 0
                }
            }
        };
        let all = InteractionGroups::all();
        let mut fluids = [heavy, light].map(|p| FluidParams {
            fluid_groups: all,
            ..p
        });
        let mut placed = [Vec::new(), Vec::new()];
        for (k, x) in lattice.into_iter().enumerate() {
            placed[usize::from(!is_heavy(k))].push(x);
        }
        let mut handles = [None, None];
        for (k, p) in fluids.iter_mut().enumerate() {
            let mut f = Fluid::new(p.clone())?;
            f.add_particles(&placed[k])?;
            handles[k] = Some(world.fluids.insert(f));
        }
        let [Some(heavy), Some(light)] = handles else {
            unreachable!("both inserted")
        };
        Ok(Self {
            world,
            heavy,
            light,
            interface_height: layers as Real * s,
            surface_height: height,
        })
    }

    /// The interface's height measured from the heavy liquid: twice the mean height of its
    /// particles (a settled layer of uniform density from the floor up to `h` has its mean at
    /// `h/2`).
    pub fn measured_interface(&self) -> Real {
        let f = &self.world.fluids[self.heavy];
        let mean = f.positions().iter().map(|x| x.y as f64).sum::<f64>() / f.len().max(1) as f64;
        (2.0 * mean) as Real
    }

    /// Relative error of the pressure of the heavy particles in the bottom layer (centers
    /// within one spacing of the floor) against the two layers' weight above them,
    /// `ρ_light·g·h_light + ρ_heavy·g·(h_interface − y)`.
    pub fn bottom_pressure_error(&self) -> Real {
        let f = &self.world.fluids[self.heavy];
        let light = self.world.fluids[self.light].params().rest_density;
        let p = f.params();
        let g = self.world.physics.gravity.length();
        let (mut measured, mut expected) = (0.0f64, 0.0f64);
        let above = light * g * (self.surface_height - self.interface_height);
        for (x, pr) in f.positions().iter().zip(f.pressures()) {
            if x.y < p.particle_spacing {
                measured += *pr as f64;
                expected += (above + p.rest_density * g * (self.interface_height - x.y)) as f64;
            }
        }
        if expected == 0.0 {
            return Real::INFINITY;
        }
        ((measured - expected) / expected) as Real
    }
}
