//! The wide BVH for single rays: obvhs's `Bvh2` collapsed into nodes of up to `W` children
//! (`W` = lanes of the `wide` vector, 8 in the renderer: [`Wide`]) whose boxes are stored
//! structure-of-arrays, so one ray tests all of a node's children with one SIMD slab test
//! and visits the hit ones nearest first (Embree's single-ray layout; Wald et al.,
//! "Getting Rid of Packets", 2008). obvhs stays the builder: the wide nodes and leaves are
//! chosen among its binary tree's nodes (taken before its leaf collapse, one primitive per
//! leaf) by the SAH-optimal collapse of Ylitie et al. (2017), with leaves costed by the
//! blocks they fill, so the wide tree's leaves are not the binary tree's.
//!
//! A leaf's triangles are stored structure-of-arrays too, in blocks of [`TRIS`] lanes (a
//! leaf of more takes consecutive blocks), and tested at once, one lane per triangle.
//!
//! Exactness: each child box is tested with the scalar traversal's arithmetic
//! (`(bound − origin) · inv`, far distance widened by 1 + 2γ₃, culled past
//! `tmax · CULL + slack`); each triangle lane performs [`intersect_triangle`]'s operations
//! in the same order (a lane whose edge function rounds to zero takes the scalar kernel,
//! which recomputes in f64), the nearest lane wins and on an exact tie in t the lowest
//! primitive id, as in every kernel ([`nearer`]); blocks holding another shape run the
//! scalar kernels. Every box is widened by one float after the build (`widen_boxes`), so a
//! ray meets every primitive it touches whatever the tree, and the tie rule makes the
//! answer independent of the order the tree is walked in: the closest distance is the
//! binary kernels' bit for bit, and so is the primitive.

use glam::{BVec3A, Vec3, Vec3A, Vec3Swizzles};
use obvhs::bvh2::Bvh2;
use obvhs::ray::Ray;
use wide::f32x8;

use super::bvh::{nearer, ray, tie_limit, Traversal, CULL};
use super::packet::{Simd, MAX};
use super::shapes::{intersect_triangle, shear_axes, Primitive, Shape, NO_LIGHT};

/// The node width the renderer uses (chosen by measurement: docs/performance.md).
pub type Wide = f32x8;

/// The SIMD type of a leaf block (lanes = triangles; measured: docs/performance.md).
type Tris = f32x8;
/// Triangles per leaf block.
const TRIS: usize = <Tris as Simd>::LANES;

/// Child slot flag: the child is a leaf.
const LEAF: u32 = 1 << 31;
/// Bits of a leaf's first block; the bits above (below [`LEAF`]) hold its block count − 1.
const FIRST_BITS: u32 = 27;
/// Most blocks per leaf the encoding holds.
const MAX_BLOCKS: usize = 1 << (31 - FIRST_BITS);
/// Most children per node (the width of [`Node::child`]).
const MAX_W: usize = 8;
thread_local! {
    /// The traversal stack, kept per thread so a ray neither allocates nor zeroes one.
    static STACK: std::cell::RefCell<Vec<(u32, f32)>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// One node: up to `S::LANES` children, their boxes by axis with one lane per child.
#[derive(Clone, Copy)]
#[repr(C)]
struct Node<S> {
    /// `bounds[0]`: box minima per axis (x, y, z), one lane per child; `bounds[1]`: maxima.
    /// Empty slots hold +∞ in both (a box no ray enters).
    bounds: [[S; 3]; 2],
    /// Per child: an inner node's index, or [`LEAF`] | (blocks − 1) << [`FIRST_BITS`] | first block.
    child: [u32; MAX_W],
    /// One bit per occupied child slot.
    valid: u32,
}

/// Up to [`TRIS`] consecutive primitives of a leaf; their vertices by lane when all are
/// triangles.
#[derive(Clone, Copy)]
#[repr(C)]
struct Block {
    /// `v[j][axis]`: vertex j's coordinate on `axis`, one lane per triangle.
    v: [[Tris; 3]; 3],
    /// Where the block's primitive ids start in [`WideBvh::ids`] (lane l is primitive
    /// `ids[first + l]`).
    first: u32,
    /// Primitives in the block.
    count: u32,
    /// Lanes that block shadow rays (not emitters).
    blockers: u32,
    /// All primitives are triangles (else the scalar kernels test them).
    triangles: bool,
}

/// The collapsed tree (see the module docs).
pub struct WideBvh<S> {
    nodes: Vec<Node<S>>,
    blocks: Vec<Block>,
    /// The primitive ids of the blocks' lanes (read only for a hit, so kept apart from
    /// the vertices a traversal streams through).
    ids: Vec<u32>,
    /// Depth in wide nodes (root = 1).
    depth: usize,
}

/// A ray set up for the SIMD triangle test: [`intersect_triangle`]'s shear frame, once.
struct Sheared {
    axes: [usize; 3],
    /// d[kx]/d[kz], d[ky]/d[kz], 1/d[kz].
    shear: [f32; 3],
    /// The origin's components, permuted to the frame.
    origin: [f32; 3],
}

impl Sheared {
    #[inline(always)]
    fn new(o: Vec3, d: Vec3) -> Sheared {
        let axes = shear_axes(d);
        // The frame's components by lane selects (the frame is a rotation of x, y, z), not
        // by indexing by axis, which branches on the axis.
        let (m0, m1) = (BVec3A::splat(axes[2] == 0), BVec3A::splat(axes[2] == 1));
        let frame = |v: Vec3| {
            let v = Vec3A::from(v);
            Vec3A::select(m0, v.yzx(), Vec3A::select(m1, v.zxy(), v))
        };
        let (fo, fd) = (frame(o), frame(d));
        // d[kx]/d[kz], d[ky]/d[kz], 1/d[kz]: the scalar test's three divisions, on lanes.
        let shear = Vec3A::new(fd.x, fd.y, 1.0) / Vec3A::splat(fd.z);
        Sheared { axes, shear: shear.to_array(), origin: fo.to_array() }
    }

    /// Each lane's distance to its triangle exactly as [`intersect_triangle`] computes it
    /// (infinity for a miss); `lanes` says which lanes matter.
    #[inline(always)]
    fn triangles(&self, b: &Block, lanes: u32, o: Vec3, d: Vec3) -> Tris {
        let rel = |j: usize| {
            let v = &b.v[j];
            [0, 1, 2].map(|k| v[self.axes[k]] - Tris::splat(self.origin[k]))
        };
        let (a, bb, c) = (rel(0), rel(1), rel(2));
        let (sx, sy, sz) = (Tris::splat(self.shear[0]), Tris::splat(self.shear[1]), Tris::splat(self.shear[2]));
        let (ax, ay) = (a[0] - sx * a[2], a[1] - sy * a[2]);
        let (bx, by) = (bb[0] - sx * bb[2], bb[1] - sy * bb[2]);
        let (cx, cy) = (c[0] - sx * c[2], c[1] - sy * c[2]);
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let (zero, inf) = (Tris::splat(0.0), Tris::splat(f32::INFINITY));
        let outside = (u.lt(zero) | v.lt(zero) | w.lt(zero)) & (u.gt(zero) | v.gt(zero) | w.gt(zero));
        let det = u + v + w;
        // An edge function that rounds to zero is recomputed in f64 by the scalar kernel;
        // those (rare) lanes take it whole.
        let mut edge = lanes & (u.eq(zero) | v.eq(zero) | w.eq(zero)).bits();
        let missed = outside | det.eq(zero);
        if edge == 0 && lanes & !missed.bits() == 0 {
            // Most blocks an incoherent ray reaches miss in every lane: skip the distance.
            return inf;
        }
        let dist = (u * sz * a[2] + v * sz * bb[2] + w * sz * c[2]) / det;
        let t = Tris::select(missed, inf, Tris::select(det.finite() & dist.finite(), dist, inf));
        if edge == 0 {
            return t;
        }
        let mut out = [0.0; MAX];
        t.store(&mut out);
        while edge != 0 {
            let l = edge.trailing_zeros() as usize;
            edge &= edge - 1;
            let at = |j: usize| Vec3::new(b.v[j][0].to_array()[l], b.v[j][1].to_array()[l], b.v[j][2].to_array()[l]);
            out[l] = intersect_triangle(at(0), at(1), at(2), o, d);
        }
        Tris::load(&out)
    }
}

/// What [`WideBvh::walk`]'s leaf callback tells it.
enum Leaf {
    /// Keep walking; the ray's `tmax` may have shrunk.
    Go,
    /// Stop: the answer is known (any-hit).
    Stop,
}

/// The SAH cost of testing one wide node's boxes, the unit of [`BLOCK_COST`].
const NODE_COST: f32 = 1.0;
/// The SAH cost of testing one leaf block, relative to a node (measured:
/// docs/performance.md).
const BLOCK_COST: f32 = 1.6;
/// The SAH cost of testing one primitive of a leaf that holds a shape other than a
/// triangle (the scalar kernels test each alone), relative to a node (measured:
/// docs/performance.md).
const PRIM_COST: f32 = 0.6;

/// True for a triangle: the shape leaf blocks test on lanes (others take the scalar
/// kernels, and the collapse costs them per primitive).
fn is_triangle(p: &Primitive) -> bool {
    matches!(p.shape, Shape::Triangle { .. })
}

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

impl<S: Simd> WideBvh<S> {
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
        let mut lo = [[f32::INFINITY; MAX]; 3];
        let mut hi = [[f32::INFINITY; MAX]; 3];
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
        let load3 = |a: &[[f32; MAX]; 3]| [S::load(&a[0]), S::load(&a[1]), S::load(&a[2])];
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
            let mut v = [[[0.0f32; MAX]; 3]; 3];
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
        Some(LEAF | ((n - 1) as u32) << FIRST_BITS | start as u32)
    }

    /// Starts loading child `c` (a node or a leaf's first block) into the cache, every
    /// cache line of it (measured: docs/performance.md). A no-op off x86-64.
    #[inline(always)]
    fn prefetch(&self, c: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let (p, bytes) = if c & LEAF != 0 {
                let first = (c & ((1 << FIRST_BITS) - 1)) as usize;
                (self.blocks.as_ptr().wrapping_add(first).cast::<i8>(), std::mem::size_of::<Block>())
            } else {
                (self.nodes.as_ptr().wrapping_add(c as usize).cast::<i8>(), std::mem::size_of::<Node<S>>())
            };
            for line in (0..bytes).step_by(64) {
                // SAFETY: a prefetch is a hint that never faults and reads nothing into the
                // program; SSE, which it needs, is part of every x86-64 target.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(line)) };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = c;
    }

    /// Bytes of the node and leaf-block arrays.
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node<S>>()
            + self.blocks.len() * std::mem::size_of::<Block>()
            + self.ids.len() * std::mem::size_of::<u32>()
    }

    /// Depth of the tree in wide nodes (root = 1).
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Wide nodes in the tree.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True when the tree has no nodes (never, for a built one).
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Walks the tree for one ray, nearest child first when `ORDER` (closest hit; any-hit
    /// visits them in slot order): `leaf(ray, block)` tests a leaf block, may lower
    /// `ray.tmax`, and says whether to go on. `slack` is the tree's absolute culling slack
    /// (see [`CULL`]).
    #[inline(always)]
    fn walk<const COUNT: bool, const ORDER: bool>(
        &self,
        slack: f32,
        ray: Ray,
        c: &mut Traversal,
        leaf: impl FnMut(&mut Ray, &Block) -> Leaf,
    ) {
        STACK.with_borrow_mut(|stack| {
            // A node at depth k leaves at most W − 1 siblings on the stack for each of the
            // k − 1 nodes above it, plus its own W: depth · (W − 1) + 1 bounds the stack;
            // W more, for the any-hit walk's stores past its top.
            let need = self.depth * (S::LANES - 1) + 1 + S::LANES;
            if stack.len() < need {
                stack.resize(need, (0, 0.0));
            }
            self.walk_with::<COUNT, ORDER>(slack, ray, c, stack, leaf)
        })
    }

    /// [`WideBvh::walk`] with its stack (long enough for the tree's depth; the top is kept
    /// in a local index, so pushes and pops stay in registers).
    #[inline(always)]
    fn walk_with<const COUNT: bool, const ORDER: bool>(
        &self,
        slack: f32,
        mut ray: Ray,
        c: &mut Traversal,
        stack: &mut [(u32, f32)],
        mut leaf: impl FnMut(&mut Ray, &Block) -> Leaf,
    ) {
        const WIDEN: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);
        let o = [S::splat(ray.origin.x), S::splat(ray.origin.y), S::splat(ray.origin.z)];
        let inv = [S::splat(ray.inv_direction.x), S::splat(ray.inv_direction.y), S::splat(ray.inv_direction.z)];
        let mut cull = ray.tmax * CULL + slack;
        let mut current = 0u32;
        let mut top = 0usize;
        loop {
            if current & LEAF != 0 {
                let first = (current & ((1 << FIRST_BITS) - 1)) as usize;
                let count = ((current & !LEAF) >> FIRST_BITS) as usize + 1;
                for block in &self.blocks[first..first + count] {
                    if COUNT {
                        c.prims += block.count as u64;
                    }
                    if let Leaf::Stop = leaf(&mut ray, block) {
                        return;
                    }
                }
                cull = ray.tmax * CULL + slack;
            } else {
                let node = &self.nodes[current as usize];
                // The scalar slab test's min(t1, t2) and max(t1, t2): `(bound − o) · inv`
                // is monotone in the bound, so these are its values bit for bit.
                let t1 = [0, 1, 2].map(|k| (node.bounds[0][k] - o[k]) * inv[k]);
                let t2 = [0, 1, 2].map(|k| (node.bounds[1][k] - o[k]) * inv[k]);
                let near = t1[0].min(t2[0]).max(t1[1].min(t2[1])).max(t1[2].min(t2[2]));
                let far = t1[0].max(t2[0]).min(t1[1].max(t2[1])).min(t1[2].max(t2[2])) * S::splat(WIDEN);
                let hit = far.ge(near) & far.ge(S::splat(0.0)) & near.lt(S::splat(cull));
                let mut bits = hit.bits() & node.valid;
                if COUNT {
                    c.nodes += node.valid.count_ones() as u64;
                }
                if bits & (bits.wrapping_sub(1)) == 0 {
                    if bits != 0 {
                        current = node.child[bits.trailing_zeros() as usize];
                        continue;
                    }
                } else if !ORDER {
                    // Any-hit: the order does not change the answer, so skip the sort
                    // (as Embree's occlusion traversal does).
                    // Every hit child is pushed in slot order without a branch per child
                    // (each slot is stored, and the top moves past it only if it was hit:
                    // where the hit children stop is data the branch predictor cannot
                    // learn), then the last is taken off again and visited straight from
                    // the node, not through a store and a load.
                    // Only the child is stored: an any-hit walk pops without the culling
                    // test (the box test was against the same cull). `j ≤ i < LANES`, so
                    // the mask changes no index; it only spares a bounds check per slot.
                    let slots = &mut stack[top..top + S::LANES];
                    let mut j = 0;
                    for (i, &child) in node.child.iter().enumerate().take(S::LANES) {
                        slots[j & (S::LANES - 1)].0 = child;
                        j += (bits >> i) as usize & 1;
                    }
                    top += j;
                    top -= 1;
                    // The new top of the stack is visited next after this subtree: start
                    // its loads now (one prefetch; every pushed child's was slower).
                    self.prefetch(stack[top - 1].0);
                    current = node.child[(31 - bits.leading_zeros()) as usize];
                    continue;
                } else {
                    let mut t = [0.0f32; MAX];
                    near.store(&mut t);
                    // The first two hit children: the nearer is visited next, the other
                    // pushed (a tie visits the later slot first, as the sort below does).
                    let i = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let k = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let (a, b) = ((node.child[i], t[i]), (node.child[k], t[k]));
                    let (near, far) = if a.1 < b.1 { (a, b) } else { (b, a) };
                    // The far children are visited later, if not culled by then: start
                    // their loads now (a walk waits on memory most of its time).
                    self.prefetch(far.0);
                    if bits == 0 {
                        // Two hits, the most common case past one: no sort.
                        stack[top] = far;
                        top += 1;
                        current = near.0;
                        continue;
                    }
                    // More: push them all, insertion-sorting the pushed ones farthest
                    // first, so the nearest is on top (ties keep slot order: deterministic).
                    let base = top;
                    stack[top] = far;
                    stack[top + 1] = near;
                    top += 2;
                    while bits != 0 {
                        let i = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        let e = (node.child[i], t[i]);
                        self.prefetch(e.0);
                        let mut j = top;
                        while j > base && stack[j - 1].1 < e.1 {
                            stack[j] = stack[j - 1];
                            j -= 1;
                        }
                        stack[j] = e;
                        top += 1;
                    }
                    top -= 1;
                    current = stack[top].0;
                    continue;
                }
            }
            // Next: the most recently saved child that the ray, as it stands, still enters
            // before its tmax (the same culling rule as the box test).
            loop {
                if top == 0 {
                    return;
                }
                top -= 1;
                let (next, t) = stack[top];
                if !ORDER || t < cull {
                    current = next;
                    if !ORDER && top > 0 {
                        // As after a push: the entry below is the any-hit walk's next.
                        self.prefetch(stack[top - 1].0);
                    }
                    break;
                }
            }
        }
    }

    /// Closest hit within `(tmin, tmax)` among `prims` (the primitives the Bvh2's leaves
    /// index): `(t, primitive index)`, or `None`. The same distance as
    /// [`Accel::closest`](super::Accel::closest), bit for bit.
    #[inline]
    #[allow(clippy::too_many_arguments)] // the ray's four values, as Accel::closest takes them
    pub fn closest<const COUNT: bool>(
        &self,
        prims: &[Primitive],
        slack: f32,
        o: Vec3,
        d: Vec3,
        tmin: f32,
        tmax: f32,
        c: &mut Traversal,
    ) -> Option<(f32, u32)> {
        let mut best = (f32::INFINITY, u32::MAX);
        let sheared = Sheared::new(o, d);
        self.walk::<COUNT, true>(slack, ray(o, d, tmin, tmax), c, |r, b| {
            if !b.triangles {
                let first = b.first as usize;
                for &id in &self.ids[first..first + b.count as usize] {
                    let limit = tie_limit(best, r.tmax);
                    let t = prims[id as usize].shape.intersect(o, d, r.tmin, limit);
                    if t < limit && nearer(t, id, best) {
                        r.tmax = t;
                        best = (t, id);
                    }
                }
                return Leaf::Go;
            }
            let lanes = (1 << b.count) - 1;
            let t = sheared.triangles(b, lanes, o, d);
            let limit = tie_limit(best, r.tmax);
            let ok = (t.gt(Tris::splat(r.tmin)) & t.lt(Tris::splat(limit))).bits() & lanes;
            if ok != 0 {
                // Each hitting lane through the tie rule: the nearest, the lowest primitive
                // id on a tie (ids are not in lane order: the leaves gather subtrees).
                let mut a = [0.0; MAX];
                t.store(&mut a);
                let mut m = ok;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let id = self.ids[b.first as usize + k];
                    if nearer(a[k], id, best) {
                        best = (a[k], id);
                        r.tmax = a[k];
                    }
                }
            }
            Leaf::Go
        });
        (best.1 != u32::MAX).then_some(best)
    }

    /// True when a non-emitting primitive of `prims` blocks `(tmin, tmax)` along the ray;
    /// stops at the first blocker. The same answer as [`Accel::occluded`](super::Accel::occluded).
    #[inline]
    #[allow(clippy::too_many_arguments)] // the ray's four values, as Accel::occluded takes them
    pub fn occluded<const COUNT: bool>(
        &self,
        prims: &[Primitive],
        slack: f32,
        o: Vec3,
        d: Vec3,
        tmin: f32,
        tmax: f32,
        c: &mut Traversal,
    ) -> bool {
        let mut blocked = false;
        let sheared = Sheared::new(o, d);
        self.walk::<COUNT, false>(slack, ray(o, d, tmin, tmax), c, |r, b| {
            if !b.triangles {
                let first = b.first as usize;
                for p in self.ids[first..first + b.count as usize].iter().map(|&id| &prims[id as usize]) {
                    if p.light == NO_LIGHT && p.shape.intersect(o, d, r.tmin, r.tmax) < r.tmax {
                        blocked = true;
                        return Leaf::Stop;
                    }
                }
                return Leaf::Go;
            }
            let t = sheared.triangles(b, b.blockers, o, d);
            if (t.gt(Tris::splat(r.tmin)) & t.lt(Tris::splat(r.tmax))).bits() & b.blockers != 0 {
                blocked = true;
                return Leaf::Stop;
            }
            Leaf::Go
        });
        blocked
    }
}
