//! The wide tree's build: the SAH-optimal collapse of obvhs's binary tree into wide
//! nodes and leaf blocks (see the module docs of `wide`).

use obvhs::bvh2::Bvh2;

use super::{is_triangle, Block, Node, Tris, WideBvh, FIRST_BITS, LEAF_FLAG, MAX_BLOCKS, MAX_W, TRIS};
use crate::accel::shapes::{Primitive, Shape, NO_LIGHT};
use crate::simd::{Vector, LANES};

/// The SAH cost of testing one wide node's boxes, the unit of [`BLOCK_COST`].
const NODE_COST: f32 = 1.0;
/// The SAH cost of testing one leaf block, relative to a node (measured:
/// docs/performance.md).
const BLOCK_COST: f32 = 1.6;
/// The SAH cost of testing one primitive of a leaf that holds a shape other than a
/// triangle (the scalar kernels test each alone), relative to a node (measured:
/// docs/performance.md).
const PRIM_COST: f32 = 0.6;

/// How a binary node's subtree is best laid out in a given number of wide child slots
/// (Ylitie et al., "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide
/// BVHs", 2017, section 4.1; obvhs's `bvh2_to_cwbvh` follows the same scheme).
#[derive(Clone, Copy, Default)]
struct Decision {
    /// SAH cost of the subtree laid out this way (surface area × [`NODE_COST`] per wide
    /// node, × [`BLOCK_COST`] per leaf block).
    cost: f32,
    /// [`LEAF_SLOT`], [`NODE_SLOT`] or [`SPLIT`].
    kind: u8,
    /// With [`SPLIT`] (and for a [`NODE_SLOT`]'s own children): the slot decisions of the
    /// two binary children.
    left: u8,
    right: u8,
}

/// The subtree takes one slot as a leaf.
const LEAF_SLOT: u8 = 0;
/// The subtree takes one slot as a wide node.
const NODE_SLOT: u8 = 1;
/// The subtree's two children share the slots (`left` + `right` + 2 of them).
const SPLIT: u8 = 2;

impl<S: Vector> WideBvh<S> {
    /// Builds the wide tree over `fine`, a binary tree with one primitive per leaf whose
    /// `primitive_indices` index `prims`: the wide nodes and leaves that minimise the SAH
    /// cost among the collapses of `fine` (see [`Decision`]), leaves of at most `max_leaf`
    /// primitives. `None` when the tree cannot be encoded (more than 2²⁷ leaf blocks, a
    /// leaf over 64 primitives): the binary traversal then serves.
    pub fn build(fine: &Bvh2, prims: &[Primitive], max_leaf: u32) -> Option<WideBvh<S>> {
        assert!(S::LANES <= MAX_W, "nodes hold at most {MAX_W} children");
        fine.nodes.first()?;
        let plan = Self::plan(fine, prims, max_leaf);
        let mut tree = WideBvh { nodes: Vec::new(), blocks: Vec::new(), ids: Vec::new(), depth: 0 };
        let root = &fine.nodes[0];
        let top = if root.is_leaf() || plan[0][0].kind == LEAF_SLOT {
            vec![0]
        } else {
            let mut kids = Vec::with_capacity(S::LANES);
            Self::children(fine, &plan, 0, 0, &mut kids);
            kids
        };
        tree.nodes.push(Node { bounds: [[S::splat(0.0); 3]; 2], child: [u32::MAX; MAX_W], valid: 0 });
        tree.fill(fine, &plan, prims, 0, &top, 1)?;
        Some(tree)
    }

    /// Every binary node's best [`Decision`] for 1 to `W` slots (index = slots − 1),
    /// bottom-up (by an explicit stack: fuzzed meshes build very deep trees).
    fn plan(fine: &Bvh2, prims: &[Primitive], max_leaf: u32) -> Vec<[Decision; MAX_W]> {
        let w = S::LANES;
        let mut plan = vec![[Decision::default(); MAX_W]; fine.nodes.len()];
        let mut count = vec![0u32; fine.nodes.len()];
        // Per binary node: how many of the primitives below it are not triangles.
        let mut other = vec![0u32; fine.nodes.len()];
        // A leaf of triangles costs its blocks; one holding another shape goes to the
        // scalar kernels, which pay per primitive.
        let leaf_cost = |area: f32, n: u32, other: u32| {
            if other == 0 {
                area * BLOCK_COST * n.div_ceil(TRIS as u32) as f32
            } else {
                area * PRIM_COST * n as f32
            }
        };
        let mut stack = vec![(0usize, false)];
        while let Some((k, ready)) = stack.pop() {
            let node = &fine.nodes[k];
            let area = node.aabb().half_area();
            if node.is_leaf() {
                count[k] = node.prim_count;
                let first = node.first_index as usize;
                other[k] = fine.primitive_indices[first..first + node.prim_count as usize]
                    .iter()
                    .filter(|&&id| !is_triangle(&prims[id as usize]))
                    .count() as u32;
                let d = Decision { cost: leaf_cost(area, count[k], other[k]), kind: LEAF_SLOT, left: 0, right: 0 };
                plan[k] = [d; MAX_W];
                continue;
            }
            let (l, r) = (node.first_index as usize, node.first_index as usize + 1);
            if !ready {
                stack.extend([(k, true), (r, false), (l, false)]);
                continue;
            }
            count[k] = count[l] + count[r];
            other[k] = other[l] + other[r];
            // One slot: a leaf, or a wide node whose W slots the children share.
            let mut inner = Decision { cost: f32::INFINITY, kind: NODE_SLOT, left: 0, right: 0 };
            for j in 0..w - 1 {
                let c = plan[l][j].cost + plan[r][w - 2 - j].cost;
                if c < inner.cost {
                    inner = Decision { cost: c, kind: NODE_SLOT, left: j as u8, right: (w - 2 - j) as u8 };
                }
            }
            inner.cost += area * NODE_COST;
            let leaf = if count[k] <= max_leaf { leaf_cost(area, count[k], other[k]) } else { f32::INFINITY };
            plan[k][0] = if leaf < inner.cost { Decision { cost: leaf, kind: LEAF_SLOT, ..inner } } else { inner };
            // i + 1 slots: as few, or split between the children.
            for i in 1..w {
                let mut best = plan[k][i - 1];
                for j in 0..i {
                    let c = plan[l][j].cost + plan[r][i - 1 - j].cost;
                    if c < best.cost {
                        best = Decision { cost: c, kind: SPLIT, left: j as u8, right: (i - 1 - j) as u8 };
                    }
                }
                plan[k][i] = best;
            }
        }
        plan
    }

    /// Appends to `out` the binary nodes that fill the wide slots of binary node `k` laid
    /// out by its decision `i`: each child that splits further contributes its own.
    fn children(fine: &Bvh2, plan: &[[Decision; MAX_W]], k: usize, i: usize, out: &mut Vec<usize>) {
        let d = plan[k][i];
        let first = fine.nodes[k].first_index as usize;
        for (c, j) in [(first, d.left as usize), (first + 1, d.right as usize)] {
            if !fine.nodes[c].is_leaf() && plan[c][j].kind == SPLIT {
                Self::children(fine, plan, c, j, out);
            } else {
                out.push(c);
            }
        }
    }

    /// Fills wide node `index` (already appended) with the binary nodes `kids`, one per
    /// slot: its leaves' blocks are appended first, then its inner children, side by side,
    /// then each of their subtrees in turn, so what one node leads to lies together in
    /// memory.
    fn fill(
        &mut self,
        fine: &Bvh2,
        plan: &[[Decision; MAX_W]],
        prims: &[Primitive],
        index: usize,
        kids: &[usize],
        depth: usize,
    ) -> Option<()> {
        self.depth = self.depth.max(depth);
        let mut lo = [[f32::INFINITY; LANES]; 3];
        let mut hi = [[f32::INFINITY; LANES]; 3];
        let mut child = [u32::MAX; MAX_W];
        let inner = |k: usize| !fine.nodes[k].is_leaf() && plan[k][0].kind != LEAF_SLOT;
        for (slot, &k) in kids.iter().enumerate() {
            let b = fine.nodes[k].aabb();
            for axis in 0..3 {
                lo[axis][slot] = b.min[axis];
                hi[axis][slot] = b.max[axis];
            }
            if !inner(k) {
                child[slot] = self.leaf(fine, prims, k)?;
            }
        }
        for (slot, &k) in kids.iter().enumerate() {
            if inner(k) {
                child[slot] = self.nodes.len() as u32;
                self.nodes.push(self.nodes[index]);
            }
        }
        let load3 = |a: &[[f32; LANES]; 3]| [S::load(&a[0]), S::load(&a[1]), S::load(&a[2])];
        self.nodes[index] = Node { bounds: [load3(&lo), load3(&hi)], child, valid: (1 << kids.len()) - 1 };
        let mut below = Vec::with_capacity(S::LANES);
        for (slot, &k) in kids.iter().enumerate() {
            if inner(k) {
                below.clear();
                Self::children(fine, plan, k, 0, &mut below);
                self.fill(fine, plan, prims, child[slot] as usize, &below, depth + 1)?;
            }
        }
        Some(())
    }

    /// Appends the blocks of a leaf holding every primitive below binary node `k`; returns
    /// its child reference.
    fn leaf(&mut self, fine: &Bvh2, prims: &[Primitive], k: usize) -> Option<u32> {
        let mut ids = Vec::new();
        let mut stack = vec![k];
        while let Some(n) = stack.pop() {
            let node = &fine.nodes[n];
            if node.is_leaf() {
                let first = node.first_index as usize;
                ids.extend_from_slice(&fine.primitive_indices[first..first + node.prim_count as usize]);
            } else {
                stack.extend([node.first_index as usize + 1, node.first_index as usize]);
            }
        }
        let (start, n) = (self.blocks.len(), ids.len().div_ceil(TRIS));
        if start + n > 1 << FIRST_BITS || n > MAX_BLOCKS || n == 0 {
            return None;
        }
        for lanes in ids.chunks(TRIS) {
            let mut v = [[[0.0f32; LANES]; 3]; 3];
            let mut blockers = 0;
            for (l, &id) in lanes.iter().enumerate() {
                let p = &prims[id as usize];
                if let Shape::Triangle { v0, v1, v2 } = p.shape {
                    for (j, vert) in [v0, v1, v2].iter().enumerate() {
                        for axis in 0..3 {
                            v[j][axis][l] = vert[axis];
                        }
                    }
                }
                blockers |= ((p.light == NO_LIGHT) as u32) << l;
            }
            let triangles = lanes.iter().all(|&id| is_triangle(&prims[id as usize]));
            let v = v.map(|axes| axes.map(|a| Tris::load(&a)));
            let first = self.ids.len() as u32;
            self.ids.extend_from_slice(lanes);
            self.blocks.push(Block { v, first, count: lanes.len() as u32, blockers, triangles });
        }
        Some(LEAF_FLAG | ((n - 1) as u32) << FIRST_BITS | start as u32)
    }
}
