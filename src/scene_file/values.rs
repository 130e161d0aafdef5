//! Numbers that are checked while they are read, so a bad value is reported at its own line.

use crate::math::{Real, Vector};
use serde::{Deserialize, Deserializer, Serialize};

macro_rules! checked_real {
    ($(#[$doc:meta])* $name:ident, $ok:expr, $what:literal) => {
        $(#[$doc])*
        #[derive(Copy, Clone, Debug, PartialEq, Serialize, Deserialize)]
        #[serde(try_from = "f64", into = "f64")]
        pub struct $name(pub Real);

        impl TryFrom<f64> for $name {
            type Error = String;
            fn try_from(v: f64) -> Result<Self, String> {
                let ok: fn(f64) -> bool = $ok;
                if ok(v) && (v as Real).is_finite() {
                    Ok($name(v as Real))
                } else {
                    Err(format!("{v} is not {}", $what))
                }
            }
        }

        impl From<$name> for f64 {
            fn from(v: $name) -> f64 {
                v.0 as f64
            }
        }
    };
}

checked_real!(
    /// A finite number greater than zero.
    Positive,
    |v| v > 0.0,
    "a positive finite number"
);
checked_real!(
    /// A finite number, zero or more.
    NonNegative,
    |v| v >= 0.0,
    "a finite number ≥ 0"
);
checked_real!(
    /// Any finite number.
    Finite,
    |v| v.is_finite(),
    "a finite number"
);

impl Default for Finite {
    fn default() -> Self {
        Finite(0.0)
    }
}

impl Default for NonNegative {
    fn default() -> Self {
        NonNegative(0.0)
    }
}

/// A vector `(x, y, z)` of finite numbers.
#[derive(Copy, Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "(f64, f64, f64)", into = "(f64, f64, f64)")]
pub struct Vec3(pub [Real; 3]);

impl Vec3 {
    /// As a rapier vector.
    pub fn vector(&self) -> Vector {
        Vector::from_array(self.0)
    }
}

impl TryFrom<(f64, f64, f64)> for Vec3 {
    type Error = String;
    fn try_from(v: (f64, f64, f64)) -> Result<Self, String> {
        let a = [v.0 as Real, v.1 as Real, v.2 as Real];
        if a.iter().all(|x| x.is_finite()) {
            Ok(Vec3(a))
        } else {
            Err(format!("{v:?} has a component that is not a finite number"))
        }
    }
}

impl From<Vec3> for (f64, f64, f64) {
    fn from(v: Vec3) -> Self {
        (v.0[0] as f64, v.0[1] as f64, v.0[2] as f64)
    }
}

/// A vector `(x, y, z)` of positive finite numbers (sizes, half extents).
#[derive(Copy, Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "(f64, f64, f64)", into = "(f64, f64, f64)")]
pub struct PositiveVec3(pub [Real; 3]);

impl PositiveVec3 {
    /// As a rapier vector.
    pub fn vector(&self) -> Vector {
        Vector::from_array(self.0)
    }
}

impl TryFrom<(f64, f64, f64)> for PositiveVec3 {
    type Error = String;
    fn try_from(v: (f64, f64, f64)) -> Result<Self, String> {
        let a = [v.0 as Real, v.1 as Real, v.2 as Real];
        if a.iter().all(|x| x.is_finite() && *x > 0.0) {
            Ok(PositiveVec3(a))
        } else {
            Err(format!(
                "{v:?} has a component that is not a positive finite number"
            ))
        }
    }
}

impl From<PositiveVec3> for (f64, f64, f64) {
    fn from(v: PositiveVec3) -> Self {
        (v.0[0] as f64, v.0[1] as f64, v.0[2] as f64)
    }
}

/// Checks done on a whole entry once it has been read.
pub(crate) trait Validate {
    fn validate(&self) -> Result<(), String>;
}

struct Checked<T>(T);

impl<'de, T: Deserialize<'de> + Validate> Deserialize<'de> for Checked<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = T::deserialize(d)?;
        v.validate().map_err(serde::de::Error::custom)?;
        Ok(Checked(v))
    }
}

/// A list whose entries are validated as each one ends (errors point at that entry).
pub(crate) fn checked_vec<'de, D, T>(d: D) -> Result<Vec<T>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de> + Validate,
{
    let v: Vec<Checked<T>> = Vec::deserialize(d)?;
    Ok(v.into_iter().map(|c| c.0).collect())
}

/// A single value validated as it ends (the error points at it).
pub(crate) fn checked<'de, D, T>(d: D) -> Result<T, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de> + Validate,
{
    Ok(Checked::<T>::deserialize(d)?.0)
}
