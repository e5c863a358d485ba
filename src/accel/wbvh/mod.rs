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
//! scalar kernels. Every box is widened by one float as the tree is filled (`widen`), so a
//! ray meets every primitive it touches whatever the tree, and the tie rule makes the
//! answer independent of the order the tree is walked in: the closest distance is the
//! binary kernels' bit for bit, and so is the primitive.

mod beam;
mod collapse;
mod stream;
mod walk;

pub(crate) use beam::{Beam, BeamLeaf};
pub use stream::MIN_STREAM;
pub use walk::INTERLEAVE;

use glam::{BVec3A, Vec3, Vec3A, Vec3Swizzles};
use wide::f32x8;

use super::lanes_of;
use super::shapes::{intersect_triangle, shear_axes, triangle_t_error, Primitive, Shape};
use crate::simd::{Vector, LANES};

/// The node width the renderer uses (chosen by measurement: docs/performance.md).
pub type Wide = f32x8;

/// The SIMD type of a leaf block (lanes = triangles; measured: docs/performance.md).
type Tris = f32x8;
/// Triangles per leaf block.
const TRIS: usize = <Tris as Vector>::WIDTH;

/// Child slot flag: the child is a leaf.
const LEAF_FLAG: u32 = 1 << 31;
/// Bits of a leaf's first block (see [`LeafRef`] for the bits above it).
const FIRST_BITS: u32 = 25;
/// Bits of a lane number in a block.
const LANE_BITS: u32 = TRIS.trailing_zeros();
/// Most blocks per leaf the encoding holds.
const MAX_BLOCKS: usize = TRIS;
/// Most children per node (the width of [`Node::child`]).
const MAX_W: usize = 8;

const _: () = assert!(FIRST_BITS + 2 * LANE_BITS == 31 && TRIS.is_power_of_two(), "a leaf reference fills 31 bits");

/// A leaf child's blocks and lanes, as its child reference encodes them: [`LEAF_FLAG`] |
/// e << (`FIRST_BITS` + `LANE_BITS`) | a << `FIRST_BITS` | first block. With a ≤ e the
/// leaf is lanes a..=e of one block, which it may share with other leaves (leaves are
/// packed, so blocks are mostly full); with a > e it is blocks first..first + e + 2, whole
/// (a leaf of more than [`TRIS`] primitives, never shared).
#[derive(Clone, Copy)]
pub(crate) struct LeafRef {
    /// The first block.
    first: usize,
    /// Blocks in the leaf.
    blocks: usize,
    /// The lanes of each block that are the leaf's (a lane past a block's count is empty).
    lanes: u32,
}

impl LeafRef {
    /// Decodes a leaf's child reference.
    #[inline(always)]
    fn of(c: u32) -> LeafRef {
        let first = (c & ((1 << FIRST_BITS) - 1)) as usize;
        let a = (c >> FIRST_BITS) & (TRIS as u32 - 1);
        let e = (c >> (FIRST_BITS + LANE_BITS)) & (TRIS as u32 - 1);
        if a <= e {
            LeafRef { first, blocks: 1, lanes: ((2 << e) - 1) & !((1 << a) - 1) }
        } else {
            LeafRef { first, blocks: e as usize + 2, lanes: u32::MAX }
        }
    }

    /// The reference of lanes `a..=e` of block `first` (`a ≤ e`), or of `blocks` (2 to
    /// [`MAX_BLOCKS`]) whole blocks from `first` (`None` for `a`, `e`).
    fn encode(first: usize, lanes: Option<(usize, usize)>, blocks: usize) -> u32 {
        let (a, e) = lanes.unwrap_or((TRIS - 1, blocks - 2));
        LEAF_FLAG | (e as u32) << (FIRST_BITS + LANE_BITS) | (a as u32) << FIRST_BITS | first as u32
    }
}

/// One node: up to `S::WIDTH` children, their boxes by axis with one lane per child.
#[derive(Clone, Copy)]
#[repr(C)]
struct Node<S> {
    /// `bounds[0]`: box minima per axis (x, y, z), one lane per child; `bounds[1]`: maxima.
    /// Empty slots hold +∞ in both (a box no ray enters).
    bounds: [[S; 3]; 2],
    /// Per child: an inner node's index, or a leaf's reference ([`LeafRef`]).
    child: [u32; MAX_W],
    /// One bit per occupied child slot.
    valid: u32,
}

/// Up to [`TRIS`] primitives of one or more leaves (see [`LeafRef`]); their vertices by
/// lane when all are triangles.
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
    /// When not all are triangles: where the block's shapes start in [`WideBvh::other`]
    /// (lane l is `other[other + l]`).
    other: u32,
}

/// The collapsed tree (see the module docs).
pub struct WideBvh<S> {
    nodes: Vec<Node<S>>,
    blocks: Vec<Block>,
    /// The primitive ids of the blocks' lanes (read only for a hit, so kept apart from
    /// the vertices a traversal streams through).
    ids: Vec<u32>,
    /// The shapes of the blocks that hold a primitive other than a triangle, one per lane
    /// (the only copy of a primitive's shape the tree keeps beside its blocks' vertices).
    other: Vec<Shape>,
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
        let error = triangle_t_error([ax, bx, cx], [ay, by, cy], [a[2], bb[2], c[2]], sz, [u, v, w], det);
        let kept = det.finite() & dist.finite() & dist.gt(error);
        let t = Tris::select(missed, inf, Tris::select(kept, dist, inf));
        if edge == 0 {
            return t;
        }
        let mut out = [0.0; LANES];
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

impl Block {
    /// The lanes that hold a primitive.
    #[inline(always)]
    fn lanes(&self) -> u32 {
        (1 << self.count) - 1
    }
}

/// True for a triangle: the shape leaf blocks test on lanes (others take the scalar
/// kernels, and the collapse costs them per primitive).
fn is_triangle(p: &Primitive) -> bool {
    matches!(p.shape, Shape::Triangle { .. })
}

impl<S: Vector> WideBvh<S> {
    /// Starts loading child `c` (a node or a leaf's first block) into the cache, every
    /// cache line of it (measured: docs/performance.md). A no-op off x86-64.
    #[inline(always)]
    fn prefetch(&self, c: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            let (p, bytes) = if c & LEAF_FLAG != 0 {
                let first = LeafRef::of(c).first;
                (self.blocks.as_ptr().wrapping_add(first).cast::<i8>(), std::mem::size_of::<Block>())
            } else {
                (self.nodes.as_ptr().wrapping_add(c as usize).cast::<i8>(), std::mem::size_of::<Node<S>>())
            };
            for line in (0..bytes).step_by(64) {
                crate::accel::prefetch_line(p.wrapping_add(line));
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
            + self.other.len() * std::mem::size_of::<Shape>()
    }

    /// The shape in lane `slot % TRIS` of block `slot / TRIS`: the tree holds every
    /// primitive's shape, so the accelerator keeps no other copy.
    #[inline(always)]
    pub(crate) fn shape(&self, slot: u32) -> Shape {
        self.lane_shape(&self.blocks[slot as usize / TRIS], slot as usize % TRIS)
    }

    /// The shape in lane `l` of block `b`.
    #[inline(always)]
    fn lane_shape(&self, b: &Block, l: usize) -> Shape {
        if b.triangles {
            let at = |j: usize| Vec3::new(b.v[j][0].as_array()[l], b.v[j][1].as_array()[l], b.v[j][2].as_array()[l]);
            Shape::Triangle { v0: at(0), v1: at(1), v2: at(2) }
        } else {
            self.other[b.other as usize + l]
        }
    }

    /// Every primitive's slot (`block · TRIS + lane`), by primitive id: what
    /// [`WideBvh::shape`] takes.
    pub(crate) fn slots(&self, prims: usize) -> Vec<u32> {
        let mut slot = vec![u32::MAX; prims];
        for (k, b) in self.blocks.iter().enumerate() {
            for l in 0..b.count as usize {
                slot[self.ids[b.first as usize + l] as usize] = (k * TRIS + l) as u32;
            }
        }
        slot
    }

    /// Calls `f(id, shape, blocker)` for each primitive of leaf `leaf` in lane order
    /// (`blocker`: it blocks shadow rays, not an emitter) until `f` returns false.
    #[inline(always)]
    pub(crate) fn leaf_prims(&self, leaf: LeafRef, mut f: impl FnMut(u32, Shape, bool) -> bool) {
        for b in &self.blocks[leaf.first..leaf.first + leaf.blocks] {
            for l in lanes_of(leaf.lanes & b.lanes()) {
                if !f(self.ids[b.first as usize + l], self.lane_shape(b, l), b.blockers >> l & 1 != 0) {
                    return;
                }
            }
        }
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
}
