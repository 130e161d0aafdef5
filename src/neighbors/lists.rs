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
}

impl NeighborLists {
    /// Rebuilds the lists for sorted `positions` over `grid` with support radius `h`.
    pub fn build(&mut self, grid: &NeighborGrid, positions: &[Vector], h: Real) {
        let n = positions.len();
        self.len = n;
        self.chunks.resize_with(n.div_ceil(CHUNK), Chunk::default);
        let h2 = h * h;
        crate::par_iter_mut!(self.chunks)
            .enumerate()
            .for_each(|(c, chunk)| {
                let start = c * CHUNK;
                let end = (start + CHUNK).min(n);
                chunk.offsets.clear();
                chunk.indices.clear();
                chunk.offsets.push(0);
                let mut cached_cell = u32::MAX;
                let mut ranges = None;
                for i in start..end {
                    let cell = grid.cell_of(i);
                    if cell != cached_cell {
                        cached_cell = cell;
                        ranges = Some(grid.neighbor_ranges(cell));
                    }
                    let xi = positions[i];
                    for &(s, e) in ranges.as_ref().map(|r| r.as_slice()).unwrap_or(&[]) {
                        for j in s..e {
                            if (xi - positions[j as usize]).length_squared() < h2 && j as usize != i
                            {
                                chunk.indices.push(j);
                            }
                        }
                    }
                    chunk.offsets.push(chunk.indices.len() as u32);
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
        self.chunks.iter().map(|c| c.indices.len()).sum()
    }

    /// Heap bytes held by the lists.
    pub fn heap_bytes(&self) -> usize {
        self.chunks
            .iter()
            .map(|c| c.offsets.capacity() * 4 + c.indices.capacity() * 4)
            .sum::<usize>()
            + self.chunks.capacity() * std::mem::size_of::<Chunk>()
    }
}
