//! The brute-force O(n²) neighbour search, kept as the reference the grid is tested against.

use crate::math::{Real, Vector};

/// For every particle, the sorted indices of the other particles closer than `h`
/// (same distance test as the grid: `|x_i − x_j|² < h²` in `Real`).
pub fn brute_force_neighbors(positions: &[Vector], h: Real) -> Vec<Vec<u32>> {
    let h2 = h * h;
    positions
        .iter()
        .enumerate()
        .map(|(i, &xi)| {
            positions
                .iter()
                .enumerate()
                .filter(|&(j, &xj)| j != i && (xi - xj).length_squared() < h2)
                .map(|(j, _)| j as u32)
                .collect()
        })
        .collect()
}

/// [`brute_force_neighbors`] in a periodic box: distances are minimum images
/// (`sep(x_i, x_j)` of [`crate::domain::MinimumImage`], the same arithmetic as the grid).
pub fn brute_force_neighbors_periodic(
    positions: &[Vector],
    h: Real,
    domain: &crate::domain::MinimumImage,
) -> Vec<Vec<u32>> {
    use crate::domain::Separation;
    let h2 = h * h;
    positions
        .iter()
        .enumerate()
        .map(|(i, &xi)| {
            positions
                .iter()
                .enumerate()
                .filter(|&(j, &xj)| j != i && domain.sep(xi, xj).length_squared() < h2)
                .map(|(j, _)| j as u32)
                .collect()
        })
        .collect()
}
