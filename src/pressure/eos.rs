//! Equations of state: `p = k(ρ − ρ0)` (Desbrun & Gascuel 1996, the Unity paper's eq. 11) or
//! Tait's `p = B((ρ/ρ0)^γ − 1)`, `B = ρ0c²/γ` (Monaghan 1994; Becker & Teschner 2007).

use crate::math::Real;
use crate::par::CHUNK;
use crate::params::EquationOfState;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Computes `pressures[i]` from `densities[i]`.
pub fn compute(
    densities: &[Real],
    eos: EquationOfState,
    rest_density: Real,
    clamp_negative: bool,
    pressures: &mut [Real],
) {
    let floor = if clamp_negative {
        0.0
    } else {
        Real::NEG_INFINITY
    };
    match eos {
        EquationOfState::Linear { stiffness } => {
            crate::par_chunks_mut!(pressures, CHUNK)
                .enumerate()
                .for_each(|(c, out)| {
                    let rho = &densities[c * CHUNK..];
                    for (p, &r) in out.iter_mut().zip(rho) {
                        *p = (stiffness * (r - rest_density)).max(floor);
                    }
                });
        }
        EquationOfState::Tait {
            speed_of_sound,
            exponent,
        } => {
            let b = rest_density * speed_of_sound * speed_of_sound / exponent;
            let inv = 1.0 / rest_density;
            let integer = exponent == exponent.round() && exponent <= 16.0;
            crate::par_chunks_mut!(pressures, CHUNK)
                .enumerate()
                .for_each(|(c, out)| {
                    let rho = &densities[c * CHUNK..];
                    for (p, &r) in out.iter_mut().zip(rho) {
                        let x = r * inv;
                        let xg = if integer {
                            x.powi(exponent as i32)
                        } else {
                            x.powf(exponent)
                        };
                        *p = (b * (xg - 1.0)).max(floor);
                    }
                });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_and_tait_at_rest_are_zero_and_grow_with_density() {
        let rho = [1000.0, 1010.0, 990.0];
        let mut p = [0.0; 3];
        compute(
            &rho,
            EquationOfState::Linear { stiffness: 100.0 },
            1000.0,
            false,
            &mut p,
        );
        assert_eq!(p, [0.0, 1000.0, -1000.0]);
        compute(
            &rho,
            EquationOfState::Linear { stiffness: 100.0 },
            1000.0,
            true,
            &mut p,
        );
        assert_eq!(p, [0.0, 1000.0, 0.0]);
        compute(
            &rho,
            EquationOfState::Tait {
                speed_of_sound: 10.0,
                exponent: 7.0,
            },
            1000.0,
            false,
            &mut p,
        );
        assert_eq!(p[0], 0.0);
        // Small compression: p ≈ c²·Δρ (the linearisation of Tait).
        assert!((p[1] - 100.0 * 10.0).abs() / 1000.0 < 0.05);
        assert!(p[2] < 0.0);
    }
}
