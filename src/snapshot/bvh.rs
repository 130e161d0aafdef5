//! Checks of the bounding-volume trees a snapshot restores: rapier's broad-phase tree and the
//! trees inside colliders' triangle meshes.
//!
//! Parry's `Bvh` indexes its node array, parent links and leaf map without bounds checks on
//! the paths rapier's broad-phase update takes (`Bvh::remove`, the SAH insertion's rotations,
//! the refits; the parallel refit writes through raw pointers at offsets computed from the
//! nodes' leaf counts), and it keeps all of that private, with no public validation that does
//! not panic. A file crafted to pass the checksum can therefore load and then panic (or worse)
//! in the first step. Rebuilding the tree is not an option: parry's incremental optimisation
//! state and the tree's exact shape decide the order in which pairs are found, so a rebuilt
//! tree breaks the bitwise equality of a restored run with an uninterrupted one.
//!
//! So the tree is read through a mirror of its serde layout: snapshots are postcard, which is
//! not self-describing, and the same bytes decode into structs with the same fields in the
//! same order ([`BroadPhase`], [`Tree`]). After rapier's world is decoded, its broad phase is
//! encoded again and decoded into the mirror, and [`check_tree`] checks every index parry
//! follows. The mirror is pinned by a test that round-trips a real world's broad phase and
//! triangle mesh bit for bit, so a parry or rapier upgrade that changes the layout fails that
//! test rather than a user's load.
//!
//! The mirror is serde's, so this module and its tests exist only with the `snapshot` feature:
//! `cargo test --release --lib bvh` runs none of them, `cargo test --release --features
//! snapshot --lib bvh` runs them (the CI script runs every lib test with `--features
//! cli,surface`, which includes `snapshot`).

use crate::error::SphError;
use crate::math::Real;
use rapier3d::geometry::{BroadPhaseBvh, ColliderSet};
use rapier3d::parry::partitioning::Bvh;
use rapier3d::parry::shape::{Shape, TriMesh};
use serde::{Deserialize, Serialize};

/// A collider handle's arena index and generation (rapier's `Index { index, generation }`).
type Handle = (u32, u32);

/// Parry's `BvhNode`: bounding box, children (or leaf key) and packed leaf count and flags.
#[derive(Serialize, Deserialize, Clone, Copy, Debug)]
pub(crate) struct Node {
    mins: [Real; 3],
    /// For a leaf (leaf count 1), the leaf's key; otherwise the wide node holding the children.
    children: u32,
    maxs: [Real; 3],
    /// Leaf count in the low 30 bits, change flags in the high 2.
    data: u32,
}

impl Node {
    fn leaf_count(&self) -> u32 {
        self.data & 0x3fff_ffff
    }

    fn is_leaf(&self) -> bool {
        self.leaf_count() == 1
    }

    fn is_finite(&self) -> bool {
        self.mins.iter().chain(&self.maxs).all(|x| x.is_finite())
    }
}

/// Parry's `BvhNodeWide`: a node's two children side by side.
#[derive(Serialize, Deserialize, Clone, Copy, Debug)]
pub(crate) struct Wide {
    left: Node,
    right: Node,
}

impl Wide {
    fn side(&self, right: bool) -> &Node {
        if right { &self.right } else { &self.left }
    }
}

/// Parry's `VecMap<BvhNodeIndex>`: the number of entries, then a slot per leaf key.
#[derive(Serialize, Deserialize, Debug)]
pub(crate) struct LeafMap {
    n: usize,
    v: Vec<Option<usize>>,
}

/// Parry's `Bvh` (0.31): wide nodes, their parents (`BvhNodeIndex`: wide node × 2 + side),
/// the leaf map (leaf key → `BvhNodeIndex`), the incremental optimiser's state and the wide
/// nodes freed by removals.
#[derive(Serialize, Deserialize, Debug)]
pub(crate) struct Tree {
    nodes: Vec<Wide>,
    parents: Vec<usize>,
    leaves: LeafMap,
    optimization: (u32, u32),
    free_wide_nodes: Vec<u32>,
}

/// Rapier's `BvhOptimizationStrategy`.
#[derive(Serialize, Deserialize, Debug)]
enum Strategy {
    SubtreeOptimizer,
    None,
}

/// Rapier's `BroadPhaseBvh` (0.36) as serialised: its tree, its pairs (sorted, with the frame
/// each was found in), each collider's paired colliders, the leaves the last update changed,
/// the colliders whose leaves were moved since, and its counters and settings.
#[derive(Serialize, Deserialize, Debug)]
pub(crate) struct BroadPhase {
    tree: Tree,
    pairs: Vec<((Handle, Handle), u32)>,
    pair_adjacency: Vec<(u32, Vec<Handle>)>,
    prev_updated_leaves: Vec<u32>,
    pending_set_aabb: Vec<Handle>,
    changes_since_optimize: u32,
    reinsert_leaf_updates: bool,
    frame_index: u32,
    optimization_strategy: Strategy,
    adaptive_change_detection_margin: bool,
}

/// Decodes `bytes` into `T`, all of them.
fn decode<'a, T: Deserialize<'a>>(bytes: &'a [u8]) -> Option<T> {
    match postcard::take_from_bytes(bytes) {
        Ok((value, [])) => Some(value),
        _ => None,
    }
}

/// The mirror of a broad phase, read from its postcard encoding; `None` when the layout is
/// not the one mirrored (another rapier or parry version).
pub(crate) fn mirror_broad_phase(bp: &BroadPhaseBvh) -> Option<(BroadPhase, Vec<u8>)> {
    let bytes = postcard::to_allocvec(bp).ok()?;
    decode(&bytes).map(|m| (m, bytes))
}

/// The mirror of a parry tree, read from its postcard encoding.
pub(crate) fn mirror_tree(tree: &Bvh) -> Option<(Tree, Vec<u8>)> {
    let bytes = postcard::to_allocvec(tree).ok()?;
    decode(&bytes).map(|m| (m, bytes))
}

/// The mirror encoded again (for the layout test).
#[cfg(test)]
pub(crate) fn encode<T: Serialize>(mirror: &T) -> Vec<u8> {
    postcard::to_allocvec(mirror).expect("the mirror encodes")
}

/// The deepest tree (in wide nodes from the root) loading accepts. Parry's refit and its
/// self-intersection walk (the broad phase's pair search) recurse once per level, so a crafted
/// chain as deep as its leaf count would overflow the stack. A tree parry builds is a few
/// times log2 of its leaf count deep (measured in `parry_builds_shallow_trees`: 16 levels for
/// 4,000 colliders inserted ten a step along a line, 58 for a strip of 20,000 triangles), and a balanced tree 1,024 deep would
/// hold 2^1024 leaves; a chain 1,024 deep refits and self-intersects on a 256 KiB stack
/// (`a_chain_at_the_depth_bound_fits_a_small_stack`), an eighth of the 2 MiB Rust gives a
/// spawned thread.
pub(crate) const MAX_TREE_DEPTH: usize = 1024;

/// What is wrong, and where: the wide node (or leaf key, or list position) concerned.
type Fault = (usize, &'static str);

/// The error of a fault of `field`.
fn bad(field: &'static str, (at, reason): Fault) -> SphError {
    SphError::InvalidParameter {
        field,
        value: at as f64,
        reason,
    }
}

/// The broad phase's tree checked by [`check_tree`] (no bound on its leaf keys: a leaf may
/// stay for a collider removed since the last step, until the next one removes it).
///
/// # Errors
/// [`SphError::InvalidParameter`] with field `"broad_phase"` naming the fault.
pub(crate) fn check_broad_phase(bp: &BroadPhaseBvh) -> Result<(), SphError> {
    let layout =
        "the broad phase's layout is not the one this build reads (rapier or parry upgraded)";
    let (mirror, _) = mirror_broad_phase(bp).ok_or(bad("broad_phase", (0, layout)))?;
    check_tree(&mirror.tree, u64::MAX).map_err(|f| bad("broad_phase", f))
}

/// Every collider's triangle mesh, polyline or compound (and a compound's parts) checked: its
/// tree by [`check_tree`], leaf keys below its number of triangles, segments or parts; a
/// mesh's or polyline's indices inside its vertex array; a mesh's pseudo-normals, topology
/// and connected components of its numbers of vertices and triangles, their indices inside
/// them. Parry's queries follow all of these without checks.
///
/// # Errors
/// [`SphError::InvalidParameter`] with field `"colliders"`, the collider's position in the set
/// and the fault.
pub(crate) fn check_collider_shapes(colliders: &ColliderSet) -> Result<(), SphError> {
    for (k, (_, c)) in colliders.iter().enumerate() {
        check_shape(c.shape()).map_err(|(_, reason)| bad("colliders", (k, reason)))?;
    }
    Ok(())
}

/// One shape's trees and index arrays (see [`check_collider_shapes`]).
fn check_shape(shape: &dyn Shape) -> Result<(), Fault> {
    if let Some(m) = shape.as_trimesh() {
        check_parry_tree(m.bvh(), m.indices().len())?;
        check_indices(m.indices().as_flattened(), m.vertices().len())?;
        check_mesh_extras(m)?;
    } else if let Some(p) = shape.as_polyline() {
        check_parry_tree(p.bvh(), p.indices().len())?;
        check_indices(p.indices().as_flattened(), p.vertices().len())?;
    } else if let Some(c) = shape.as_compound() {
        check_parry_tree(c.bvh(), c.shapes().len())?;
        for (_, part) in c.shapes() {
            check_shape(part.as_ref())?;
        }
    }
    Ok(())
}

/// Every index below `len`.
fn check_indices(indices: &[u32], len: usize) -> Result<(), Fault> {
    match indices.iter().position(|&i| i as usize >= len) {
        Some(k) => Err((k, "a shape's vertex index is outside its vertex array")),
        None => Ok(()),
    }
}

/// A mesh's pseudo-normals, half-edge topology and connected components: one entry per
/// vertex, triangle or half-edge as parry builds them, every index inside its array.
fn check_mesh_extras(m: &TriMesh) -> Result<(), Fault> {
    let (vertices, faces) = (m.vertices().len(), m.indices().len());
    let wrong = (
        0,
        "a mesh's pseudo-normals, topology or components do not match its triangles",
    );
    if let Some(n) = m.pseudo_normals()
        && (n.vertices_pseudo_normal.len() != vertices || n.edges_pseudo_normal.len() != faces)
    {
        return Err(wrong);
    }
    if let Some(t) = m.topology() {
        let edges = t.half_edges.len();
        let inside = t.vertices.len() == vertices
            && t.faces.len() == faces
            && t.vertices.iter().all(|v| (v.half_edge as usize) < edges)
            && t.faces.iter().all(|f| (f.half_edge as usize) < edges)
            && t.half_edges.iter().all(|e| {
                (e.next as usize) < edges
                    && (e.twin as usize) < edges
                    && (e.vertex as usize) < vertices
                    && (e.face as usize) < faces
            });
        if !inside {
            return Err(wrong);
        }
    }
    if let Some(c) = m.connected_components() {
        let inside = c.face_colors.len() == faces
            && c.face_colors
                .iter()
                .all(|&k| (k as usize) + 1 < c.ranges.len())
            && c.grouped_faces.iter().all(|&f| (f as usize) < faces)
            && c.ranges.windows(2).all(|r| r[0] <= r[1])
            && c.ranges.last().is_none_or(|&r| r <= c.grouped_faces.len());
        if !inside {
            return Err(wrong);
        }
    }
    Ok(())
}

/// A parry tree checked by [`check_tree`], its leaf keys below `leaf_keys`.
fn check_parry_tree(tree: &Bvh, leaf_keys: usize) -> Result<(), Fault> {
    let (mirror, _) = mirror_tree(tree).ok_or((
        0,
        "a shape's tree layout is not the one this build reads (parry upgraded)",
    ))?;
    check_tree(&mirror, leaf_keys as u64)
}

/// Checks that `t` is a tree parry can work on: one parent per wide node; from the root, every
/// child index inside the node array, every wide node reached once (no cycle, no sharing),
/// its parent link pointing back, every leaf count the sum of the children's (a leaf's 1),
/// every bounding box finite (rapier inserts no other); the leaf map naming exactly the leaves
/// reached, each at its place, keys below `leaf_keys`; the free list naming distinct wide nodes
/// outside the tree. A one-leaf tree is its root's left half in a node array of length one,
/// as parry leaves it; an empty tree has no node and no leaf.
///
/// # Errors
/// The wide node (or key, or position) and the fault.
pub(crate) fn check_tree(t: &Tree, leaf_keys: u64) -> Result<(), Fault> {
    let len = t.nodes.len();
    if t.parents.len() != len {
        return Err((t.parents.len(), "parents and nodes differ in number"));
    }
    let entries = t.leaves.v.iter().filter(|e| e.is_some()).count();
    if entries != t.leaves.n {
        return Err((entries, "the leaf map's count is not its number of entries"));
    }
    if len == 0 {
        return if entries == 0 && t.free_wide_nodes.is_empty() {
            Ok(())
        } else {
            Err((entries, "an empty tree with leaves or free nodes"))
        };
    }
    let reached = if t.nodes[0].right.leaf_count() == 0 {
        check_single_leaf(t, leaf_keys)?
    } else {
        check_reachable(t, leaf_keys)?
    };
    if reached.leaves != entries {
        return Err((entries, "the leaf map names leaves outside the tree"));
    }
    check_free_list(t, &reached.wide)
}

/// What a walk from the root reached: the wide nodes (by index) and the number of leaves.
struct Reached {
    wide: Vec<bool>,
    leaves: usize,
}

/// A one-leaf tree: the root's left half a leaf, mapped at left of wide node 0, nothing else.
fn check_single_leaf(t: &Tree, leaf_keys: u64) -> Result<Reached, Fault> {
    let root = &t.nodes[0];
    if t.nodes.len() != 1 || !root.left.is_leaf() {
        return Err((0, "a one-leaf root that is not alone or not a leaf"));
    }
    if !root.left.is_finite() {
        return Err((0, "a bounding box is not finite"));
    }
    let key = root.left.children as usize;
    if key as u64 >= leaf_keys || t.leaves.v.get(key).copied().flatten() != Some(0) {
        return Err((key, "a leaf's map entry does not point at it"));
    }
    Ok(Reached {
        wide: vec![true],
        leaves: 1,
    })
}

/// Walks the tree from the root, checking every link (see [`check_tree`]).
fn check_reachable(t: &Tree, leaf_keys: u64) -> Result<Reached, Fault> {
    let len = t.nodes.len();
    let mut wide = vec![false; len];
    wide[0] = true;
    let mut leaves = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((k, depth)) = stack.pop() {
        if depth > MAX_TREE_DEPTH {
            return Err((k, "a tree is deeper than MAX_TREE_DEPTH (1024) wide nodes"));
        }
        for right in [false, true] {
            let node = t.nodes[k].side(right);
            let here = 2 * k + right as usize;
            if !node.is_finite() {
                return Err((k, "a bounding box is not finite"));
            }
            if node.is_leaf() {
                let key = node.children;
                if key as u64 >= leaf_keys
                    || t.leaves.v.get(key as usize).copied().flatten() != Some(here)
                {
                    return Err((key as usize, "a leaf's map entry does not point at it"));
                }
                leaves += 1;
                continue;
            }
            let c = node.children as usize;
            if c == 0 || c >= len {
                return Err((k, "a child index is outside the node array"));
            }
            if std::mem::replace(&mut wide[c], true) {
                return Err((
                    c,
                    "a wide node is reached twice (a cycle or a shared child)",
                ));
            }
            if t.parents[c] != here {
                return Err((c, "a wide node's parent link does not point at its parent"));
            }
            let below = t.nodes[c].left.leaf_count() as u64 + t.nodes[c].right.leaf_count() as u64;
            if node.leaf_count() as u64 != below {
                return Err((c, "a leaf count is not the sum of its children's"));
            }
            stack.push((c, depth + 1));
        }
    }
    Ok(Reached { wide, leaves })
}

/// The free list: distinct wide nodes inside the array and outside the tree.
fn check_free_list(t: &Tree, reached: &[bool]) -> Result<(), Fault> {
    let mut seen = reached.to_vec();
    for (k, &free) in t.free_wide_nodes.iter().enumerate() {
        match seen.get_mut(free as usize) {
            Some(s) if !*s => *s = true,
            _ => {
                return Err((
                    k,
                    "a free wide node is outside the array, in the tree or listed twice",
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vector;
    use rapier3d::prelude::{ColliderBuilder, PhysicsWorld, RigidBodyBuilder};

    /// A world whose broad phase has seen insertions, removals, re-insertions and the
    /// incremental optimiser: 60 balls falling on a floor and a triangle mesh, one in three
    /// removed after a while, 20 more added.
    fn busy_world(mut look: impl FnMut(&PhysicsWorld)) -> PhysicsWorld {
        let mut w = PhysicsWorld::new();
        w.insert_collider(ColliderBuilder::cuboid(4.0, 0.1, 4.0), None);
        let (vertices, indices) = (
            vec![
                Vector::new(-1.0, 0.2, -1.0),
                Vector::new(1.0, 0.2, -1.0),
                Vector::new(1.0, 0.4, 1.0),
                Vector::new(-1.0, 0.4, 1.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        );
        w.insert_collider(ColliderBuilder::trimesh(vertices, indices).unwrap(), None);
        let mut colliders = Vec::new();
        let add = |w: &mut PhysicsWorld, colliders: &mut Vec<_>, i: usize| {
            let at = Vector::new(
                (i % 7) as Real * 0.3 - 1.0,
                0.5 + (i / 7) as Real * 0.25,
                0.1,
            );
            let b = w.insert_body(RigidBodyBuilder::dynamic().translation(at));
            colliders.push(w.insert_collider(ColliderBuilder::ball(0.1), Some(b)));
        };
        for i in 0..60 {
            add(&mut w, &mut colliders, i);
        }
        for frame in 0..120 {
            w.step();
            look(&w);
            if frame == 40 {
                for h in colliders.iter().step_by(3) {
                    w.remove_collider(*h);
                }
                // Saved between a removal and the step that takes the leaves out.
                look(&w);
            }
            if frame == 60 {
                for i in 60..80 {
                    add(&mut w, &mut colliders, i);
                }
                look(&w);
            }
        }
        w
    }

    /// The mirror reads rapier's broad phase and parry's tree exactly: decoded and encoded
    /// again, the bytes are the same, and a real world's trees pass the checks at every
    /// step of a busy run. A rapier or parry upgrade that changes either layout fails here.
    #[test]
    fn the_mirror_round_trips_real_trees() {
        let mut checked = 0;
        let w = busy_world(|w| {
            let (mirror, bytes) = mirror_broad_phase(&w.broad_phase).expect("the layout");
            assert_eq!(encode(&mirror), bytes);
            assert!(mirror.tree.nodes.len() > 1);
            check_tree(&mirror.tree, u64::MAX).unwrap();
            checked += 1;
        });
        assert_eq!(checked, 122);
        let mesh = w
            .colliders
            .iter()
            .find_map(|(_, c)| c.shape().as_trimesh())
            .expect("the mesh");
        let (mirror, bytes) = mirror_tree(mesh.bvh()).expect("the layout");
        assert_eq!(encode(&mirror), bytes);
        assert_eq!(mirror.leaves.n, 2);
        check_parry_tree(mesh.bvh(), 2).unwrap();
        assert!(check_parry_tree(mesh.bvh(), 1).is_err());
        check_collider_shapes(&w.colliders).unwrap();
    }

    /// The small trees parry special-cases pass: empty, one leaf (a partial root), two, and
    /// back to one and to none by removals, saved before and after the step that applies them.
    #[test]
    fn small_trees_pass() {
        let check = |w: &PhysicsWorld| {
            let (mirror, bytes) = mirror_broad_phase(&w.broad_phase).unwrap();
            assert_eq!(encode(&mirror), bytes);
            check_tree(&mirror.tree, u64::MAX).unwrap();
            mirror.tree.nodes.len()
        };
        let mut w = PhysicsWorld::new();
        w.step();
        assert_eq!(check(&w), 0);
        let a = w.insert_collider(ColliderBuilder::ball(0.1), None);
        w.step();
        assert_eq!(check(&w), 1);
        let b = w.insert_collider(ColliderBuilder::ball(0.1).translation(Vector::X), None);
        w.step();
        assert_eq!(check(&w), 1);
        w.insert_collider(ColliderBuilder::ball(0.1).translation(Vector::Y), None);
        w.step();
        assert_eq!(check(&w), 2);
        for h in [a, b] {
            w.remove_collider(h);
            check(&w);
            w.step();
            check(&w);
        }
        assert_eq!(check(&w), 1);
        let last = w.colliders.iter().next().unwrap().0;
        w.remove_collider(last);
        w.step();
        assert_eq!(check(&w), 0);
    }

    /// Each fault the checks name, made in a real tree's mirror, is refused.
    #[test]
    fn broken_trees_are_refused() {
        let w = busy_world(|_| {});
        let (good, _) = mirror_broad_phase(&w.broad_phase).unwrap();
        let refused = |edit: &dyn Fn(&mut Tree)| {
            let mut t = decode::<Tree>(&encode(&good.tree)).unwrap();
            edit(&mut t);
            check_tree(&t, u64::MAX).unwrap_err()
        };
        let internal = good.tree.nodes[0].left.children as usize;
        assert!(!good.tree.nodes[0].left.is_leaf());
        refused(&|t| t.nodes[0].left.children = t.nodes.len() as u32);
        refused(&|t| t.nodes[0].left.children = 0);
        refused(&|t| t.nodes[0].right.children = t.nodes[0].left.children);
        refused(&|t| t.nodes[0].left.data += 1);
        refused(&|t| t.nodes[internal].left.data ^= 0b11);
        refused(&|t| t.nodes[0].left.mins[1] = Real::NAN);
        refused(&|t| t.parents[internal] ^= 1);
        refused(&|t| {
            t.parents.pop();
        });
        refused(&|t| t.leaves.n += 1);
        refused(&|t| t.leaves.v.push(Some(0)));
        refused(&|t| t.free_wide_nodes.push(internal as u32));
        refused(&|t| t.free_wide_nodes.push(u32::MAX));
        let leaf = (0..good.tree.nodes.len())
            .flat_map(|k| [(k, false), (k, true)])
            .find(|&(k, r)| good.tree.nodes[k].side(r).is_leaf())
            .unwrap();
        refused(&|t| {
            let key = t.nodes[leaf.0].side(leaf.1).children as usize;
            t.leaves.v[key] = Some(2 * leaf.0 + !leaf.1 as usize);
        });
    }

    /// The depth of a tree, in wide nodes from the root (a one-leaf tree: 1).
    fn depth(t: &Tree) -> usize {
        let mut deepest = 0;
        let mut stack = vec![(0usize, 1usize)];
        while let Some((k, d)) = stack.pop() {
            deepest = deepest.max(d);
            for right in [false, true] {
                let n = t.nodes[k].side(right);
                if n.leaf_count() > 1 {
                    stack.push((n.children as usize, d + 1));
                }
            }
        }
        if t.nodes.is_empty() { 0 } else { deepest }
    }

    /// Trees parry builds stay far below [`MAX_TREE_DEPTH`]: rapier's broad phase with 4,000
    /// colliders inserted ten a step along a line (the incremental insertion's worst order)
    /// and a 20,000-triangle strip (the binned build). Prints the depths.
    #[test]
    fn parry_builds_shallow_trees() {
        let mut w = PhysicsWorld::new();
        for i in 0..4000 {
            let at = Vector::new(i as Real * 0.5, 0.0, 0.0);
            w.insert_collider(ColliderBuilder::ball(0.1).translation(at), None);
            if i % 10 == 9 {
                w.step();
            }
        }
        w.step();
        let (bp, _) = mirror_broad_phase(&w.broad_phase).unwrap();
        let line = depth(&bp.tree);
        let n = 10_000u32;
        let vertices: Vec<_> = (0..=n)
            .flat_map(|i| [0.0, 1.0].map(|z| Vector::new(i as Real * 0.1, 0.0, z)))
            .collect();
        let indices: Vec<_> = (0..n)
            .flat_map(|i| {
                [
                    [2 * i, 2 * i + 2, 2 * i + 1],
                    [2 * i + 1, 2 * i + 2, 2 * i + 3],
                ]
            })
            .collect();
        let mesh = TriMesh::new(vertices, indices).unwrap();
        let (m, _) = mirror_tree(mesh.bvh()).unwrap();
        let strip = depth(&m);
        println!(
            "depths: broad phase of 4,000 in a line {line}, strip of 20,000 triangles {strip}"
        );
        assert!(
            line > 12 && strip > 14,
            "a tree of that size is at least log2(n) deep"
        );
        assert!(line < MAX_TREE_DEPTH / 8 && strip < MAX_TREE_DEPTH / 8);
        check_tree(&bp.tree, u64::MAX).unwrap();
        check_tree(&m, 2 * n as u64).unwrap();
    }

    /// A chain of wide nodes `d` deep (each holding one leaf and the next node), as a file
    /// could craft it, with the root parent and optimiser state of a real tree.
    fn chain(d: usize, like: &Tree) -> Tree {
        let leaf = |key: usize| Node {
            mins: [key as Real; 3],
            children: key as u32,
            maxs: [key as Real + 1.5; 3],
            data: 1,
        };
        let nodes = (0..d)
            .map(|k| {
                let right = if k + 1 == d {
                    leaf(d)
                } else {
                    Node {
                        mins: [(k + 1) as Real; 3],
                        children: (k + 1) as u32,
                        maxs: [d as Real + 1.5; 3],
                        data: (d - k) as u32,
                    }
                };
                Wide {
                    left: leaf(k),
                    right,
                }
            })
            .collect();
        let parents = (0..d).map(|k| {
            if k == 0 {
                like.parents[0]
            } else {
                2 * (k - 1) + 1
            }
        });
        let mut v: Vec<_> = (0..d).map(|k| Some(2 * k)).collect();
        v.push(Some(2 * (d - 1) + 1));
        Tree {
            nodes,
            parents: parents.collect(),
            leaves: LeafMap { n: d + 1, v },
            optimization: like.optimization,
            free_wide_nodes: Vec::new(),
        }
    }

    /// A chain exactly [`MAX_TREE_DEPTH`] deep passes the checks, one level more is refused,
    /// and parry refits and self-intersects the deepest accepted chain on a thread with a
    /// 256 KiB stack (an eighth of a spawned thread's 2 MiB) in optimised builds: the bound
    /// leaves parry's recursions that margin (debug builds: within the 2 MiB).
    #[test]
    fn a_chain_at_the_depth_bound_fits_a_small_stack() {
        let w = busy_world(|_| {});
        let (real, _) = mirror_broad_phase(&w.broad_phase).unwrap();
        let deepest = chain(MAX_TREE_DEPTH, &real.tree);
        check_tree(&deepest, u64::MAX).unwrap();
        assert_eq!(depth(&deepest), MAX_TREE_DEPTH);
        let (_, reason) = check_tree(&chain(MAX_TREE_DEPTH + 1, &real.tree), u64::MAX).unwrap_err();
        assert!(reason.contains("deeper"), "{reason}");
        let mut bvh: Bvh = postcard::from_bytes(&encode(&deepest)).expect("parry reads the chain");
        // Unoptimised builds take larger frames per level: their bound is the 2 MiB of a
        // spawned thread itself.
        let stack = if cfg!(debug_assertions) {
            2 << 20
        } else {
            256 << 10
        };
        let pairs = std::thread::Builder::new()
            .stack_size(stack)
            .spawn(move || {
                let mut ws = rapier3d::parry::partitioning::BvhWorkspace::default();
                bvh.refit(&mut ws);
                let mut pairs = 0;
                bvh.traverse_bvtt_single_tree::<false>(&mut ws, &mut |_, _| pairs += 1);
                pairs
            })
            .unwrap()
            .join()
            .expect("no overflow");
        // Each leaf's box overlaps the next one's only.
        assert_eq!(pairs, MAX_TREE_DEPTH);
    }
}
