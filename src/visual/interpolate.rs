//! Positions between the last two physics steps, for drawing at another rate than the
//! physics steps (the usual "fixed physics step, variable frame rate" loop).

use crate::fluid::Fluid;
use crate::math::{Real, Vector};
use crate::{SphError, SphResult};

/// Records a fluid's particles after each physics step and returns positions interpolated
/// between the last two records, particle by particle **by id** (the fluid re-sorts its
/// particles every step, so index `i` is not the same particle twice).
///
/// A particle present in the latest record but not in the one before (just emitted) stays
/// at its latest position; a particle removed since (drained) is not returned. Memory: one
/// position and one stamp per id up to the largest id seen (16 bytes each).
///
/// # Examples
///
/// ```
/// use rapier_sph::visual::Interpolation;
/// use rapier_sph::FluidWorld;
/// # use rapier_sph::{Fluid, FluidParamsBuilder};
/// # use rapier_sph::math::Vector;
/// # let mut world = FluidWorld::new();
/// # let mut fluid = Fluid::new(FluidParamsBuilder::water(0.05).build()?)?;
/// # fluid.add_block(Vector::ZERO, Vector::new(0.2, 0.2, 0.2))?;
/// # let water = world.fluids.insert(fluid);
/// let mut lerp = Interpolation::new();
/// lerp.record(&world.fluids[water]);
/// world.step()?;                       // one physics step (1/60 s)
/// lerp.record(&world.fluids[water]);
/// // Drawing 40 % of the way from the previous step to the latest:
/// let positions = lerp.positions(0.4)?;
/// assert_eq!(positions.len(), world.fluids[water].len());
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Clone, Debug, Default)]
pub struct Interpolation {
    /// Position of each id at the record before the latest.
    previous: Vec<Vector>,
    /// The record number at which `previous[id]` was written (0: never).
    previous_stamp: Vec<u32>,
    /// The latest record, in the fluid's order at that time.
    ids: Vec<u32>,
    current: Vec<Vector>,
    records: u32,
    out: Vec<Vector>,
}

impl Interpolation {
    /// An empty recorder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records the fluid's particles after a physics step.
    pub fn record(&mut self, fluid: &Fluid) {
        self.record_unchecked(fluid.ids(), fluid.positions());
    }

    /// Records any particles given by stable `ids` and their `positions`.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] (`positions`) when the slices differ in length.
    pub fn record_positions(&mut self, ids: &[u32], positions: &[Vector]) -> SphResult<()> {
        if ids.len() != positions.len() {
            return Err(SphError::InvalidParameter {
                field: "positions",
                value: positions.len() as f64,
                reason: "must have as many entries as ids",
            });
        }
        self.record_unchecked(ids, positions);
        Ok(())
    }

    fn record_unchecked(&mut self, ids: &[u32], positions: &[Vector]) {
        // The latest record becomes the previous one, stored by id.
        self.records += 1;
        let stamp = self.records;
        if let Some(&max) = self.ids.iter().max() {
            let len = max as usize + 1;
            if self.previous.len() < len {
                self.previous.resize(len, Vector::ZERO);
                self.previous_stamp.resize(len, 0);
            }
        }
        for (&id, &p) in self.ids.iter().zip(&self.current) {
            self.previous[id as usize] = p;
            self.previous_stamp[id as usize] = stamp;
        }
        self.ids.clear();
        self.ids.extend_from_slice(ids);
        self.current.clear();
        self.current.extend_from_slice(positions);
    }

    /// The ids of the latest record, in the order of [`Self::positions`].
    pub fn ids(&self) -> &[u32] {
        &self.ids
    }

    /// Positions at `alpha` of the way from the record before the latest (0) to the latest
    /// (1), in the latest record's order. `(1 − α)·p₀ + α·p₁` per particle, which gives `p₀`
    /// and `p₁` exactly at the ends.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] (`alpha`) unless `0 ≤ alpha ≤ 1`.
    pub fn positions(&mut self, alpha: Real) -> SphResult<&[Vector]> {
        if !(0.0..=1.0).contains(&alpha) {
            return Err(SphError::InvalidParameter {
                field: "alpha",
                value: alpha as f64,
                reason: "must be in [0, 1]",
            });
        }
        let stamp = self.records;
        let (previous, stamps) = (&self.previous, &self.previous_stamp);
        self.out.clear();
        self.out
            .extend(self.ids.iter().zip(&self.current).map(|(&id, &p1)| {
                let id = id as usize;
                if id < stamps.len() && stamps[id] == stamp {
                    previous[id] * (1.0 - alpha) + p1 * alpha
                } else {
                    p1
                }
            }));
        Ok(&self.out)
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.previous.capacity() * 12
            + self.previous_stamp.capacity() * 4
            + self.ids.capacity() * 4
            + (self.current.capacity() + self.out.capacity()) * 12
    }
}
