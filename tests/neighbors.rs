//! The hashed grid and its neighbour lists against the brute-force O(n²) oracle, on the
//! inputs where grids go wrong: particles exactly on cell borders, coincident particles,
//! clusters far apart (and far from the origin), negative coordinates, cell keys that alias
//! when they wrap, and pairs straddling the origin by less than `h`.
//!
//! Both searches use the same test `|x_i − x_j|² < h²` in f32, so the lists must be equal,
//! element for element (both are in ascending index order). No tolerance.

mod common;

use common::rng;
use rand::Rng;
use rapier_sph::math::{Real, Vector};
use rapier_sph::neighbors::oracle::brute_force_neighbors;
use rapier_sph::neighbors::{NeighborGrid, NeighborLists};

/// Sorts `positions` with `grid` (cell size `h`), permutes them as the pipeline does, builds
/// cells and lists, and compares every list with the oracle's on the permuted positions.
/// The grid and lists are reused across calls (warm workspaces must not leak old data).
fn check(
    grid: &mut NeighborGrid,
    lists: &mut NeighborLists,
    positions: &[Vector],
    h: Real,
    label: &str,
) {
    if let Err(e) = try_check(grid, lists, positions, h, label) {
        panic!("{e}");
    }
}

/// [`check`], returning the first difference from the oracle as an error.
fn try_check(
    grid: &mut NeighborGrid,
    lists: &mut NeighborLists,
    positions: &[Vector],
    h: Real,
    label: &str,
) -> Result<(), String> {
    let n = positions.len();
    grid.sort(positions, h);
    let perm = grid.permutation();
    assert_eq!(perm.len(), n, "{label}: permutation length");
    // A permutation: every old index exactly once, keys ascending.
    let mut seen = vec![false; n];
    for w in perm.windows(2) {
        assert!(w[0].0 <= w[1].0, "{label}: keys not sorted");
    }
    for &(_, i) in perm {
        assert!(
            !seen[i as usize],
            "{label}: index {i} twice in the permutation"
        );
        seen[i as usize] = true;
    }
    let sorted: Vec<Vector> = perm.iter().map(|&(_, i)| positions[i as usize]).collect();
    grid.build_cells();
    lists.build(grid, &sorted, h);
    assert_eq!(lists.len(), n, "{label}: list count");
    let oracle = brute_force_neighbors(&sorted, h);
    let mut pairs = 0;
    for (i, expected) in oracle.iter().enumerate() {
        let got = lists.of(i);
        if got != expected.as_slice() {
            let missing: Vec<u32> = expected
                .iter()
                .copied()
                .filter(|j| !got.contains(j))
                .collect();
            let extra: Vec<u32> = got
                .iter()
                .copied()
                .filter(|j| !expected.contains(j))
                .collect();
            let show = |js: &[u32]| {
                js.iter()
                    .take(4)
                    .map(|&j| {
                        let d = sorted[i] - sorted[j as usize];
                        format!(
                            "#{j} at {:?} (d = {:e}, d² = {:e})",
                            sorted[j as usize],
                            d.length(),
                            d.length_squared()
                        )
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            return Err(format!(
                "{label}: neighbours of #{i} at {:?} (h = {h:e}, h² = {:e}) differ: grid {:?}, oracle {:?}; \
                 missing {}; extra {}",
                sorted[i],
                h * h,
                got.len(),
                expected.len(),
                show(&missing),
                show(&extra)
            ));
        }
        pairs += got.len();
    }
    assert_eq!(lists.total_pairs(), pairs, "{label}: total pairs");
    Ok(())
}

fn uniform(rng: &mut rand_pcg::Pcg64, n: usize, center: Vector, half: Real) -> Vec<Vector> {
    (0..n)
        .map(|_| {
            center
                + Vector::new(
                    rng.random_range(-half..half),
                    rng.random_range(-half..half),
                    rng.random_range(-half..half),
                )
        })
        .collect()
}

#[test]
fn random_clouds_with_negative_coordinates() {
    let mut grid = NeighborGrid::default();
    let mut lists = NeighborLists::default();
    let mut r = rng(1);
    for (n, half, h) in [
        (3000, 1.0, 0.1),
        (2000, 0.3, 0.1), // dense: ~70 neighbours each
        (500, 5.0, 0.1),  // sparse: mostly empty lists
        (1500, 0.5, 0.037),
        (10, 0.05, 0.1), // fewer particles than one cell holds
        (1, 0.05, 0.1),  // one particle
        (0, 0.0, 0.1),   // none
    ] {
        let pts = if n == 0 {
            Vec::new()
        } else {
            uniform(&mut r, n, Vector::new(-0.2, -0.7, 0.1), half)
        };
        check(
            &mut grid,
            &mut lists,
            &pts,
            h,
            &format!("cloud n={n} half={half} h={h}"),
        );
    }
}

/// Points on a lattice of step `h` (coordinates `i·h` as f32 computes them, i.e. exactly on
/// cell borders up to the rounding of `i·h` and of `x/h` inside the grid), also with every
/// coordinate moved by one ulp up or down at random, and at half steps.
#[test]
fn particles_on_cell_borders() {
    let mut grid = NeighborGrid::default();
    let mut lists = NeighborLists::default();
    let mut r = rng(2);
    for h in [0.1, 0.05, 0.3, 1.0 / 3.0, 0.7, 0.0123, 2.5, 1.0, 0.125, 0.2] {
        let k = |i: i32| i as Real * h;
        let mut lattice = Vec::new();
        for i in -6..6 {
            for j in -6..6 {
                for l in -6..6 {
                    lattice.push(Vector::new(k(i), k(j), k(l)));
                }
            }
        }
        check(
            &mut grid,
            &mut lists,
            &lattice,
            h,
            &format!("lattice h={h}"),
        );

        let nudge = |x: Real, r: &mut rand_pcg::Pcg64| match r.random_range(0..3) {
            0 => x.next_down(),
            1 => x.next_up(),
            _ => x,
        };
        let nudged: Vec<Vector> = lattice
            .iter()
            .map(|p| Vector::new(nudge(p.x, &mut r), nudge(p.y, &mut r), nudge(p.z, &mut r)))
            .collect();
        check(
            &mut grid,
            &mut lists,
            &nudged,
            h,
            &format!("nudged lattice h={h}"),
        );

        // Half steps: pairs at distance h/2 and h along each axis, exactly on borders.
        let half: Vec<Vector> = (-12..12)
            .flat_map(|i| {
                (-3..3).map(move |j| Vector::new(0.5 * i as Real * h, j as Real * h, 0.0))
            })
            .collect();
        check(
            &mut grid,
            &mut lists,
            &half,
            h,
            &format!("half-step lattice h={h}"),
        );
    }
}

/// Pairs closer than `h` that straddle the origin: `x_i` a tiny negative number (cell −1),
/// `x_j` the largest f32 with `x_j − x_i < h` (cell 0 or 1 depending on how `x_j/h` rounds).
/// A grid must still find them, for every `h`.
#[test]
fn pairs_straddling_the_origin() {
    let mut grid = NeighborGrid::default();
    let mut lists = NeighborLists::default();
    let mut r = rng(3);
    let mut pts = Vec::new();
    let mut failures = Vec::new();
    let trials = 2000;
    for _ in 0..trials {
        let h: Real = r.random_range(0.01..1.0);
        let xi: Real = -r.random_range(1e-12..1e-6) * h;
        // Largest x_j with (x_j − x_i) < h in f32 (the oracle's own test decides).
        let mut xj = h;
        while (xj - xi) * (xj - xi) >= h * h {
            xj = xj.next_down();
        }
        pts.clear();
        pts.push(Vector::new(xi, 0.0, 0.0));
        pts.push(Vector::new(xj, 0.0, 0.0));
        // Along y and z too, and on the diagonal.
        pts.push(Vector::new(5.0 * h, xi, 0.0));
        pts.push(Vector::new(5.0 * h, xj, 0.0));
        pts.push(Vector::new(-5.0 * h, 0.0, xi));
        pts.push(Vector::new(-5.0 * h, 0.0, xj));
        let label = format!("straddling pair, h={h:e}, x_i={xi:e}, x_j={xj:e}");
        if let Err(e) = try_check(&mut grid, &mut lists, &pts, h, &label) {
            failures.push(e);
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {trials} random h miss a neighbour pair straddling the origin; first ones:\n{}",
        failures.len(),
        failures[..failures.len().min(3)].join("\n")
    );
}

#[test]
fn coincident_particles() {
    let mut grid = NeighborGrid::default();
    let mut lists = NeighborLists::default();
    let mut r = rng(4);
    let h = 0.1;
    let base = uniform(&mut r, 60, Vector::ZERO, 0.3);
    let mut pts = Vec::new();
    for (k, p) in base.iter().enumerate() {
        // 1 to 8 copies of each point, interleaved with random points.
        for _ in 0..(1 + k % 8) {
            pts.push(*p);
            pts.push(uniform(&mut r, 1, Vector::ZERO, 0.3)[0]);
        }
    }
    // A large pile at one point, on a cell corner.
    pts.extend(std::iter::repeat_n(Vector::new(0.2, -0.1, 0.0), 50));
    check(&mut grid, &mut lists, &pts, h, "coincident");
    // All particles at one point.
    let pile = vec![Vector::new(-0.3, 0.4, 0.05); 300];
    check(&mut grid, &mut lists, &pile, h, "single pile");
}

/// Clusters at ±1e4 m on every axis and at the origin, checked together (f32 resolves
/// about 1 mm at 1e4 m, so the clusters use h = 0.1 and are spread over 0.5 m).
#[test]
fn far_apart_clusters() {
    let mut grid = NeighborGrid::default();
    let mut lists = NeighborLists::default();
    let mut r = rng(5);
    let h = 0.1;
    let mut pts = Vec::new();
    for c in [
        Vector::ZERO,
        Vector::splat(1e4),
        Vector::splat(-1e4),
        Vector::new(1e4, -1e4, 0.0),
        Vector::new(-1e4, 0.0, 1e4),
        Vector::new(0.0, 1e4, -1e4),
    ] {
        pts.extend(uniform(&mut r, 400, c, 0.25));
    }
    check(&mut grid, &mut lists, &pts, h, "far clusters");
}

/// Cell coordinates wrap at 2²¹ cells per axis: with h = 0.125 (exact in binary), cells
/// 2²⁰ apart... i.e. x = +2²⁰·h and x = −2²⁰·h share their wrapped key. Clusters there
/// (and at every combination of wrapped axes) must not see each other, and must still
/// see their own neighbours.
#[test]
fn wrapped_cell_keys_alias_without_false_neighbours() {
    let mut grid = NeighborGrid::default();
    let mut lists = NeighborLists::default();
    let mut r = rng(6);
    let h: Real = 0.125;
    let w = (1u32 << 20) as Real * h; // 131072 m: f32 resolves 1/64 m there
    let mut pts = Vec::new();
    for c in [
        Vector::new(w, 0.0, 0.0),
        Vector::new(-w, 0.0, 0.0),
        Vector::new(0.0, w, -w),
        Vector::new(0.0, -w, w),
        Vector::new(w, w, w),
        Vector::new(-w, -w, -w),
        Vector::ZERO,
    ] {
        // Points on the 1/64 m grid f32 can hold there, within 0.3 m of the center.
        for _ in 0..300 {
            let o = Vector::new(
                r.random_range(-19..19) as Real / 64.0,
                r.random_range(-19..19) as Real / 64.0,
                r.random_range(-19..19) as Real / 64.0,
            );
            pts.push(c + o);
        }
    }
    check(&mut grid, &mut lists, &pts, h, "wrapped keys");
}

/// The workspace shrinks and grows between builds (a fluid losing and gaining particles).
#[test]
fn reused_workspace_big_small_big() {
    let mut grid = NeighborGrid::default();
    let mut lists = NeighborLists::default();
    let mut r = rng(7);
    for n in [2000, 3, 700, 0, 1200, 257, 256, 255, 1] {
        let pts = uniform(&mut r, n, Vector::new(0.5, -0.5, 0.0), 0.4);
        check(&mut grid, &mut lists, &pts, 0.08, &format!("reuse n={n}"));
    }
}
