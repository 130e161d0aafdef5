//! One switch between rayon and the serial build.
//!
//! Every per-particle loop in the crate is a *gather*: a particle reads its neighbours and
//! writes only its own entries, over fixed-size chunks whose boundaries do not depend on the
//! number of threads. No float is ever accumulated across threads, so the serial build
//! (`--no-default-features`) and the parallel build with any thread count give bitwise
//! the same results (see `tests/parallel_parity.rs`).

#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Particles per work item. Fixed, so chunk boundaries never depend on the thread count.
pub const CHUNK: usize = 256;

/// Neighbours processed together by the pair loops (see `density::compute`).
pub const LANES: usize = 8;

// `lane_sum` below is written out for eight lanes: changing LANES must change it too.
const _: () = assert!(LANES == 8, "lane_sum is written for 8 lanes");

/// Sum of lane accumulators in a fixed order (so results never depend on anything but the data).
#[inline(always)]
pub fn lane_sum<T: Copy + std::ops::Add<Output = T>>(a: [T; LANES]) -> T {
    ((a[0] + a[4]) + (a[1] + a[5])) + ((a[2] + a[6]) + (a[3] + a[7]))
}

/// `true` when the CPU runs AVX2 (checked at run time, cached by the standard library;
/// always `false` off x86-64).
#[inline(always)]
pub fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `true` when the CPU runs AVX-512 F and VL (checked at run time; `false` off x86-64).
#[inline(always)]
pub fn has_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `true` when the CPU has the `popcnt` instruction (checked at run time; `false` off
/// x86-64). The AVX-512 neighbour scan counts each block's accepted candidates with it
/// (without it, a bit-twiddling count of ten instructions per block and member).
#[inline(always)]
pub fn has_popcnt() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("popcnt")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The widest explicit vector path the pair passes may take (`pressure::fused`, `density`):
/// 2 AVX-512 F and VL, 1 AVX2, 0 none (detected at run time; in this crate's unit tests,
/// also bounded by the ceiling [`wide`] obeys, so one test compares every path).
#[inline]
pub(crate) fn packed_level() -> u8 {
    #[cfg(test)]
    let ceiling = tests::CEILING.load(std::sync::atomic::Ordering::Relaxed);
    #[cfg(not(test))]
    let ceiling = 0;
    if ceiling == 0 && has_avx512() {
        2
    } else if ceiling <= 1 && has_avx2() {
        1
    } else {
        0
    }
}

/// Runs `f`, compiled for AVX-512 (F and VL) or else AVX2 where the CPU has them: the pair
/// loops' lane arrays ([`LANES`]) then run as one 8-wide vector instead of two 4-wide SSE2
/// halves (AVX-512VL adds 32 vector registers and masked operations on those 8 lanes:
/// 5–12 % off the pair passes on Zen 4). `f` must be `#[inline(always)]` all the way
/// down for its body to be compiled inside the vector function. Same arithmetic lane by
/// lane on every path (no FMA, no reassociation: Rust does neither on its own), so the same
/// results bit for bit (the unit test `wide_and_portable_pair_passes_agree_bit_for_bit`
/// compares the three paths).
#[inline(always)]
pub fn wide<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(test)]
    let ceiling = tests::CEILING.load(std::sync::atomic::Ordering::Relaxed);
    #[cfg(not(test))]
    let ceiling = 0;
    if ceiling >= 2 {
        return f();
    }
    #[cfg(target_arch = "x86_64")]
    if ceiling == 0 && has_avx512() {
        #[target_feature(enable = "avx2,avx512f,avx512vl")]
        #[inline]
        unsafe fn avx512<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        // SAFETY: AVX-512F/VL were detected at run time.
        return unsafe { avx512(f) };
    }
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        #[target_feature(enable = "avx2")]
        #[inline]
        unsafe fn avx2<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        // SAFETY: AVX2 was detected at run time.
        return unsafe { avx2(f) };
    }
    f()
}

/// Eight-lane helpers of the AVX2 pair passes (`pressure::fused`, `density`): loading the
/// neighbours' values into lanes.
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx {
    use super::LANES;
    use crate::math::Real;
    use std::arch::x86_64::*;

    /// The three coordinates of the vectors at `base` (three floats each) of the block's
    /// eight indices, as lanes: each vector read with one 4-float load (its three floats
    /// and the next one's first) and the eight transposed in registers, which is cheaper
    /// than three gathers.
    ///
    /// # Safety
    /// AVX; every index below the last vector's (the 4-float load of the last one would
    /// read past the array).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn load_xyz(base: *const f32, block: &[u32]) -> (__m256, __m256, __m256) {
        // SAFETY: as the caller promised: each load reads floats 3j..3j + 4 of the array.
        unsafe {
            let at = |l: usize| _mm_loadu_ps(base.add(3 * block[l] as usize));
            let pair = |a: usize, b: usize| _mm256_set_m128(at(b), at(a));
            let (t0, t1, t2, t3) = (pair(0, 4), pair(1, 5), pair(2, 6), pair(3, 7));
            let (u0, u1) = (_mm256_unpacklo_ps(t0, t1), _mm256_unpacklo_ps(t2, t3));
            let (u2, u3) = (_mm256_unpackhi_ps(t0, t1), _mm256_unpackhi_ps(t2, t3));
            (
                _mm256_shuffle_ps::<0x44>(u0, u1),
                _mm256_shuffle_ps::<0xEE>(u0, u1),
                _mm256_shuffle_ps::<0x44>(u2, u3),
            )
        }
    }

    /// [`load_xyz`] by three gathers (any index within the array; `i3` holds `3·idx`).
    ///
    /// # Safety
    /// AVX2; every index within the array.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn gather_xyz(base: *const f32, i3: __m256i) -> (__m256, __m256, __m256) {
        // SAFETY: as the caller promised.
        unsafe {
            (
                gather(base, i3),
                gather(base.add(1), i3),
                gather(base.add(2), i3),
            )
        }
    }

    /// A particle's value at every lane's index (`base[idx·stride]`, `stride` 1 or 3).
    ///
    /// # Safety
    /// AVX2; every `idx·stride` within the array at `base`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn gather(base: *const f32, idx: __m256i) -> __m256 {
        // SAFETY: as the caller promised.
        unsafe { _mm256_i32gather_ps::<4>(base, idx) }
    }

    /// The indices `rest` (at most [`LANES`]) padded with `pad` to a block. A masked load
    /// and one register store, not a copy loop: the copy became a `memcpy` call, and the
    /// block's 8-lane load after it a store-forwarding stall.
    ///
    /// # Safety
    /// AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn padded_block(rest: &[u32], pad: u32) -> [u32; LANES] {
        assert!(rest.len() <= LANES);
        let mut out = [0u32; LANES];
        // SAFETY: AVX2 (the caller's); the masked load reads only the lanes below
        // `rest.len()`, which are inside `rest`; `out` holds 8 u32.
        unsafe {
            let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
            let valid = _mm256_cmpgt_epi32(_mm256_set1_epi32(rest.len() as i32), lane);
            let got = _mm256_maskload_epi32(rest.as_ptr() as *const i32, valid);
            let idx = _mm256_blendv_epi8(_mm256_set1_epi32(pad as i32), got, valid);
            _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, idx);
        }
        out
    }

    /// The 8×8 transpose: lane `l` of output `k` is lane `k` of input `l`.
    ///
    /// # Safety
    /// AVX.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn transpose(a: [__m256; 8]) -> [__m256; 8] {
        // SAFETY: AVX (the caller's).
        unsafe {
            let t0 = _mm256_unpacklo_ps(a[0], a[1]);
            let t1 = _mm256_unpackhi_ps(a[0], a[1]);
            let t2 = _mm256_unpacklo_ps(a[2], a[3]);
            let t3 = _mm256_unpackhi_ps(a[2], a[3]);
            let t4 = _mm256_unpacklo_ps(a[4], a[5]);
            let t5 = _mm256_unpackhi_ps(a[4], a[5]);
            let t6 = _mm256_unpacklo_ps(a[6], a[7]);
            let t7 = _mm256_unpackhi_ps(a[6], a[7]);
            let u0 = _mm256_shuffle_ps::<0x44>(t0, t2);
            let u1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
            let u2 = _mm256_shuffle_ps::<0x44>(t1, t3);
            let u3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
            let u4 = _mm256_shuffle_ps::<0x44>(t4, t6);
            let u5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
            let u6 = _mm256_shuffle_ps::<0x44>(t5, t7);
            let u7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
            [
                _mm256_permute2f128_ps::<0x20>(u0, u4),
                _mm256_permute2f128_ps::<0x20>(u1, u5),
                _mm256_permute2f128_ps::<0x20>(u2, u6),
                _mm256_permute2f128_ps::<0x20>(u3, u7),
                _mm256_permute2f128_ps::<0x31>(u0, u4),
                _mm256_permute2f128_ps::<0x31>(u1, u5),
                _mm256_permute2f128_ps::<0x31>(u2, u6),
                _mm256_permute2f128_ps::<0x31>(u3, u7),
            ]
        }
    }

    /// Eight lanes stored as an array.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn lanes(v: __m256) -> [Real; LANES] {
        let mut out = [0.0; LANES];
        // SAFETY: AVX (the callers'); `out` holds 8 floats.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), v) };
        out
    }
}

/// `slice.par_chunks_mut(n)` with the `parallel` feature, `slice.chunks_mut(n)` without.
#[doc(hidden)]
#[macro_export]
macro_rules! par_chunks_mut {
    ($slice:expr, $n:expr) => {{
        #[cfg(feature = "parallel")]
        {
            $slice.par_chunks_mut($n)
        }
        #[cfg(not(feature = "parallel"))]
        {
            $slice.chunks_mut($n)
        }
    }};
}

/// `slice.par_chunks(n)` with the `parallel` feature, `slice.chunks(n)` without.
#[doc(hidden)]
#[macro_export]
macro_rules! par_chunks {
    ($slice:expr, $n:expr) => {{
        #[cfg(feature = "parallel")]
        {
            $slice.par_chunks($n)
        }
        #[cfg(not(feature = "parallel"))]
        {
            $slice.chunks($n)
        }
    }};
}

/// `slice.par_iter_mut()` with the `parallel` feature, `slice.iter_mut()` without.
#[doc(hidden)]
#[macro_export]
macro_rules! par_iter_mut {
    ($slice:expr) => {{
        #[cfg(feature = "parallel")]
        {
            $slice.par_iter_mut()
        }
        #[cfg(not(feature = "parallel"))]
        {
            $slice.iter_mut()
        }
    }};
}

/// `slice.par_iter()` with the `parallel` feature, `slice.iter()` without.
#[doc(hidden)]
#[macro_export]
macro_rules! par_iter {
    ($slice:expr) => {{
        #[cfg(feature = "parallel")]
        {
            $slice.par_iter()
        }
        #[cfg(not(feature = "parallel"))]
        {
            $slice.iter()
        }
    }};
}

/// Reorders `data` so that `data[k] = old[perm[k]]`, using `scratch` as the destination and
/// swapping it in. Allocation-free once `scratch` has grown to the particle count.
pub(crate) fn permute<T: Copy + Send + Sync>(
    data: &mut Vec<T>,
    scratch: &mut Vec<T>,
    perm: &[(u64, u32)],
) {
    debug_assert_eq!(data.len(), perm.len());
    if data.is_empty() {
        return;
    }
    scratch.clear();
    scratch.resize(data.len(), data[0]);
    {
        let src: &[T] = data;
        crate::par_chunks_mut!(scratch, CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                let base = c * CHUNK;
                for (k, o) in out.iter_mut().enumerate() {
                    *o = src[perm[base + k].1 as usize];
                }
            });
    }
    std::mem::swap(data, scratch);
}

#[cfg(test)]
pub(crate) mod tests {
    use crate::kernel::CubicSpline;
    use crate::math::{Real, Vector};
    use crate::neighbors::{NeighborGrid, NeighborLists};
    use std::sync::atomic::{AtomicU8, Ordering};

    /// The widest path [`super::wide`] may take: 0 any, 1 AVX2 at most, 2 portable (this
    /// module's test only; the results are the same either way, so other tests running
    /// meanwhile are not affected).
    pub(crate) static CEILING: AtomicU8 = AtomicU8::new(0);

    /// Density, pressure force and viscosity passes give the same bits through the AVX-512
    /// and AVX2 paths (where the CPU has them) and the portable one.
    /// A jittered 12³ lattice at spacing `s` with random velocities, sorted into the grid's
    /// order, and its neighbour lists for support `h`.
    fn jittered_block(h: Real, s: Real) -> (Vec<Vector>, Vec<Vector>, NeighborLists) {
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as Real / (1u64 << 24) as Real - 0.5
        };
        let mut positions = Vec::new();
        let mut velocities = Vec::new();
        for x in 0..12 {
            for y in 0..12 {
                for z in 0..12 {
                    let p = Vector::new(x as Real, y as Real, z as Real) * s;
                    positions.push(p + Vector::new(next(), next(), next()) * (0.4 * s));
                    velocities.push(Vector::new(next(), next(), next()));
                }
            }
        }
        let mut grid = NeighborGrid::default();
        grid.sort(&positions, h);
        let perm: Vec<usize> = grid
            .permutation()
            .iter()
            .map(|&(_, i)| i as usize)
            .collect();
        let positions: Vec<Vector> = perm.iter().map(|&i| positions[i]).collect();
        let velocities: Vec<Vector> = perm.iter().map(|&i| velocities[i]).collect();
        grid.build_cells();
        let mut lists = NeighborLists::default();
        lists.build(&grid, &positions, h);
        (positions, velocities, lists)
    }

    #[test]
    fn wide_and_portable_pair_passes_agree_bit_for_bit() {
        let (h, s, m) = (0.1, 0.05, 0.125);
        let (positions, velocities, lists) = jittered_block(h, s);
        let n = positions.len();
        let run = |ceiling: u8| {
            CEILING.store(ceiling, Ordering::Relaxed);
            let (mut rho, mut inv) = (vec![0.0; n], vec![0.0; n]);
            let pairs = crate::neighbors::Pairs {
                positions: &positions,
                neighbors: &lists,
                mass: m,
                h,
                sep: crate::domain::Open,
            };
            crate::density::compute::<CubicSpline, _>(
                &positions,
                &lists,
                m,
                h,
                None,
                &mut rho,
                &mut inv,
                crate::domain::Open,
            );
            let pressures: Vec<Real> = rho.iter().map(|r| 100.0 * (r - 1000.0)).collect();
            let mut acc = vec![Vector::ZERO; n];
            crate::pressure::wcsph::pressure_accelerations::<CubicSpline, _>(
                &positions,
                &inv,
                &pressures,
                &lists,
                m,
                h,
                None,
                &mut acc,
                crate::domain::Open,
            );
            crate::forces::viscosity::add_accelerations(
                &pairs,
                &velocities,
                &inv,
                (0.5, 1e-3),
                &mut acc,
            );
            CEILING.store(0, Ordering::Relaxed);
            let mut bits: Vec<u32> = rho.iter().map(|v| v.to_bits()).collect();
            bits.extend(
                acc.iter()
                    .flat_map(|a| [a.x.to_bits(), a.y.to_bits(), a.z.to_bits()]),
            );
            bits
        };
        if !super::has_avx512() {
            eprintln!("no AVX-512 on this CPU: the widest run took the AVX2 or portable path");
        }
        if !super::has_avx2() {
            eprintln!("no AVX2 on this CPU: every run took the portable path");
        }
        let (widest, avx2, portable) = (run(0), run(1), run(2));
        assert_eq!(widest.len(), n * 4);
        assert!(avx2 == portable, "the AVX2 and portable passes differ");
        assert!(widest == portable, "the AVX-512 and portable passes differ");
    }
}
