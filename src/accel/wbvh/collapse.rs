//! The wide tree's build: the SAH-optimal collapse of obvhs's binary tree into wide
//! nodes and leaf blocks (see the module docs of `wbvh`).

use obvhs::bvh2::Bvh2;

use super::{is_triangle, Block, LeafRef, Node, Tris, WideBvh, FIRST_BITS, MAX_BLOCKS, MAX_W, TRIS};
use crate::accel::shapes::{Primitive, Shape, NO_LIGHT};
use crate::accel::{bvh2, prefetch_line, widen, BuildPhases, Lap};
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
/// block) is kept apart while the plan is made. Packed in a byte (kind in bits 6–7, the
/// left and right children's slot decisions in bits 3–5 and 0–2), so the plan's minima are
/// selects rather than branches and the plan takes 8 bytes a node.
#[derive(Clone, Copy, Default)]
struct Decision(u8);

impl Decision {
    fn new(kind: u8, left: usize, right: usize) -> Decision {
        Decision(kind << 6 | (left as u8) << 3 | right as u8)
    }

    /// [`LEAF_SLOT`], [`NODE_SLOT`] or [`SPLIT`].
    fn kind(self) -> u8 {
        self.0 >> 6
    }

    /// With [`SPLIT`] (and for a [`NODE_SLOT`]'s own children): the slot decision of the
    /// left binary child.
    fn left(self) -> usize {
        (self.0 >> 3 & 7) as usize
    }

    /// Likewise of the right binary child.
    fn right(self) -> usize {
        (self.0 & 7) as usize
    }
}

const _: () = assert!(MAX_W <= 8, "a decision packs slot counts in 3 bits");

/// How many nodes ahead the plan loads a node's children's costs: [`bvh2::bottom_up`]
/// visits mostly downwards by index, long after the children (sphere 8's plan 0.23 →
/// 0.18 s; 64 ahead gained nothing more).
const PREFETCH: usize = 16;

/// The subtree takes one slot as a leaf.
const LEAF_SLOT: u8 = 0;
/// The subtree takes one slot as a wide node.
const NODE_SLOT: u8 = 1;
/// The subtree's two children share the slots (`left` + `right` + 2 of them).
const SPLIT: u8 = 2;

impl<S: Vector> WideBvh<S> {
    /// Lays out the wide tree over `fine`, a binary tree with one primitive per leaf whose
    /// `primitive_indices` index `prims` (its boxes as built: they are widened here, see
    /// [`widen`]): the wide nodes and leaves that minimise the SAH cost among the collapses
    /// of `fine` (see [`Decision`]), leaves of at most `max_leaf` primitives, filled with
    /// nodes and the primitives of each leaf block; [`Layout::finish`] makes the blocks.
    /// `None` when the tree cannot be encoded (more than 2²⁵ leaf blocks, a leaf over 64
    /// primitives): the binary traversal then serves. Sets the plan's and the fill's phases.
    pub fn lay_out<'a>(
        fine: &'a Bvh2,
        prims: &'a [Primitive],
        max_leaf: u32,
        phases: &mut BuildPhases,
    ) -> Option<Layout<'a, S>> {
        assert!(S::WIDTH <= MAX_W, "nodes hold at most {MAX_W} children");
        fine.nodes.first()?;
        let mut lap = Lap::start();
        // Only a mesh with other shapes needs each leaf's primitives looked at.
        let mixed = !prims.iter().all(is_triangle);
        let plan = Self::plan(fine, prims, mixed, max_leaf);
        phases.wide_plan = lap.next();
        let mut tree = WideBvh { nodes: Vec::new(), blocks: Vec::new(), ids: Vec::new(), other: Vec::new(), depth: 0 };
        let root = &fine.nodes[0];
        let mut top = Slots::default();
        if root.is_leaf() || plan[0][0].kind() == LEAF_SLOT {
            top.push(0);
        } else {
            Self::children(fine, &plan, 0, 0, &mut top);
        }
        tree.nodes.push(Node { bounds: [[S::splat(0.0); 3]; 2], child: [u32::MAX; MAX_W], valid: 0 });
        let mut packer = Packer {
            fine,
            prims,
            mixed,
            lanes: Vec::new(),
            len: Vec::new(),
            open: Vec::new(),
            ids: Vec::new(),
            stack: Vec::new(),
        };
        tree.fill(&plan, &mut packer, 0, top.as_slice(), 1)?;
        phases.wide_fill = lap.next();
        Some(Layout { tree, packer })
    }

    /// Every binary node's best [`Decision`] for 1 to `W` slots (index = slots − 1),
    /// bottom-up ([`bvh2::bottom_up`]). The areas are those of obvhs's boxes, before the
    /// fill widens them by a float (widening each here took the dragon's plan from 7 to
    /// 11 ms; traversal counts on the paper's scenes moved by under 0.02%).
    fn plan(fine: &Bvh2, prims: &[Primitive], mixed: bool, max_leaf: u32) -> Vec<[Decision; MAX_W]> {
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
        let decide = |k: usize| {
            // Nodes are mostly visited downwards by index, and a parent's children were
            // visited long before: their costs are loaded a few nodes ahead.
            if let Some(ahead) = k.checked_sub(PREFETCH).map(|a| &fine.nodes[a]) {
                if !ahead.is_leaf() {
                    let l = ahead.first_index as usize;
                    prefetch_line(costs.as_ptr().wrapping_add(l + 1));
                    prefetch_line(count.as_ptr().wrapping_add(l));
                }
            }
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
                plan[k] = [Decision::new(LEAF_SLOT, 0, 0); MAX_W];
                return;
            }
            let (l, r) = (node.first_index as usize, node.first_index as usize + 1);
            count[k] = count[l] + count[r];
            other[k] = other[l] + other[r];
            let (cl, cr) = (costs[l + 1], costs[r + 1]);
            let (mut cost, mut best) = ([0.0f32; MAX_W], [Decision::default(); MAX_W]);
            // One slot: a leaf, or a wide node whose W slots the children share. Every
            // minimum takes the first of equal costs, as the plan always has (the tree, and
            // so the primitive ids, stay the same).
            let (mut inner_cost, mut inner) = (f32::INFINITY, Decision::new(NODE_SLOT, 0, 0));
            for j in 0..w - 1 {
                let c = cl[j] + cr[w - 2 - j];
                let better = c < inner_cost;
                inner_cost = if better { c } else { inner_cost };
                inner = if better { Decision::new(NODE_SLOT, j, w - 2 - j) } else { inner };
            }
            inner_cost += area * NODE_COST;
            let leaf = if count[k] <= max_leaf { leaf_cost(area, count[k], other[k]) } else { f32::INFINITY };
            (cost[0], best[0]) = if leaf < inner_cost {
                (leaf, Decision::new(LEAF_SLOT, inner.left(), inner.right()))
            } else {
                (inner_cost, inner)
            };
            // i + 1 slots: as few, or split between the children. A subtree of n
            // primitives fills at most n slots: a decision for more is the one for n (a
            // split giving a child more slots than it fills costs what a split with fewer
            // slots, already weighed, costs, and only a strictly cheaper one is taken), so
            // the splits that would give a child more are skipped and the rest copied.
            let (nl, nr) = (count[l] as usize, count[r] as usize);
            for i in 1..w {
                let (mut ci, mut bi) = (cost[i - 1], best[i - 1]);
                for j in i.saturating_sub(nr)..i.min(nl) {
                    let c = cl[j] + cr[i - 1 - j];
                    let better = c < ci;
                    ci = if better { c } else { ci };
                    bi = if better { Decision::new(SPLIT, j, i - 1 - j) } else { bi };
                }
                (cost[i], best[i]) = (ci, bi);
            }
            (costs[k + 1], plan[k]) = (cost, best);
        };
        bvh2::bottom_up(fine, decide);
        plan
    }

    /// Appends to `out` the binary nodes that fill the wide slots of binary node `k` laid
    /// out by its decision `i`: each child that splits further contributes its own.
    fn children(fine: &Bvh2, plan: &[[Decision; MAX_W]], k: usize, i: usize, out: &mut Slots) {
        let d = plan[k][i];
        let first = fine.nodes[k].first_index as usize;
        for (c, j) in [(first, d.left()), (first + 1, d.right())] {
            if !fine.nodes[c].is_leaf() && plan[c][j].kind() == SPLIT {
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
        let inner = |k: usize| !fine.nodes[k].is_leaf() && plan[k][0].kind() != LEAF_SLOT;
        for (slot, &k) in kids.iter().enumerate() {
            let b = widen(fine.nodes[k].aabb());
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
        for (slot, &k) in kids.iter().enumerate() {
            if inner(k) {
                let mut below = Slots::default();
                Self::children(fine, plan, k, 0, &mut below);
                self.fill(plan, packer, child[slot] as usize, below.as_slice(), depth + 1)?;
            }
        }
        Some(())
    }
}

/// A wide tree laid out by [`WideBvh::lay_out`]: its nodes, and the primitives of each
/// leaf block, whose blocks are not made yet.
pub struct Layout<'a, S: Vector> {
    tree: WideBvh<S>,
    packer: Packer<'a>,
}

impl<S: Vector> Layout<'_, S> {
    /// The finished tree: its leaf blocks made from the primitives, which take ids `id_of`
    /// (their places in the tree's primitive order). Sets the blocks' phase.
    pub fn finish(self, id_of: &[u32], phases: &mut BuildPhases) -> WideBvh<S> {
        use rayon::prelude::*;
        let mut lap = Lap::start();
        let (mut tree, packer) = (self.tree, self.packer);
        let (prims, n) = (packer.prims, packer.len.len());
        tree.ids = (0..n).flat_map(|b| packer.block(b)).map(|&i| id_of[i as usize]).collect();
        let mut first = Vec::with_capacity(n);
        (0..n).fold(0u32, |at, b| {
            first.push(at);
            at + packer.len[b] as u32
        });
        if packer.mixed {
            // Shapes other than triangles go to `other` in block order.
            tree.blocks = (0..n)
                .map(|b| {
                    let block = block(prims, packer.block(b), first[b], tree.other.len() as u32);
                    if !block.triangles {
                        tree.other.extend(packer.block(b).iter().map(|&id| prims[id as usize].shape));
                    }
                    block
                })
                .collect();
        } else {
            // Blocks of triangles only are independent: made on every thread, in order.
            tree.blocks = (0..n).into_par_iter().map(|b| block(prims, packer.block(b), first[b], 0)).collect();
        }
        phases.wide_blocks = lap.next();
        tree
    }
}

/// Blocks a leaf may still be packed into: the most recently opened ones with free lanes
/// (a few, so that what one node leads to stays together in memory; measured:
/// docs/performance.md).
const OPEN: usize = 4;

/// The binary nodes that fill one wide node's slots (at most [`MAX_W`]), kept on the
/// stack: the fill makes one for every wide node.
#[derive(Default)]
struct Slots {
    k: [usize; MAX_W],
    n: usize,
}

impl Slots {
    fn push(&mut self, k: usize) {
        self.k[self.n] = k;
        self.n += 1;
    }

    fn as_slice(&self) -> &[usize] {
        &self.k[..self.n]
    }
}

/// The leaf blocks as they are filled from a binary tree's leaves: each block's primitive
/// ids, and the blocks still open to more leaves.
struct Packer<'a> {
    /// The binary tree being collapsed, with one primitive per leaf.
    fine: &'a Bvh2,
    /// The primitives its leaves index.
    prims: &'a [Primitive],
    /// Whether any of them is not a triangle.
    mixed: bool,
    /// Block b's primitive ids: `lanes[b · TRIS ..][.. len[b]]`.
    lanes: Vec<u32>,
    len: Vec<u8>,
    /// Open blocks, oldest first (at most [`OPEN`]).
    open: Vec<usize>,
    /// Scratch for one leaf: its primitive ids, and the walk that gathers them.
    ids: Vec<u32>,
    stack: Vec<usize>,
}

impl Packer<'_> {
    /// Block `b`'s primitive ids.
    fn block(&self, b: usize) -> &[u32] {
        &self.lanes[b * TRIS..b * TRIS + self.len[b] as usize]
    }

    /// Appends an empty block and returns its index.
    fn open_block(&mut self) -> usize {
        self.lanes.resize(self.lanes.len() + TRIS, 0);
        self.len.push(0);
        self.len.len() - 1
    }

    /// Appends `ids` to block `b`.
    fn put(&mut self, b: usize, ids: &[u32]) {
        let a = b * TRIS + self.len[b] as usize;
        self.lanes[a..a + ids.len()].copy_from_slice(ids);
        self.len[b] += ids.len() as u8;
    }

    /// Places a leaf holding every primitive below binary node `k` and returns its child
    /// reference ([`LeafRef`]). A leaf of triangles that fits in a block goes into the open
    /// block it fills best, or a new one; a larger leaf, or one holding another shape,
    /// takes blocks of its own. `None` past the encoding's limits.
    fn leaf(&mut self, k: usize) -> Option<u32> {
        let fine = self.fine;
        let mut ids = std::mem::take(&mut self.ids);
        ids.clear();
        self.stack.clear();
        self.stack.push(k);
        while let Some(n) = self.stack.pop() {
            let node = &fine.nodes[n];
            if node.is_leaf() {
                let first = node.first_index as usize;
                ids.extend_from_slice(&fine.primitive_indices[first..first + node.prim_count as usize]);
            } else {
                self.stack.extend([node.first_index as usize + 1, node.first_index as usize]);
            }
        }
        let reference = self.place(&ids);
        self.ids = ids;
        reference
    }

    /// Places the leaf of primitives `ids` (see [`Packer::leaf`]).
    fn place(&mut self, ids: &[u32]) -> Option<u32> {
        let (n, prims) = (ids.len(), self.prims);
        if n == 0 || n > MAX_BLOCKS * TRIS || self.len.len() + n.div_ceil(TRIS) > 1 << FIRST_BITS {
            return None;
        }
        if n > TRIS || (self.mixed && !ids.iter().all(|&id| is_triangle(&prims[id as usize]))) {
            let first = self.len.len();
            for chunk in ids.chunks(TRIS) {
                let b = self.open_block();
                self.put(b, chunk);
            }
            let blocks = self.len.len() - first;
            return Some(LeafRef::encode(first, (blocks == 1).then_some((0, n - 1)), blocks));
        }
        // Best fit: the open block with the fewest free lanes that still holds the leaf.
        let fit = (0..self.open.len())
            .filter(|&i| self.len[self.open[i]] as usize + n <= TRIS)
            .max_by_key(|&i| (self.len[self.open[i]], i));
        let at = match fit {
            Some(i) => self.open[i],
            None => {
                let b = self.open_block();
                self.open.push(b);
                if self.open.len() > OPEN {
                    self.open.remove(0);
                }
                b
            }
        };
        let a = self.len[at] as usize;
        self.put(at, ids);
        if a + n == TRIS {
            self.open.retain(|&b| b != at);
        }
        Some(LeafRef::encode(at, Some((a, a + n - 1)), 1))
    }
}

/// The leaf block holding primitives `lanes` (one per lane, indices of `prims`), whose
/// ids start at `first` in the tree's id table and, unless all are triangles, whose shapes
/// start at `other` in its table of other shapes.
fn block(prims: &[Primitive], lanes: &[u32], first: u32, other: u32) -> Block {
    let mut v = [[[0.0f32; LANES]; 3]; 3];
    let (mut blockers, mut triangles) = (0, true);
    for (l, &id) in lanes.iter().enumerate() {
        let p = &prims[id as usize];
        if let Shape::Triangle { v0, v1, v2 } = p.shape {
            for (j, vert) in [v0, v1, v2].iter().enumerate() {
                for axis in 0..3 {
                    v[j][axis][l] = vert[axis];
                }
            }
        } else {
            triangles = false;
        }
        blockers |= ((p.light == NO_LIGHT) as u32) << l;
    }
    let v = v.map(|axes| axes.map(|a| Tris::load(&a)));
    Block { v, first, count: lanes.len() as u32, blockers, triangles, other }
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
