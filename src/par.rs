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
