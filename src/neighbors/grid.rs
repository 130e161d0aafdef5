use crate::math::{Real, Vector};
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

const BITS: u32 = 21;
const MASK: u64 = (1 << BITS) - 1;
const EMPTY: u32 = u32::MAX;

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
    let cx = (p.x as f64 * inv_cell).floor() as i64 as u64;
    let cy = (p.y as f64 * inv_cell).floor() as i64 as u64;
    let cz = (p.z as f64 * inv_cell).floor() as i64 as u64;
    pack(cx, cy, cz)
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
    /// Open-addressing hash table from cell key to cell index (`EMPTY` marks free slots).
    table: Vec<(u64, u32)>,
    table_mask: usize,
    /// `64 − log2(table length)`: the hash keeps the product's top bits.
    table_shift: u32,
}

impl NeighborGrid {
    /// Computes cell keys for `positions` and sorts them. Returns `true` when the order
    /// changed; then [`Self::permutation`] tells where each particle goes.
    pub fn sort(&mut self, positions: &[Vector], cell_size: Real) -> bool {
        self.cell_size = cell_size;
        self.inv_cell = 1.0 / (cell_size as f64 * (1.0 + CELL_MARGIN));
        let inv = self.inv_cell;
        self.sort_keys.resize(positions.len(), (0, 0));
        crate::par_chunks_mut!(self.sort_keys, CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                let base = c * CHUNK;
                for (k, o) in out.iter_mut().enumerate() {
                    let i = base + k;
                    *o = (cell_key(positions[i], inv), i as u32);
                }
            });
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

    /// `(key, old index)` of every particle in sorted order: sorted particle `k` was particle
    /// `permutation()[k].1` before [`Self::sort`].
    pub fn permutation(&self) -> &[(u64, u32)] {
        &self.sort_keys
    }

    /// Builds the cell ranges and the hash table. Call after [`Self::sort`] and after the
    /// per-particle arrays were permuted.
    pub fn build_cells(&mut self) {
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
        self.table.resize(capacity, (0, EMPTY));
        self.table_mask = capacity - 1;
        self.table_shift = 64 - capacity.trailing_zeros();
        for (c, &key) in self.cell_keys.iter().enumerate() {
            let mut slot = self.hash(key);
            while self.table[slot].1 != EMPTY {
                slot = (slot + 1) & self.table_mask;
            }
            self.table[slot] = (key, c as u32);
        }
    }

    /// Fibonacci hashing: the top bits of `key·2⁶⁴/φ` (every key bit reaches them; the
    /// product's middle bits, used before, ignored the z coordinate of small tables and
    /// chained every column of cells into one probe sequence).
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
            let (k, c) = self.table[slot];
            if c == EMPTY {
                return None;
            }
            if k == key {
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
        let key = self.cell_keys[c as usize];
        let (x, y, z) = (key & MASK, (key >> BITS) & MASK, (key >> (2 * BITS)) & MASK);
        let mut out = CellRanges {
            ranges: [(0, 0); 27],
            len: 0,
        };
        for dz in [MASK, 0, 1] {
            for dy in [MASK, 0, 1] {
                for dx in [MASK, 0, 1] {
                    // Adding MASK is subtracting 1 modulo 2^21.
                    let k = pack(x.wrapping_add(dx), y.wrapping_add(dy), z.wrapping_add(dz));
                    if let Some(n) = self.find_cell(k) {
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
            + self.table.capacity() * 16
    }
}
