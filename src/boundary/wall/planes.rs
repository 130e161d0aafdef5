//! Each particle's walls as planes, for DFSPH's `predict_walls`: the velocity contact will
//! leave a particle (it stops at the contact radius from each wall; [`WallPlanes::clip`]) and
//! the walls' density at the substep's end ([`WallPlanes::coverage_after`]).
//!
//! The walls' density of a particle is `ρ0·Φ_full·U`, `U = 1 − Π_k (1 − a_k)` the union of
//! the half-spaces of the colliders near, `a_k = Φ(d_k)/Φ_full` a function of the distance
//! `d_k` to collider `k` alone (see the module docs of `boundary::wall`). Its rate of change,
//! `(v_i − v_wall)·∇ρ_wall`, predicts it to first order; over a long substep a particle moving
//! towards a wall crosses the curvature of `Φ` (`Φ'' > 0` next to a wall: the linear
//! prediction comes out low). Kept as planes (the distance, the normal and the wall's normal
//! speed at the closest point), the walls' density at the substep's end is the same union at
//! `d_k + dt·(v_i − v_k)·n_k`: a table look-up per wall. (In the game pool that curvature
//! is a small part of the floor layer's prediction error; contact is the large one, see
//! `Dfsph::predict_walls`.)

use crate::kernel::HalfSpaceTable;
use crate::math::{Real, Vector};

/// Most walls kept per particle; a particle with more keeps the linear prediction.
pub(crate) const MAX_PLANES: usize = 4;

/// One particle's walls as planes (see the module docs); `count` of them, or
/// [`WallPlanes::OVERFLOW`] when more walls were near than [`MAX_PLANES`].
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(crate) struct WallPlanes {
    /// Signed distance to each wall's surface (positive on the fluid side).
    pub distance: [Real; MAX_PLANES],
    /// Each wall's normal at its closest point, pointing to the fluid.
    pub normal: [Vector; MAX_PLANES],
    /// Each wall's velocity along that normal at its closest point (0 for static walls).
    pub speed: [Real; MAX_PLANES],
    /// Walls kept.
    pub count: u8,
}

impl WallPlanes {
    /// `count` of a particle with more walls near than [`MAX_PLANES`].
    pub const OVERFLOW: u8 = u8::MAX;

    /// No wall kept (the same as `default()`).
    pub const EMPTY: WallPlanes = WallPlanes {
        distance: [0.0; MAX_PLANES],
        normal: [Vector::ZERO; MAX_PLANES],
        speed: [0.0; MAX_PLANES],
        count: 0,
    };

    /// Adds a wall (or marks the particle as having too many).
    #[inline(always)]
    pub fn push(&mut self, distance: Real, normal: Vector, speed: Real) {
        let k = self.count as usize;
        if k >= MAX_PLANES {
            self.count = Self::OVERFLOW;
            return;
        }
        self.distance[k] = distance;
        self.normal[k] = normal;
        self.speed[k] = speed;
        self.count += 1;
    }

    /// The velocity `v` as contact will leave it after `dt`: along each wall's normal, the
    /// particle stops at `radius` from the wall (or is pushed out to it).
    #[inline(always)]
    pub fn clip(&self, mut v: Vector, dt: Real, radius: Real) -> Vector {
        let count = self.count as usize;
        if count == 0 || count > MAX_PLANES {
            return v;
        }
        for k in 0..count {
            let s = v.dot(self.normal[k]) - self.speed[k];
            if self.distance[k] + dt * s < radius {
                v += self.normal[k] * ((radius - self.distance[k]) / dt - s);
            }
        }
        v
    }

    /// The coverage `U` of the union after the particle moves with velocity `v` for `dt`
    /// (`table`: the density kernel's half-space table, `full` its whole integral); `None`
    /// when no wall or too many were kept.
    #[inline(always)]
    pub fn coverage_after(
        &self,
        v: Vector,
        dt: Real,
        table: &HalfSpaceTable,
        full: Real,
    ) -> Option<Real> {
        let count = self.count as usize;
        if count == 0 || count > MAX_PLANES {
            return None;
        }
        let mut keep: Real = 1.0;
        for k in 0..count {
            let d = self.distance[k] + dt * (v.dot(self.normal[k]) - self.speed[k]);
            let a = (table.eval(d).0 / full).min(1.0);
            keep *= 1.0 - a;
        }
        Some(1.0 - keep)
    }
}
