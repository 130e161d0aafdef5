//! WCSPH's pressure force ([`super::wcsph::pressure_accelerations`], Müller's form) and the
//! explicit viscosity ([`crate::forces::viscosity::add_accelerations`]) in one pass over the
//! pairs: both read the same neighbours after the density pass, so one walk of the lists
//! gathers each neighbour's position and `1/ρ_j` once and forms each pair's distance (and its
//! square root) once for both sums.
//!
//! Bit for bit the two passes run one after the other: each sum keeps its own lane
//! accumulators, the same operations in the same order per lane, the same remainder loop and
//! the same final combination per particle (`a = f_p·(m/2)/ρ_i`, the wall's term, then
//! `+ f_v·ε·m/ρ_i`), and the viscosity's limiter runs after the pass exactly as after its own
//! (the unit test below compares the bits).

use crate::domain::Separation;
use crate::forces::viscosity::{AtomicMax, MAX_EXCHANGE};
use crate::kernel::{Kernel, ViscosityLaplacian};
use crate::math::{Real, Vector};
use crate::neighbors::Pairs;
use crate::par::{CHUNK, LANES, lane_sum};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// What [`pressure_and_viscosity`] reads.
pub(crate) struct FusedInput<'a, S> {
    /// Positions, lists, mass, support and separation.
    pub pairs: Pairs<'a, S>,
    /// `1/ρ` of every particle.
    pub inv_densities: &'a [Real],
    /// Pressures from the equation of state.
    pub pressures: &'a [Real],
    /// The walls' density gradient `∇ρ_wall`, with walls that count.
    pub wall: Option<&'a [Vector]>,
    /// Velocities (the viscosity's input).
    pub velocities: &'a [Vector],
    /// Viscosity ε (Pa·s, > 0) and the substep (s), for the explicit limit.
    pub viscosity: (Real, Real),
}

/// One particle's three sums: the pressure force's `Σ_j −(p_i + p_j)/ρ_j ∇W_ij`, the
/// viscosity's `Σ_j (v_j − v_i)/ρ_j ∇²W_ij` and its weight `Σ_j ∇²W_ij/ρ_j`.
struct Sums {
    pressure: Vector,
    viscous: Vector,
    weight: Real,
}

/// Overwrites `accelerations` with the pressure acceleration of
/// [`super::wcsph::pressure_accelerations`] plus the viscous one of
/// [`crate::forces::viscosity::add_accelerations`] (limited where the explicit update would
/// overshoot, as there), for one fluid. Returns how many particles the viscosity limited.
pub(crate) fn pressure_and_viscosity<K: Kernel, S: Separation>(
    input: &FusedInput<'_, S>,
    accelerations: &mut [Vector],
) -> usize {
    let (pairs, inv) = (&input.pairs, input.inv_densities);
    let kernel = K::new(pairs.h);
    let lap = ViscosityLaplacian::new(pairs.h);
    let half_m = 0.5 * pairs.mass;
    let (viscosity, dt) = input.viscosity;
    let em = viscosity * pairs.mass;
    let largest = AtomicMax::default();
    let n = pairs.positions.len();
    assert!(
        inv.len() == n
            && input.pressures.len() == n
            && input.velocities.len() == n
            && pairs.neighbors.len() == n
            && input.wall.is_none_or(|w| w.len() == n),
        "the fused pass's arrays differ in length"
    );
    let packed = avx::usable::<S>(n);
    #[cfg(target_arch = "x86_64")]
    let wide512 = crate::par::packed_level() == 2;
    let coef = (half_m, em);
    crate::par_chunks_mut!(accelerations, CHUNK)
        .enumerate()
        .for_each(|(c, out)| {
            let most = if packed {
                // SAFETY: `avx::usable` checked AVX2 at run time, an open domain and the
                // index range; the lengths are asserted above; AVX-512 F and VL detected.
                #[cfg(target_arch = "x86_64")]
                unsafe {
                    if wide512 {
                        avx::chunk512(input, (&kernel, &lap), coef, (c, out))
                    } else {
                        avx::chunk(input, (&kernel, &lap), coef, (c, out))
                    }
                }
                #[cfg(not(target_arch = "x86_64"))]
                unreachable!()
            } else {
                crate::par::wide(
                    #[inline(always)]
                    || {
                        chunk_loop(input, coef, (c, out), |i| {
                            particle_sums(input, (&kernel, &lap), i)
                        })
                    },
                )
            };
            largest.raise(most * em * dt);
        });
    if !largest.exceeds(MAX_EXCHANGE) {
        return 0;
    }
    crate::forces::viscosity::limit_by_distance(
        pairs,
        (input.velocities, inv),
        (em, dt),
        accelerations,
    )
}

/// The particles of chunk `c` (accelerations `out`): each one's [`Sums`] from `sums`, combined
/// as the two passes combine them (`coef = (m/2, ε·m)`). Returns the chunk's largest
/// viscous weight `Σ_j ∇²W_ij/(ρ_i ρ_j)`.
#[inline(always)]
fn chunk_loop<S>(
    input: &FusedInput<'_, S>,
    (half_m, em): (Real, Real),
    (c, out): (usize, &mut [Vector]),
    mut sums: impl FnMut(usize) -> Sums,
) -> Real {
    let inv = input.inv_densities;
    let base = c * CHUNK;
    let mut most: Real = 0.0;
    for (k, a) in out.iter_mut().enumerate() {
        let i = base + k;
        let s = sums(i);
        *a = s.pressure * (half_m * inv[i]);
        if let Some(grad) = input.wall {
            let pi = input.pressures[i];
            *a -= grad[i] * (0.5 * pi * inv[i] * inv[i]);
        }
        *a += s.viscous * (em * inv[i]);
        most = most.max(s.weight * inv[i]);
    }
    most
}

/// Particle `i`'s [`Sums`]: [`LANES`] neighbours at a time in lane arrays, each sum with the
/// lane arithmetic of its own pass, then the rest one by one.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // uniform lane loops, as the passes' own
fn particle_sums<K: Kernel, S: Separation>(
    input: &FusedInput<'_, S>,
    (kernel, lap): (&K, &ViscosityLaplacian),
    i: usize,
) -> Sums {
    let (positions, sep) = (input.pairs.positions, &input.pairs.sep);
    let (inv, pressures, velocities) = (input.inv_densities, input.pressures, input.velocities);
    let (xi, vi, pi) = (positions[i], velocities[i], pressures[i]);
    let coincident = K::COINCIDENT_FRACTION * input.pairs.h;
    let (mut fx, mut fy, mut fz) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
    let (mut gx, mut gy, mut gz) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
    let mut w = [0.0; LANES];
    let nb = input.pairs.neighbors.of(i);
    let mut blocks = nb.chunks_exact(LANES);
    for block in &mut blocks {
        let (mut rx, mut ry, mut rz, mut d) =
            ([0.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
        let (mut dvx, mut dvy, mut dvz) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        let (mut s, mut ij) = ([0.0; LANES], [0.0; LANES]);
        // Gathers only; the arithmetic follows in uniform loops that vectorise.
        for l in 0..LANES {
            let j = block[l] as usize;
            let r = sep.sep(xi, positions[j]);
            (rx[l], ry[l], rz[l]) = (r.x, r.y, r.z);
            d[l] = r.length_squared();
            ij[l] = inv[j];
            s[l] = (pi + pressures[j]) * ij[l];
            let dv = velocities[j] - vi;
            (dvx[l], dvy[l], dvz[l]) = (dv.x, dv.y, dv.z);
        }
        for l in 0..LANES {
            d[l] = d[l].sqrt();
        }
        // The pressure force's lanes, as `pressure_accelerations` forms them.
        let mut c = [0.0; LANES];
        for l in 0..LANES {
            // 1/d for separated pairs, 0 for coincident ones (fixed up below).
            let far = (d[l] > coincident) as u32 as Real;
            c[l] = kernel.dw(d[l]) * (far / d[l].max(coincident)) * s[l];
        }
        for l in 0..LANES {
            fx[l] -= rx[l] * c[l];
            fy[l] -= ry[l] * c[l];
            fz[l] -= rz[l] * c[l];
        }
        // The viscosity's lanes, as `forces::viscosity` forms them.
        for l in 0..LANES {
            let lw = lap.laplacian(d[l]) * ij[l];
            w[l] += lw;
            gx[l] += dvx[l] * lw;
            gy[l] += dvy[l] * lw;
            gz[l] += dvz[l] * lw;
        }
        if d.iter().any(|&dl| dl <= coincident) {
            for l in 0..LANES {
                if d[l] <= coincident {
                    let g = kernel.gradient(Vector::ZERO, d[l], i as u32, block[l]) * s[l];
                    (fx[l], fy[l], fz[l]) = (fx[l] - g.x, fy[l] - g.y, fz[l] - g.z);
                }
            }
        }
    }
    let lanes = Sums {
        pressure: Vector::new(lane_sum(fx), lane_sum(fy), lane_sum(fz)),
        viscous: Vector::new(lane_sum(gx), lane_sum(gy), lane_sum(gz)),
        weight: lane_sum(w),
    };
    remainder(input, (kernel, lap), i, blocks.remainder(), lanes)
}

/// Adds the neighbours `rest` (fewer than [`LANES`], after the full blocks) of particle `i`
/// to its lane sums `s` one by one, as each pass's own remainder loop does.
#[inline(always)]
fn remainder<K: Kernel, S: Separation>(
    input: &FusedInput<'_, S>,
    (kernel, lap): (&K, &ViscosityLaplacian),
    i: usize,
    rest: &[u32],
    mut s: Sums,
) -> Sums {
    let (positions, sep) = (input.pairs.positions, &input.pairs.sep);
    let (inv, pressures, velocities) = (input.inv_densities, input.pressures, input.velocities);
    let (xi, vi, pi) = (positions[i], velocities[i], pressures[i]);
    for &j in rest {
        let ju = j as usize;
        let r = sep.sep(xi, positions[ju]);
        let d = r.length();
        let grad = kernel.gradient(r, d, i as u32, j);
        s.pressure -= grad * ((pi + pressures[ju]) * inv[ju]);
        let l = lap.laplacian(d) * inv[ju];
        s.viscous += (velocities[ju] - vi) * l;
        s.weight += l;
    }
    s
}

/// The pass with AVX2 (open domains): each block of [`LANES`] neighbours in 8-lane
/// registers, the neighbours' values gathered by index (`vgatherdps`). The same operations
/// per lane in the same order as [`particle_sums`] (IEEE add, multiply, divide and square
/// root; no FMA), so the same bits (the unit test below compares them).
mod avx {
    use super::*;
    #[cfg(target_arch = "x86_64")]
    use crate::par::avx::{gather, gather_xyz, lanes, load_xyz, padded_block, transpose};
    #[cfg(target_arch = "x86_64")]
    use std::arch::x86_64::*;

    /// Whether the AVX2 pass runs: AVX2 detected at run time, an open domain, and every
    /// position's last coordinate within an `i32` gather offset.
    pub(super) fn usable<S: Separation>(n: usize) -> bool {
        cfg!(target_arch = "x86_64")
            && !S::PERIODIC
            && crate::par::packed_level() >= 1
            && n.checked_mul(3).is_some_and(|m| m <= i32::MAX as usize)
    }

    /// [`chunk_loop`] over [`particle_sums`] (chunk `c`, accelerations `out`).
    ///
    /// # Safety
    /// The CPU must run AVX2 and [`usable`] must hold; `input`'s arrays all hold one entry
    /// per position.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn chunk<K: Kernel, S: Separation>(
        input: &FusedInput<'_, S>,
        kl: (&K, &ViscosityLaplacian),
        coef: (Real, Real),
        (c, out): (usize, &mut [Vector]),
    ) -> Real {
        // SAFETY: as the caller promised.
        chunk_loop(input, coef, (c, out), |i| unsafe {
            particle_sums(input, kl, i)
        })
    }

    /// [`chunk`] compiled with AVX-512 F and VL as well (the same 8-lane code with 32 vector
    /// registers instead of 16: fewer spills).
    ///
    /// # Safety
    /// As [`chunk`], and the CPU must run AVX-512 F and VL.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    pub(super) unsafe fn chunk512<K: Kernel, S: Separation>(
        input: &FusedInput<'_, S>,
        kl: (&K, &ViscosityLaplacian),
        coef: (Real, Real),
        (c, out): (usize, &mut [Vector]),
    ) -> Real {
        // SAFETY: as the caller promised.
        chunk_loop(input, coef, (c, out), |i| unsafe {
            particle_sums(input, kl, i)
        })
    }

    /// Eight lanes of each coordinate of a vector.
    #[cfg(target_arch = "x86_64")]
    type Lanes3 = [__m256; 3];

    /// What every block of particle `i` reads of `i` itself, broadcast to the lanes.
    #[cfg(target_arch = "x86_64")]
    struct Me {
        x: Lanes3,
        v: Lanes3,
        p: __m256,
        /// The coincidence distance `K::COINCIDENT_FRACTION·h`.
        co: __m256,
        /// The last particle's index.
        last: __m256i,
    }

    /// The lane accumulators of [`Sums`]: pressure force, viscosity, weight.
    #[cfg(target_arch = "x86_64")]
    struct Acc {
        f: Lanes3,
        g: Lanes3,
        w: __m256,
    }

    /// One block's neighbours: positions, velocities, `1/ρ_j`, `p_j`.
    #[cfg(target_arch = "x86_64")]
    struct Block {
        x: Lanes3,
        v: Lanes3,
        inv: __m256,
        p: __m256,
    }

    /// Particle `i`'s [`Sums`], as [`super::particle_sums`] forms them.
    ///
    /// # Safety
    /// As [`chunk`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn particle_sums<K: Kernel, S: Separation>(
        input: &FusedInput<'_, S>,
        (kernel, lap): (&K, &ViscosityLaplacian),
        i: usize,
    ) -> Sums {
        let positions = input.pairs.positions;
        let (xi, vi) = (positions[i], input.velocities[i]);
        let mut blocks = input.pairs.neighbors.of(i).chunks_exact(LANES);
        // SAFETY: AVX2 (the caller's); `load` checks every index below the length.
        unsafe {
            let splat = |v: Vector| [v.x, v.y, v.z].map(|c| _mm256_set1_ps(c));
            let me = Me {
                x: splat(xi),
                v: splat(vi),
                p: _mm256_set1_ps(input.pressures[i]),
                co: _mm256_set1_ps(K::COINCIDENT_FRACTION * input.pairs.h),
                last: _mm256_set1_epi32((positions.len() - 1) as i32),
            };
            let zero = _mm256_setzero_ps();
            let mut acc = Acc {
                f: [zero; 3],
                g: [zero; 3],
                w: zero,
            };
            for block in &mut blocks {
                let nb = load(input, block, me.last);
                let (d, s) = add_block((kernel, lap), &me, &nb, &mut acc);
                let near = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(d, me.co));
                if near != 0 {
                    coincident(kernel, (i, block, near), (d, s), &mut acc.f);
                }
            }
            let sum3 = |a: Lanes3| {
                Vector::new(
                    lane_sum(lanes(a[0])),
                    lane_sum(lanes(a[1])),
                    lane_sum(lanes(a[2])),
                )
            };
            let lanes = Sums {
                pressure: sum3(acc.f),
                viscous: sum3(acc.g),
                weight: lane_sum(lanes(acc.w)),
            };
            rest(input, (kernel, lap), (&me, i), blocks.remainder(), lanes)
        }
    }

    /// [`super::remainder`] with the pair terms formed in lanes: the neighbours `rest`
    /// (fewer than [`LANES`], after the full blocks) of particle `i` padded with `i` to a
    /// block, each term formed with the remainder loop's own operations (`r·(dW/d)·s_j`,
    /// not the blocks' `dW·(1/d)`), then added to the sums one by one in list order, as
    /// that loop adds them: the seven sums (pressure force, viscosity, weight) in one
    /// register, one 8-lane add per neighbour, the pressure terms negated (`a − b` is
    /// `a + (−b)` in IEEE arithmetic). A coincident pair among them (or a NaN distance)
    /// sends the particle to the scalar loop. The scalar loop, a square root and a division
    /// per pair, took 40 % of the pass at 27.8 neighbours.
    ///
    /// # Safety
    /// As [`chunk`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn rest<K: Kernel, S: Separation>(
        input: &FusedInput<'_, S>,
        (kernel, lap): (&K, &ViscosityLaplacian),
        (me, i): (&Me, usize),
        rest: &[u32],
        s: Sums,
    ) -> Sums {
        if rest.is_empty() {
            return s;
        }
        // SAFETY: AVX2 (the caller's); `load` checks every index below the length.
        unsafe {
            let idx = padded_block(rest, i as u32);
            let nb = load(input, &idx, me.last);
            let r: Lanes3 = [
                _mm256_sub_ps(me.x[0], nb.x[0]),
                _mm256_sub_ps(me.x[1], nb.x[1]),
                _mm256_sub_ps(me.x[2], nb.x[2]),
            ];
            let d2 = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(r[0], r[0]), _mm256_mul_ps(r[1], r[1])),
                _mm256_mul_ps(r[2], r[2]),
            );
            let d = _mm256_sqrt_ps(d2);
            let co = _mm256_set1_ps(K::COINCIDENT_FRACTION * kernel.support());
            let valid = (1 << rest.len()) - 1;
            let far = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(d, co));
            if far & valid != valid {
                return super::remainder(input, (kernel, lap), i, rest, s);
            }
            let grad = _mm256_div_ps(kernel.dw_avx(d), d);
            let sj = _mm256_mul_ps(_mm256_add_ps(me.p, nb.p), nb.inv);
            let lw = _mm256_mul_ps(lap.laplacian_avx(d), nb.inv);
            // Written out: closures do not inherit the target features (each intrinsic
            // in one became a call).
            let neg = _mm256_set1_ps(-0.0);
            let mut rows = [_mm256_setzero_ps(); LANES];
            for k in 0..3 {
                rows[k] = _mm256_xor_ps(_mm256_mul_ps(_mm256_mul_ps(r[k], grad), sj), neg);
                rows[3 + k] = _mm256_mul_ps(_mm256_sub_ps(nb.v[k], me.v[k]), lw);
            }
            rows[6] = lw;
            let cols = transpose(rows);
            let (p, v) = (s.pressure, s.viscous);
            let mut acc = _mm256_setr_ps(p.x, p.y, p.z, v.x, v.y, v.z, s.weight, 0.0);
            for (l, col) in cols.iter().enumerate().take(LANES - 1) {
                if l >= rest.len() {
                    break;
                }
                acc = _mm256_add_ps(acc, *col);
            }
            let a = lanes(acc);
            Sums {
                pressure: Vector::new(a[0], a[1], a[2]),
                viscous: Vector::new(a[3], a[4], a[5]),
                weight: a[6],
            }
        }
    }

    /// The neighbours `block` of one particle into lanes, after checking every index below
    /// the particle count (unsigned compare: the loads and gathers stay inside the arrays).
    ///
    /// # Safety
    /// AVX2; the input's arrays all hold one entry per position.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn load<S>(input: &FusedInput<'_, S>, block: &[u32], last: __m256i) -> Block {
        // `Vector` is three `f32`s (repr(C)): coordinate `k` of particle `j` is float `3j + k`.
        const _: () = assert!(std::mem::size_of::<Vector>() == 12);
        let px = input.pairs.positions.as_ptr() as *const f32;
        let vx = input.velocities.as_ptr() as *const f32;
        // SAFETY: every index is checked below the length before a load.
        unsafe {
            let idx = _mm256_loadu_si256(block.as_ptr() as *const __m256i);
            let inside = _mm256_cmpeq_epi32(_mm256_max_epu32(idx, last), last);
            assert!(
                _mm256_movemask_epi8(inside) == -1,
                "neighbour index out of range"
            );
            // The last particle's 4-float load would pass the end: gathers for its block.
            let at_end = _mm256_movemask_epi8(_mm256_cmpeq_epi32(idx, last)) != 0;
            let ((x0, x1, x2), (v0, v1, v2)) = if at_end {
                let i3 = _mm256_add_epi32(_mm256_add_epi32(idx, idx), idx);
                (gather_xyz(px, i3), gather_xyz(vx, i3))
            } else {
                (load_xyz(px, block), load_xyz(vx, block))
            };
            Block {
                x: [x0, x1, x2],
                v: [v0, v1, v2],
                inv: gather(input.inv_densities.as_ptr(), idx),
                p: gather(input.pressures.as_ptr(), idx),
            }
        }
    }

    /// Adds one block's pair terms to `acc`, each in its own pass's order; returns the
    /// distances and the pressure factors `(p_i + p_j)/ρ_j` (for the coincident pairs).
    ///
    /// # Safety
    /// AVX.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // the three coordinates' lanes
    unsafe fn add_block<K: Kernel>(
        (kernel, lap): (&K, &ViscosityLaplacian),
        me: &Me,
        nb: &Block,
        acc: &mut Acc,
    ) -> (__m256, __m256) {
        // SAFETY: AVX (the caller's).
        unsafe {
            let r: Lanes3 = std::array::from_fn(|k| _mm256_sub_ps(me.x[k], nb.x[k]));
            let d2 = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(r[0], r[0]), _mm256_mul_ps(r[1], r[1])),
                _mm256_mul_ps(r[2], r[2]),
            );
            let d = _mm256_sqrt_ps(d2);
            let s = _mm256_mul_ps(_mm256_add_ps(me.p, nb.p), nb.inv);
            // The pressure force's lanes: 1/d for separated pairs, 0 for coincident ones.
            let far = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(d, me.co), _mm256_set1_ps(1.0));
            let c = _mm256_mul_ps(
                _mm256_mul_ps(
                    kernel.dw_avx(d),
                    _mm256_div_ps(far, _mm256_max_ps(d, me.co)),
                ),
                s,
            );
            for k in 0..3 {
                acc.f[k] = _mm256_sub_ps(acc.f[k], _mm256_mul_ps(r[k], c));
            }
            // The viscosity's lanes.
            let lw = _mm256_mul_ps(lap.laplacian_avx(d), nb.inv);
            acc.w = _mm256_add_ps(acc.w, lw);
            for k in 0..3 {
                let dv = _mm256_sub_ps(nb.v[k], me.v[k]);
                acc.g[k] = _mm256_add_ps(acc.g[k], _mm256_mul_ps(dv, lw));
            }
            (d, s)
        }
    }

    /// The coincident pairs of a block (bits of `near`): their pressure term along
    /// [`crate::math::coincident_direction`], as the portable pass adds it.
    ///
    /// # Safety
    /// AVX2.
    #[cfg(target_arch = "x86_64")]
    #[cold]
    #[target_feature(enable = "avx2")]
    unsafe fn coincident<K: Kernel>(
        kernel: &K,
        (i, block, near): (usize, &[u32], i32),
        (d, s): (__m256, __m256),
        f: &mut Lanes3,
    ) {
        // SAFETY: AVX (the caller's).
        unsafe {
            let (dl, sl) = (lanes(d), lanes(s));
            let mut a = f.map(|v| lanes(v));
            for l in 0..LANES {
                if near & (1 << l) != 0 {
                    let g = kernel.gradient(Vector::ZERO, dl[l], i as u32, block[l]) * sl[l];
                    (a[0][l], a[1][l], a[2][l]) = (a[0][l] - g.x, a[1][l] - g.y, a[2][l] - g.z);
                }
            }
            *f = a.map(|v| _mm256_loadu_ps(v.as_ptr()));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Open;
    use crate::kernel::CubicSpline;
    use crate::neighbors::{NeighborGrid, NeighborLists};

    /// A jittered 10³ lattice at spacing `s` (a few particles coincident, some with no
    /// neighbour in a full block) with random velocities, sorted, and its lists for `h`.
    fn cloud(h: Real, s: Real) -> (Vec<Vector>, Vec<Vector>, NeighborLists) {
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as Real / (1u64 << 24) as Real - 0.5
        };
        let (mut x, mut v) = (Vec::new(), Vec::new());
        for a in 0..10 {
            for b in 0..10 {
                for c in 0..10 {
                    let p = Vector::new(a as Real, b as Real, c as Real) * s;
                    x.push(p + Vector::new(next(), next(), next()) * (0.4 * s));
                    v.push(Vector::new(next(), next(), next()));
                }
            }
        }
        x[7] = x[8];
        x.push(Vector::splat(20.0 * s));
        v.push(Vector::ZERO);
        let mut grid = NeighborGrid::default();
        grid.sort(&x, h);
        let perm: Vec<usize> = grid.permutation().iter().map(|p| p.1 as usize).collect();
        let x: Vec<Vector> = perm.iter().map(|&i| x[i]).collect();
        let v: Vec<Vector> = perm.iter().map(|&i| v[i]).collect();
        grid.build_cells();
        let mut lists = NeighborLists::default();
        lists.build(&grid, &x, h);
        (x, v, lists)
    }

    /// The fused pass gives the bits of the pressure pass followed by the viscosity pass,
    /// with and without walls, below the explicit limit and beyond it (limiter running),
    /// through each vector path the CPU has (AVX-512, AVX2, portable).
    #[test]
    fn fused_pass_equals_the_two_passes_bit_for_bit() {
        use std::sync::atomic::Ordering;
        for ceiling in [0, 1, 2] {
            crate::par::tests::CEILING.store(ceiling, Ordering::Relaxed);
            fused_against_two_passes();
        }
        crate::par::tests::CEILING.store(0, Ordering::Relaxed);
    }

    /// `count` particles of one cell (so sorted in their own order) closer than `h` to
    /// each other, the last coincident with the first, random velocities: the first
    /// particle's list holds the others with the coincident one last, so `count` from 2
    /// to 18 gives every remainder length after the 8-lane blocks, with a coincident pair
    /// in it (the lanes' scalar fallback) and without.
    fn cluster(h: Real, count: usize) -> (Vec<Vector>, Vec<Vector>, NeighborLists) {
        let mut seed = 0x9E37_79B9_7F4A_7C15u64 ^ count as u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as Real / (1u64 << 24) as Real
        };
        let (mut x, mut v) = (Vec::new(), Vec::new());
        for _ in 0..count {
            x.push(Vector::splat(0.1 * h) + Vector::new(next(), next(), next()) * (0.3 * h));
            v.push(Vector::new(next(), next(), next()) - Vector::splat(0.5));
        }
        x[count - 1] = x[0];
        let mut grid = NeighborGrid::default();
        grid.sort(&x, h);
        assert!(
            grid.permutation()
                .iter()
                .enumerate()
                .all(|(k, p)| p.1 as usize == k)
        );
        grid.build_cells();
        let mut lists = NeighborLists::default();
        lists.build(&grid, &x, h);
        assert_eq!(lists.of(0).len(), count - 1);
        (x, v, lists)
    }

    fn fused_against_two_passes() {
        let (x, v, lists) = cloud(0.1, 0.05);
        compare_fused(x, v, lists, true);
        for count in 2..=18 {
            let (x, v, lists) = cluster(0.1, count);
            compare_fused(x, v, lists, false);
        }
    }

    /// The fused pass against the two passes on these particles; `limiter`: the strong
    /// viscosity must make the limiter run.
    fn compare_fused(x: Vec<Vector>, v: Vec<Vector>, lists: NeighborLists, limiter: bool) {
        let (h, m) = (0.1, 0.125);
        let n = x.len();
        let (mut rho, mut inv) = (vec![0.0; n], vec![0.0; n]);
        crate::density::compute::<CubicSpline, _>(&x, &lists, m, h, None, &mut rho, &mut inv, Open);
        let p: Vec<Real> = rho.iter().map(|r| 300.0 * (r - 900.0)).collect();
        let wall: Vec<Vector> = (0..n)
            .map(|k| Vector::new(0.0, (k % 3) as Real, 1.0))
            .collect();
        let pairs = Pairs {
            positions: &x,
            neighbors: &lists,
            mass: m,
            h,
            sep: Open,
        };
        for (walls, eps, limited) in [(false, 0.5, false), (true, 0.5, false), (true, 4e4, true)] {
            let wall = walls.then_some(&wall[..]);
            let dt = 1e-3;
            let mut two = vec![Vector::ZERO; n];
            crate::pressure::wcsph::pressure_accelerations::<CubicSpline, _>(
                &x, &inv, &p, &lists, m, h, wall, &mut two, Open,
            );
            let lim2 =
                crate::forces::viscosity::add_accelerations(&pairs, &v, &inv, (eps, dt), &mut two);
            let input = FusedInput {
                pairs,
                inv_densities: &inv,
                pressures: &p,
                wall,
                velocities: &v,
                viscosity: (eps, dt),
            };
            let mut one = vec![Vector::splat(7.0); n];
            let lim1 = pressure_and_viscosity::<CubicSpline, _>(&input, &mut one);
            assert_eq!(lim1, lim2);
            if limiter {
                assert_eq!(
                    lim1 > 0,
                    limited,
                    "walls {walls}, ε {eps}: limiter ran {lim1}"
                );
            }
            for k in 0..n {
                let (a, b) = (one[k], two[k]);
                assert!(
                    a.x.to_bits() == b.x.to_bits()
                        && a.y.to_bits() == b.y.to_bits()
                        && a.z.to_bits() == b.z.to_bits(),
                    "particle {k}: fused {a:?}, two passes {b:?}"
                );
            }
        }
    }
}
