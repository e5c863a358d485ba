//! Ray streams through the wide tree (Barringer & Akenine-Möller, "Dynamic Ray Stream
//! Traversal", 2014; Fuetterling et al., "Efficient Ray Tracing Kernels for Modern CPU
//! Architectures", 2015): a queue enters the root as one stream of ray indices; at each
//! node every ray of the stream tests the node's children in one SIMD slab test (the
//! single-ray walk's arithmetic, so the same boxes are entered), and the stream splits
//! into one stream per child, each ray going to every child it enters. A node's boxes are
//! loaded once for all the rays that reach it, and the loop over them has no stack and
//! no branch per ray. The queue is first split by direction octant, and a stream's
//! child streams are visited in the order their boxes' centres come along its octant's
//! diagonal; a ray whose closest hit so far is nearer than its entry into a child is
//! dropped from that child's stream when it is visited (the single walk's culling rule).
//! A stream that has thinned below [`MIN_STREAM`] rays finishes one ray at a time with
//! the single-ray walk from its node.
//!
//! Exactness: every ray meets the primitives the single walk would test, in another
//! order; the tie rule ([`nearer`](crate::accel::nearer)) makes the closest hit
//! independent of the order, so each answer is the single-ray kernel's bit for bit.

use glam::Vec3;

use super::walk::{AnyHitSearch, ClosestSearch, Leaf};
use super::{Block, Node, WideBvh, LEAF_FLAG, MAX_W};
use crate::accel::order::{by_octant, octant_starts};
use crate::accel::{cull_at, Ray, SlabRay, Traversal, WIDEN};
use crate::simd::{Vector, LANES};

/// Rays below which a child stream finishes one ray at a time (chosen by measurement:
/// docs/performance.md).
pub const MIN_STREAM: usize = 16;

/// Most rays traced as one stream; a longer queue goes in slices of this many (a render
/// wave's camera rays: its bounce queue is one stream).
pub const MAX_STREAM: usize = 4096;

/// A ray as the stream's box tests read it: origin, reciprocal direction and culling
/// distance, packed into half a cache line.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct BoxRay {
    o: [f32; 3],
    inv: [f32; 3],
    /// Boxes entered at or past this distance are skipped; −∞ once the ray is done
    /// (an any-hit ray that found a blocker).
    cull: f32,
}

/// A stream waiting to be visited: `node` (an index, or a leaf's reference) and its rays,
/// `len` entries from `start` in the stream buffer.
#[derive(Clone, Copy)]
struct Frame {
    node: u32,
    /// The direction octant of the stream's rays (bit k: negative along axis k).
    octant: u8,
    start: usize,
    len: usize,
}

/// The buffers of one thread's streams, kept so a queue allocates nothing.
#[derive(Default)]
struct Scratch {
    boxes: Vec<BoxRay>,
    /// The streams on the frame stack, back to back: (ray, entry distance into the
    /// stream's node).
    entries: Vec<(u32, f32)>,
    /// One node's child streams while it splits its stream: `MAX_W` regions of the
    /// stream's length.
    split: Vec<(u32, f32)>,
    frames: Vec<Frame>,
    /// The single-ray walk's stack.
    stack: Vec<(u32, f32)>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

impl<S: Vector> WideBvh<S> {
    /// Traces `n` rays (`ray(i)`) as one stream from the root (see the module docs).
    /// `search(ray)` makes a ray's state, `test(state, slab ray, block, lanes)` tests a
    /// leaf block for it (lowering the slab ray's `tmax` for a closer hit, or saying
    /// stop), and `done(i, state)` takes every ray's answer, in index order. `ORDER`:
    /// closest hit (child streams nearest first, rays culled by their hits); else any
    /// hit (slot order).
    #[allow(clippy::too_many_arguments)] // the rays, their searches and answers, the walk's settings
    #[inline(always)]
    fn stream<const COUNT: bool, const ORDER: bool, T>(
        &self,
        slack: f32,
        n: usize,
        ray: impl Fn(usize) -> Ray,
        search: impl Fn(Ray) -> T,
        mut test: impl FnMut(&mut T, &mut SlabRay, &Block, u32) -> Leaf,
        mut done: impl FnMut(usize, T),
        c: &mut Traversal,
    ) {
        // A longer queue goes in slices, which bounds the scratch memory.
        for base in (0..n).step_by(MAX_STREAM) {
            let n = (n - base).min(MAX_STREAM);
            let ray = |i: usize| ray(base + i);
            let done = |i: usize, state: T| done(base + i, state);
            self.stream_slice::<COUNT, ORDER, T>(slack, n, ray, &search, &mut test, done, c);
        }
    }

    /// [`WideBvh::stream`] of at most [`MAX_STREAM`] rays.
    #[allow(clippy::too_many_arguments)] // as `stream`
    #[inline(always)]
    fn stream_slice<const COUNT: bool, const ORDER: bool, T>(
        &self,
        slack: f32,
        n: usize,
        ray: impl Fn(usize) -> Ray,
        search: &impl Fn(Ray) -> T,
        test: &mut impl FnMut(&mut T, &mut SlabRay, &Block, u32) -> Leaf,
        mut done: impl FnMut(usize, T),
        c: &mut Traversal,
    ) {
        SCRATCH.with_borrow_mut(|s| {
            let Scratch { boxes, entries, split, frames, stack } = s;
            let mut rays: Vec<(SlabRay, T)> = Vec::with_capacity(n);
            boxes.clear();
            entries.clear();
            for i in 0..n {
                let r = ray(i);
                let slab = r.slab();
                boxes.push(BoxRay {
                    o: slab.origin.to_array(),
                    inv: slab.inv_direction.to_array(),
                    cull: cull_at(slab.tmax, slack),
                });
                rays.push((slab, search(r)));
            }
            // One stream per direction octant: rays of one octant agree on which of two
            // boxes along an axis comes first, so a stream's order suits its rays.
            let dir = |i: usize| Vec3::from(rays[i].0.direction);
            let starts = octant_starts(n, dir);
            entries.resize(n, (0, 0.0));
            by_octant(n, dir, starts, |at, i, _| entries[at] = (i as u32, f32::NEG_INFINITY));
            let need = self.stack_len();
            if stack.len() < need {
                stack.resize(need, (0, 0.0));
            }
            if split.len() < MAX_W * n {
                split.resize(MAX_W * n, (0, 0.0));
            }
            frames.clear();
            // The last octant's stream is on top, its entries last in the buffer.
            for k in 0..8 {
                if starts[k + 1] > starts[k] {
                    frames.push(Frame { node: 0, octant: k as u8, start: starts[k], len: starts[k + 1] - starts[k] });
                }
            }
            while let Some(f) = frames.pop() {
                // Everything past this stream belongs to streams already visited.
                entries.truncate(f.start + f.len);
                let (rest, boxes) = (&entries[f.start..], &mut boxes[..]);
                if f.node & LEAF_FLAG != 0 || f.len < MIN_STREAM {
                    self.finish::<COUNT, ORDER, T, _>(slack, f.node, rest, boxes, &mut rays, stack, c, test);
                } else {
                    let node = &self.nodes[f.node as usize];
                    let counts = split_stream::<COUNT, S>(node, rest, boxes, f.len, split, c);
                    push_children::<ORDER, S>(node, f.octant, counts, f.len, split, entries, frames);
                }
            }
            for (i, (_, state)) in rays.into_iter().enumerate() {
                done(i, state);
            }
        })
    }

    /// Walks each ray of a thin stream, or of a leaf's (`entries`), that still enters
    /// `node` through its subtree alone, with the single-ray walk.
    #[allow(clippy::too_many_arguments)] // the node, its stream, the rays' state, the search
    #[inline(never)] // the walk's hot loops each in a function of their own: measured
    fn finish<const COUNT: bool, const ORDER: bool, T, F: FnMut(&mut T, &mut SlabRay, &Block, u32) -> Leaf>(
        &self,
        slack: f32,
        node: u32,
        entries: &[(u32, f32)],
        boxes: &mut [BoxRay],
        rays: &mut [(SlabRay, T)],
        stack: &mut [(u32, f32)],
        c: &mut Traversal,
        test: &mut F,
    ) {
        for &(r, t) in entries {
            let b = &mut boxes[r as usize];
            if !enters(t, b.cull) {
                continue;
            }
            let (slab, state) = &mut rays[r as usize];
            let (walked, stop) =
                self.walk_subtree::<COUNT, ORDER>(slack, *slab, node, stack, c, &mut |r, block, lanes| {
                    test(state, r, block, lanes)
                });
            *slab = walked;
            b.cull = if stop { f32::NEG_INFINITY } else { cull_at(slab.tmax, slack) };
        }
    }

    /// [`WideBvh::closest`] of `n` rays traced as one stream ([`WideBvh::stream`]):
    /// `out(i, hit)` for every ray `i`, in index order.
    pub fn closest_stream<const COUNT: bool>(
        &self,
        slack: f32,
        n: usize,
        ray: impl Fn(usize) -> Ray,
        mut out: impl FnMut(usize, Option<(f32, u32)>),
        c: &mut Traversal,
    ) {
        self.stream::<COUNT, true, _>(
            slack,
            n,
            ray,
            ClosestSearch::new,
            #[inline(always)]
            |s: &mut ClosestSearch, r, b, lanes| s.test(self, r, b, lanes),
            |i, s| out(i, s.hit()),
            c,
        );
    }

    /// [`WideBvh::occluded`] of `n` rays traced as one stream ([`WideBvh::stream`]):
    /// `out(i, blocked)` for every ray `i`, in index order.
    pub fn occluded_stream<const COUNT: bool>(
        &self,
        slack: f32,
        n: usize,
        ray: impl Fn(usize) -> Ray,
        mut out: impl FnMut(usize, bool),
        c: &mut Traversal,
    ) {
        self.stream::<COUNT, false, _>(
            slack,
            n,
            ray,
            AnyHitSearch::new,
            #[inline(always)]
            |s: &mut AnyHitSearch, r, b, lanes| s.test(self, r, b, lanes),
            |i, s| out(i, s.blocked),
            c,
        );
    }
}

/// Whether a ray that entered a stream's node at `t` still does with its culling distance
/// now at `cull` (false for NaN, as the box test).
#[inline(always)]
fn enters(t: f32, cull: f32) -> bool {
    t < cull
}

/// Splits a stream (`entries`, `len` of them; rays culled since they entered are
/// dropped) among `node`'s children: child slot k's stream goes to `split[k · len..]`,
/// its length to the count returned. Each ray tests all children in one SIMD slab test,
/// the single walk's ([`Walker::hit_children`](super::walk)), and is written to every
/// slot's region, the slot's count moving past it only where it entered the child (a
/// store per slot costs less than a branch per entered child, which data decides).
#[inline(never)] // the walk's hot loops each in a function of their own: measured
fn split_stream<const COUNT: bool, S: Vector>(
    node: &Node<S>,
    entries: &[(u32, f32)],
    boxes: &[BoxRay],
    len: usize,
    split: &mut [(u32, f32)],
    c: &mut Traversal,
) -> [usize; MAX_W] {
    let mut counts = [0usize; MAX_W];
    let mut near = [0.0f32; LANES];
    for &(r, t) in entries {
        let b = &boxes[r as usize];
        if !enters(t, b.cull) {
            continue;
        }
        let o = b.o.map(S::splat);
        let inv = b.inv.map(S::splat);
        let t1 = [0, 1, 2].map(|k| (node.bounds[0][k] - o[k]) * inv[k]);
        let t2 = [0, 1, 2].map(|k| (node.bounds[1][k] - o[k]) * inv[k]);
        let tn = t1[0].fast_min(t2[0]).fast_max(t1[1].fast_min(t2[1])).fast_max(t1[2].fast_min(t2[2]));
        let far =
            t1[0].fast_max(t2[0]).fast_min(t1[1].fast_max(t2[1])).fast_min(t1[2].fast_max(t2[2])) * S::splat(WIDEN);
        let hit = far.ge(tn) & far.ge(S::splat(0.0)) & tn.lt(S::splat(b.cull));
        if COUNT {
            c.nodes += node.valid.count_ones() as u64;
        }
        let bits = hit.bits() & node.valid;
        tn.store(&mut near);
        for k in 0..S::WIDTH.min(MAX_W) {
            // counts[k] is below the rays seen so far, so the index stays in slot k's region.
            split[k * len + counts[k]] = (r, near[k]);
            counts[k] += (bits >> k) as usize & 1;
        }
    }
    counts
}

/// Appends `node`'s child streams (counted in `counts`, in `split` as [`split_stream`]
/// left them) to the stream buffer and their frames to the stack, the stream to visit
/// first on top: for closest hit (`ORDER`) the child whose box centre comes first along
/// the stream's octant (each ray's own entry distances order its children no better,
/// counted in node visits, and cost a pass over the stream: measured), else the last
/// slot. Empty children get no frame.
#[allow(clippy::too_many_arguments)] // the node and its stream's octant, the split, the stack
#[inline(always)]
fn push_children<const ORDER: bool, S: Vector>(
    node: &Node<S>,
    octant: u8,
    counts: [usize; MAX_W],
    len: usize,
    split: &[(u32, f32)],
    entries: &mut Vec<(u32, f32)>,
    frames: &mut Vec<Frame>,
) {
    let mut order = [(0.0f32, 0usize); MAX_W];
    let mut m = 0;
    // Box centres (doubled) along the octant's direction: the order rays of the octant
    // meet the boxes in when they are apart.
    let mut along = [0.0f32; LANES];
    if ORDER {
        let sign = |k: usize| S::splat(if octant >> k & 1 != 0 { -1.0 } else { 1.0 });
        let c = |k: usize| (node.bounds[0][k] + node.bounds[1][k]) * sign(k);
        // Empty slots hold infinities; their keys are never read.
        (c(0) + c(1) + c(2)).store(&mut along);
    }
    for (k, &count) in counts.iter().enumerate().take(S::WIDTH.min(MAX_W)) {
        if count == 0 {
            continue;
        }
        // Any hit: the last slot first, as the single walk.
        let key = if ORDER { along[k] } else { -(k as f32) };
        order[m] = (key, k);
        m += 1;
    }
    // Farthest first onto the stack, so the nearest is visited next (ties by slot:
    // deterministic).
    order[..m].sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(b.1.cmp(&a.1)));
    for &(_, k) in &order[..m] {
        let start = entries.len();
        entries.extend_from_slice(&split[k * len..k * len + counts[k]]);
        frames.push(Frame { node: node.child[k], octant, start, len: counts[k] });
    }
}
