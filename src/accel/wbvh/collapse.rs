//! The wide tree's build: the SAH-optimal collapse of obvhs's binary tree into wide
//! nodes and leaf blocks (see the module docs of `wbvh`).

use obvhs::bvh2::Bvh2;

use super::{is_triangle, Block, LeafRef, Node, Tris, WideBvh, FIRST_BITS, MAX_BLOCKS, MAX_W, TRIS};
use crate::accel::shapes::{Primitive, Shape, NO_LIGHT};
use crate::accel::{bvh2, BuildPhases, Lap};
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
/// Its SAH cost (surface area × [`NODE_COST`] per wide node, × [`BLOCK_COST`] per leaf
/// block) is kept apart while the plan is made.
#[derive(Clone, Copy, Default)]
struct Decision {
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
    pub fn build(fine: &Bvh2, prims: &[Primitive], max_leaf: u32, phases: &mut BuildPhases) -> Option<WideBvh<S>> {
        assert!(S::WIDTH <= MAX_W, "nodes hold at most {MAX_W} children");
        fine.nodes.first()?;
        let mut lap = Lap::start();
        let plan = Self::plan(fine, prims, max_leaf);
        phases.wide_plan = lap.next();
        let mut tree = WideBvh { nodes: Vec::new(), blocks: Vec::new(), ids: Vec::new(), other: Vec::new(), depth: 0 };
        let root = &fine.nodes[0];
        let top = if root.is_leaf() || plan[0][0].kind == LEAF_SLOT {
            vec![0]
        } else {
            let mut kids = Vec::with_capacity(S::WIDTH);
            Self::children(fine, &plan, 0, 0, &mut kids);
            kids
        };
        tree.nodes.push(Node { bounds: [[S::splat(0.0); 3]; 2], child: [u32::MAX; MAX_W], valid: 0 });
        let mut packer = Packer { fine, prims, blocks: Vec::new(), open: Vec::new() };
        tree.fill(&plan, &mut packer, 0, &top, 1)?;
        phases.wide_fill = lap.next();
        tree.blocks = packer.blocks.iter().map(|ids| block(prims, ids, &mut tree.ids, &mut tree.other)).collect();
        phases.wide_blocks = lap.next();
        Some(tree)
    }

    /// Every binary node's best [`Decision`] for 1 to `W` slots (index = slots − 1),
    /// bottom-up ([`bvh2::bottom_up`]).
    fn plan(fine: &Bvh2, prims: &[Primitive], max_leaf: u32) -> Vec<[Decision; MAX_W]> {
        let w = S::WIDTH;
        let n = fine.nodes.len();
        let mut plan = vec![[Decision::default(); MAX_W]; n];
        // The decisions' costs, node k at k + 1: obvhs puts siblings side by side from
        // index 1, so a node's two children share a cache line.
        let mut costs = vec![[0.0f32; MAX_W]; n + 1];
        let mut count = vec![0u32; n];
        // Per binary node: how many of the primitives below it are not triangles.
        let mut other = vec![0u32; n];
        // A leaf of triangles costs its blocks; one holding another shape goes to the
        // scalar kernels, which pay per primitive.
        let leaf_cost = |area: f32, n: u32, other: u32| {
            if other == 0 {
                area * BLOCK_COST * n.div_ceil(TRIS as u32) as f32
            } else {
                area * PRIM_COST * n as f32
            }
        };
        // Only a mesh with other shapes needs each leaf's primitives looked at.
        let mixed = !prims.iter().all(is_triangle);
        let decide = |k: usize| {
            let node = &fine.nodes[k];
            let area = node.aabb().half_area();
            if node.is_leaf() {
                count[k] = node.prim_count;
                let first = node.first_index as usize;
                other[k] = match mixed {
                    true => fine.primitive_indices[first..first + node.prim_count as usize]
                        .iter()
                        .filter(|&&id| !is_triangle(&prims[id as usize]))
                        .count() as u32,
                    false => 0,
                };
                costs[k + 1] = [leaf_cost(area, count[k], other[k]); MAX_W];
                plan[k] = [Decision { kind: LEAF_SLOT, left: 0, right: 0 }; MAX_W];
                return;
            }
            let (l, r) = (node.first_index as usize, node.first_index as usize + 1);
            count[k] = count[l] + count[r];
            other[k] = other[l] + other[r];
            let (cl, cr) = (costs[l + 1], costs[r + 1]);
            let (mut cost, mut best) = ([0.0f32; MAX_W], [Decision::default(); MAX_W]);
            // One slot: a leaf, or a wide node whose W slots the children share.
            let (mut inner_cost, mut inner) = (f32::INFINITY, Decision { kind: NODE_SLOT, left: 0, right: 0 });
            for j in 0..w - 1 {
                let c = cl[j] + cr[w - 2 - j];
                if c < inner_cost {
                    (inner_cost, inner) = (c, Decision { kind: NODE_SLOT, left: j as u8, right: (w - 2 - j) as u8 });
                }
            }
            inner_cost += area * NODE_COST;
            let leaf = if count[k] <= max_leaf { leaf_cost(area, count[k], other[k]) } else { f32::INFINITY };
            (cost[0], best[0]) =
                if leaf < inner_cost { (leaf, Decision { kind: LEAF_SLOT, ..inner }) } else { (inner_cost, inner) };
            // i + 1 slots: as few, or split between the children. A subtree of n
            // primitives fills at most n slots: a decision for more is the one for n (a
            // split giving a child more slots than it fills costs what a split with fewer
            // slots, already weighed, costs, and only a strictly cheaper one is taken), so
            // the splits that would give a child more are skipped and the rest copied.
            let (nl, nr) = (count[l] as usize, count[r] as usize);
            for i in 1..w {
                (cost[i], best[i]) = (cost[i - 1], best[i - 1]);
                for j in i.saturating_sub(nr)..i.min(nl) {
                    let c = cl[j] + cr[i - 1 - j];
                    if c < cost[i] {
                        (cost[i], best[i]) = (c, Decision { kind: SPLIT, left: j as u8, right: (i - 1 - j) as u8 });
                    }
                }
            }
            (costs[k + 1], plan[k]) = (cost, best);
        };
        bvh2::bottom_up(fine, decide);
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

    /// Fills wide node `index` (already appended) with the binary nodes `kids` of
    /// `packer`'s tree, one per slot: its leaves are packed first, then its inner children
    /// appended side by side, then each of their subtrees filled in turn, so what one node
    /// leads to lies together in memory.
    fn fill(
        &mut self,
        plan: &[[Decision; MAX_W]],
        packer: &mut Packer,
        index: usize,
        kids: &[usize],
        depth: usize,
    ) -> Option<()> {
        self.depth = self.depth.max(depth);
        let fine = packer.fine;
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
                child[slot] = packer.leaf(k)?;
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
        let mut below = Vec::with_capacity(S::WIDTH);
        for (slot, &k) in kids.iter().enumerate() {
            if inner(k) {
                below.clear();
                Self::children(fine, plan, k, 0, &mut below);
                self.fill(plan, packer, child[slot] as usize, &below, depth + 1)?;
            }
        }
        Some(())
    }
}

/// Blocks a leaf may still be packed into: the most recently opened ones with free lanes
/// (a few, so that what one node leads to stays together in memory; measured:
/// docs/performance.md).
const OPEN: usize = 4;

/// The leaf blocks as they are filled from a binary tree's leaves: each block's primitive
/// ids, and the blocks still open to more leaves.
struct Packer<'a> {
    /// The binary tree being collapsed, with one primitive per leaf.
    fine: &'a Bvh2,
    /// The primitives its leaves index.
    prims: &'a [Primitive],
    blocks: Vec<Vec<u32>>,
    /// Open blocks, oldest first (at most [`OPEN`]).
    open: Vec<usize>,
}

impl Packer<'_> {
    /// Places a leaf holding every primitive below binary node `k` and returns its child
    /// reference ([`LeafRef`]). A leaf of triangles that fits in a block goes into the open
    /// block it fills best, or a new one; a larger leaf, or one holding another shape,
    /// takes blocks of its own. `None` past the encoding's limits.
    fn leaf(&mut self, k: usize) -> Option<u32> {
        let (fine, prims) = (self.fine, self.prims);
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
        let n = ids.len();
        if n == 0 || n > MAX_BLOCKS * TRIS || self.blocks.len() + n.div_ceil(TRIS) > 1 << FIRST_BITS {
            return None;
        }
        if n > TRIS || !ids.iter().all(|&id| is_triangle(&prims[id as usize])) {
            let first = self.blocks.len();
            self.blocks.extend(ids.chunks(TRIS).map(<[u32]>::to_vec));
            let blocks = self.blocks.len() - first;
            return Some(LeafRef::encode(first, (blocks == 1).then_some((0, n - 1)), blocks));
        }
        // Best fit: the open block with the fewest free lanes that still holds the leaf.
        let fit = (0..self.open.len())
            .filter(|&i| self.blocks[self.open[i]].len() + n <= TRIS)
            .max_by_key(|&i| (self.blocks[self.open[i]].len(), i));
        let at = match fit {
            Some(i) => self.open[i],
            None => {
                self.blocks.push(Vec::with_capacity(TRIS));
                self.open.push(self.blocks.len() - 1);
                if self.open.len() > OPEN {
                    self.open.remove(0);
                }
                self.blocks.len() - 1
            }
        };
        let a = self.blocks[at].len();
        self.blocks[at].extend_from_slice(&ids);
        if a + n == TRIS {
            self.open.retain(|&b| b != at);
        }
        Some(LeafRef::encode(at, Some((a, a + n - 1)), 1))
    }
}

/// The leaf block holding primitives `lanes` (one per lane), its ids appended to `ids`
/// and, unless all are triangles, its shapes to `other`.
fn block(prims: &[Primitive], lanes: &[u32], ids: &mut Vec<u32>, other: &mut Vec<Shape>) -> Block {
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
    let (first, at) = (ids.len() as u32, other.len() as u32);
    ids.extend_from_slice(lanes);
    if !triangles {
        other.extend(lanes.iter().map(|&id| prims[id as usize].shape));
    }
    Block { v, first, count: lanes.len() as u32, blockers, triangles, other: at }
}

#[cfg(test)]
mod tests {
    use crate::accel::shapes::{Primitive, Shape, NO_LIGHT};
    use crate::accel::{nearer, Accel, BvhQuality, Ray, Traversal, Walk};
    use glam::Vec3;

    /// Leaves packed into shared blocks, larger leaves over several blocks and leaves of
    /// other shapes in blocks of their own all give every kernel of the wide tree the
    /// brute-force answer (closest hit with the tie rule; any hit ignoring emitters), at
    /// every leaf size; at the renderer's leaf size the blocks are mostly full.
    #[test]
    fn packed_leaves_give_brute_force_answers_at_every_leaf_size() {
        let mut h = 7u32;
        let mut rnd = || {
            h = crate::sampling::mix(h);
            crate::sampling::to_unit(h)
        };
        let mut prims = Vec::new();
        for k in 0..3000u32 {
            let c = Vec3::new(rnd(), rnd(), rnd()) * 10.0 - 5.0;
            let e = |r: &mut dyn FnMut() -> f32| Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * 0.8;
            let shape = match k % 97 {
                0 => Shape::Sphere { center: c, radius: 0.2 },
                1 => Shape::Quad { corner: c, u: e(&mut rnd), v: e(&mut rnd) },
                _ => Shape::Triangle { v0: c, v1: c + e(&mut rnd), v2: c + e(&mut rnd) },
            };
            let light = if k % 13 == 0 { 0 } else { NO_LIGHT };
            prims.push(Primitive { shape, material: 0, light });
        }
        for max_leaf in [1, 3, 8, 16, 64] {
            let accel = Accel::build_with(prims.clone(), max_leaf, BvhQuality::High);
            let wide = accel.wide.as_ref().expect("a wide tree");
            let filled = wide.blocks.iter().map(|b| b.count as f32).sum::<f32>() / wide.blocks.len() as f32;
            if max_leaf == 8 {
                assert!(filled > 6.5, "{filled} primitives per block");
            }
            let mut rays = Vec::new();
            for _ in 0..2000 {
                let o = Vec3::new(rnd(), rnd(), rnd()) * 14.0 - 7.0;
                let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
                rays.push(Ray::new(o, d, 0.0, 1.0 + rnd() * 20.0));
            }
            let (mut many, mut streamed) = (vec![None; rays.len()], vec![None; rays.len()]);
            let mut stream_blocked = vec![None; rays.len()];
            let whole = |i: usize| Ray { tmax: f32::INFINITY, ..rays[i] };
            let c = &mut Traversal::default();
            accel.closest_many::<false>(Walk::Interleaved, rays.len(), whole, |i, hit| many[i] = Some(hit), c);
            accel.closest_many::<false>(Walk::Stream, rays.len(), whole, |i, hit| streamed[i] = Some(hit), c);
            accel.occluded_many::<false>(Walk::Stream, rays.len(), |i| rays[i], |i, b| stream_blocked[i] = Some(b), c);
            for (i, r) in rays.iter().enumerate() {
                let mut best = (f32::INFINITY, u32::MAX);
                let mut blocked = false;
                for (id, p) in accel.prims().enumerate() {
                    let t = p.shape.intersect(r.origin, r.dir, 0.0, f32::INFINITY);
                    if t < f32::INFINITY && nearer(t, id as u32, best) {
                        best = (t, id as u32);
                    }
                    blocked |= p.light == NO_LIGHT && t < r.tmax;
                }
                let expect = (best.1 != u32::MAX).then_some(best);
                let whole = Ray { tmax: f32::INFINITY, ..*r };
                assert_eq!(
                    accel.closest::<false>(whole, &mut Traversal::default()),
                    expect,
                    "leaf {max_leaf}, ray {i}"
                );
                assert_eq!(many[i], Some(expect), "leaf {max_leaf}, ray {i}, interleaved");
                assert_eq!(streamed[i], Some(expect), "leaf {max_leaf}, ray {i}, stream");
                assert_eq!(stream_blocked[i], Some(blocked), "leaf {max_leaf}, ray {i}, stream any-hit");
                assert_eq!(accel.occluded::<false>(*r, &mut Traversal::default()), blocked, "leaf {max_leaf}, ray {i}");
            }
        }
    }
}
