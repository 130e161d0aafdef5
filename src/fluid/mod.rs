//! Fluids: particles stored as structure of arrays, and the set that holds several fluids.

mod attributes;
mod fluid_set;
#[cfg(feature = "snapshot")]
pub(crate) mod snapshot;

pub(crate) use attributes::Attributes;

pub use fluid_set::{FluidHandle, FluidSet};

use crate::error::{SphError, SphResult};
use crate::math::{Real, Vector, is_finite};
use crate::params::FluidParams;

/// Mutable views of one fluid's particle arrays, borrowed together: the step's stages take
/// the ones they use. Every array has one entry per particle, in the same order.
pub(crate) struct ParticlesMut<'a> {
    pub positions: &'a mut Vec<Vector>,
    pub velocities: &'a mut Vec<Vector>,
    pub accelerations: &'a mut Vec<Vector>,
    pub densities: &'a mut Vec<Real>,
    pub pressures: &'a mut Vec<Real>,
    pub ids: &'a mut Vec<u32>,
    pub attributes: &'a mut Attributes,
}

/// One fluid: its parameters and its particles, one `Vec` per attribute.
///
/// Particles are re-sorted by grid cell at every step, so a particle's index changes from
/// step to step; [`Fluid::ids`] gives each particle a stable identifier. All attribute
/// slices share the same order.
#[derive(Clone, Debug)]
pub struct Fluid {
    params: FluidParams,
    pub(crate) positions: Vec<Vector>,
    pub(crate) velocities: Vec<Vector>,
    pub(crate) accelerations: Vec<Vector>,
    pub(crate) densities: Vec<Real>,
    pub(crate) pressures: Vec<Real>,
    pub(crate) ids: Vec<u32>,
    /// Named per-particle values kept by the stages (e.g. DFSPH's warm starts); they follow
    /// the particles through every re-sort, removal and append.
    pub(crate) attributes: Attributes,
    next_id: u32,
    quarantined: usize,
    /// Particles added by emitters / removed by sinks over the fluid's life.
    pub(crate) emitted: usize,
    pub(crate) drained: usize,
    /// Emitters and sinks (see [`crate::emitter`]).
    pub(crate) sources: crate::emitter::Sources,
    /// Particle capacity: emitters pause when it is reached.
    pub(crate) capacity: Option<usize>,
    /// Set when particles were added: the next contact stage first pushes particles that
    /// start inside a solid out through its nearest surface.
    pub(crate) needs_depenetration: bool,
    /// Set when an overlap relaxation was stopped by its round cap: the next substep goes on
    /// relaxing.
    pub(crate) relax_pending: bool,
}

impl Fluid {
    /// An empty fluid. The parameters are validated again here.
    pub fn new(params: FluidParams) -> SphResult<Self> {
        params.validate()?;
        Ok(Self {
            params,
            positions: Vec::new(),
            velocities: Vec::new(),
            accelerations: Vec::new(),
            densities: Vec::new(),
            pressures: Vec::new(),
            ids: Vec::new(),
            attributes: Attributes::default(),
            next_id: 0,
            quarantined: 0,
            emitted: 0,
            drained: 0,
            sources: Default::default(),
            capacity: None,
            needs_depenetration: false,
            relax_pending: false,
        })
    }

    /// The fluid's parameters.
    pub fn params(&self) -> &FluidParams {
        &self.params
    }

    /// Replaces the parameters (validated), e.g. to change the rest density mid-run as the
    /// paper's Figure 8 does.
    pub fn set_params(&mut self, params: FluidParams) -> SphResult<()> {
        params.validate()?;
        self.params = params;
        Ok(())
    }

    /// Adds particles at rest. Returns the range of their ids. Refuses non-finite positions
    /// with [`SphError::InvalidParticle`] (and then adds nothing).
    pub fn add_particles(&mut self, positions: &[Vector]) -> SphResult<std::ops::Range<u32>> {
        self.add_particles_with_velocities(positions, None)
    }

    /// Adds particles with initial velocities (`velocities.len()` must equal
    /// `positions.len()`). Returns the range of their ids.
    pub fn add_particles_with_velocities(
        &mut self,
        positions: &[Vector],
        velocities: Option<&[Vector]>,
    ) -> SphResult<std::ops::Range<u32>> {
        if let Some(v) = velocities
            && v.len() != positions.len()
        {
            return Err(SphError::InvalidParticle {
                index: v.len().min(positions.len()),
                reason: "positions and velocities differ in length",
            });
        }
        for (index, p) in positions.iter().enumerate() {
            if !is_finite(*p) {
                return Err(SphError::InvalidParticle {
                    index,
                    reason: "position is not finite",
                });
            }
            if p.abs().max_element() > 1.0e7 {
                return Err(SphError::InvalidParticle {
                    index,
                    reason: "position beyond 10,000 km: single precision cannot resolve particle spacing there",
                });
            }
        }
        if let Some(v) = velocities {
            for (index, v) in v.iter().enumerate() {
                if !is_finite(*v) {
                    return Err(SphError::InvalidParticle {
                        index,
                        reason: "velocity is not finite",
                    });
                }
            }
        }
        if self.next_id.checked_add(positions.len() as u32).is_none()
            || positions.len() > u32::MAX as usize
        {
            return Err(SphError::InvalidParticle {
                index: 0,
                reason: "more than 2^32 particles added over the fluid's life",
            });
        }
        if let Some(cap) = self.capacity
            && self.positions.len() + positions.len() > cap
        {
            return Err(SphError::InvalidParticle {
                index: cap.saturating_sub(self.positions.len()),
                reason: "the fluid's capacity is reached (see `Fluid::set_capacity`)",
            });
        }
        self.append_unchecked(positions, velocities.unwrap_or(&[]));
        self.needs_depenetration = true;
        Ok(self.next_id - positions.len() as u32..self.next_id)
    }

    /// Appends particles already checked (finite, outside solids); `velocities` empty means at
    /// rest. Gives up silently only past 2^32 ids, which `add_particles_with_velocities`
    /// refuses first.
    pub(crate) fn append_unchecked(&mut self, positions: &[Vector], velocities: &[Vector]) {
        let count = positions.len() as u32;
        let start = self.next_id;
        let end = start.wrapping_add(count);
        self.positions.extend_from_slice(positions);
        if velocities.len() == positions.len() {
            self.velocities.extend_from_slice(velocities);
        } else {
            self.velocities.resize(self.positions.len(), Vector::ZERO);
        }
        self.ids.extend(start..end);
        self.next_id = end;
        let n = self.positions.len();
        self.accelerations.resize(n, Vector::ZERO);
        self.densities.resize(n, self.params.rest_density);
        self.pressures.resize(n, 0.0);
        self.attributes.resize(n);
    }

    /// Sets the particle capacity (`None`: unbounded). With a capacity, every per-particle
    /// array is reserved for it once (the pipeline's scratch for the fluid at its next step),
    /// so emitting up to it never reallocates them; emitters pause when it is reached (the step report says so)
    /// and [`Fluid::add_particles`] refuses to go beyond it. Refuses a capacity below the
    /// current particle count, or one whose memory cannot be reserved.
    pub fn set_capacity(&mut self, capacity: Option<usize>) -> SphResult<()> {
        if let Some(cap) = capacity {
            if cap < self.len() {
                return Err(SphError::InvalidParameter {
                    field: "capacity",
                    value: cap as f64,
                    reason: "below the current particle count",
                });
            }
            // An impossible capacity (a typo in a scene file) is an error, not an abort.
            let fail = |_| SphError::InvalidParameter {
                field: "capacity",
                value: cap as f64,
                reason: "cannot reserve memory for that many particles",
            };
            let extra = cap - self.len();
            self.positions.try_reserve_exact(extra).map_err(fail)?;
            self.velocities.try_reserve_exact(extra).map_err(fail)?;
            self.accelerations.try_reserve_exact(extra).map_err(fail)?;
            self.densities.try_reserve_exact(extra).map_err(fail)?;
            self.pressures.try_reserve_exact(extra).map_err(fail)?;
            self.ids.try_reserve_exact(extra).map_err(fail)?;
            for v in self.attributes.values_mut() {
                v.try_reserve_exact(extra).map_err(fail)?;
            }
        }
        self.capacity = capacity;
        Ok(())
    }

    /// The particle capacity, if any (see [`Fluid::set_capacity`]).
    pub fn capacity(&self) -> Option<usize> {
        self.capacity
    }

    /// Particles added by this fluid's emitters over its life.
    pub fn emitted(&self) -> usize {
        self.emitted
    }

    /// Particles removed by this fluid's sinks over its life.
    pub fn drained(&self) -> usize {
        self.drained
    }

    /// Fills the box `[min, min + size)` with particles on a cubic lattice at the fluid's
    /// particle spacing (the first particle half a spacing inside `min`). Returns the ids.
    pub fn add_block(&mut self, min: Vector, size: Vector) -> SphResult<std::ops::Range<u32>> {
        if !is_finite(min) || !is_finite(size) || size.min_element() <= 0.0 {
            return Err(SphError::InvalidParameter {
                field: "size",
                value: size.min_element() as f64,
                reason: "a block needs a finite origin and positive finite size",
            });
        }
        let s = self.params.particle_spacing;
        let counts = (size / s).floor().max(Vector::ONE);
        let points = lattice(
            min + Vector::splat(0.5 * s),
            counts.x as usize,
            counts.y as usize,
            counts.z as usize,
            s,
        );
        self.add_particles(&points)
    }

    /// Removes every particle for which `remove(position, velocity, id)` is true. Returns how
    /// many were removed. (Sinks use this; nothing else removes particles.)
    pub fn remove_particles_where(
        &mut self,
        mut remove: impl FnMut(Vector, Vector, u32) -> bool,
    ) -> usize {
        let n = self.positions.len();
        // Nothing moves before the first removed particle: find it first (most calls remove
        // nothing and then only read).
        let Some(first) =
            (0..n).position(|r| remove(self.positions[r], self.velocities[r], self.ids[r]))
        else {
            return 0;
        };
        let mut w = first;
        for r in first + 1..n {
            if !remove(self.positions[r], self.velocities[r], self.ids[r]) {
                self.positions[w] = self.positions[r];
                self.velocities[w] = self.velocities[r];
                self.ids[w] = self.ids[r];
                self.accelerations[w] = self.accelerations[r];
                self.densities[w] = self.densities[r];
                self.pressures[w] = self.pressures[r];
                for a in self.attributes.values_mut() {
                    a[w] = a[r];
                }
                w += 1;
            }
        }
        for v in [
            &mut self.positions,
            &mut self.velocities,
            &mut self.accelerations,
        ] {
            v.truncate(w);
        }
        self.ids.truncate(w);
        self.densities.truncate(w);
        self.pressures.truncate(w);
        for a in self.attributes.values_mut() {
            a.truncate(w);
        }
        n - w
    }

    /// Removes every particle whose position or velocity is not finite (NaN or infinite),
    /// before it can poison its neighbours through the density sums. Returns how many were
    /// removed; the pipeline calls this at the start of every frame and after any substep that
    /// produced such a particle, and reports the count as `StepReport::quarantined`.
    pub fn quarantine_non_finite(&mut self) -> usize {
        let removed = self.remove_particles_where(|x, v, _| !is_finite(x) || !is_finite(v));
        self.quarantined += removed;
        removed
    }

    /// Particles removed over the fluid's life because they became non-finite.
    pub fn quarantined(&self) -> usize {
        self.quarantined
    }

    /// The parameters and the particle arrays, borrowed apart (the step reads the first and
    /// writes the second).
    pub(crate) fn split_mut(&mut self) -> (&FluidParams, ParticlesMut<'_>) {
        (
            &self.params,
            ParticlesMut {
                positions: &mut self.positions,
                velocities: &mut self.velocities,
                accelerations: &mut self.accelerations,
                densities: &mut self.densities,
                pressures: &mut self.pressures,
                ids: &mut self.ids,
                attributes: &mut self.attributes,
            },
        )
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// `true` when the fluid has no particle.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Particle positions (m).
    pub fn positions(&self) -> &[Vector] {
        &self.positions
    }

    /// Particle velocities (m/s).
    pub fn velocities(&self) -> &[Vector] {
        &self.velocities
    }

    /// Mutable velocities, to kick particles from game code.
    pub fn velocities_mut(&mut self) -> &mut [Vector] {
        &mut self.velocities
    }

    /// Densities computed by the last step (kg/m³).
    pub fn densities(&self) -> &[Real] {
        &self.densities
    }

    /// Pressures computed by the last step (Pa).
    pub fn pressures(&self) -> &[Real] {
        &self.pressures
    }

    /// Accelerations of the last step (m/s²), all forces included.
    pub fn accelerations(&self) -> &[Vector] {
        &self.accelerations
    }

    /// Stable particle identifiers (the order of every attribute slice changes each step).
    pub fn ids(&self) -> &[u32] {
        &self.ids
    }

    /// Total mass (kg): particle count times particle mass.
    pub fn total_mass(&self) -> Real {
        self.len() as Real * self.params.particle_mass
    }

    /// Total linear momentum (kg·m/s), summed in f64.
    pub fn linear_momentum(&self) -> [f64; 3] {
        let m = self.params.particle_mass as f64;
        let mut p = [0.0f64; 3];
        for v in &self.velocities {
            p[0] += m * v.x as f64;
            p[1] += m * v.y as f64;
            p[2] += m * v.z as f64;
        }
        p
    }

    /// Total kinetic energy (J), summed in f64.
    pub fn kinetic_energy(&self) -> f64 {
        let m = self.params.particle_mass as f64;
        self.velocities
            .iter()
            .map(|v| 0.5 * m * v.length_squared() as f64)
            .sum()
    }

    /// Heap bytes held by the fluid's particle arrays (the step's scratch for the fluid is
    /// the pipeline's: [`crate::FluidPipeline::heap_bytes`]).
    pub fn heap_bytes(&self) -> usize {
        let v = std::mem::size_of::<Vector>();
        (self.positions.capacity() + self.velocities.capacity() + self.accelerations.capacity()) * v
            + (self.densities.capacity() + self.pressures.capacity()) * 4
            + self.ids.capacity() * 4
            + self.attributes.heap_bytes()
    }
}

/// Points of an `nx × ny × nz` cubic lattice with spacing `s` starting at `origin`,
/// x fastest.
pub fn lattice(origin: Vector, nx: usize, ny: usize, nz: usize, s: Real) -> Vec<Vector> {
    let mut out = Vec::with_capacity(nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                out.push(origin + Vector::new(i as Real, j as Real, k as Real) * s);
            }
        }
    }
    out
}
