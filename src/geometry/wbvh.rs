//! The wide BVH for single rays: obvhs's `Bvh2` collapsed into nodes of up to `W` children
//! (`W` = lanes of the `wide` vector, 8 in the renderer: [`Wide`]) whose boxes are stored
//! structure-of-arrays, so one ray tests all of a node's children with one SIMD slab test
//! and visits the hit ones nearest first (Embree's single-ray layout; Wald et al.,
//! "Getting Rid of Packets", 2008). obvhs stays the builder: the collapse only regroups
//! its nodes, and the leaves are its leaves, over the same primitive order.
//!
//! Exactness: each child box is tested with the scalar traversal's arithmetic
//! (`(bound − origin) · inv`, far distance widened by 1 + 2γ₃, culled past
//! `tmax · CULL + slack`), and leaves run the scalar primitive kernels. Skipping the
//! binary tree's intermediate boxes loses no hit: a parent's computed entry distance is
//! never later than its child's (subtraction and multiplication round monotonically), so
//! a primitive reachable here is reachable there. The closest distance is the same bit
//! for bit; only on an exact tie in t may the primitive differ.

use glam::Vec3;
use obvhs::bvh2::Bvh2;
use obvhs::ray::Ray;
use wide::f32x8;

use super::bvh::{Traversal, CULL};
use super::packet::{Simd, MAX};
use super::shapes::{Primitive, NO_LIGHT};

/// The node width the renderer uses (chosen by measurement: docs/performance.md).
pub type Wide = f32x8;

/// Child slot flag: the child is a leaf.
const LEAF: u32 = 1 << 31;
/// Bits of a leaf's first primitive; the bits above (below [`LEAF`]) hold its count − 1.
const FIRST_BITS: u32 = 25;
/// Most primitives per leaf the encoding holds.
const MAX_LEAF: u32 = 1 << (31 - FIRST_BITS);
/// Entries of the traversal stack; a tree that may need more is not built (the
/// scalar traversal serves it).
const STACK: usize = 512;

/// One node: up to `S::LANES` children, their boxes by axis with one lane per child.
#[derive(Clone, Copy)]
#[repr(C)]
struct Node<S> {
    /// Box minima per axis (x, y, z), one lane per child; empty slots hold +∞.
    lo: [S; 3],
    /// Box maxima per axis; empty slots hold +∞ too (a box no ray enters).
    hi: [S; 3],
    /// Per child: an inner node's index, or [`LEAF`] | (count − 1) << [`FIRST_BITS`] | first.
    child: [u32; MAX],
    /// One bit per occupied child slot.
    valid: u32,
}

/// The collapsed tree (see the module docs).
pub struct WideBvh<S> {
    nodes: Vec<Node<S>>,
    /// Depth in wide nodes (root = 1): bounds the stack.
    depth: usize,
}

/// What [`WideBvh::walk`]'s leaf callback tells it.
enum Leaf {
    /// Keep walking; the ray's `tmax` may have shrunk.
    Go,
    /// Stop: the answer is known (any-hit).
    Stop,
}

impl<S: Simd> WideBvh<S> {
    /// Collapses `bvh` (whose leaves index primitives in the order the caller keeps);
    /// `None` when the tree cannot be encoded (more than 2²⁵ primitives, a leaf over 64,
    /// or deep enough to overflow the fixed stack): the scalar traversal then serves.
    pub fn build(bvh: &Bvh2) -> Option<WideBvh<S>> {
        let root = bvh.nodes.first()?;
        let mut tree = WideBvh { nodes: Vec::new(), depth: 0 };
        let top = if root.is_leaf() { vec![0] } else { tree.collect(bvh, 0) };
        tree.emit(bvh, &top, 1)?;
        ((S::LANES - 1) * tree.depth < STACK).then_some(tree)
    }

    /// The Bvh2 nodes that become the children of the wide node replacing inner node
    /// `n`: its two children, then repeatedly the inner one of largest surface area
    /// replaced by its two children, until `W` are found or all are leaves.
    fn collect(&self, bvh: &Bvh2, n: usize) -> Vec<usize> {
        let first = bvh.nodes[n].first_index as usize;
        let mut kids = vec![first, first + 1];
        while kids.len() < S::LANES {
            let widest = kids
                .iter()
                .enumerate()
                .filter(|(_, &k)| !bvh.nodes[k].is_leaf())
                .max_by(|a, b| bvh.nodes[*a.1].aabb().half_area().total_cmp(&bvh.nodes[*b.1].aabb().half_area()));
            let Some((i, &k)) = widest else { break };
            let f = bvh.nodes[k].first_index as usize;
            kids[i] = f;
            kids.insert(i + 1, f + 1);
        }
        kids
    }

    /// Appends the wide node holding the Bvh2 nodes `kids` (and, depth first, the nodes
    /// below it); returns its index.
    fn emit(&mut self, bvh: &Bvh2, kids: &[usize], depth: usize) -> Option<u32> {
        self.depth = self.depth.max(depth);
        let index = self.nodes.len();
        let mut lo = [[f32::INFINITY; MAX]; 3];
        let mut hi = [[f32::INFINITY; MAX]; 3];
        let mut child = [u32::MAX; MAX];
        self.nodes.push(Node { lo: [S::splat(0.0); 3], hi: [S::splat(0.0); 3], child, valid: 0 });
        for (slot, &k) in kids.iter().enumerate() {
            let node = &bvh.nodes[k];
            let b = node.aabb();
            for axis in 0..3 {
                lo[axis][slot] = b.min[axis];
                hi[axis][slot] = b.max[axis];
            }
            child[slot] = if node.is_leaf() {
                let (first, count) = (node.first_index, node.prim_count);
                if first >= 1 << FIRST_BITS || count > MAX_LEAF {
                    return None;
                }
                LEAF | (count - 1) << FIRST_BITS | first
            } else {
                let below = self.collect(bvh, k);
                self.emit(bvh, &below, depth + 1)?
            };
        }
        let load3 = |a: &[[f32; MAX]; 3]| [S::load(&a[0]), S::load(&a[1]), S::load(&a[2])];
        self.nodes[index] = Node { lo: load3(&lo), hi: load3(&hi), child, valid: (1 << kids.len()) - 1 };
        Some(index as u32)
    }

    /// Bytes of the node array.
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node<S>>()
    }

    /// Wide nodes in the tree.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True when the tree has no nodes (never, for a built one).
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Walks the tree for one ray, nearest child first: `leaf(ray, prims)` tests a leaf's
    /// primitive range, may lower `ray.tmax`, and says whether to go on. `slack` is the
    /// tree's absolute culling slack (see [`CULL`]).
    #[inline(always)]
    fn walk<const COUNT: bool>(
        &self,
        slack: f32,
        mut ray: Ray,
        c: &mut Traversal,
        mut leaf: impl FnMut(&mut Ray, std::ops::Range<usize>) -> Leaf,
    ) {
        const WIDEN: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);
        let o = [S::splat(ray.origin.x), S::splat(ray.origin.y), S::splat(ray.origin.z)];
        let inv = [S::splat(ray.inv_direction.x), S::splat(ray.inv_direction.y), S::splat(ray.inv_direction.z)];
        let mut stack = [(0u32, 0.0f32); STACK];
        let mut len = 0;
        let mut cull = ray.tmax * CULL + slack;
        let mut current = 0u32;
        loop {
            if current & LEAF != 0 {
                let first = (current & ((1 << FIRST_BITS) - 1)) as usize;
                let count = ((current & !LEAF) >> FIRST_BITS) as usize + 1;
                if COUNT {
                    c.prims += count as u64;
                }
                if let Leaf::Stop = leaf(&mut ray, first..first + count) {
                    return;
                }
                cull = ray.tmax * CULL + slack;
            } else {
                let node = &self.nodes[current as usize];
                let mut near = S::splat(f32::NEG_INFINITY);
                let mut far = S::splat(f32::INFINITY);
                for k in 0..3 {
                    let t1 = (node.lo[k] - o[k]) * inv[k];
                    let t2 = (node.hi[k] - o[k]) * inv[k];
                    near = near.max(t1.min(t2));
                    far = far.min(t1.max(t2));
                }
                let far = far * S::splat(WIDEN);
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
                } else {
                    let mut t = [0.0f32; MAX];
                    near.store(&mut t);
                    // Push every hit child, then insertion-sort the pushed ones farthest
                    // first, so the nearest is on top (ties keep slot order: deterministic).
                    let base = len;
                    while bits != 0 {
                        let i = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        let e = (node.child[i], t[i]);
                        let mut j = len;
                        while j > base && stack[j - 1].1 < e.1 {
                            stack[j] = stack[j - 1];
                            j -= 1;
                        }
                        stack[j] = e;
                        len += 1;
                    }
                    len -= 1;
                    current = stack[len].0;
                    continue;
                }
            }
            // Next: the most recently saved child that the ray, as it stands, still enters
            // before its tmax (the same culling rule as the box test).
            loop {
                if len == 0 {
                    return;
                }
                len -= 1;
                if stack[len].1 < cull {
                    current = stack[len].0;
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
        self.walk::<COUNT>(slack, Ray::new(o.into(), d.into(), tmin, tmax), c, |r, range| {
            for id in range {
                let t = prims[id].shape.intersect(o, d, r.tmin, r.tmax);
                if t < r.tmax {
                    r.tmax = t;
                    best = (t, id as u32);
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
        self.walk::<COUNT>(slack, Ray::new(o.into(), d.into(), tmin, tmax), c, |r, range| {
            for id in range {
                let p = &prims[id];
                if p.light == NO_LIGHT && p.shape.intersect(o, d, r.tmin, r.tmax) < r.tmax {
                    blocked = true;
                    return Leaf::Stop;
                }
            }
            Leaf::Go
        });
        blocked
    }
}
