use super::NeighborGrid;
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
/// `h`, in ascending order (the particle itself is not listed).
///
/// Stored per chunk of [`CHUNK`] particles (one offset array and one index array each) so
/// the lists are built in parallel with no final copy and no allocation once warm.
#[derive(Clone, Debug, Default)]
pub struct NeighborLists {
    chunks: Vec<Chunk>,
    len: usize,
    xs: Vec<Real>,
    ys: Vec<Real>,
    zs: Vec<Real>,
}

/// Candidates tested together in the neighbour scan.
const BLOCK: usize = 8;

impl NeighborLists {
    /// Rebuilds the lists for sorted `positions` over `grid` with support radius `h`.
    pub fn build(&mut self, grid: &NeighborGrid, positions: &[Vector], h: Real) {
        let n = positions.len();
        self.len = n;
        // Coordinates as three flat arrays, so the candidate test below runs on several
        // candidates at once (SIMD) instead of one 12-byte vector at a time.
        self.xs.resize(n, 0.0);
        self.ys.resize(n, 0.0);
        self.zs.resize(n, 0.0);
        crate::par_chunks_mut!(self.xs, CHUNK)
            .zip(crate::par_chunks_mut!(self.ys, CHUNK))
            .zip(crate::par_chunks_mut!(self.zs, CHUNK))
            .enumerate()
            .for_each(|(c, ((x, y), z))| {
                for (k, p) in positions[c * CHUNK..c * CHUNK + x.len()].iter().enumerate() {
                    x[k] = p.x;
                    y[k] = p.y;
                    z[k] = p.z;
                }
            });
        self.chunks.resize_with(n.div_ceil(CHUNK), Chunk::default);
        let h2 = h * h;
        let (xs, ys, zs) = (&self.xs[..], &self.ys[..], &self.zs[..]);
        crate::par_iter_mut!(self.chunks)
            .enumerate()
            .for_each(|(c, chunk)| {
                let start = c * CHUNK;
                let end = (start + CHUNK).min(n);
                chunk.offsets.clear();
                chunk.offsets.push(0);
                // `indices` is used as a buffer longer than its content: every candidate is
                // written, and the end advances only for true neighbours, so the candidate loop
                // has no unpredictable branch (about 15 % of candidates are neighbours).
                let buf = &mut chunk.indices;
                let mut used = 0usize;
                let mut cached_cell = grid.cell_of(start);
                let mut ranges = grid.neighbor_ranges(cached_cell);
                for i in start..end {
                    let cell = grid.cell_of(i);
                    if cell != cached_cell {
                        cached_cell = cell;
                        ranges = grid.neighbor_ranges(cell);
                    }
                    let candidates: usize = ranges
                        .as_slice()
                        .iter()
                        .map(|&(s, e)| (e - s) as usize)
                        .sum();
                    if buf.len() < used + candidates + BLOCK {
                        buf.resize((used + candidates + BLOCK).max(2 * buf.len()), 0);
                    }
                    let (xi, yi, zi) = (xs[i], ys[i], zs[i]);
                    let first = used;
                    for &(s, e) in ranges.as_slice() {
                        let (s, e) = (s as usize, e as usize);
                        let blocks = (e - s) / BLOCK;
                        for b in 0..blocks {
                            let j0 = s + b * BLOCK;
                            let bx: &[Real; BLOCK] = xs[j0..j0 + BLOCK].try_into().unwrap();
                            let by: &[Real; BLOCK] = ys[j0..j0 + BLOCK].try_into().unwrap();
                            let bz: &[Real; BLOCK] = zs[j0..j0 + BLOCK].try_into().unwrap();
                            let mut inside = [0u32; BLOCK];
                            for k in 0..BLOCK {
                                let (dx, dy, dz) = (xi - bx[k], yi - by[k], zi - bz[k]);
                                inside[k] = (dx * dx + dy * dy + dz * dz < h2) as u32;
                            }
                            let out: &mut [u32; BLOCK] =
                                (&mut buf[used..used + BLOCK]).try_into().unwrap();
                            let mut w = 0usize;
                            for k in 0..BLOCK {
                                out[w] = (j0 + k) as u32;
                                w += inside[k] as usize;
                            }
                            used += w;
                        }
                        for j in s + blocks * BLOCK..e {
                            let (dx, dy, dz) = (xi - xs[j], yi - ys[j], zi - zs[j]);
                            buf[used] = j as u32;
                            used += (dx * dx + dy * dy + dz * dz < h2) as usize;
                        }
                    }
                    // The particle itself passed the test (distance 0): take it out. The list is
                    // ascending, so it is found by a binary search.
                    if let Ok(p) = buf[first..used].binary_search(&(i as u32)) {
                        buf.copy_within(first + p + 1..used, first + p);
                        used -= 1;
                    }
                    chunk.offsets.push(used as u32);
                }
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

    /// Number of particles the lists were built for.
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
            + (self.xs.capacity() + self.ys.capacity() + self.zs.capacity()) * 4
    }
}
