//! Neighbour search: an unbounded hashed grid of cells of size `h`, particles re-sorted by
//! cell every step, and flat per-particle neighbour lists.
//!
//! 1. [`NeighborGrid::sort`] computes each particle's cell key and sorts particles by it
//!    (cells in z, y, x order, so the three cells of an x-row are adjacent in memory). The
//!    caller then permutes every per-particle array with the same permutation.
//! 2. [`NeighborGrid::build_cells`] finds each occupied cell's particle range and indexes the
//!    cells in a hash table. Cell coordinates wrap at 2²¹ per axis, so the grid needs no
//!    preset box: particles may be anywhere, at negative or far coordinates. Cells that
//!    alias after wrapping share a key, which only adds candidates that the distance test
//!    rejects.
//! 3. [`NeighborLists::build`] visits the 27 cells around each particle (merged into at most
//!    27, usually 9, contiguous index ranges) and keeps the particles closer than `h`.
//!
//! [`oracle`] holds the brute-force O(n²) search the tests compare against.

mod grid;
mod lists;
pub mod oracle;

pub use grid::NeighborGrid;
pub use lists::NeighborLists;
