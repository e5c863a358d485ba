//! The single-ray walk of the wide tree: one ray tests all of a node's children in one
//! SIMD slab test and visits the hit ones nearest first (closest hit) or in slot order
//! (any hit); leaf blocks test their triangles on lanes.

use glam::Vec3;

use super::{Block, LeafRef, Node, Sheared, Tris, WideBvh, LEAF_FLAG};
use crate::accel::{cull_at, lanes_of, nearer, tie_limit, Ray, SlabRay, Traversal, WIDEN};
use crate::simd::{Vector, LANES};

thread_local! {
    /// The traversal stack, kept per thread so a ray neither allocates nor zeroes one.
    static WALK_STACK: std::cell::RefCell<Vec<(u32, f32)>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Rays one thread walks at once in [`WideBvh::closest_many`] and
/// [`WideBvh::occluded_many`] (chosen by measurement: docs/performance.md).
pub const INTERLEAVE: usize = 8;

/// What a walk's leaf test tells it.
pub(super) enum Leaf {
    /// Keep walking; the ray's `tmax` may have shrunk.
    Go,
    /// Stop: the answer is known (any-hit).
    Stop,
}

/// One ray's walk through the tree as a value: the ray's lanes and segment, the node or
/// leaf it visits next, and the top of its stack (the stack itself is the caller's). A
/// walk is a sequence of [`Walker::step`]s, so one thread can interleave several.
struct Walker<S> {
    o: [S; 3],
    inv: [S; 3],
    ray: SlabRay,
    /// The tree's absolute culling slack (see [`CULL`](crate::accel::CULL)).
    slack: f32,
    /// Boxes entered at or past this distance are skipped.
    cull: f32,
    current: u32,
    top: usize,
}

impl<S: Vector> Walker<S> {
    /// A walk of `ray` from the root.
    #[inline(always)]
    fn new(ray: SlabRay, slack: f32) -> Self {
        Walker {
            o: [S::splat(ray.origin.x), S::splat(ray.origin.y), S::splat(ray.origin.z)],
            inv: [S::splat(ray.inv_direction.x), S::splat(ray.inv_direction.y), S::splat(ray.inv_direction.z)],
            cull: cull_at(ray.tmax, slack),
            ray,
            slack,
            current: 0,
            top: 0,
        }
    }

    /// Visits the current node (tests its children's boxes, nearest first when `ORDER`,
    /// in slot order for any-hit) or leaf (`leaf(ray, block, lanes)` tests the leaf's
    /// lanes of each of its blocks, may lower `ray.tmax`, and says whether to go on), then
    /// moves to the next; false when the walk is over. `stack` is long enough for the
    /// tree's depth ([`WideBvh::stack_len`]).
    #[inline(always)]
    fn step<const COUNT: bool, const ORDER: bool>(
        &mut self,
        tree: &WideBvh<S>,
        stack: &mut [(u32, f32)],
        c: &mut Traversal,
        leaf: &mut impl FnMut(&mut SlabRay, &Block, u32) -> Leaf,
    ) -> bool {
        let current = self.current;
        if current & LEAF_FLAG != 0 {
            if !self.visit_leaf::<COUNT>(tree, c, leaf) {
                return false;
            }
        } else {
            let node = &tree.nodes[current as usize];
            let (bits, near) = self.hit_children::<COUNT>(node, c);
            if bits & (bits.wrapping_sub(1)) == 0 {
                if bits != 0 {
                    self.current = node.child[bits.trailing_zeros() as usize];
                    return true;
                }
            } else {
                if ORDER {
                    self.push_nearest_first(tree, node, bits, near, stack);
                } else {
                    self.push_any_order(tree, node, bits, stack);
                }
                return true;
            }
        }
        self.pop::<ORDER>(tree, stack)
    }

    /// Tests the current leaf's lanes of each of its blocks (`leaf`); false when it says
    /// stop. The culling distance follows the ray's `tmax`.
    #[inline(always)]
    fn visit_leaf<const COUNT: bool>(
        &mut self,
        tree: &WideBvh<S>,
        c: &mut Traversal,
        leaf: &mut impl FnMut(&mut SlabRay, &Block, u32) -> Leaf,
    ) -> bool {
        let l = LeafRef::of(self.current);
        for block in &tree.blocks[l.first..l.first + l.blocks] {
            let lanes = l.lanes & block.lanes();
            if COUNT {
                c.prims += lanes.count_ones() as u64;
            }
            if let Leaf::Stop = leaf(&mut self.ray, block, lanes) {
                return false;
            }
        }
        self.cull = cull_at(self.ray.tmax, self.slack);
        true
    }

    /// The children of `node` the ray enters before the culling distance (bit k: slot k),
    /// and their entry distances.
    #[inline(always)]
    fn hit_children<const COUNT: bool>(&self, node: &Node<S>, c: &mut Traversal) -> (u32, S) {
        let (o, inv) = (&self.o, &self.inv);
        // The scalar slab test's min(t1, t2) and max(t1, t2): `(bound − o) · inv`
        // is monotone in the bound, so these are its values bit for bit.
        let t1 = [0, 1, 2].map(|k| (node.bounds[0][k] - o[k]) * inv[k]);
        let t2 = [0, 1, 2].map(|k| (node.bounds[1][k] - o[k]) * inv[k]);
        let near = t1[0].fast_min(t2[0]).fast_max(t1[1].fast_min(t2[1])).fast_max(t1[2].fast_min(t2[2]));
        let far =
            t1[0].fast_max(t2[0]).fast_min(t1[1].fast_max(t2[1])).fast_min(t1[2].fast_max(t2[2])) * S::splat(WIDEN);
        let hit = far.ge(near) & far.ge(S::splat(0.0)) & near.lt(S::splat(self.cull));
        if COUNT {
            c.nodes += node.valid.count_ones() as u64;
        }
        (hit.bits() & node.valid, near)
    }

    /// Any-hit, two or more children hit (`bits`): the order does not change the answer,
    /// so skip the sort (as Embree's occlusion traversal does). Every hit child is pushed
    /// in slot order without a branch per child (each slot is stored, and the top moves
    /// past it only if it was hit: where the hit children stop is data the branch
    /// predictor cannot learn), then the last is taken off again and visited straight
    /// from the node, not through a store and a load. Only the child is stored: an any-hit
    /// walk pops without the culling test (the box test was against the same cull).
    #[inline(always)]
    fn push_any_order(&mut self, tree: &WideBvh<S>, node: &Node<S>, bits: u32, stack: &mut [(u32, f32)]) {
        let mut top = self.top;
        // `j ≤ i < LANES`, so the mask changes no index; it only spares a bounds check per
        // slot.
        let slots = &mut stack[top..top + S::WIDTH];
        let mut j = 0;
        for (i, &child) in node.child.iter().enumerate().take(S::WIDTH) {
            slots[j & (S::WIDTH - 1)].0 = child;
            j += (bits >> i) as usize & 1;
        }
        top += j;
        top -= 1;
        // The new top of the stack is visited next after this subtree: start its loads
        // now (one prefetch; every pushed child's was slower).
        tree.prefetch(stack[top - 1].0);
        self.top = top;
        self.current = node.child[(31 - bits.leading_zeros()) as usize];
    }

    /// Closest hit, two or more children hit (`bits`, entered at `near`): the nearest is
    /// visited next, the others pushed farthest first.
    #[inline(always)]
    fn push_nearest_first(
        &mut self,
        tree: &WideBvh<S>,
        node: &Node<S>,
        mut bits: u32,
        near: S,
        stack: &mut [(u32, f32)],
    ) {
        let mut top = self.top;
        let mut t = [0.0f32; LANES];
        near.store(&mut t);
        // The first two hit children: the nearer is visited next, the other pushed (a tie
        // visits the later slot first, as the sort below does).
        let i = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let k = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let (a, b) = ((node.child[i], t[i]), (node.child[k], t[k]));
        let (near, far) = if a.1 < b.1 { (a, b) } else { (b, a) };
        // The far children are visited later, if not culled by then: start their loads
        // now (a walk waits on memory most of its time).
        tree.prefetch(far.0);
        if bits == 0 {
            // Two hits, the most common case past one: no sort.
            stack[top] = far;
            self.top = top + 1;
            self.current = near.0;
            return;
        }
        // More: push them all, insertion-sorting the pushed ones farthest first, so the
        // nearest is on top (ties keep slot order: deterministic).
        let base = top;
        stack[top] = far;
        stack[top + 1] = near;
        top += 2;
        while bits != 0 {
            let i = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let e = (node.child[i], t[i]);
            tree.prefetch(e.0);
            let mut j = top;
            while j > base && stack[j - 1].1 < e.1 {
                stack[j] = stack[j - 1];
                j -= 1;
            }
            stack[j] = e;
            top += 1;
        }
        top -= 1;
        self.top = top;
        self.current = stack[top].0;
    }

    /// Moves to the most recently saved child that the ray, as it stands, still enters
    /// before its tmax (the same culling rule as the box test); false when none is left.
    #[inline(always)]
    fn pop<const ORDER: bool>(&mut self, tree: &WideBvh<S>, stack: &[(u32, f32)]) -> bool {
        let mut top = self.top;
        loop {
            if top == 0 {
                self.top = 0;
                return false;
            }
            top -= 1;
            let (next, t) = stack[top];
            if !ORDER || t < self.cull {
                self.current = next;
                self.top = top;
                if !ORDER && top > 0 {
                    // As after a push: the entry below is the any-hit walk's next.
                    tree.prefetch(stack[top - 1].0);
                }
                return true;
            }
        }
    }
}

impl<S: Vector> WideBvh<S> {
    /// Entries of one walk's stack: a node at depth k leaves at most W − 1 siblings on the
    /// stack for each of the k − 1 nodes above it, plus its own W, so depth · (W − 1) + 1
    /// bounds it; W more, for the any-hit walk's stores past its top.
    pub(super) fn stack_len(&self) -> usize {
        self.depth * (S::WIDTH - 1) + 1 + S::WIDTH
    }

    /// Walks the tree for one ray (see [`Walker::step`]). `slack` is the tree's absolute
    /// culling slack (see [`CULL`](crate::accel::CULL)).
    #[inline(always)]
    fn walk<const COUNT: bool, const ORDER: bool>(
        &self,
        slack: f32,
        ray: SlabRay,
        c: &mut Traversal,
        mut leaf: impl FnMut(&mut SlabRay, &Block, u32) -> Leaf,
    ) {
        WALK_STACK.with_borrow_mut(|stack| {
            let need = self.stack_len();
            if stack.len() < need {
                stack.resize(need, (0, 0.0));
            }
            let mut walker = Walker::new(ray, slack);
            while walker.step::<COUNT, ORDER>(self, stack, c, &mut leaf) {}
        })
    }

    /// Walks `ray` from `start` (a node's index or a leaf's reference) through the subtree
    /// under it, as [`WideBvh::walk`] walks the whole tree, on `stack` (at least
    /// [`WideBvh::stack_len`] long). Returns the ray as the walk left it (its `tmax`
    /// lowered by closest hits) and whether a leaf test said stop.
    #[inline(always)]
    pub(super) fn walk_subtree<const COUNT: bool, const ORDER: bool>(
        &self,
        slack: f32,
        ray: SlabRay,
        start: u32,
        stack: &mut [(u32, f32)],
        c: &mut Traversal,
        leaf: &mut impl FnMut(&mut SlabRay, &Block, u32) -> Leaf,
    ) -> (SlabRay, bool) {
        let mut stopped = false;
        let mut walker = Walker::new(ray, slack);
        walker.current = start;
        let mut test = |r: &mut SlabRay, b: &Block, lanes: u32| {
            let l = leaf(r, b, lanes);
            stopped |= matches!(l, Leaf::Stop);
            l
        };
        while walker.step::<COUNT, ORDER>(self, stack, c, &mut test) {}
        (walker.ray, stopped)
    }

    /// Tests lanes `lanes` of leaf block `b` for the closest hit of the ray `o`, `d`
    /// (sheared: `sheared`) within `r`'s segment, lowering `r.tmax` and updating `best` by
    /// the tie rule.
    #[allow(clippy::too_many_arguments)] // the block, the ray in three forms, the search's state
    #[inline(always)]
    pub(super) fn closest_block(
        &self,
        b: &Block,
        lanes: u32,
        o: Vec3,
        d: Vec3,
        sheared: &Sheared,
        r: &mut SlabRay,
        best: &mut (f32, u32),
    ) {
        if !b.triangles {
            for l in lanes_of(lanes) {
                let id = self.ids[b.first as usize + l];
                let limit = tie_limit(*best, r.tmax);
                let t = self.other[b.other as usize + l].intersect(o, d, r.tmin, limit);
                if t < limit && nearer(t, id, *best) {
                    r.tmax = t;
                    *best = (t, id);
                }
            }
            return;
        }
        let t = sheared.triangles(b, lanes, o, d);
        let limit = tie_limit(*best, r.tmax);
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
                if nearer(a[k], id, *best) {
                    *best = (a[k], id);
                    r.tmax = a[k];
                }
            }
        }
    }

    /// True when a non-emitting primitive in lanes `lanes` of leaf block `b` blocks `r`'s
    /// segment of the ray `o`, `d` (sheared: `sheared`).
    #[allow(clippy::too_many_arguments)] // the block and its lanes, the ray in three forms
    #[inline(always)]
    pub(super) fn block_blocks(&self, b: &Block, lanes: u32, o: Vec3, d: Vec3, sheared: &Sheared, r: &SlabRay) -> bool {
        let blockers = b.blockers & lanes;
        if !b.triangles {
            return lanes_of(blockers)
                .any(|l| self.other[b.other as usize + l].intersect(o, d, r.tmin, r.tmax) < r.tmax);
        }
        let t = sheared.triangles(b, blockers, o, d);
        (t.gt(Tris::splat(r.tmin)) & t.lt(Tris::splat(r.tmax))).bits() & blockers != 0
    }

    /// Closest hit along `ray`: `(t, primitive index)`, or `None`. The same hit as
    /// [`Accel::closest`](crate::accel::Accel::closest), bit for bit.
    #[inline]
    pub fn closest<const COUNT: bool>(&self, slack: f32, ray: Ray, c: &mut Traversal) -> Option<(f32, u32)> {
        let mut best = (f32::INFINITY, u32::MAX);
        let (o, d) = (ray.origin, ray.dir);
        let sheared = Sheared::new(o, d);
        self.walk::<COUNT, true>(slack, ray.slab(), c, |r, b, lanes| {
            self.closest_block(b, lanes, o, d, &sheared, r, &mut best);
            Leaf::Go
        });
        (best.1 != u32::MAX).then_some(best)
    }

    /// True when a non-emitting primitive blocks `ray`'s segment; stops at the
    /// first blocker. The same answer as [`Accel::occluded`](crate::accel::Accel::occluded).
    #[inline]
    pub fn occluded<const COUNT: bool>(&self, slack: f32, ray: Ray, c: &mut Traversal) -> bool {
        let mut blocked = false;
        let (o, d) = (ray.origin, ray.dir);
        let sheared = Sheared::new(o, d);
        self.walk::<COUNT, false>(slack, ray.slab(), c, |r, b, lanes| {
            if self.block_blocks(b, lanes, o, d, &sheared, r) {
                blocked = true;
                return Leaf::Stop;
            }
            Leaf::Go
        });
        blocked
    }

    /// Walks `n` rays ([`Ray`]s by index, `ray(i)`) [`INTERLEAVE`] at a time on this
    /// thread: each step of one ray's walk ends by prefetching the node or leaf it visits
    /// next, and the other rays take a step each before it comes back, so their memory
    /// loads overlap instead of each walk waiting on its own (a single-ray API such as
    /// Embree's `rtcIntersect1` cannot do this; a wavefront holds thousands of independent
    /// rays). `search(index, ray)` makes a ray's state, `test(state, slab ray, block)`
    /// tests a leaf block, and `done(index, state)` takes each finished ray's answer (in
    /// the order rays finish). Each ray walks exactly as alone, so its answer is the
    /// single-ray kernel's.
    #[allow(clippy::too_many_arguments)] // the rays, their searches and answers, the walk's settings
    #[inline(always)]
    fn interleave<const COUNT: bool, const ORDER: bool, T>(
        &self,
        slack: f32,
        n: usize,
        ray: impl Fn(usize) -> Ray,
        search: impl Fn(Ray) -> T,
        mut test: impl FnMut(&mut T, &mut SlabRay, &Block, u32) -> Leaf,
        mut done: impl FnMut(usize, T),
        c: &mut Traversal,
    ) {
        WALK_STACK.with_borrow_mut(|stack| {
            let need = self.stack_len();
            if stack.len() < need * INTERLEAVE {
                stack.resize(need * INTERLEAVE, (0, 0.0));
            }
            let start = |i: usize| {
                let r = ray(i);
                (Walker::<S>::new(r.slab(), slack), i, search(r))
            };
            let mut slots: [Option<(Walker<S>, usize, T)>; INTERLEAVE] = std::array::from_fn(|_| None);
            let mut next = 0;
            for slot in &mut slots {
                if next < n {
                    *slot = Some(start(next));
                    next += 1;
                }
            }
            let mut live = next;
            while live > 0 {
                for (slot, stack) in slots.iter_mut().zip(stack.chunks_exact_mut(need)) {
                    let Some((walker, _, state)) = slot else { continue };
                    if walker.step::<COUNT, ORDER>(self, stack, c, &mut |r, b, lanes| test(state, r, b, lanes)) {
                        self.prefetch(walker.current);
                        continue;
                    }
                    let (_, index, state) = match next < n {
                        true => {
                            next += 1;
                            slot.replace(start(next - 1))
                        }
                        false => {
                            live -= 1;
                            slot.take()
                        }
                    }
                    .expect("an active slot");
                    done(index, state);
                }
            }
        })
    }

    /// [`WideBvh::closest`] of `n` rays, interleaved ([`WideBvh::interleave`]): `out(i,
    /// hit)` for every ray `i`, in the order they finish.
    pub fn closest_many<const COUNT: bool>(
        &self,
        slack: f32,
        n: usize,
        ray: impl Fn(usize) -> Ray,
        mut out: impl FnMut(usize, Option<(f32, u32)>),
        c: &mut Traversal,
    ) {
        let test = |s: &mut ClosestSearch, r: &mut SlabRay, b: &Block, lanes| s.test(self, r, b, lanes);
        self.interleave::<COUNT, true, _>(slack, n, ray, ClosestSearch::new, test, |i, s| out(i, s.hit()), c);
    }

    /// [`WideBvh::occluded`] of `n` rays, interleaved ([`WideBvh::interleave`]): `out(i,
    /// blocked)` for every ray `i`, in the order they finish.
    pub fn occluded_many<const COUNT: bool>(
        &self,
        slack: f32,
        n: usize,
        ray: impl Fn(usize) -> Ray,
        mut out: impl FnMut(usize, bool),
        c: &mut Traversal,
    ) {
        let test = |s: &mut AnyHitSearch, r: &mut SlabRay, b: &Block, lanes| s.test(self, r, b, lanes);
        self.interleave::<COUNT, false, _>(slack, n, ray, AnyHitSearch::new, test, |i, s| out(i, s.blocked), c);
    }
}

/// One ray's closest-hit search as the queue walks (interleaved, stream) keep it beside
/// its walk: the ray sheared once for the triangle test, and the best hit so far (the
/// ray itself is the walk's slab ray, which every test is handed).
pub(super) struct ClosestSearch {
    sheared: Sheared,
    best: (f32, u32),
}

impl ClosestSearch {
    /// The search of `r`, nothing found yet.
    #[inline(always)]
    pub(super) fn new(r: Ray) -> Self {
        ClosestSearch { sheared: Sheared::new(r.origin, r.dir), best: (f32::INFINITY, u32::MAX) }
    }

    /// Tests lanes `lanes` of leaf block `b` of `tree` for the ray `r`
    /// ([`WideBvh::closest_block`]).
    #[inline(always)]
    pub(super) fn test<S: Vector>(&mut self, tree: &WideBvh<S>, r: &mut SlabRay, b: &Block, lanes: u32) -> Leaf {
        let (o, d) = (Vec3::from(r.origin), Vec3::from(r.direction));
        tree.closest_block(b, lanes, o, d, &self.sheared, r, &mut self.best);
        Leaf::Go
    }

    /// The closest hit found: `(t, primitive)`, or `None`.
    #[inline(always)]
    pub(super) fn hit(&self) -> Option<(f32, u32)> {
        (self.best.1 != u32::MAX).then_some(self.best)
    }
}

/// One shadow ray's any-hit search, as [`ClosestSearch`] for closest hits.
pub(super) struct AnyHitSearch {
    sheared: Sheared,
    /// A blocker was found.
    pub(super) blocked: bool,
}

impl AnyHitSearch {
    /// The search of `r`, nothing found yet.
    #[inline(always)]
    pub(super) fn new(r: Ray) -> Self {
        AnyHitSearch { sheared: Sheared::new(r.origin, r.dir), blocked: false }
    }

    /// Tests lanes `lanes` of leaf block `b` of `tree` for the ray `r`
    /// ([`WideBvh::block_blocks`]); stop at a blocker.
    #[inline(always)]
    pub(super) fn test<S: Vector>(&mut self, tree: &WideBvh<S>, r: &mut SlabRay, b: &Block, lanes: u32) -> Leaf {
        let (o, d) = (Vec3::from(r.origin), Vec3::from(r.direction));
        if tree.block_blocks(b, lanes, o, d, &self.sheared, r) {
            self.blocked = true;
            return Leaf::Stop;
        }
        Leaf::Go
    }
}
