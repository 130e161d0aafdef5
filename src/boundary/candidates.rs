//! Per-cell candidate colliders, from rapier's broad-phase BVH.

use crate::math::{Real, Vector};
use crate::neighbors::NeighborGrid;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::partitioning::{Bvh, BvhNode};
use rapier3d::geometry::{ColliderHandle, ColliderSet, InteractionGroups};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Cells per work item when looking up candidates.
const CELL_CHUNK: usize = 64;

#[derive(Clone, Debug, Default)]
struct Chunk {
    offsets: Vec<u32>,
    handles: Vec<ColliderHandle>,
    /// A box around each candidate's shape (same order as `handles`).
    boxes: Vec<Aabb>,
}

/// For each occupied cell, the colliders its particles may touch during the step.
#[derive(Clone, Debug, Default)]
pub struct ContactWorkspace {
    chunks: Vec<Chunk>,
    any: bool,
}

/// The colliders a fluid may meet: those of rapier's broad-phase tree whose collision groups
/// pass the fluid's, and the colliders of moving bodies from the coupling table.
#[derive(Copy, Clone)]
pub struct ColliderQuery<'a> {
    /// The broad-phase's tree.
    pub bvh: &'a Bvh,
    /// The colliders.
    pub colliders: &'a ColliderSet,
    /// The fluid's collision groups.
    pub groups: InteractionGroups,
    /// The moving bodies of the substep, if any.
    pub coupling: Option<&'a super::Coupling>,
}

impl ContactWorkspace {
    /// Finds the candidate colliders of every cell of `grid`. `previous` and `positions` are
    /// the particles' positions at the start and end of the step; `radius` the contact radius.
    pub fn gather(
        &mut self,
        grid: &NeighborGrid,
        previous: &[Vector],
        positions: &[Vector],
        radius: Real,
        query: &ColliderQuery<'_>,
    ) {
        let ColliderQuery {
            bvh,
            colliders,
            groups,
            coupling,
        } = *query;
        let coupling = coupling.filter(|c| !c.is_off());
        let n_cells = grid.num_cells();
        self.chunks
            .resize_with(n_cells.div_ceil(CELL_CHUNK), Chunk::default);
        let margin = radius * 1.01 + 1e-6;
        let found = crate::par_iter_mut!(self.chunks)
            .enumerate()
            .map(|(c, chunk)| {
                chunk.offsets.clear();
                chunk.handles.clear();
                chunk.boxes.clear();
                chunk.offsets.push(0);
                let start = c * CELL_CHUNK;
                let end = (start + CELL_CHUNK).min(n_cells);
                for cell in start..end {
                    let (s, e) = grid.cell_range(cell as u32);
                    let mut mins = Vector::splat(Real::MAX);
                    let mut maxs = Vector::splat(Real::MIN);
                    for i in s as usize..e as usize {
                        mins = mins.min(previous[i]).min(positions[i]);
                        maxs = maxs.max(previous[i]).max(positions[i]);
                    }
                    // Non-finite particles give a NaN box: it overlaps nothing, and those
                    // particles are counted and reported by the particle update.
                    let aabb = Aabb::new(mins, maxs).loosened(margin);
                    for leaf in bvh.leaves(|node: &BvhNode| node.aabb().intersects(&aabb)) {
                        if let Some((co, handle)) = colliders.get_unknown_gen(leaf)
                            && co.is_enabled()
                            && !co.is_sensor()
                            && groups.test(co.collision_groups())
                            && !coupling.is_some_and(|c| c.is_nonfixed(handle))
                        {
                            chunk.handles.push(handle);
                            // At the collider's current pose (the broad-phase box of a
                            // moving body may lag it).
                            chunk.boxes.push(co.compute_aabb());
                        }
                    }
                    // Colliders of moving bodies come from the coupling table, with the box
                    // they sweep over the substep (rapier's broad-phase boxes may lag them).
                    if let Some(c) = coupling {
                        for m in c.table() {
                            if m.aabb.loosened(margin).intersects(&aabb)
                                && colliders
                                    .get(m.handle)
                                    .is_some_and(|co| groups.test(co.collision_groups()))
                            {
                                chunk.handles.push(m.handle);
                                chunk.boxes.push(m.aabb);
                            }
                        }
                    }
                    chunk.offsets.push(chunk.handles.len() as u32);
                }
                !chunk.handles.is_empty()
            });
        #[cfg(feature = "parallel")]
        let any = rayon::iter::ParallelIterator::reduce(found, || false, |a, b| a || b);
        #[cfg(not(feature = "parallel"))]
        let any = found.fold(false, |a, b| a || b);
        self.any = any;
    }

    /// Forgets every candidate (a scene with no collider).
    pub fn clear(&mut self) {
        self.chunks.clear();
        self.any = false;
    }

    /// `true` when at least one cell has a candidate collider.
    pub fn any(&self) -> bool {
        self.any
    }

    /// Candidate colliders of cell `cell`.
    #[inline]
    pub fn of_cell(&self, cell: u32) -> &[ColliderHandle] {
        let cell = cell as usize;
        let chunk = &self.chunks[cell / CELL_CHUNK];
        let k = cell % CELL_CHUNK;
        &chunk.handles[chunk.offsets[k] as usize..chunk.offsets[k + 1] as usize]
    }

    /// Candidate colliders of cell `cell` with a box around each one's shape.
    #[inline]
    pub fn of_cell_with_boxes(&self, cell: u32) -> (&[ColliderHandle], &[Aabb]) {
        let cell = cell as usize;
        let chunk = &self.chunks[cell / CELL_CHUNK];
        let k = cell % CELL_CHUNK;
        let range = chunk.offsets[k] as usize..chunk.offsets[k + 1] as usize;
        (&chunk.handles[range.clone()], &chunk.boxes[range])
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.chunks
            .iter()
            .map(|c| {
                c.offsets.capacity() * 4
                    + c.handles.capacity() * std::mem::size_of::<ColliderHandle>()
                    + c.boxes.capacity() * std::mem::size_of::<Aabb>()
            })
            .sum::<usize>()
            + self.chunks.capacity() * std::mem::size_of::<Chunk>()
    }
}
