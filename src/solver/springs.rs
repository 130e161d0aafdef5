//! Viscoelastic springs for the double-density relaxation: Clavet, Beaudoin & Poulin,
//! "Particle-based Viscoelastic Fluid Simulation", SCA 2005, section 5 (Algorithms 3 and 4).
//!
//! Every pair of particles closer than `h` is joined by a spring. A new spring starts at rest
//! length `L = h` (Alg. 4); while the pair's distance `r` stays within the yield band
//! `|r − L| ≤ γ·L` the rest length keeps its value, beyond it the rest length flows towards
//! `r` at the plasticity rate `α`:
//!
//! ```text
//! r > L + γL:  L += dt·α·(r − L − γL)        r < L − γL:  L −= dt·α·(L − γL − r)
//! ```
//!
//! Springs whose rest length exceeds `h` are removed. Each spring displaces its two particles
//! (Alg. 3) by `∓D/2` with `D = dt²·k·(1 − L/h)·(L − r)·r̂_ij`, `r̂_ij` from `i` towards `j`:
//! a spring shorter than its rest length pushes the pair apart, a longer one pulls it together,
//! and springs near the support radius (`L → h`) fade out. The fluid then remembers its recent
//! shape: a blob that is stretched pulls back, one that is compressed slowly flows.
//!
//! How it runs here: the paper loops over pairs and moves both particles; here each particle
//! keeps its own copy of each of its springs (keyed by the partner's id, which survives the
//! per-step re-sort) and gathers the displacements of its springs in one Jacobi pass. Both
//! copies of a spring see the same distance bit for bit (`|x_i − x_j|` and `|x_j − x_i|` round
//! alike) and apply the same update, so they stay equal; the pair's displacements are exact
//! opposites, so linear momentum is conserved. A spring whose partner was drained or
//! quarantined is dropped. Deterministic, and the same with any thread count.
//!
//! Units: `k` is a multiple of `c²/(h²·N)`, `c` the fluid's speed of sound and `N` the number
//! of neighbours in the rest lattice ([`crate::FluidParams::expected_neighbours`]): the `N`
//! springs of a particle together then push like an equation of state with speed of sound
//! `c·√k`, and the time step obeys that acoustic limit (as the relaxation's stiffness does).
//! Without the `1/N` a particle's thirty-odd springs add up: in units of `c²/h²` they blow an
//! isolated blob apart at 3× the acoustic step. `α` is a rate in 1/s; `γ` a
//! ratio. The defaults are a starting point (the paper gives no SI values), not a calibrated
//! material.

pub use super::clavet::Springs;
use crate::domain::Separation;
use crate::math::{Real, Vector};
use crate::neighbors::NeighborLists;
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// The springs of a fluid, row by row: row `r` belongs to the particle with id `owners[r]`
/// and holds `(partner id, rest length)` pairs at `offsets[r]..offsets[r + 1]`, sorted by
/// partner id. Rows follow the particle order of the step that made them.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "snapshot", derive(serde::Serialize, serde::Deserialize))]
pub struct SpringSet {
    owners: Vec<u32>,
    offsets: Vec<u32>,
    partners: Vec<u32>,
    rest: Vec<Real>,
}

impl SpringSet {
    /// Number of springs (each pair counted twice, once per particle).
    pub fn len(&self) -> usize {
        self.partners.len()
    }

    /// `true` when there is no spring.
    pub fn is_empty(&self) -> bool {
        self.partners.is_empty()
    }

    /// The springs of the particle with id `id`: `(partner id, rest length)`.
    pub fn of(&self, id: u32) -> impl Iterator<Item = (u32, Real)> + '_ {
        let row = self.owners.iter().position(|&o| o == id);
        let range = row.map_or(0..0, |r| {
            self.offsets[r] as usize..self.offsets[r + 1] as usize
        });
        self.partners[range.clone()]
            .iter()
            .copied()
            .zip(self.rest[range].iter().copied())
    }

    /// `true` when the rows are well formed (used when a snapshot is restored).
    #[cfg(feature = "snapshot")]
    pub(crate) fn is_consistent(&self) -> bool {
        self.offsets.len() == self.owners.len() + 1
            && self.offsets.first() == Some(&0)
            && self.offsets.windows(2).all(|w| w[0] <= w[1])
            && self.offsets.last().map(|&e| e as usize) == Some(self.partners.len())
            && self.partners.len() == self.rest.len()
            && self.rest.iter().all(|l| l.is_finite() && *l > 0.0)
            || (self.owners.is_empty() && self.offsets.is_empty() && self.partners.is_empty())
    }

    /// `true` when every owner and partner is an id below `next_id` (a handed-out id: the
    /// spring stage sizes its by-id tables by the largest id; used when a snapshot is
    /// restored).
    #[cfg(feature = "snapshot")]
    pub(crate) fn ids_below(&self, next_id: u32) -> bool {
        self.owners
            .iter()
            .chain(&self.partners)
            .all(|&id| id < next_id)
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        (self.owners.capacity()
            + self.offsets.capacity()
            + self.partners.capacity()
            + self.rest.capacity())
            * 4
    }
}

const NONE: u32 = u32::MAX;

/// A value per particle id: a table indexed by id while the ids are dense (the largest at
/// most [`DENSE_IDS`] times the entries, plus 1,024), else the entries sorted by id and found
/// by binary search. Ids are handed out over a fluid's life: a fluid fed by an emitter and
/// drained by a sink holds a few thousand particles with ids in the billions, and a table
/// sized by the largest id (as this was) would take gigabytes (a snapshot may also name any
/// id below its next id).
#[derive(Clone, Debug, Default)]
struct IdTable {
    direct: Vec<u32>,
    sorted: Vec<(u32, u32)>,
    dense: bool,
}

/// See [`IdTable`].
const DENSE_IDS: usize = 4;

impl IdTable {
    /// Fills the table with `entries` (`(id, value)`), `max_id` the largest id plus one.
    fn fill(&mut self, entries: impl Iterator<Item = (u32, u32)>, max_id: usize, count: usize) {
        self.dense = max_id <= DENSE_IDS * count + 1024;
        if self.dense {
            if self.direct.len() < max_id {
                self.direct.resize(max_id, NONE);
            }
            for (id, v) in entries {
                self.direct[id as usize] = v;
            }
        } else {
            self.sorted.clear();
            self.sorted.extend(entries);
            self.sorted.sort_unstable_by_key(|e| e.0);
        }
    }

    /// Resets the entries of `ids` (a dense table's; a sorted one is refilled).
    fn clear(&mut self, ids: impl Iterator<Item = u32>) {
        if self.dense {
            for id in ids {
                self.direct[id as usize] = NONE;
            }
        }
    }

    /// The value of `id` (`NONE` if it has none).
    #[inline(always)]
    fn get(&self, id: u32) -> u32 {
        if self.dense {
            self.direct.get(id as usize).copied().unwrap_or(NONE)
        } else {
            self.sorted
                .binary_search_by_key(&id, |e| e.0)
                .map_or(NONE, |k| self.sorted[k].1)
        }
    }

    /// Heap bytes held.
    fn heap_bytes(&self) -> usize {
        self.direct.capacity() * 4 + self.sorted.capacity() * 8
    }
}

/// Scratch of the spring stage (reused from step to step).
#[derive(Clone, Debug, Default)]
pub(crate) struct SpringBuffers {
    /// Row of the previous spring set by particle id (`NONE` elsewhere).
    row_of_id: IdTable,
    /// Current particle index by id (`NONE` elsewhere).
    index_of_id: IdTable,
    chunks: Vec<SpringChunk>,
    displacement: Vec<Vector>,
}

#[derive(Clone, Debug, Default)]
struct SpringChunk {
    offsets: Vec<u32>,
    partners: Vec<u32>,
    rest: Vec<Real>,
    /// `(partner id, distance, partner index)` of the pairs within h of the particle being
    /// processed.
    row: Vec<(u32, Real, u32)>,
}

impl SpringBuffers {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.row_of_id.heap_bytes()
            + self.index_of_id.heap_bytes()
            + self.displacement.capacity() * 12
            + self
                .chunks
                .iter()
                .map(|c| {
                    (c.offsets.capacity() + c.partners.capacity() + c.rest.capacity()) * 4
                        + c.row.capacity() * 12
                })
                .sum::<usize>()
    }
}

/// Inputs of one spring stage.
pub(crate) struct SpringContext<'a> {
    /// Neighbour lists of the predicted positions.
    pub neighbors: &'a NeighborLists,
    /// Stable particle ids, in the current order.
    pub ids: &'a [u32],
    /// Support radius.
    pub h: Real,
    /// Speed of sound of the fluid (m/s).
    pub speed_of_sound: Real,
    /// Neighbours of a particle in the rest lattice.
    pub expected_neighbours: Real,
    /// Time step.
    pub dt: Real,
}

/// The springs' pass with the separations formed by `sep` (see [`crate::domain`]).
pub(crate) fn apply_in<S: Separation>(
    ctx: &SpringContext<'_>,
    settings: &Springs,
    springs: &mut SpringSet,
    buffers: &mut SpringBuffers,
    positions: &mut [Vector],
    sep: S,
) -> usize {
    let n = positions.len();
    let h = ctx.h;
    let k = settings.stiffness * ctx.speed_of_sound * ctx.speed_of_sound
        / (h * h * ctx.expected_neighbours.max(1.0));
    let dt = ctx.dt;
    buffers.index(springs, ctx.ids);
    let SpringBuffers {
        row_of_id,
        index_of_id,
        chunks,
        displacement,
    } = buffers;
    displacement.resize(n, Vector::ZERO);
    chunks.resize_with(n.div_ceil(CHUNK), SpringChunk::default);
    let rows = Rows {
        ctx,
        sep,
        positions,
        old: springs,
        row_of_id,
        index_of_id,
        gamma: settings.yield_ratio,
        alpha: settings.plasticity,
        dt2k_half: 0.5 * dt * dt * k,
    };
    crate::par_iter_mut!(chunks)
        .zip(crate::par_chunks_mut!(displacement, CHUNK))
        .enumerate()
        .for_each(|(c, (chunk, out))| {
            chunk.offsets.clear();
            chunk.partners.clear();
            chunk.rest.clear();
            chunk.offsets.push(0);
            for (k_, dx) in out.iter_mut().enumerate() {
                *dx = rows.particle(c * CHUNK + k_, chunk);
                chunk.offsets.push(chunk.partners.len() as u32);
            }
        });
    buffers.unindex(springs, ctx.ids);
    springs.collect(ctx.ids, &buffers.chunks);
    let displacement: &[Vector] = &buffers.displacement;
    crate::par_chunks_mut!(positions, CHUNK)
        .enumerate()
        .for_each(|(c, x)| {
            for (k_, x) in x.iter_mut().enumerate() {
                *x += displacement[c * CHUNK + k_];
            }
        });
    springs.len()
}

impl SpringBuffers {
    /// Fills the id tables: the row of each owner of `springs`, the index of each of `ids`.
    fn index(&mut self, springs: &SpringSet, ids: &[u32]) {
        let max_id = ids
            .iter()
            .chain(springs.owners.iter())
            .copied()
            .max()
            .map_or(0, |m| m as usize + 1);
        let count = ids.len() + springs.owners.len();
        let rows = springs.owners.iter().enumerate();
        self.row_of_id
            .fill(rows.map(|(r, &o)| (o, r as u32)), max_id, count);
        let indices = ids.iter().enumerate();
        self.index_of_id
            .fill(indices.map(|(i, &id)| (id, i as u32)), max_id, count);
    }

    /// Resets the id tables for the next step (only the entries [`Self::index`] set).
    fn unindex(&mut self, springs: &SpringSet, ids: &[u32]) {
        self.row_of_id.clear(springs.owners.iter().copied());
        self.index_of_id.clear(ids.iter().copied());
    }
}

impl SpringSet {
    /// The new set from the chunks' rows, rows in the current particle order (`ids`).
    fn collect(&mut self, ids: &[u32], chunks: &[SpringChunk]) {
        self.owners.clear();
        self.owners.extend_from_slice(ids);
        self.offsets.clear();
        self.partners.clear();
        self.rest.clear();
        self.offsets.push(0);
        for chunk in chunks {
            let start = self.partners.len() as u32;
            self.offsets
                .extend(chunk.offsets[1..].iter().map(|&o| start + o));
            self.partners.extend_from_slice(&chunk.partners);
            self.rest.extend_from_slice(&chunk.rest);
        }
    }
}

/// What the spring update of one particle reads: the stage's inputs, the positions, the
/// previous spring set with its id tables, and the material (yield ratio `γ`, plasticity
/// `α`, and `½dt²k`).
struct Rows<'a, S> {
    ctx: &'a SpringContext<'a>,
    sep: S,
    positions: &'a [Vector],
    old: &'a SpringSet,
    row_of_id: &'a IdTable,
    index_of_id: &'a IdTable,
    gamma: Real,
    alpha: Real,
    dt2k_half: Real,
}

impl<S: Separation> Rows<'_, S> {
    /// The springs of sorted particle `i` after this step, appended to `chunk`'s partners and
    /// rest lengths, and the displacement they give the particle.
    ///
    /// Pairs within h, by partner id, then one merge with the old row (also by partner id):
    /// existing springs flow, new ones start at L = h (Alg. 4); springs to particles now
    /// beyond h keep their rest length (Alg. 4 only adjusts pairs within h), springs to
    /// removed particles are dropped.
    #[inline(always)]
    fn particle(&self, i: usize, chunk: &mut SpringChunk) -> Vector {
        let (h, dt) = (self.ctx.h, self.ctx.dt);
        let (positions, sep, ids) = (self.positions, &self.sep, self.ctx.ids);
        let xi = positions[i];
        let old_row = match self.row_of_id.get(ids[i]) {
            NONE => 0..0,
            r => self.old.offsets[r as usize] as usize..self.old.offsets[r as usize + 1] as usize,
        };
        let (old_partners, old_rest) =
            (&self.old.partners[old_row.clone()], &self.old.rest[old_row]);
        let row = &mut chunk.row;
        row.clear();
        for &j in self.ctx.neighbors.of(i) {
            let r = sep.sep(xi, positions[j as usize]).length();
            if r < h {
                row.push((ids[j as usize], r, j));
            }
        }
        row.sort_unstable_by_key(|e| e.0);
        let mut acc = Vector::ZERO;
        let (mut a, mut b) = (0, 0);
        while a < row.len() || b < old_partners.len() {
            let next_new = row.get(a).map_or(u32::MAX, |e| e.0);
            let next_old = old_partners.get(b).copied().unwrap_or(u32::MAX);
            let (partner, l, j) = if next_new <= next_old {
                let (partner, r, j) = row[a];
                a += 1;
                let mut l = if next_new == next_old {
                    b += 1;
                    old_rest[b - 1]
                } else {
                    h
                };
                let band = self.gamma * l;
                if r > l + band {
                    l += dt * self.alpha * (r - l - band);
                } else if r < l - band {
                    l -= dt * self.alpha * (l - band - r);
                }
                (partner, l, j)
            } else {
                b += 1;
                match self.index_of_id.get(next_old) {
                    NONE => continue,
                    j => (next_old, old_rest[b - 1], j),
                }
            };
            if l > h {
                continue;
            }
            let d = sep.sep(positions[j as usize], xi);
            let r = d.length();
            if r > 1e-6 * h {
                // −D/2 for particle i, D along r̂ from i to j.
                acc -= d * (self.dt2k_half * (1.0 - l / h) * (l - r) / r);
            }
            chunk.partners.push(partner);
            chunk.rest.push(l);
        }
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ids handed out over a long life (an emitter and a sink): a few particles with ids near
    /// `u32::MAX` are kept sorted (a few bytes each), not in a table of 2^32 entries, and
    /// both kinds of table answer the same.
    #[test]
    fn id_tables_stay_sized_by_the_entries() {
        let ids: Vec<u32> = (0..100).map(|k| u32::MAX - 1 - 7 * k).collect();
        let mut sparse = IdTable::default();
        let entries = ids.iter().enumerate().map(|(i, &id)| (id, i as u32));
        sparse.fill(entries, u32::MAX as usize, ids.len());
        assert!(!sparse.dense);
        assert!(sparse.heap_bytes() < 4096, "{} bytes", sparse.heap_bytes());
        let small: Vec<u32> = (0..100).map(|k| 7 * k).collect();
        let mut dense = IdTable::default();
        let entries = small.iter().enumerate().map(|(i, &id)| (id, i as u32));
        dense.fill(entries, 694, small.len());
        assert!(dense.dense);
        for k in 0..100u32 {
            assert_eq!(sparse.get(u32::MAX - 1 - 7 * k), k);
            assert_eq!(dense.get(7 * k), k);
            assert_eq!(sparse.get(u32::MAX - 2 - 7 * k), NONE);
            assert_eq!(dense.get(7 * k + 1), NONE);
        }
        dense.clear(small.iter().copied());
        assert!((0..700).all(|id| dense.get(id) == NONE));
    }
}
