//! Math types: rapier's own, re-exported, plus the few glam ↔ nalgebra conversions.
//!
//! The public API of this crate speaks rapier's math types ([`Real`], [`Vector`], [`Pose`]),
//! which since rapier 0.30 are glam types (through `glamx`). A rapier user never converts.
//! Where nalgebra's linear algebra is used (small dense matrices in diagnostics and tests),
//! conversions go through this module only.

pub use rapier3d::math::{Pose, Real, Rotation, Vector};

/// Converts a rapier/glam vector to an nalgebra vector.
#[inline]
pub fn to_na(v: Vector) -> nalgebra::Vector3<Real> {
    nalgebra::Vector3::new(v.x, v.y, v.z)
}

/// Converts an nalgebra vector to a rapier/glam vector.
#[inline]
pub fn from_na(v: &nalgebra::Vector3<Real>) -> Vector {
    Vector::new(v.x, v.y, v.z)
}

/// `true` when all three components are finite (no NaN, no infinity).
#[inline]
pub fn is_finite(v: Vector) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

/// `true` when a velocity's squared speed is finite: its components are finite and its speed
/// is below about 1.8·10¹⁹ m/s (in `f32`). Beyond that the kinetic energy, the adaptive step's
/// speed and the contact sweep overflow, and a particle written at such a speed got through a
/// closed container's walls (1.5·10³⁴ m/s); the step treats it as non-finite (quarantined and
/// counted), as it does NaN.
///
/// ```
/// use rapier_sph::math::{Vector, is_finite_velocity};
/// assert!(is_finite_velocity(Vector::new(1e6, 0.0, 0.0)));
/// assert!(!is_finite_velocity(Vector::new(1e20, 0.0, 0.0)));
/// assert!(!is_finite_velocity(Vector::new(f32::NAN, 0.0, 0.0)));
/// ```
#[inline]
pub fn is_finite_velocity(v: Vector) -> bool {
    v.length_squared().is_finite()
}

/// A deterministic unit direction for a pair of coincident particles `(i, j)`.
///
/// Two particles at exactly the same position have no defined separation direction, yet the
/// pressure force between them must push them apart. This returns a direction that depends
/// only on the pair's indices and is antisymmetric (`coincident_direction(i, j) ==
/// -coincident_direction(j, i)`), so the pair's forces still cancel exactly and the result
/// is the same on every run and every thread count.
#[inline]
pub fn coincident_direction(i: u32, j: u32) -> Vector {
    let (lo, hi, sign) = if i < j { (i, j, 1.0) } else { (j, i, -1.0) };
    // A small integer hash of the unordered pair picks one of 6 axis directions.
    let h = (lo as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (hi as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    let axis = match (h >> 32) % 6 {
        0 => Vector::X,
        1 => Vector::NEG_X,
        2 => Vector::Y,
        3 => Vector::NEG_Y,
        4 => Vector::Z,
        _ => Vector::NEG_Z,
    };
    axis * sign
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn na_round_trip() {
        let v = Vector::new(1.5, -2.0, 3.25);
        assert_eq!(from_na(&to_na(v)), v);
    }

    #[test]
    fn coincident_direction_is_antisymmetric_unit() {
        for i in 0..50u32 {
            for j in 0..50u32 {
                if i == j {
                    continue;
                }
                let a = coincident_direction(i, j);
                let b = coincident_direction(j, i);
                assert_eq!(a, -b);
                assert!((a.length() - 1.0).abs() < 1e-6);
            }
        }
    }
}
