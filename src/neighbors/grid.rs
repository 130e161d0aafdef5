use crate::domain::MinimumImage;
use crate::math::{Real, Vector};
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

const BITS: u32 = 21;
const MASK: u64 = (1 << BITS) - 1;
const EMPTY: u32 = u32::MAX;
/// Set on a sort key (above the 63 bits of a cell key) while sorting: the particle left
/// the cell it was in at the previous sort (see `NeighborGrid::merge_movers`).
const MOVED: u64 = 1 << 63;

/// A cell's integer coordinates packed into one key: `z` major, `x` minor, each wrapped to
/// 21 bits. Sorting by key gathers particles cell by cell, with x-neighbouring cells adjacent.
#[inline(always)]
fn pack(cx: u64, cy: u64, cz: u64) -> u64 {
    ((cz & MASK) << (2 * BITS)) | ((cy & MASK) << BITS) | (cx & MASK)
}

/// Cells are this much larger than `h` (relatively), so that two particles closer than `h`
/// (as the f32 distance test sees it) always fall in the same or adjacent cells.
const CELL_MARGIN: f64 = 1e-5;

#[inline(always)]
fn cell_key(p: Vector, inv_cell: f64) -> u64 {
    // In f64: `floor(x / cell)` is then exact to ~1e-16 relative at any f32 coordinate, far
    // inside the 1e-5 margin; in f32 a coordinate within 1e-7·h of a cell border could land
    // two cells away from a neighbour. `as i64` saturates (NaN gives 0): any input is a key.
    let cx = floor_i64(p.x as f64 * inv_cell) as u64;
    let cy = floor_i64(p.y as f64 * inv_cell) as u64;
    let cz = floor_i64(p.z as f64 * inv_cell) as u64;
    pack(cx, cy, cz)
}

/// `x.floor() as i64` without the `floor` library call (x86-64 without SSE4.1 has no
/// rounding instruction): the same value for every input, NaN (0) and saturation included.
#[inline(always)]
fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    t.saturating_sub(((t as f64) > x) as i64)
}

/// The memory of `keys` (its `len · 16` bytes) as `4 · len` reals, zeroed.
///
/// A `(u64, u32)` entry has 4 bytes of padding, which need not be initialised; every byte
/// is written with zero first so the reals are initialised values (16 bytes a particle
/// written once per build: small beside the scan).
pub(crate) fn keys_as_reals(keys: &mut Vec<(u64, u32)>) -> &mut [Real] {
    const _: () = assert!(std::mem::size_of::<(u64, u32)>() == 4 * std::mem::size_of::<Real>());
    let len = keys.len();
    let bytes = len * std::mem::size_of::<(u64, u32)>();
    // SAFETY: the pointer is the vector's own allocation, valid for `len` entries; writing
    // zero bytes through a byte pointer initialises every byte, padding included, and zero
    // bytes are a valid `u64`, `u32` and `f32`. The slice then covers those `bytes`
    // initialised bytes (aligned to 8 ≥ 4) and borrows the vector mutably for as long as it
    // lives; any bit pattern the reals leave is a valid `u64` or `u32` for the next sort,
    // which rewrites every entry.
    unsafe {
        std::ptr::write_bytes(keys.as_mut_ptr() as *mut u8, 0, bytes);
        std::slice::from_raw_parts_mut(keys.as_mut_ptr() as *mut Real, 4 * len)
    }
}

/// Contiguous particle index ranges covering the 27 cells around one cell.
#[derive(Copy, Clone, Debug)]
pub struct CellRanges {
    ranges: [(u32, u32); 27],
    len: usize,
}

impl CellRanges {
    /// The ranges `start..end` of sorted particle indices.
    #[inline(always)]
    pub fn as_slice(&self) -> &[(u32, u32)] {
        &self.ranges[..self.len]
    }
}

/// The cells found around the last cell of a neighbour search (see
/// [`NeighborGrid::neighbor_ranges_after`]): per row of cells (fixed y and z offsets) the
/// indices of its cells x−1, x and x+1 (`EMPTY` when absent).
#[derive(Copy, Clone, Debug)]
pub(crate) struct Window {
    valid: bool,
    key: u64,
    /// The x coordinate of the last cell's x+1 neighbour.
    next_x: u64,
    cells: [[u32; 3]; 9],
}

impl Default for Window {
    fn default() -> Self {
        Self {
            valid: false,
            key: 0,
            next_x: 0,
            cells: [[EMPTY; 3]; 9],
        }
    }
}

/// An unbounded uniform grid over sorted particles. See the [module docs](super).
#[derive(Clone, Debug, Default)]
pub struct NeighborGrid {
    inv_cell: f64,
    cell_size: Real,
    /// `(cell key, index before sorting)` for every particle, sorted by key after [`Self::sort`].
    sort_keys: Vec<(u64, u32)>,
    /// Key of each occupied cell, ascending.
    cell_keys: Vec<u64>,
    /// `cell_starts[c]..cell_starts[c + 1]` are the (sorted) particles of cell `c`.
    cell_starts: Vec<u32>,
    /// Cell index of each sorted particle.
    particle_cells: Vec<u32>,
    /// Open-addressing hash table from cell key to cell index (`EMPTY` marks free slots):
    /// a slot holds the index only, its key is `cell_keys[index]` (4 bytes a slot, not 16:
    /// ~4 bytes per particle less at 7 particles a cell).
    table: Vec<u32>,
    table_mask: usize,
    /// `64 − log2(table length)`: the hash keeps the product's top bits.
    table_shift: u32,
    /// Set by [`Self::sort_periodic`]: the cells tile a periodic box.
    periodic: Option<PeriodicCells>,
    /// Scratch: the particles that changed cell (see `merge_movers`).
    movers: Vec<(u64, u32)>,
    /// Set by [`Self::build_cells`], cleared by a sort: the cells are those of the sort
    /// keys, which may then be overwritten ([`Self::take_idle_keys`]).
    cells_built: bool,
}

/// The cells of a periodic box: `n[a]` cells along axis `a`, each `1/inv_cell[a] ≥ h` long,
/// dividing the box's edge exactly.
#[derive(Copy, Clone, Debug)]
struct PeriodicCells {
    min: [f64; 3],
    inv_cell: [f64; 3],
    n: [u64; 3],
}

impl PeriodicCells {
    fn new(domain: &MinimumImage, h: Real) -> Self {
        let mut out = Self {
            min: [0.0; 3],
            inv_cell: [0.0; 3],
            n: [0; 3],
        };
        for a in 0..3 {
            let len = domain.max[a] as f64 - domain.min[a] as f64;
            // As many cells as fit with the open grid's margin (at least 3: the domain's
            // validation asks for edges of at least 3·h), at most 2^20 (keys hold 21 bits).
            let n = (len / (h as f64 * (1.0 + CELL_MARGIN))).floor();
            let n = n.clamp(3.0, (1u64 << 20) as f64) as u64;
            out.min[a] = domain.min[a] as f64;
            out.inv_cell[a] = n as f64 / len;
            out.n[a] = n;
        }
        out
    }

    /// The key of the cell holding `p`, wrapped into the box (any input gives a key).
    #[inline(always)]
    fn key(&self, p: Vector) -> u64 {
        let c = |a: usize, x: Real| {
            let k = ((x as f64 - self.min[a]) * self.inv_cell[a]).floor() as i64;
            k.rem_euclid(self.n[a] as i64) as u64
        };
        pack(c(0, p.x), c(1, p.y), c(2, p.z))
    }
}

impl NeighborGrid {
    /// Computes cell keys for `positions` and sorts them. Returns `true` when the order
    /// changed; then [`Self::permutation`] tells where each particle goes.
    pub fn sort(&mut self, positions: &[Vector], cell_size: Real) -> bool {
        self.periodic = None;
        self.cell_size = cell_size;
        self.inv_cell = 1.0 / (cell_size as f64 * (1.0 + CELL_MARGIN));
        let inv = self.inv_cell;
        self.fill_keys(positions, |p| cell_key(p, inv))
    }

    /// Writes `(key(positions[i]), i)` for every particle, flagged [`MOVED`] when the
    /// particle is not in the cell [`Self::build_cells`] last put it in (when that was done
    /// for as many particles), then sorts them.
    fn fill_keys(&mut self, positions: &[Vector], key: impl Fn(Vector) -> u64 + Sync) -> bool {
        let n = positions.len();
        self.cells_built = false;
        let previous = self.particle_cells.len() == n && !self.cell_keys.is_empty();
        self.sort_keys.resize(n, (0, 0));
        let (cell_keys, particle_cells) = (&self.cell_keys, &self.particle_cells);
        crate::par_chunks_mut!(self.sort_keys, CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                let base = c * CHUNK;
                for (k, o) in out.iter_mut().enumerate() {
                    let i = base + k;
                    let key = key(positions[i]);
                    let moved = previous && cell_keys.get(particle_cells[i] as usize) != Some(&key);
                    *o = (key | ((moved as u64) << 63), i as u32);
                }
            });
        if previous && let Some(reordered) = self.merge_movers() {
            return reordered;
        }
        if previous {
            crate::par_chunks_mut!(self.sort_keys, CHUNK).for_each(|out| {
                for o in out {
                    o.0 &= !MOVED;
                }
            });
        }
        self.sort_by_key()
    }

    /// [`Self::sort`] for a periodic box: cells at least `h` long that divide each edge of the
    /// box exactly, their coordinates wrapped modulo the number of cells per axis, so the
    /// cells across a face are neighbours. Positions outside the box (a prediction that
    /// left it) fall in the cell of their periodic image.
    pub fn sort_periodic(&mut self, positions: &[Vector], h: Real, domain: &MinimumImage) -> bool {
        let cells = PeriodicCells::new(domain, h);
        self.periodic = Some(cells);
        self.cell_size = h;
        self.inv_cell = cells.inv_cell[0];
        self.fill_keys(positions, |p| cells.key(p))
    }

    /// `true` when the last sort was [`Self::sort_periodic`].
    pub fn is_periodic(&self) -> bool {
        self.periodic.is_some()
    }

    fn sort_by_key(&mut self) -> bool {
        // Already sorted (a fluid at rest, or a second call): nothing to move.
        if self.sort_keys.windows(2).all(|w| w[0] <= w[1]) {
            return false;
        }
        // Keys are unique (the index breaks ties), so the unstable sort is deterministic.
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            self.sort_keys.par_sort_unstable();
        }
        #[cfg(not(feature = "parallel"))]
        self.sort_keys.sort_unstable();
        true
    }

    /// Sorts keys flagged by [`Self::fill_keys`] when few particles changed cell (the usual
    /// step): those that stayed in their cell are still in order, so only the others (the
    /// movers, `m` of them) are sorted, then merged in: O(n + m log m) and serial, against a
    /// parallel sort of all `n` (the dam break at 2,500 particles on 2 threads: ~40 movers a
    /// step, the neighbour search stage 162 → 150 µs). Returns whether the order changed, or
    /// `None` when it does not apply (more than an eighth of the particles moved, or those
    /// that stayed are not in order: the arrays changed since the last sort), with every key
    /// back in the array, in some order. The result is the sorted order either way: keys are
    /// unique and the kept run is checked to ascend.
    fn merge_movers(&mut self) -> Option<bool> {
        let n = self.sort_keys.len();
        let limit = n / 8;
        let mut movers = std::mem::take(&mut self.movers);
        movers.clear();
        let keys = &mut self.sort_keys[..];
        // Up to the first mover nothing moves: just check the order.
        let mut r = 0;
        let mut last = (0, 0);
        let mut give_up = false;
        while r < n {
            let e = keys[r];
            if e.0 & MOVED != 0 {
                break;
            }
            give_up |= r > 0 && last >= e;
            last = e;
            r += 1;
        }
        // Then the particles that stayed go to the front, in order; the movers aside.
        let first_mover = r;
        let mut kept = r;
        while r < n && !give_up {
            let e = keys[r];
            if e.0 & MOVED != 0 {
                movers.push((e.0 & !MOVED, e.1));
                give_up = movers.len() > limit;
            } else {
                give_up = kept > 0 && last >= e;
                last = e;
                keys[kept] = e;
                kept += 1;
            }
            r += 1;
        }
        if give_up {
            // Slots `kept..kept + movers.len()` are exactly the movers' (every key read so
            // far went to one side or the other): put them back.
            keys[kept..kept + movers.len()].copy_from_slice(&movers);
            self.movers = movers;
            return None;
        }
        if movers.is_empty() {
            self.movers = movers;
            return Some(false);
        }
        movers.sort_unstable();
        // Merge from the back: the write slot never falls below the kept run's read slot.
        // The kept keys above the largest mover shift up as one block.
        let top = movers[movers.len() - 1];
        let above = keys[..kept].partition_point(|e| *e < top);
        let shift = movers.len();
        keys.copy_within(above..kept, above + shift);
        let (mut a, mut b) = (above, shift);
        let mut out = above + shift;
        while b > 0 {
            out -= 1;
            if a > 0 && keys[a - 1] > movers[b - 1] {
                keys[out] = keys[a - 1];
                a -= 1;
            } else {
                keys[out] = movers[b - 1];
                b -= 1;
            }
        }
        self.movers = movers;
        // A mover may land where it was (the order is then unchanged).
        let changed = keys[first_mover..]
            .iter()
            .zip(first_mover..)
            .any(|(e, k)| e.1 as usize != k);
        Some(changed)
    }

    /// `(key, old index)` of every particle in sorted order: sorted particle `k` was particle
    /// `permutation()[k].1` before [`Self::sort`].
    pub fn permutation(&self) -> &[(u64, u32)] {
        &self.sort_keys
    }

    /// [`Self::permutation`], and the buffer of each particle's cell as a scratch: between a
    /// sort and [`Self::build_cells`] it is not read, and `build_cells` rewrites it whole (to
    /// the sorted count), whatever it then holds. The re-sort swaps the ids through it.
    pub(crate) fn permutation_and_cells(&mut self) -> (&[(u64, u32)], &mut Vec<u32>) {
        (&self.sort_keys, &mut self.particle_cells)
    }

    /// The sort keys, taken out once the cells are built (empty before): they are not read
    /// again until the next sort rewrites them, so the neighbour lists' build writes its
    /// flat coordinates in their memory ([`keys_as_reals`]: 12 bytes per particle that no
    /// buffer of its own holds). Give them back with [`Self::put_back_keys`];
    /// [`Self::permutation`] is meaningless until the next sort.
    pub(crate) fn take_idle_keys(&mut self) -> Vec<(u64, u32)> {
        if !self.cells_built {
            return Vec::new();
        }
        std::mem::take(&mut self.sort_keys)
    }

    /// Returns the keys [`Self::take_idle_keys`] took (an empty vector when it took none
    /// leaves the keys in place).
    pub(crate) fn put_back_keys(&mut self, keys: Vec<(u64, u32)>) {
        if keys.capacity() > 0 {
            self.sort_keys = keys;
        }
    }

    /// Reserves the buffer of each particle's cell (see [`Self::permutation_and_cells`])
    /// for `capacity` particles. A failed reservation is left to its own growth.
    pub(crate) fn reserve(&mut self, capacity: usize) {
        let cells = &mut self.particle_cells;
        let _ = cells.try_reserve_exact(capacity.saturating_sub(cells.len()));
    }

    /// Builds the cell ranges and the hash table. Call after [`Self::sort`] and after the
    /// per-particle arrays were permuted.
    /// A second call before the next sort changes nothing (the keys are the same) and
    /// returns at once.
    pub fn build_cells(&mut self) {
        if self.cells_built {
            return;
        }
        self.cells_built = true;
        let n = self.sort_keys.len();
        self.cell_keys.clear();
        self.cell_starts.clear();
        self.particle_cells.resize(n, 0);
        for (i, &(key, _)) in self.sort_keys.iter().enumerate() {
            if self.cell_keys.last() != Some(&key) {
                self.cell_keys.push(key);
                self.cell_starts.push(i as u32);
            }
            self.particle_cells[i] = (self.cell_keys.len() - 1) as u32;
        }
        self.cell_starts.push(n as u32);

        let capacity = (2 * self.cell_keys.len()).next_power_of_two().max(16);
        self.table.clear();
        self.table.resize(capacity, EMPTY);
        self.table_mask = capacity - 1;
        self.table_shift = 64 - capacity.trailing_zeros();
        for (c, &key) in self.cell_keys.iter().enumerate() {
            let mut slot = self.hash(key);
            while self.table[slot] != EMPTY {
                slot = (slot + 1) & self.table_mask;
            }
            self.table[slot] = c as u32;
        }
    }

    /// Fibonacci hashing: the top bits of `key·2⁶⁴/φ` (every key bit reaches them; the
    /// product's middle bits would ignore the z coordinate of small tables and chain every
    /// column of cells into one probe sequence).
    #[inline(always)]
    fn hash(&self, key: u64) -> usize {
        (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> self.table_shift) as usize
    }

    /// The index of the occupied cell with this key, if any.
    #[inline(always)]
    pub fn find_cell(&self, key: u64) -> Option<u32> {
        if self.cell_keys.is_empty() {
            return None;
        }
        let mut slot = self.hash(key);
        loop {
            let c = self.table[slot];
            if c == EMPTY {
                return None;
            }
            if self.cell_keys[c as usize] == key {
                return Some(c);
            }
            slot = (slot + 1) & self.table_mask;
        }
    }

    /// Number of occupied cells.
    pub fn num_cells(&self) -> usize {
        self.cell_keys.len()
    }

    /// Cell size (the kernel support `h`).
    pub fn cell_size(&self) -> Real {
        self.cell_size
    }

    /// Sorted-particle range `start..end` of cell `c`.
    #[inline(always)]
    pub fn cell_range(&self, c: u32) -> (u32, u32) {
        (
            self.cell_starts[c as usize],
            self.cell_starts[c as usize + 1],
        )
    }

    /// The cell of sorted particle `i`.
    #[inline(always)]
    pub fn cell_of(&self, i: usize) -> u32 {
        self.particle_cells[i]
    }

    /// Particle ranges of the (up to) 27 occupied cells around cell `c`, adjacent ranges
    /// merged. The ranges come in ascending order.
    pub fn neighbor_ranges(&self, c: u32) -> CellRanges {
        self.neighbor_ranges_of::<false>(c, &mut Window::default())
    }

    /// [`Self::neighbor_ranges`] in a periodic box (after [`Self::sort_periodic`]): the
    /// cells across a face are the neighbours of the cells on it.
    pub fn periodic_neighbor_ranges(&self, c: u32) -> CellRanges {
        self.neighbor_ranges_of::<true>(c, &mut Window::default())
    }

    /// [`Self::neighbor_ranges`] (or its periodic form), reusing the cells `window` found
    /// around the previous cell when `c` is its neighbour along x (the usual case: cells are
    /// sorted x-minor): the rows around `c` are then those around the previous cell shifted
    /// by one, and only their new end cells are looked for, next to the cells already found
    /// (no hash lookup, which at 100,000 particles is a cache miss). Same ranges as a fresh
    /// call.
    #[inline(always)]
    pub(crate) fn neighbor_ranges_after<const PERIODIC: bool>(
        &self,
        c: u32,
        window: &mut Window,
    ) -> CellRanges {
        self.neighbor_ranges_of::<PERIODIC>(c, window)
    }

    /// Kept whole (88 lines): split into the row search, the axis wrap and the range merge
    /// (each `#[inline(always)]`), the neighbour search measured 166 [162-169] µs against
    /// main's 160 [158-165]; whole, 163 [161-167] against 164 [158-166] (`cargo run --release
    /// --example stage_medians -- 2500 1500 1`, 6 runs each alternated with main's build on
    /// one core).
    #[inline(always)]
    fn neighbor_ranges_of<const PERIODIC: bool>(&self, c: u32, window: &mut Window) -> CellRanges {
        let key = self.cell_keys[c as usize];
        let (x, y, z) = (key & MASK, (key >> BITS) & MASK, (key >> (2 * BITS)) & MASK);
        let mut out = CellRanges {
            ranges: [(0, 0); 27],
            len: 0,
        };
        // Coordinates of the cell before and after along each axis: modulo 2^21 (adding
        // MASK is subtracting 1) in open space, modulo the cell count in a periodic box.
        let around = |v: u64, a: usize| -> [u64; 3] {
            if PERIODIC {
                let n = self.periodic.map_or(1 << BITS, |p| p.n[a]);
                [(v + n - 1) % n, v, (v + 1) % n]
            } else {
                [v.wrapping_add(MASK), v, v.wrapping_add(1)]
            }
        };
        let (xs, ys, zs) = (around(x, 0), around(y, 1), around(z, 2));
        // The previous cell was this one's x−1 neighbour: its rows' cells x and x+1 are
        // this cell's x−1 and x.
        let slide = window.valid && window.key & !MASK == key & !MASK && window.next_x == x;
        let n_cells = self.cell_keys.len();
        let mut row = 0;
        for cz in zs {
            for cy in ys {
                // Keys are sorted and the row's keys ascend (but where coordinates wrap):
                // after a cell `pc` of key `pk` was found, a larger key of the same row, with
                // the keys between them looked up and absent, can only be cell `pc + 1`.
                let mut prev: Option<(u32, u64)> = None;
                // The row's cells are found in place in the window, entry by entry: a
                // local array copied there whole after 4-byte writes made an 8-byte read of
                // 4-byte stores (a store-forwarding stall per row: 11 % of the scan's time
                // at 100,000 particles).
                let cells = &mut window.cells[row];
                let first = if slide {
                    (cells[0], cells[1], cells[2]) = (cells[1], cells[2], EMPTY);
                    for k in 0..2 {
                        if cells[k] != EMPTY {
                            prev = Some((cells[k], pack(xs[k], cy, cz)));
                        } else if prev.is_some_and(|(_, pk)| pack(xs[k], cy, cz) < pk) {
                            prev = None;
                        }
                    }
                    2
                } else {
                    *cells = [EMPTY; 3];
                    0
                };
                for (k, &cx) in xs.iter().enumerate().skip(first) {
                    let key = pack(cx, cy, cz);
                    let found = match prev {
                        Some((pc, pk)) if key > pk => {
                            let next = pc as usize + 1;
                            (next < n_cells && self.cell_keys[next] == key).then_some(next as u32)
                        }
                        _ => {
                            prev = None;
                            self.find_cell(key)
                        }
                    };
                    if let Some(n) = found {
                        prev = Some((n, key));
                        cells[k] = n;
                    }
                }
                row += 1;
                for &n in cells.iter() {
                    if n != EMPTY {
                        let (s, e) = self.cell_range(n);
                        if out.len > 0 && out.ranges[out.len - 1].1 == s {
                            out.ranges[out.len - 1].1 = e;
                        } else {
                            out.ranges[out.len] = (s, e);
                            out.len += 1;
                        }
                    }
                }
            }
        }
        window.valid = true;
        window.key = key;
        window.next_x = xs[2];
        // Wrapped cells (coordinates near ±2^20 cells) can come out of order: keep the
        // ranges sorted so neighbour lists are always in ascending index order.
        let ranges = &mut out.ranges[..out.len];
        if !ranges.is_sorted() {
            ranges.sort_unstable();
        }
        out
    }

    /// Heap bytes held by the grid (for the memory figures).
    pub fn heap_bytes(&self) -> usize {
        self.sort_keys.capacity() * 16
            + self.cell_keys.capacity() * 8
            + self.cell_starts.capacity() * 4
            + self.particle_cells.capacity() * 4
            + self.table.capacity() * 4
            + self.movers.capacity() * 16
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid sorted before (the particles moved since, a few changing cell, as in a step)
    /// sorts them exactly as a fresh grid does, whether it merges the movers or falls back
    /// to a full sort (many movers; particles reordered behind its back; a new count).
    #[test]
    fn resorting_after_a_move_matches_a_fresh_sort() {
        let h = 0.1;
        let mut seed = 0x853C_49E6_748F_EA9Bu64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as Real / (1u64 << 24) as Real
        };
        let mut positions: Vec<Vector> = (0..2000)
            .map(|_| Vector::new(next(), next(), next()) - Vector::splat(0.5))
            .collect();
        let mut grid = NeighborGrid::default();
        let apply = |grid: &NeighborGrid, p: &mut Vec<Vector>| {
            *p = grid
                .permutation()
                .iter()
                .map(|&(_, i)| p[i as usize])
                .collect();
        };
        grid.sort(&positions, h);
        apply(&grid, &mut positions);
        grid.build_cells();
        // (fraction of particles moved, how far, reverse the arrays first)
        let mut merged = 0;
        for (fraction, step, reverse) in [
            (0.0, 0.0, false),
            (0.02, 0.05, false),
            (0.05, 0.3, false),
            (0.02, 2.0, false),
            (0.001, 0.02, false),
            (0.5, 0.2, false),
            (0.02, 0.05, true),
        ] {
            for p in positions.iter_mut() {
                if next() < fraction {
                    *p += (Vector::new(next(), next(), next()) - Vector::splat(0.5)) * step;
                }
            }
            if reverse {
                positions.reverse();
            }
            let mut fresh = NeighborGrid::default();
            let fresh_changed = fresh.sort(&positions, h);
            let changed = grid.sort(&positions, h);
            assert_eq!(grid.permutation(), fresh.permutation(), "{fraction} {step}");
            assert_eq!(changed, fresh_changed, "{fraction} {step}");
            merged += usize::from(!grid.movers.is_empty() && fraction < 0.1 && !reverse);
            apply(&grid, &mut positions);
            grid.build_cells();
        }
        // The merge itself ran (not only the full sort).
        assert!(merged >= 3, "merged {merged} times");
        // Another particle count: the previous cells do not apply.
        positions.truncate(1500);
        let mut fresh = NeighborGrid::default();
        fresh.sort(&positions, h);
        grid.sort(&positions, h);
        assert_eq!(grid.permutation(), fresh.permutation());
    }
}
