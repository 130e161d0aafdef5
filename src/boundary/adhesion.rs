//! The walls' adhesion term (Akinci et al. 2013, over the solid's volume instead of
//! boundary particles; see the `forces::surface_tension` module): for each particle,
//! `Σ_walls G(d) n_w`, `d` its signed distance to the collider's surface and `n_w` the
//! surface's normal there (pointing to the fluid), from the same point projection as the
//! walls' density ([`super::wall`]). The surface-tension stage turns it into the
//! acceleration `−β ρ0 Σ G(d) n_w`.

use super::bodies::entry_of;
use super::candidates::ContactWorkspace;
use super::wall::{WallQuery, surface_near};
use crate::forces::surface_tension::AdhesionTable;
use crate::math::Vector;
use crate::neighbors::NeighborGrid;
use crate::par::CHUNK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

/// Writes `Σ_walls G(d) n_w` of every particle of `grid` (sorted `positions`) into `out`,
/// from the colliders `candidates` found near each cell. Moving bodies stand where the
/// walls' density takes them (their pose at the substep's start, or its end for predicted
/// positions).
pub(crate) fn update(
    candidates: &ContactWorkspace,
    grid: &NeighborGrid,
    positions: &[Vector],
    query: &WallQuery<'_>,
    table: &AdhesionTable,
    out: &mut Vec<Vector>,
) {
    out.clear();
    out.resize(positions.len(), Vector::ZERO);
    let (_, colliders, _) = query.scene;
    let moving = query.coupling.map_or(&[][..], |c| c.table());
    let h = table.support();
    crate::par_chunks_mut!(out[..], CHUNK)
        .enumerate()
        .for_each(|(k, rows)| {
            for (l, w) in rows.iter_mut().enumerate() {
                let i = k * CHUNK + l;
                for &handle in candidates.of_cell(grid.cell_of(i)) {
                    let Some(co) = colliders.get(handle) else {
                        continue;
                    };
                    let pose = match entry_of(moving, handle).map(|(_, m)| m) {
                        Some(m) if m.moving && query.predicted => &m.stop,
                        Some(m) if m.moving => &m.start,
                        _ => co.position(),
                    };
                    if let Some((d, normal, _)) = surface_near(co, pose, positions[i], h) {
                        *w += normal * table.eval(d);
                    }
                }
            }
        });
}
