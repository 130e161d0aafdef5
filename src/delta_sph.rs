//! WCSPH's densities from the continuity equation with δ-SPH density diffusion
//! ([`crate::WcsphDensity::Continuity`]), instead of kernel summation.
//!
//! Each particle carries the fluid's share of its density, `ρ_f`, as the attribute
//! [`ATTRIBUTE`] (so re-sorts, sinks and snapshots move it with the particle). A substep
//! reads `ρ_i = ρ_f,i + ρ_wall,i`, the walls' share summed from the walls' current pose as
//! with summation (`boundary::wall`: a moving body's walls are where they are), and once the
//! particle update and contact have moved the particles (`pipeline::substep`) advances
//!
//! ```text
//! Δρ_f,i = ρ_i Σ_j V_j (Δx_i − Δx_j)·∇W_ij                                  (continuity)
//!        + dt·δ·ĥ·c0 Σ_j 2(ρ_j − ρ_i − ρ^H_ji) (r_ji·∇W_ij)/(|r_ij|² + η²) V_j   (diffusion)
//! ```
//!
//! with `V_j = m/ρ_j`, the gradients at the substep's start and `Δx` each particle's move over
//! the substep: `dt·v^{n+1}` for a particle only the update moved (the continuity equation
//! `dρ_i/dt = ρ_i Σ_j V_j (v_i − v_j)·∇W_ij` of Antuono et al. 2010, "Free-surface flows
//! solved by means of SPH schemes with numerical diffusive terms", Comput. Phys. Commun. 181,
//! 532–549), and where it ended for a particle contact pushed out of a wall. Contact moves
//! particles without a velocity; integrated from the velocities alone, a settled column
//! lost half its height in two seconds (contact squeezing it at the walls, unseen by the
//! density: bottom pressure −85 %, N = 8). The second line is the density diffusion of
//! Molteni & Colagrossi (2009, Comput. Phys. Commun. 180, 861–872), `ĥ` the δ-SPH smoothing
//! length (half this crate's support radius `h`), `η = 0.1·ĥ`, with the hydrostatic
//! correction of Fourtakas et al. (2019, "Local uniform stencil (LUST) boundary condition
//! for arbitrary 3-D boundaries in parallel smoothed particle hydrodynamics (SPH) models",
//! Comput. Fluids 190, 346–361; DualSPHysics' "DDT Fourtakas"): the diffusion acts on the
//! density's difference from the hydrostatic one, `ρ^H_ji = ρ0·g·(x_j − x_i)/c0²`
//! (Fourtakas' `ρ0((1 + ρ0·g·z_ij/C_B)^{1/γ} − 1)` to first order in `ρ0·g·z/C_B`: 0.13 %
//! apart over a 4 cm support in water at c0 = 30 m/s; exact for the linear equation of
//! state), so a settled column keeps its hydrostatic densities instead of diffusing them
//! away (Molteni & Colagrossi's term alone does). The overlap relaxation's moves (after
//! particles are added or pushed out of a solid, `pipeline::relax`) are not counted.
//!
//! A particle seen for the first time (a new attribute value is zero) starts at its summed
//! density, at least `ρ0`: free-surface particles, which summation leaves short of
//! neighbours, start at rest density, as the continuity equation keeps them.

use crate::domain::Separation;
use crate::fluid::Attributes;
use crate::kernel::Kernel;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use crate::par::CHUNK;
use crate::params::FluidParams;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// The attribute holding each particle's fluid share of its density, `ρ_f` (kg/m³).
pub(crate) const ATTRIBUTE: &str = "wcsph.continuity_density";

/// The substep's motion, as the pipeline holds it after contact: where the particles
/// started, their neighbours there and their `1/ρ` of the substep.
pub(crate) struct Motion<'a> {
    /// Positions at the substep's start (the neighbour lists' positions).
    pub start: &'a [Vector],
    /// Neighbour lists of `start`.
    pub neighbors: &'a NeighborLists,
    /// `1/ρ` of every particle over the substep.
    pub inv_densities: &'a [Real],
    /// Gravity (m/s²).
    pub gravity: Vector,
    /// The substep (s).
    pub dt: Real,
}

/// What [`increment`] reads: the substep's start and end positions, its densities and the
/// constants of the two terms.
struct Terms<'a> {
    motion: &'a Motion<'a>,
    end: &'a [Vector],
    densities: &'a [Real],
    mass: Real,
    /// `dt·δ·ĥ·c0`, the diffusion's coefficient times the substep (m²).
    diffusion: Real,
    /// `η²` (m²).
    eta2: Real,
    /// `ρ0·g/c0²` (kg/m⁴): `ρ^H_ji = −hydrostatic·r_ij`.
    hydrostatic: Vector,
}

/// Advances each particle's stored density over the substep, after the particle update and
/// contact: the continuity term from each pair's relative displacement `Δx_i − Δx_j`
/// (`dt·(v_i − v_j)` for particles only the update moved; a particle contact pushed out of
/// a wall counts where it ended), the gradients and the diffusion at the substep's start.
/// `end` and `densities` are the particles' positions and densities, `delta` the
/// diffusion coefficient δ.
pub(crate) fn advance<K: Kernel, S: Separation>(
    params: &FluidParams,
    (end, densities): (&[Vector], &[Real]),
    attributes: &mut Attributes,
    motion: &Motion<'_>,
    delta: Real,
    sep: S,
) {
    let c0 = params.equation_of_state.speed_of_sound();
    let h_delta = 0.5 * params.smoothing_length;
    let terms = Terms {
        motion,
        end,
        densities,
        mass: params.particle_mass,
        diffusion: motion.dt * delta * h_delta * c0,
        eta2: 0.01 * h_delta * h_delta,
        hydrostatic: motion.gravity * (params.rest_density / (c0 * c0)),
    };
    let kernel = K::new(params.smoothing_length);
    let k = attributes.ensure(ATTRIBUTE, end.len());
    crate::par_chunks_mut!(attributes.get_mut(k), CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let base = c * CHUNK;
            for (k, s) in out.iter_mut().enumerate() {
                *s += increment(&terms, &kernel, base + k, sep);
            }
        });
}

/// The change of `ρ_f,i` over the substep: the continuity term plus the diffusion (module
/// docs), both integrated over the substep.
#[inline]
fn increment<K: Kernel, S: Separation>(t: &Terms<'_>, kernel: &K, i: usize, sep: S) -> Real {
    let m = t.motion;
    let xi = m.start[i];
    let di = sep.sep(t.end[i], xi);
    let rho_i = t.densities[i];
    let coincident = K::COINCIDENT_FRACTION * kernel.support();
    let (mut compression, mut diffusion) = (0.0, 0.0);
    for &j in m.neighbors.of(i) {
        let j = j as usize;
        let r = sep.sep(xi, m.start[j]);
        let d2 = r.length_squared();
        let d = d2.sqrt();
        if d <= coincident {
            // No direction between coincident particles: neither term has one.
            continue;
        }
        // ∇W_ij = f·r_ij.
        let f = kernel.dw(d) / d;
        let vol = t.mass * m.inv_densities[j];
        let dj = sep.sep(t.end[j], m.start[j]);
        compression += vol * f * (di - dj).dot(r);
        let excess = t.densities[j] - rho_i + t.hydrostatic.dot(r);
        diffusion -= vol * 2.0 * excess * f * d2 / (d2 + t.eta2);
    }
    rho_i * compression + t.diffusion * diffusion
}

#[cfg(test)]
mod tests {
    use crate::{Fluid, FluidParamsBuilder, FluidWorld, Solver, WcsphDensity};

    /// A block of fluid moving uniformly in open space keeps its densities: the continuity
    /// term of a uniform motion is zero pair by pair, and the diffusion of a lattice without
    /// gravity only smooths the lattice's own density differences.
    #[test]
    fn uniform_motion_keeps_the_density() {
        let params = FluidParamsBuilder::water(0.05)
            .solver(Solver::Wcsph)
            .wcsph_density(WcsphDensity::DELTA_SPH)
            .viscosity(0.0)
            .build()
            .unwrap();
        let s = params.particle_spacing;
        let mut fluid = Fluid::new(params).unwrap();
        let pts = crate::fluid::try_lattice(crate::math::Vector::ZERO, 5, 5, 5, s).unwrap();
        fluid.add_particles(&pts).unwrap();
        for v in fluid.velocities_mut() {
            *v = crate::math::Vector::new(1.0, 0.5, 0.0);
        }
        let mut world = FluidWorld::new();
        world.physics.gravity = crate::math::Vector::ZERO;
        let h = world.fluids.insert(fluid);
        world.step_fluids().unwrap();
        let before: Vec<_> = world.fluids[h].densities().to_vec();
        for _ in 0..5 {
            world.step_fluids().unwrap();
        }
        let after = world.fluids[h].densities();
        // Every particle at least ρ0 (surface particles start there) and unchanged but for
        // the diffusion between the lattice's summed densities (within 3·10⁻⁵ of ρ0, 0.03)
        // and the surface's ρ0: a smoothing moves no density beyond the largest difference.
        for (a, b) in before.iter().zip(after) {
            assert!(*a >= 1000.0 - 1e-3, "{a}");
            assert!((a - b).abs() < 0.05, "{a} -> {b}");
        }
    }
}
