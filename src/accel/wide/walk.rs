//! The single-ray walk of the wide tree: one ray tests all of a node's children in one
//! SIMD slab test and visits the hit ones nearest first (closest hit) or in slot order
//! (any hit); leaf blocks test their triangles on lanes.

use super::{Block, Sheared, Tris, WideBvh, FIRST_BITS, LEAF_FLAG};
use crate::accel::shapes::{Primitive, NO_LIGHT};
use crate::accel::{nearer, tie_limit, Ray, SlabRay, Traversal, CULL};
use crate::simd::{Vector, LANES};

thread_local! {
    /// The traversal stack, kept per thread so a ray neither allocates nor zeroes one.
    static WALK_STACK: std::cell::RefCell<Vec<(u32, f32)>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// What [`WideBvh::walk`]'s leaf callback tells it.
enum Leaf {
    /// Keep walking; the ray's `tmax` may have shrunk.
    Go,
    /// Stop: the answer is known (any-hit).
    Stop,
}

impl<S: Vector> WideBvh<S> {
    /// Walks the tree for one ray, nearest child first when `ORDER` (closest hit; any-hit
    /// visits them in slot order): `leaf(ray, block)` tests a leaf block, may lower
    /// `ray.tmax`, and says whether to go on. `slack` is the tree's absolute culling slack
    /// (see [`CULL`]).
    #[inline(always)]
    fn walk<const COUNT: bool, const ORDER: bool>(
        &self,
        slack: f32,
        ray: SlabRay,
        c: &mut Traversal,
        leaf: impl FnMut(&mut SlabRay, &Block) -> Leaf,
    ) {
        WALK_STACK.with_borrow_mut(|stack| {
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
        mut ray: SlabRay,
        c: &mut Traversal,
        stack: &mut [(u32, f32)],
        mut leaf: impl FnMut(&mut SlabRay, &Block) -> Leaf,
    ) {
        const WIDEN: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);
        let o = [S::splat(ray.origin.x), S::splat(ray.origin.y), S::splat(ray.origin.z)];
        let inv = [S::splat(ray.inv_direction.x), S::splat(ray.inv_direction.y), S::splat(ray.inv_direction.z)];
        let mut cull = ray.tmax * CULL + slack;
        let mut current = 0u32;
        let mut top = 0usize;
        loop {
            if current & LEAF_FLAG != 0 {
                let first = (current & ((1 << FIRST_BITS) - 1)) as usize;
                let count = ((current & !LEAF_FLAG) >> FIRST_BITS) as usize + 1;
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
                let near = t1[0].fast_min(t2[0]).fast_max(t1[1].fast_min(t2[1])).fast_max(t1[2].fast_min(t2[2]));
                let far = t1[0].fast_max(t2[0]).fast_min(t1[1].fast_max(t2[1])).fast_min(t1[2].fast_max(t2[2]))
                    * S::splat(WIDEN);
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
                    let mut t = [0.0f32; LANES];
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

    /// Closest hit along `ray` among `prims` (the primitives the Bvh2's leaves
    /// index): `(t, primitive index)`, or `None`. The same distance as
    /// [`Accel::closest`](super::Accel::closest), bit for bit.
    #[inline]
    pub fn closest<const COUNT: bool>(
        &self,
        prims: &[Primitive],
        slack: f32,
        ray: Ray,
        c: &mut Traversal,
    ) -> Option<(f32, u32)> {
        let mut best = (f32::INFINITY, u32::MAX);
        let (o, d) = (ray.origin, ray.dir);
        let sheared = Sheared::new(o, d);
        self.walk::<COUNT, true>(slack, ray.slab(), c, |r, b| {
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
                let mut a = [0.0; LANES];
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

    /// True when a non-emitting primitive of `prims` blocks `ray`'s segment;
    /// stops at the first blocker. The same answer as [`Accel::occluded`](super::Accel::occluded).
    #[inline]
    pub fn occluded<const COUNT: bool>(&self, prims: &[Primitive], slack: f32, ray: Ray, c: &mut Traversal) -> bool {
        let mut blocked = false;
        let (o, d) = (ray.origin, ray.dir);
        let sheared = Sheared::new(o, d);
        self.walk::<COUNT, false>(slack, ray.slab(), c, |r, b| {
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
