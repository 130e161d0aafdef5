use super::NeighborGrid;
use super::grid::{CellRanges, Window};
use crate::domain::{MinimumImage, Open, Separation};
use crate::math::{Real, Vector};
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Neighbour lists of one chunk of [`CHUNK`] consecutive particles.
#[derive(Clone, Debug, Default)]
struct Chunk {
    /// `offsets[k]..offsets[k + 1]` index `indices` for the chunk's `k`-th particle.
    offsets: Vec<u32>,
    indices: Vec<u32>,
}

/// Flat neighbour lists: for every particle, the indices of the other particles closer than
/// `h`, in ascending order (the particle itself is not listed). Every index is below
/// [`Self::len`], checked when the lists are built.
///
/// Stored per chunk of `CHUNK` particles (one offset array and one index array each) so
/// the lists are built in parallel with no final copy and no allocation once warm.
#[derive(Clone, Debug, Default)]
pub struct NeighborLists {
    chunks: Vec<Chunk>,
    len: usize,
    /// The coordinates' buffer of a build given none (see [`Self::build_in`]).
    coords: Vec<Real>,
}

/// Candidates tested together in the neighbour scan.
const BLOCK: usize = 8;

/// Candidates tested together by the AVX-512 scan ([`scan_chunk_avx512`]).
const WIDE: usize = 16;

/// Entries of padding at infinity after the coordinate arrays, and of slack after each
/// range in the index buffer: a block (of [`BLOCK`] or [`WIDE`] lanes) may run past the
/// last particle, and stores all its lanes.
const PAD: usize = WIDE;

/// Which instructions the scan uses (the lists are the same with each: same arithmetic per
/// lane, no FMA; the unit test below compares them).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum Isa {
    /// Scalar, or two SSE2 halves per block on x86-64.
    Portable,
    /// 8-lane blocks, one 8-lane store per block.
    Avx2,
    /// 16-lane blocks compacted in a register (`vpcompressd`) and stored at once.
    Avx512,
}

impl Isa {
    /// The widest the CPU runs (checked at run time). The periodic scan is scalar.
    fn best(periodic: bool) -> Self {
        if periodic {
            Isa::Portable
        } else if crate::par::has_avx512() && crate::par::has_popcnt() {
            Isa::Avx512
        } else if crate::par::has_avx2() {
            Isa::Avx2
        } else {
            Isa::Portable
        }
    }
}

/// For every 8-bit mask of accepted candidates: the lane numbers of its set bits in
/// ascending order (padded with zeros), and how many there are. The scan stores all eight
/// entries of a block and advances by the count, so it has no branch per candidate.
const COMPACT: [([u8; BLOCK], u8); 256] = {
    let mut table = [([0u8; BLOCK], 0u8); 256];
    let mut mask = 0;
    while mask < 256 {
        let mut n = 0;
        let mut lane = 0;
        while lane < BLOCK {
            if mask & (1 << lane) != 0 {
                table[mask].0[n] = lane as u8;
                n += 1;
            }
            lane += 1;
        }
        table[mask].1 = n as u8;
        mask += 1;
    }
    table
};

/// Bit `k` set when candidate `j0 + k` is closer than `sqrt(h2)` to `(xi, yi, zi)`.
/// Same arithmetic as the scalar test `dx·dx + dy·dy + dz·dz < h2` (in this order, no FMA),
/// so the lists do not depend on how the test is vectorised: one 8-lane pass with `AVX2`
/// (only inside code compiled for it, see [`scan_chunk_avx2`]), two 4-lane SSE2 halves
/// otherwise on x86-64, scalar elsewhere.
#[inline(always)]
fn block_mask<const AVX2: bool>(
    coords: Coords<'_>,
    j0: usize,
    point: (Real, Real, Real),
    h2: Real,
) -> u32 {
    let (Coords { xs, ys, zs }, (xi, yi, zi)) = (coords, point);
    let bx: &[Real; BLOCK] = xs[j0..j0 + BLOCK].try_into().unwrap();
    let by: &[Real; BLOCK] = ys[j0..j0 + BLOCK].try_into().unwrap();
    let bz: &[Real; BLOCK] = zs[j0..j0 + BLOCK].try_into().unwrap();
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        if AVX2 {
            // SAFETY: `AVX2` is set only in code compiled with AVX2 enabled
            // (`scan_chunk_avx2`, entered after run-time detection); each load reads the 8
            // floats of a checked array.
            return unsafe {
                let dx = _mm256_sub_ps(_mm256_set1_ps(xi), _mm256_loadu_ps(bx.as_ptr()));
                let dy = _mm256_sub_ps(_mm256_set1_ps(yi), _mm256_loadu_ps(by.as_ptr()));
                let dz = _mm256_sub_ps(_mm256_set1_ps(zi), _mm256_loadu_ps(bz.as_ptr()));
                let d2 = _mm256_add_ps(
                    _mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                    _mm256_mul_ps(dz, dz),
                );
                _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(d2, _mm256_set1_ps(h2))) as u32
            };
        }
        // SSE2 is part of every x86-64 CPU: two 4-lane halves, `movmskps` for the bits.
        // SAFETY: the loads read 4 floats from arrays of 8 at offsets 0 and 4; SSE2 is
        // always available on x86_64.
        unsafe {
            let (vx, vy, vz, vh) = (
                _mm_set1_ps(xi),
                _mm_set1_ps(yi),
                _mm_set1_ps(zi),
                _mm_set1_ps(h2),
            );
            let half = |o: usize| {
                let dx = _mm_sub_ps(vx, _mm_loadu_ps(bx.as_ptr().add(o)));
                let dy = _mm_sub_ps(vy, _mm_loadu_ps(by.as_ptr().add(o)));
                let dz = _mm_sub_ps(vz, _mm_loadu_ps(bz.as_ptr().add(o)));
                let d2 = _mm_add_ps(
                    _mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)),
                    _mm_mul_ps(dz, dz),
                );
                _mm_movemask_ps(_mm_cmplt_ps(d2, vh)) as u32
            };
            half(0) | (half(4) << 4)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut mask = 0u32;
        for k in 0..BLOCK {
            let (dx, dy, dz) = (xi - bx[k], yi - by[k], zi - bz[k]);
            mask |= ((dx * dx + dy * dy + dz * dz < h2) as u32) << k;
        }
        mask
    }
}

/// [`COMPACT`]'s lane numbers widened to `u32`, for one 8-lane load (AVX2).
static COMPACT32: [[u32; BLOCK]; 256] = {
    let mut table = [[0u32; BLOCK]; 256];
    let mut mask = 0;
    while mask < 256 {
        let mut k = 0;
        while k < BLOCK {
            table[mask][k] = COMPACT[mask].0[k] as u32;
            k += 1;
        }
        mask += 1;
    }
    table
};

/// `out[k] = j0 + lanes[k]` in one 8-lane add and store (AVX2).
#[inline(always)]
fn store_lanes_avx2(out: &mut [u32; BLOCK], j0: u32, lanes: &[u32; BLOCK]) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: called only with `AVX2` set, as in `block_mask`; `out` and `lanes` are 8 u32 each.
    unsafe {
        use std::arch::x86_64::*;
        let v = _mm256_add_epi32(
            _mm256_set1_epi32(j0 as i32),
            _mm256_loadu_si256(lanes.as_ptr() as *const __m256i),
        );
        _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, v);
    }
    #[cfg(not(target_arch = "x86_64"))]
    for k in 0..BLOCK {
        out[k] = j0 + lanes[k];
    }
}

/// [`block_mask`] with the separation's minimum image (scalar: the periodic path only).
/// The distance is `sep(x_i, x_j).length_squared()`, exactly as the pair loops form it.
#[inline(always)]
fn periodic_block_mask<S: Separation>(
    sep: &S,
    coords: Coords<'_>,
    j0: usize,
    point: (Real, Real, Real),
    h2: Real,
) -> u32 {
    let Coords { xs, ys, zs } = coords;
    let xi = Vector::new(point.0, point.1, point.2);
    let mut mask = 0u32;
    for k in 0..BLOCK {
        let j = j0 + k;
        // Padding entries are at infinity: their image is NaN, which fails the test.
        let d = sep.sep(xi, Vector::new(xs[j], ys[j], zs[j]));
        mask |= ((d.length_squared() < h2) as u32) << k;
    }
    mask
}

/// The sorted particles' coordinates as three flat arrays, each with [`PAD`] entries at
/// infinity after the last particle (a block may run past it).
#[derive(Copy, Clone)]
struct Coords<'a> {
    xs: &'a [Real],
    ys: &'a [Real],
    zs: &'a [Real],
}

/// What the scan of a chunk reads: the grid, the coordinates, `h²`, the separation and the
/// particle count.
struct Scan<'a, S> {
    grid: &'a NeighborGrid,
    coords: Coords<'a>,
    h2: Real,
    sep: &'a S,
    n: usize,
}

/// [`scan_chunk`] compiled with AVX2 (8-lane distance tests and one 8-lane store per block).
/// The lists are the same as without it: the same arithmetic per lane, no FMA.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn scan_chunk_avx2<S: Separation>(
    c: usize,
    chunk: &mut Chunk,
    scan: &Scan<'_, S>,
    buf: &mut Vec<u32>,
) {
    scan_chunk::<S, true>(c, chunk, scan, buf)
}

/// Particles of one cell tested together against each block of candidates (they share the
/// cell's candidate ranges, so a block is loaded once for all of them).
const GROUP: usize = 4;

/// How many particles from `i` (at most [`GROUP`], before `end`) are in `cell`.
#[inline(always)]
fn group_len(grid: &NeighborGrid, i: usize, end: usize, cell: u32) -> usize {
    let mut g = 1;
    while g < GROUP && i + g < end && grid.cell_of(i + g) == cell {
        g += 1;
    }
    g
}

/// Makes room in the group scratch `buf` for `g` lists over `ranges` and returns the room
/// one list gets: every candidate plus `PAD` per range (a list's last block stores a whole
/// block past its end). Member `q` of a group writes from `q·room`, and the group's lists
/// are appended to its chunk's when the group is done ([`Group::close`]).
#[inline(always)]
fn reserve_group(buf: &mut Vec<u32>, g: usize, ranges: &super::grid::CellRanges) -> usize {
    let room: usize = ranges
        .as_slice()
        .iter()
        .map(|&(s, e)| (e - s) as usize + PAD)
        .sum();
    let need = g * room;
    if buf.len() < need {
        // One scratch per thread, grown to a power of two (at least 32 KiB): it reaches its
        // size in the first steps and is reused after (a warm step allocates nothing).
        buf.resize(need.next_power_of_two().max(SCRATCH_MIN), 0);
    }
    room
}

/// Entries the group scratch starts with (four members over 27 cells of 8 particles each,
/// their padding included, take ~1,500).
const SCRATCH_MIN: usize = 8192;

std::thread_local! {
    /// Each thread's group scratch (see [`reserve_group`]): the lists of a group are
    /// written here, each member in a room for all its candidates, then appended to the
    /// chunk's lists at their exact length. Writing them in place would leave a group's
    /// room (~20 % of the pairs at 27.8 neighbours) unused at the end of every chunk.
    static GROUP_SCRATCH: std::cell::RefCell<Vec<u32>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Appends `list` to `indices`, growing it by an eighth beyond what it needs when it is
/// full: a chunk's lists change little from one step to the next, so a warm buffer rarely
/// grows, and its capacity stays within an eighth of the pairs it holds. (Doubling held 195
/// bytes per particle for 111 bytes of lists in the step bench's dam break at 105,350
/// particles. An eighth grew again in a settling pool, tests/no_alloc.rs, while the scan
/// wrote in place and a chunk's buffer had to hold a whole group's candidates beyond its
/// lists; the lists alone vary less.)
#[inline(always)]
fn append_list(indices: &mut Vec<u32>, list: &[u32]) {
    let need = indices.len() + list.len();
    if indices.capacity() < need {
        indices.reserve_exact(need + need / 8 - indices.len());
    }
    indices.extend_from_slice(list);
}

/// The candidate ranges of the cell last asked for (consecutive particles share a cell, and
/// a cell's x neighbour reuses its window: see [`NeighborGrid::neighbor_ranges_after`]).
struct CellCache {
    cell: u32,
    ranges: CellRanges,
    window: Window,
}

impl CellCache {
    /// The cache holding the ranges of `cell` (in a periodic box with `S::PERIODIC`).
    #[inline(always)]
    fn new<S: Separation>(grid: &NeighborGrid, cell: u32) -> Self {
        let mut window = Window::default();
        let ranges = Self::find::<S>(grid, cell, &mut window);
        Self {
            cell,
            ranges,
            window,
        }
    }

    /// The ranges of `cell`.
    #[inline(always)]
    fn of<S: Separation>(&mut self, grid: &NeighborGrid, cell: u32) -> &CellRanges {
        if cell != self.cell {
            self.cell = cell;
            self.ranges = Self::find::<S>(grid, cell, &mut self.window);
        }
        &self.ranges
    }

    #[inline(always)]
    fn find<S: Separation>(grid: &NeighborGrid, cell: u32, window: &mut Window) -> CellRanges {
        if S::PERIODIC {
            grid.neighbor_ranges_after::<true>(cell, window)
        } else {
            grid.neighbor_ranges_after::<false>(cell, window)
        }
    }
}

/// Up to [`GROUP`] particles of one cell, from particle `i`, scanned together: member `q`'s
/// list is written in the group scratch from `q·room` and ends at `cursor[q]` so far.
struct Group {
    i: usize,
    g: usize,
    room: usize,
    cursor: [usize; GROUP],
}

// Indexed loops over the group, as in `scan_chunk_avx512`.
#[allow(clippy::needless_range_loop)]
impl Group {
    /// The group of `cell` from particle `i` (the chunk ending at `end`), its room reserved
    /// in the scratch `buf` for lists over `ranges` (see [`reserve_group`]).
    #[inline(always)]
    fn new(
        grid: &NeighborGrid,
        (i, end): (usize, usize),
        cell: u32,
        buf: &mut Vec<u32>,
        ranges: &CellRanges,
    ) -> Self {
        let g = group_len(grid, i, end, cell);
        let room = reserve_group(buf, g, ranges);
        let mut cursor = [0usize; GROUP];
        for q in 0..g {
            cursor[q] = q * room;
        }
        Self { i, g, room, cursor }
    }

    /// Appends each member's list to the chunk's `indices` and its end to `offsets`.
    #[inline(always)]
    fn close(&self, buf: &[u32], chunk: &mut Chunk) {
        for q in 0..self.g {
            append_list(&mut chunk.indices, &buf[q * self.room..self.cursor[q]]);
            chunk.offsets.push(chunk.indices.len() as u32);
        }
    }
}

/// Builds the lists of chunk `c` (see [`NeighborLists::build`]).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // indexed group loops, as in `scan_chunk_avx512`
fn scan_chunk<S: Separation, const AVX2: bool>(
    c: usize,
    chunk: &mut Chunk,
    scan: &Scan<'_, S>,
    buf: &mut Vec<u32>,
) {
    let start = c * CHUNK;
    let end = (start + CHUNK).min(scan.n);
    chunk.offsets.clear();
    chunk.offsets.push(0);
    chunk.indices.clear();
    // The group scratch `buf` is longer than its content: every block stores all its lanes
    // and the end advances only over the accepted ones.
    scan_groups::<S, AVX2>((start, end), chunk, scan, buf);
}

/// [`scan_chunk`]'s groups, particles `start..end`, through the group scratch `buf`.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // indexed group loops, as in `scan_chunk_avx512`
fn scan_groups<S: Separation, const AVX2: bool>(
    (start, end): (usize, usize),
    chunk: &mut Chunk,
    scan: &Scan<'_, S>,
    buf: &mut Vec<u32>,
) {
    let grid = scan.grid;
    let mut cache = CellCache::new::<S>(grid, grid.cell_of(start));
    // Up to `GROUP` particles of one cell are tested against each block of candidates in
    // turn (the block stays in registers or L1).
    let mut i = start;
    while i < end {
        let cell = grid.cell_of(i);
        let ranges = cache.of::<S>(grid, cell);
        let mut group = Group::new(grid, (i, end), cell, buf, ranges);
        let Coords { xs, ys, zs } = scan.coords;
        let mut points = [(0.0, 0.0, 0.0); GROUP];
        for q in 0..group.g {
            points[q] = (xs[i + q], ys[i + q], zs[i + q]);
        }
        for &(s, e) in ranges.as_slice() {
            let mut j0 = s as usize;
            while j0 < e as usize {
                scan_block::<S, AVX2>(scan, &mut group, &points, (j0, e as usize), buf);
                j0 += BLOCK;
            }
        }
        group.close(buf, chunk);
        i += group.g;
    }
}

/// Tests the candidates `j0..min(j0 + BLOCK, e)` for every member of `group` (at `points`),
/// appending the accepted ones to its lists in `buf`.
#[inline(always)]
fn scan_block<S: Separation, const AVX2: bool>(
    scan: &Scan<'_, S>,
    group: &mut Group,
    points: &[(Real, Real, Real); GROUP],
    (j0, e): (usize, usize),
    buf: &mut [u32],
) {
    let mut tail = u32::MAX;
    if e - j0 < BLOCK {
        tail = (1 << (e - j0)) - 1;
    }
    for (q, &point) in points.iter().enumerate().take(group.g) {
        let me = group.i + q;
        let mut mask = if S::PERIODIC {
            periodic_block_mask(scan.sep, scan.coords, j0, point, scan.h2)
        } else {
            block_mask::<AVX2>(scan.coords, j0, point, scan.h2)
        } & tail;
        // The particle itself passes the test (distance 0): drop its bit.
        if (j0..j0 + BLOCK).contains(&me) {
            mask &= !(1 << (me - j0));
        }
        let (lanes, count) = &COMPACT[mask as usize];
        let at = group.cursor[q];
        let out: &mut [u32; BLOCK] = (&mut buf[at..at + BLOCK]).try_into().unwrap();
        if AVX2 {
            store_lanes_avx2(out, j0 as u32, &COMPACT32[mask as usize]);
        } else {
            for k in 0..BLOCK {
                out[k] = j0 as u32 + lanes[k] as u32;
            }
        }
        group.cursor[q] += *count as usize;
    }
}

/// [`scan_chunk`] with AVX-512: 16 candidates per block, tested for up to four particles of
/// one cell at once (one set of loads), the accepted ones compacted in a register
/// (`vpcompressd`; the memory form is slow on some CPUs) and stored with one 16-lane store.
/// Open space only (the periodic scan is scalar). The lists are the same as
/// the other scans': the same arithmetic per lane (subtract, square, add in the same order,
/// no FMA) and the same ascending order.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,popcnt")]
// Indexed loops over the group: the same loops with `zip`/`enumerate` made the neighbour
// search 12 % slower (217 → 244 µs at 2,500 particles on one thread).
#[allow(clippy::needless_range_loop)]
unsafe fn scan_chunk_avx512<S: Separation>(
    c: usize,
    chunk: &mut Chunk,
    scan: &Scan<'_, S>,
    buf: &mut Vec<u32>,
) {
    debug_assert!(!S::PERIODIC);
    let n = scan.n;
    let Coords { xs, ys, zs } = scan.coords;
    let start = c * CHUNK;
    let end = (start + CHUNK).min(n);
    chunk.offsets.clear();
    chunk.offsets.push(0);
    chunk.indices.clear();
    // Every load of `scan_wide_block` reads `WIDE` floats from `j0 < e ≤ n`: the arrays
    // hold `n + PAD`.
    assert!(xs.len() >= n + WIDE && ys.len() >= n + WIDE && zs.len() >= n + WIDE);
    // SAFETY: AVX-512F is enabled here as there.
    unsafe { scan_groups_avx512((start, end), chunk, scan, buf) };
}

/// [`scan_chunk_avx512`]'s groups, particles `start..end`, through the group scratch `buf`.
///
/// # Safety
/// The CPU must support AVX-512F, and the coordinate arrays must hold `n + WIDE` entries.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,popcnt")]
#[allow(clippy::needless_range_loop)] // indexed group loops (see `scan_chunk_avx512`)
unsafe fn scan_groups_avx512<S: Separation>(
    (start, end): (usize, usize),
    chunk: &mut Chunk,
    scan: &Scan<'_, S>,
    buf: &mut Vec<u32>,
) {
    use std::arch::x86_64::*;
    let grid = scan.grid;
    let Coords { xs, ys, zs } = scan.coords;
    let mut cache = CellCache::new::<S>(grid, grid.cell_of(start));
    // Up to `GROUP` particles of one cell are tested against each block of candidates at
    // once (one set of loads for all).
    let mut i = start;
    while i < end {
        let cell = grid.cell_of(i);
        let ranges = cache.of::<S>(grid, cell);
        let mut group = Group::new(grid, (i, end), cell, buf, ranges);
        let mut points = [(
            _mm512_setzero_ps(),
            _mm512_setzero_ps(),
            _mm512_setzero_ps(),
        ); GROUP];
        for q in 0..group.g {
            points[q] = (
                _mm512_set1_ps(xs[i + q]),
                _mm512_set1_ps(ys[i + q]),
                _mm512_set1_ps(zs[i + q]),
            );
        }
        for &(s, e) in ranges.as_slice() {
            let mut j0 = s as usize;
            while j0 < e as usize {
                // SAFETY: `j0 < e ≤ n` and the arrays hold `n + WIDE` (the caller's
                // assertion); AVX-512F is enabled here as there.
                unsafe {
                    scan_wide_block(scan, &mut group, &points, (j0, e as usize), buf);
                }
                j0 += WIDE;
            }
        }
        group.close(buf, chunk);
        i += group.g;
    }
}

/// [`scan_block`] with AVX-512: the candidates `j0..min(j0 + WIDE, e)` tested for every
/// member of `group` (at `points`, broadcast) with one set of loads, the accepted ones
/// compacted in a register and stored with one 16-lane store.
///
/// # Safety
/// The CPU must support AVX-512F, and `j0 + WIDE` must not pass the coordinate arrays' end.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,popcnt")]
#[inline]
#[allow(clippy::needless_range_loop)] // indexed group loops (see `scan_chunk_avx512`)
unsafe fn scan_wide_block<S: Separation>(
    scan: &Scan<'_, S>,
    group: &mut Group,
    points: &[(
        std::arch::x86_64::__m512,
        std::arch::x86_64::__m512,
        std::arch::x86_64::__m512,
    ); GROUP],
    (j0, e): (usize, usize),
    buf: &mut [u32],
) {
    use std::arch::x86_64::*;
    let Coords { xs, ys, zs } = scan.coords;
    // SAFETY: the caller keeps `j0 + WIDE` within the arrays.
    let (bx, by, bz) = unsafe {
        (
            _mm512_loadu_ps(xs.as_ptr().add(j0)),
            _mm512_loadu_ps(ys.as_ptr().add(j0)),
            _mm512_loadu_ps(zs.as_ptr().add(j0)),
        )
    };
    let vh = _mm512_set1_ps(scan.h2);
    let mut tail = u32::MAX;
    if e - j0 < WIDE {
        tail = (1 << (e - j0)) - 1;
    }
    let lanes = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    let index = _mm512_add_epi32(_mm512_set1_epi32(j0 as i32), lanes);
    for q in 0..group.g {
        let (vx, vy, vz) = points[q];
        let dx = _mm512_sub_ps(vx, bx);
        let dy = _mm512_sub_ps(vy, by);
        let dz = _mm512_sub_ps(vz, bz);
        let d2 = _mm512_add_ps(
            _mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)),
            _mm512_mul_ps(dz, dz),
        );
        let mut mask = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(d2, vh) as u32 & tail;
        // The particle itself passes the test (distance 0): drop its bit.
        let me = group.i + q;
        if (j0..j0 + WIDE).contains(&me) {
            mask &= !(1 << (me - j0));
        }
        let packed = _mm512_maskz_compress_epi32(mask as __mmask16, index);
        // Each member's region holds `PAD = WIDE` entries of slack per range: a block
        // starts at most `e − s − 1` entries past its range's start and stores `WIDE`.
        let at = group.cursor[q];
        debug_assert!(at + WIDE <= buf.len());
        // SAFETY: `at + WIDE ≤ (q + 1)·room ≤ buf.len()` (see `reserve_group`: the room
        // counts every candidate and `PAD` per range); unaligned store of 16 u32.
        unsafe { _mm512_storeu_si512(buf.as_mut_ptr().add(at) as *mut __m512i, packed) };
        group.cursor[q] += mask.count_ones() as usize;
    }
}

impl NeighborLists {
    /// Rebuilds the lists for sorted `positions` over `grid` with support radius `h`.
    pub fn build(&mut self, grid: &NeighborGrid, positions: &[Vector], h: Real) {
        self.build_owned(grid, positions, (h, Open), Isa::best(false));
    }

    /// [`Self::build`] in a periodic box, over a grid sorted by
    /// [`NeighborGrid::sort_periodic`]: distances are minimum images, so particles across a
    /// face (or edge, or corner) of the box are neighbours.
    pub fn build_periodic(
        &mut self,
        grid: &NeighborGrid,
        positions: &[Vector],
        h: Real,
        domain: MinimumImage,
    ) {
        self.build_owned(grid, positions, (h, domain), Isa::best(true));
    }

    /// [`Self::build`] (or [`Self::build_periodic`] with a `domain`) with the coordinates'
    /// flat copies in `scratch`, a buffer idle during the build, when it holds
    /// [`Self::coords_len`] entries (else in a buffer of the lists' own).
    pub(crate) fn build_in(
        &mut self,
        grid: &NeighborGrid,
        positions: &[Vector],
        (h, domain): (Real, Option<MinimumImage>),
        scratch: &mut [Real],
    ) {
        let need = Self::coords_len(positions.len());
        match (domain, scratch.len() >= need) {
            (None, true) => self.build_with(grid, positions, (h, Open), Isa::best(false), scratch),
            (Some(d), true) => self.build_with(grid, positions, (h, d), Isa::best(true), scratch),
            (None, false) => self.build(grid, positions, h),
            (Some(d), false) => self.build_periodic(grid, positions, h, d),
        }
    }

    /// Entries of the coordinates' flat copies for `n` particles: three arrays of `n` and
    /// [`PAD`] entries of padding.
    pub(crate) fn coords_len(n: usize) -> usize {
        3 * (n + PAD)
    }

    /// [`Self::build_with`] with the coordinates in the lists' own buffer.
    fn build_owned<S: Separation>(
        &mut self,
        grid: &NeighborGrid,
        positions: &[Vector],
        (h, sep): (Real, S),
        isa: Isa,
    ) {
        let mut coords = std::mem::take(&mut self.coords);
        coords.resize(Self::coords_len(positions.len()), 0.0);
        self.build_with(grid, positions, (h, sep), isa, &mut coords);
        self.coords = coords;
    }

    /// Builds the lists with the coordinates' flat copies written to `coords` (at least
    /// [`Self::coords_len`] entries; whatever they held is overwritten).
    #[inline(always)]
    fn build_with<S: Separation>(
        &mut self,
        grid: &NeighborGrid,
        positions: &[Vector],
        (h, sep): (Real, S),
        isa: Isa,
        coords: &mut [Real],
    ) {
        let n = positions.len();
        self.len = n;
        // Coordinates as three flat arrays, so the candidate test below runs on a block of
        // candidates at once (SIMD) instead of one 12-byte vector at a time. Each array has
        // PAD entries of padding at infinity, so a block may run past the last particle.
        let (xs, rest) = coords[..Self::coords_len(n)].split_at_mut(n + PAD);
        let (ys, zs) = rest.split_at_mut(n + PAD);
        crate::par_chunks_mut!(xs[..n], CHUNK)
            .zip(crate::par_chunks_mut!(ys[..n], CHUNK))
            .zip(crate::par_chunks_mut!(zs[..n], CHUNK))
            .enumerate()
            .for_each(|(c, ((x, y), z))| {
                for (k, p) in positions[c * CHUNK..c * CHUNK + x.len()].iter().enumerate() {
                    x[k] = p.x;
                    y[k] = p.y;
                    z[k] = p.z;
                }
            });
        for a in [&mut *xs, &mut *ys, &mut *zs] {
            a[n..].fill(Real::INFINITY);
        }
        self.chunks.resize_with(n.div_ceil(CHUNK), Chunk::default);
        let h2 = h * h;
        let scan = Scan {
            grid,
            coords: Coords { xs, ys, zs },
            h2,
            sep: &sep,
            n,
        };
        // A periodic scan is always scalar (`Isa::best(true)`).
        let isa = if S::PERIODIC { Isa::Portable } else { isa };
        // The group scratch is borrowed here, outside the functions compiled for AVX2 or
        // AVX-512, so that the whole scan inlines into them.
        crate::par_iter_mut!(self.chunks)
            .enumerate()
            .for_each(|(c, chunk)| {
                GROUP_SCRATCH.with_borrow_mut(|buf| match isa {
                    // SAFETY: `Isa::best` chose these after run-time detection (the unit
                    // test asks only for what the CPU has).
                    #[cfg(target_arch = "x86_64")]
                    Isa::Avx512 => unsafe { scan_chunk_avx512(c, chunk, &scan, buf) },
                    #[cfg(target_arch = "x86_64")]
                    Isa::Avx2 => unsafe { scan_chunk_avx2(c, chunk, &scan, buf) },
                    _ => scan_chunk::<S, false>(c, chunk, &scan, buf),
                });
                // The lists' invariant, which the solvers' pair passes read their
                // neighbours' values by without a check per pair (see `Self::len`).
                let top = chunk.indices.iter().fold(0, |m: u32, &j| m.max(j));
                assert!(
                    chunk.indices.is_empty() || (top as usize) < n,
                    "a neighbour index beyond the particles"
                );
            });
    }

    /// Neighbours of particle `i`.
    #[inline(always)]
    pub fn of(&self, i: usize) -> &[u32] {
        let chunk = &self.chunks[i / CHUNK];
        let k = i % CHUNK;
        &chunk.indices[chunk.offsets[k] as usize..chunk.offsets[k + 1] as usize]
    }

    /// The lists of chunk `c` (particles `c·CHUNK..`): `offsets` (one more than the chunk's
    /// particles; particle `k`'s neighbours are `indices[offsets[k]..offsets[k + 1]]`) and
    /// `indices`.
    #[inline(always)]
    pub(crate) fn chunk(&self, c: usize) -> (&[u32], &[u32]) {
        let chunk = &self.chunks[c];
        (&chunk.offsets, &chunk.indices)
    }

    /// Number of particles the lists were built for; every listed index is below it (checked
    /// by each build), which lets the solvers' pair passes read a neighbour's value without
    /// a bounds check per pair.
    pub fn len(&self) -> usize {
        self.len
    }

    /// `true` when built for no particle.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Total number of (directed) neighbour pairs.
    pub fn total_pairs(&self) -> usize {
        self.chunks
            .iter()
            .map(|c| *c.offsets.last().unwrap_or(&0) as usize)
            .sum()
    }

    /// Heap bytes held by the lists.
    pub fn heap_bytes(&self) -> usize {
        self.chunks
            .iter()
            .map(|c| c.offsets.capacity() * 4 + c.indices.capacity() * 4)
            .sum::<usize>()
            + self.chunks.capacity() * std::mem::size_of::<Chunk>()
            + self.coords.capacity() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vector scans the CPU runs.
    fn available() -> Vec<Isa> {
        let mut out = Vec::new();
        if crate::par::has_avx2() {
            out.push(Isa::Avx2);
        }
        if crate::par::has_avx512() && crate::par::has_popcnt() {
            out.push(Isa::Avx512);
        }
        out
    }

    /// The AVX2 and AVX-512 scans (those the CPU has) and the SSE2/scalar scan give the
    /// same lists, on clouds near and far from the origin, with particles on cell borders.
    #[test]
    fn vector_and_portable_scans_give_the_same_lists() {
        let h = 0.1;
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as Real / (1u64 << 24) as Real
        };
        for center in [
            Vector::ZERO,
            Vector::new(-3.05, 0.2, 7.0),
            Vector::new(1.0e4, -2.0e3, 5.0e2),
        ] {
            let mut positions: Vec<Vector> = (0..3000)
                .map(|_| center + Vector::new(next(), next(), next()) * 0.6)
                .collect();
            // Some exactly on cell borders, some coincident.
            let c = (center / h).floor() * h;
            for (k, p) in positions.iter_mut().enumerate().take(50) {
                *p = c + Vector::new((k % 5) as Real * h, 0.0, (k / 10) as Real * h);
            }
            positions[100] = positions[101];
            let mut grid = NeighborGrid::default();
            grid.sort(&positions, h);
            let sorted: Vec<Vector> = grid
                .permutation()
                .iter()
                .map(|&(_, i)| positions[i as usize])
                .collect();
            grid.build_cells();
            let mut portable = NeighborLists::default();
            portable.build_owned(&grid, &sorted, (h, Open), Isa::Portable);
            assert!(portable.total_pairs() > 0);
            for isa in available() {
                let mut wide = NeighborLists::default();
                wide.build_owned(&grid, &sorted, (h, Open), isa);
                assert_eq!(wide.total_pairs(), portable.total_pairs(), "{isa:?}");
                for i in 0..sorted.len() {
                    assert_eq!(
                        wide.of(i),
                        portable.of(i),
                        "{isa:?}: particle {i} near {center:?}"
                    );
                }
            }
        }
    }
}
