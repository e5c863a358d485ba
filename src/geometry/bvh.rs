//! The acceleration structure: an obvhs `Bvh2` over all primitives (obvhs builds it),
//! traversed one ray at a time by our own stack traversal of its nodes, which counts
//! nodes and primitives tested for the profiling stats.

use glam::Vec3;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::Bvh2;
use obvhs::ray::{Ray, RayHit};
use obvhs::BvhBuildParams;
use std::time::Instant;

use super::shapes::{Primitive, NO_LIGHT};
use super::wbvh::{Wide, WideBvh};

/// Traversal work counters: what one or more traversals cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Traversal {
    /// BVH nodes whose bounding box was tested.
    pub nodes: u64,
    /// Primitives whose intersection test ran.
    pub prims: u64,
    /// Packet traversals: node pairs tested for a packet (one SIMD test each, 16 lanes in
    /// the renderer).
    pub packet_steps: u64,
    /// Active lanes summed over those tests (utilisation = lanes / (LANES · steps)).
    pub packet_lanes: u64,
    /// Rays traced in packets (the rest went one at a time).
    pub packet_rays: u64,
}

/// Most primitives per leaf (obvhs's collapse may make leaves smaller; measured:
/// docs/performance.md).
pub const LEAF: u32 = 8;

/// Deepest tree the fixed-size traversal stack handles; deeper trees (never seen from
/// obvhs's builders on real meshes) fall back to obvhs's own traversal.
pub(crate) const STACK: usize = 128;

/// Conservative ray–box slab test: the far distance is widened by 1 + 2γ₃ (PBRT's
/// bound on the rounding of the slab distances), so a ray through a box's edge or corner
/// is never lost to rounding.
#[inline(always)]
pub(crate) fn slab(b: &obvhs::aabb::Aabb, ray: &Ray) -> f32 {
    const WIDEN: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);
    let t1 = (b.min - ray.origin) * ray.inv_direction;
    let t2 = (b.max - ray.origin) * ray.inv_direction;
    let tmin = t1.min(t2).max_element();
    let tmax = t1.max(t2).min_element() * WIDEN;
    if tmax >= tmin && tmax >= 0.0 {
        tmin
    } else {
        f32::INFINITY
    }
}

/// The reciprocal of a ray direction's component for the slab tests: `1/x`, clamped to
/// ±`f32::MAX` (a zero component gives ±MAX by its sign). Never NaN and never zero, so
/// `(bound − origin) · inv` is never NaN (a bound on the origin's plane gives 0). obvhs's
/// `Ray::new` clamps at ±1/ε instead, which is not conservative: a ray parallel to an axis
/// passing within `t / 8.4·10⁶` inside a box's face (a camera ray exactly along −z, 10⁻⁶
/// from a triangle's edge at distance 10) gets a slab interval on that axis ending before
/// its hit, and the box is skipped; every kernel builds its rays with this instead.
#[inline(always)]
pub(crate) fn inv_dir(x: f32) -> f32 {
    (1.0 / x).clamp(-f32::MAX, f32::MAX)
}

/// An obvhs ray from `o` along `d` over `(tmin, tmax)`, with [`inv_dir`]'s reciprocals.
#[inline(always)]
pub(crate) fn ray(o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Ray {
    Ray {
        origin: o.into(),
        direction: d.into(),
        inv_direction: glam::Vec3A::new(inv_dir(d.x), inv_dir(d.y), inv_dir(d.z)),
        tmin,
        tmax,
    }
}

/// The bound to test a primitive against in a closest-hit search that has found `best`
/// so far (`(∞, u32::MAX)` before any hit) along a ray whose limit is now `tmax`: `tmax`
/// itself before a hit (exclusive, as callers ask); after one (`tmax` = its distance),
/// the next float up, so a primitive hit at exactly that distance is found too and
/// [`nearer`] can rule on the tie.
#[inline(always)]
pub(crate) fn tie_limit(best: (f32, u32), tmax: f32) -> f32 {
    if best.1 == u32::MAX {
        tmax
    } else {
        tmax.next_up()
    }
}

/// The closest-hit rule of every kernel: a hit at `t` (below [`tie_limit`]) by primitive
/// `id` replaces `best` when nearer, or exactly as near with a lower id. So the answer is
/// the lowest-id primitive at the closest distance whatever order a traversal (binary,
/// wide, packet; any tree) meets them in; exact ties happen where surfaces meet, on two
/// walls' shared edge, and the primitive decides the normal and material.
#[inline(always)]
pub(crate) fn nearer(t: f32, id: u32, best: (f32, u32)) -> bool {
    t < best.0 || (t == best.0 && id < best.1)
}

/// A box is skipped only when its entry distance exceeds the ray's current `tmax` by more
/// than `tmax · (CULL − 1) + Accel::slack`. The entry distance and a primitive's hit
/// distance round independently, so a primitive lying on a face of its own box (every
/// axis-aligned triangle) can have an entry distance past its hit distance: by ulps of t
/// for distant hits, by ulps of the scene's coordinates for close ones. Culling at `tmax`
/// exactly (as pbrt does) then loses that hit whenever a slightly farther one was found
/// first, and the result depends on traversal order. The slack (2⁻¹⁶ of t, plus 2⁻¹⁶ of the
/// scene's largest coordinate) costs a few extra box visits and keeps the scalar and packet
/// traversals on the same hits.
pub(crate) const CULL: f32 = 1.0 + 1.0 / 65536.0;

/// The node indices a traversal still has to visit (fixed size, see [`STACK`]).
pub(crate) struct NodeStack {
    items: [u32; STACK],
    len: usize,
}

impl NodeStack {
    pub(crate) fn new() -> NodeStack {
        NodeStack { items: [0; STACK], len: 0 }
    }

    /// Saved nodes.
    #[inline(always)]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// The next inner node after testing a node pair whose inner children to `descend`
    /// into are flagged (nearer first): the nearer child, saving the farther one; else the
    /// one child; else the most recently saved node; `None` when the walk is over.
    #[inline(always)]
    pub(crate) fn next(&mut self, descend: [bool; 2], near: &Bvh2Node, far: &Bvh2Node) -> Option<usize> {
        match descend {
            [true, true] => {
                self.items[self.len] = far.first_index;
                self.len += 1;
                Some(near.first_index as usize)
            }
            [true, false] => Some(near.first_index as usize),
            [false, true] => Some(far.first_index as usize),
            [false, false] => {
                self.len = self.len.checked_sub(1)?;
                Some(self.items[self.len] as usize)
            }
        }
    }
}

/// Walks, for one ray, the subtree below an inner node whose two children start at
/// `first` (children adjacent, nearer child first), with the culling `slack` of [`CULL`].
/// Shared by the single-ray traversal and the packet traversal's fallback for packets
/// whose active lanes have thinned out.
/// `leaf` tests a leaf's primitives, may shrink `ray.tmax`, and returns false to stop.
#[inline(always)]
pub(crate) fn subtree<const COUNT: bool>(
    nodes: &[Bvh2Node],
    first: usize,
    slack: f32,
    mut ray: Ray,
    c: &mut Traversal,
    mut leaf: impl FnMut(&mut Ray, std::ops::Range<usize>, &mut Traversal) -> bool,
) {
    let mut stack = NodeStack::new();
    let mut current = first;
    loop {
        let (mut near, mut far) = (&nodes[current], &nodes[current + 1]);
        let (mut t_near, mut t_far) = (slab(near.aabb(), &ray), slab(far.aabb(), &ray));
        if COUNT {
            c.nodes += 2;
        }
        if t_near > t_far {
            std::mem::swap(&mut near, &mut far);
            std::mem::swap(&mut t_near, &mut t_far);
        }
        let mut descend = [false; 2];
        for (k, (node, t)) in [(near, t_near), (far, t_far)].into_iter().enumerate() {
            if t >= ray.tmax * CULL + slack {
                continue;
            }
            if node.is_leaf() {
                let first = node.first_index as usize;
                if !leaf(&mut ray, first..first + node.prim_count as usize, c) {
                    return;
                }
            } else {
                descend[k] = true;
            }
        }
        let Some(next) = stack.next(descend, near, far) else { return };
        current = next;
    }
}

/// Primitives reordered to the BVH's leaf order, with the BVH over them.
pub struct Accel {
    /// Primitives, in BVH order: a traversal's primitive id indexes this directly.
    pub prims: Vec<Primitive>,
    pub(crate) bvh: Option<Bvh2>,
    /// The same tree collapsed to [`Wide`] children per node, for single rays (`None`
    /// when empty or not encodable: the binary traversal then serves).
    pub(crate) wide: Option<WideBvh<Wide>>,
    /// Depth of the tree (root = 1), which bounds the traversal stack.
    pub(crate) depth: usize,
    /// Absolute culling slack (see [`CULL`]).
    pub(crate) slack: f32,
    /// Seconds the BVH build took.
    pub build_seconds: f64,
}

/// obvhs's `build_bvh2` without its closing debug self-check, which asserts the tree is
/// shallower than the default traversal stack before [`Accel::build_with`] can size the
/// stack to the tree; the same steps in the same order, so the same tree. Also returns the
/// tree as it stood before the leaf collapse (one primitive per leaf), from which the wide
/// BVH chooses its own nodes and leaves.
fn build_bvh2(prims: &[Primitive], params: &BvhBuildParams) -> (Bvh2, Bvh2) {
    let indices = (0..prims.len() as u32).collect();
    let mut bvh = obvhs::ploc::PlocBuilder::with_capacity(prims.len()).build(
        params.ploc_search_distance,
        prims,
        indices,
        params.sort_precision,
        params.search_depth_threshold,
    );
    let mut reinsertion = obvhs::bvh2::reinsertion::ReinsertionOptimizer::default();
    reinsertion.run(&mut bvh, params.reinsertion_batch_ratio, None);
    let fine = bvh.clone();
    obvhs::bvh2::leaf_collapser::collapse(
        &mut bvh,
        params.max_prims_per_leaf.clamp(1, 255),
        params.collapse_traversal_cost,
    );
    let ratio = params.reinsertion_batch_ratio * params.post_collapse_reinsertion_batch_ratio_multiplier;
    reinsertion.run(&mut bvh, ratio, None);
    (bvh, fine)
}

/// Widens every node's box by one float outward on each side. A ray parallel to an axis
/// (a zero direction component, reciprocal ±`f32::MAX`: [`inv_dir`]) that runs exactly in
/// a box's face plane gets `(bound − o) · inv` = 0 for that face: kept when it is the near
/// face, skipped when it is the far one. The triangle test still reports hits on that
/// face (on an edge two triangles share), so which of them a ray along a shared edge met
/// depended on which box the tree put each in. Widened, a face that primitives touch is
/// never exactly in the ray's plane on the wrong side, the box is kept, and every kernel
/// meets every primitive the ray touches, whatever the tree. Parents contain their
/// children's widened boxes (rounding outward is monotone).
fn widen_boxes(bvh: &mut Bvh2) {
    for node in &mut bvh.nodes {
        let b = node.aabb();
        let out = |v: glam::Vec3A, up: bool| {
            glam::Vec3A::from(v.to_array().map(|x| if up { x.next_up() } else { x.next_down() }))
        };
        let widened = obvhs::aabb::Aabb { min: out(b.min, false), max: out(b.max, true) };
        node.set_aabb(widened);
    }
}

/// How much time the BVH build spends on the tree's quality (the names are Embree's
/// `RTC_BUILD_QUALITY_*`). Every kernel's answers are the same either way, bit for bit;
/// only the build's and the traversal's times differ (measured: docs/performance.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BvhQuality {
    /// obvhs's medium preset: the build 0.55–0.75× as long as `High`'s, incoherent rays
    /// through the wide kernel up to 11% slower on the scanned meshes.
    Medium,
    /// obvhs's slow preset (a wider PLOC search, more reinsertion).
    #[default]
    High,
}

impl Accel {
    /// Builds the BVH over `prims` (which may be empty) with leaves of at most [`LEAF`]
    /// primitives, at [`BvhQuality::High`].
    pub fn build(prims: Vec<Primitive>) -> Accel {
        Accel::build_with(prims, LEAF, BvhQuality::High)
    }

    /// [`Accel::build`] with leaves of at most `max_leaf` primitives (1 to 64; the SAH
    /// decides below that) and the given quality.
    pub fn build_with(prims: Vec<Primitive>, max_leaf: u32, quality: BvhQuality) -> Accel {
        let start = Instant::now();
        if prims.is_empty() {
            return Accel { prims, bvh: None, wide: None, depth: 0, slack: 0.0, build_seconds: 0.0 };
        }
        let preset = match quality {
            BvhQuality::Medium => BvhBuildParams::medium_build(),
            BvhQuality::High => BvhBuildParams::slow_build(),
        };
        // The slow preset's pre-splitting, which `build_bvh2` does not do, would duplicate
        // primitive references.
        let params = BvhBuildParams { max_prims_per_leaf: max_leaf.clamp(1, 64), pre_split: false, ..preset };
        let (mut bvh, mut fine) = build_bvh2(&prims, &params);
        widen_boxes(&mut bvh);
        widen_boxes(&mut fine);
        // obvhs sizes its traversal stack by `max_depth` (96 by default); a pathological
        // mesh (found by fuzzing) builds deeper trees, which take obvhs's traversal (see
        // `STACK`), so give it a stack that holds them, as obvhs's own insertion does.
        bvh.max_depth = (bvh.depth(0) + 1).max(bvh.max_depth);
        #[cfg(debug_assertions)]
        bvh.validate(&prims, false, params.pre_split);
        // Reorder once so traversal needs no primitive_indices indirection.
        let prims: Vec<Primitive> = bvh.primitive_indices.iter().map(|&i| prims[i as usize]).collect();
        let depth = bvh.depth(0);
        let root = bvh.nodes[0].aabb();
        let scale = Vec3::from(root.min).abs().max(Vec3::from(root.max).abs()).max_element();
        let slack = if scale.is_finite() { scale / 65536.0 } else { 0.0 };
        // The one-primitive-leaf tree indexes the input order; point it at the reordered
        // primitives, whose ids the wide kernel returns.
        let mut id_of = vec![0u32; prims.len()];
        for (new, &old) in bvh.primitive_indices.iter().enumerate() {
            id_of[old as usize] = new as u32;
        }
        for i in &mut fine.primitive_indices {
            *i = id_of[*i as usize];
        }
        let wide = WideBvh::build(&fine, &prims, params.max_prims_per_leaf);
        Accel { prims, bvh: Some(bvh), wide, depth, slack, build_seconds: start.elapsed().as_secs_f64() }
    }

    /// Bytes of the acceleration structure beside the primitives: the binary nodes, the
    /// wide nodes and the primitives themselves, in that order.
    pub fn bytes(&self) -> [usize; 3] {
        [
            self.bvh.as_ref().map_or(0, |b| b.nodes.len() * std::mem::size_of::<Bvh2Node>()),
            self.wide.as_ref().map_or(0, WideBvh::bytes),
            self.prims.len() * std::mem::size_of::<Primitive>(),
        ]
    }

    /// [`Accel::closest`] through the wide BVH (one ray, all of a node's children in one
    /// SIMD test): the same distance bit for bit.
    #[inline]
    pub fn closest_wide<const COUNT: bool>(
        &self,
        o: Vec3,
        d: Vec3,
        tmin: f32,
        tmax: f32,
        c: &mut Traversal,
    ) -> Option<(f32, u32)> {
        match &self.wide {
            Some(w) => w.closest::<COUNT>(&self.prims, self.slack, o, d, tmin, tmax, c),
            None => self.closest::<COUNT>(o, d, tmin, tmax, c),
        }
    }

    /// [`Accel::occluded`] through the wide BVH: the same answer.
    #[inline]
    pub fn occluded_wide<const COUNT: bool>(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32, c: &mut Traversal) -> bool {
        match &self.wide {
            Some(w) => w.occluded::<COUNT>(&self.prims, self.slack, o, d, tmin, tmax, c),
            None => self.occluded::<COUNT>(o, d, tmin, tmax, c),
        }
    }

    /// Stack-based traversal of the obvhs `Bvh2` nodes (children adjacent, nearer child
    /// first), counting work when `COUNT`. `leaf` tests a leaf's primitives, may shrink
    /// `ray.tmax`, and returns false to stop (any-hit).
    #[inline(always)]
    fn traverse<const COUNT: bool>(
        &self,
        bvh: &Bvh2,
        mut ray: Ray,
        c: &mut Traversal,
        mut leaf: impl FnMut(&mut Ray, std::ops::Range<usize>, &mut Traversal) -> bool,
    ) {
        let nodes = &bvh.nodes;
        let root = &nodes[0];
        if COUNT {
            c.nodes += 1;
        }
        if slab(root.aabb(), &ray) >= ray.tmax * CULL + self.slack {
            return;
        }
        if root.is_leaf() {
            let first = root.first_index as usize;
            leaf(&mut ray, first..first + root.prim_count as usize, c);
            return;
        }
        subtree::<COUNT>(nodes, root.first_index as usize, self.slack, ray, c, leaf);
    }

    /// [`Accel::closest`] through obvhs's own single-ray traversal (`Bvh2::ray_traverse`):
    /// the fallback for trees deeper than [`STACK`], and the reference the benchmarks
    /// compare with. Culls boxes at `tmax` exactly, so on a tie within rounding it may
    /// return another hit than [`Accel::closest`] (see [`CULL`]).
    pub fn closest_obvhs(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, u32)> {
        let bvh = self.bvh.as_ref()?;
        let prims = &self.prims;
        let mut hit = RayHit::none();
        let mut best = (f32::INFINITY, u32::MAX);
        // obvhs keeps the strictly nearer hit; the tie rule is applied here.
        bvh.ray_traverse(ray(o, d, tmin, tmax), &mut hit, |r, id| {
            let limit = tie_limit(best, r.tmax);
            let t = prims[id].shape.intersect(o, d, r.tmin, limit);
            if t < limit && nearer(t, id as u32, best) {
                best = (t, id as u32);
            }
            if t < r.tmax {
                t
            } else {
                f32::INFINITY
            }
        });
        (best.1 != u32::MAX).then_some(best)
    }

    /// [`Accel::occluded`] through obvhs's own any-hit traversal (`Bvh2::ray_traverse_miss`).
    pub fn occluded_obvhs(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
        let Some(bvh) = self.bvh.as_ref() else { return false };
        let prims = &self.prims;
        !bvh.ray_traverse_miss(ray(o, d, tmin, tmax), |r, id| {
            let p = &prims[id];
            if p.light == NO_LIGHT && p.shape.intersect(o, d, r.tmin, r.tmax) < r.tmax {
                0.0
            } else {
                f32::INFINITY
            }
        })
    }

    /// Closest hit along the ray within `(tmin, tmax)`: `(t, primitive index)`, or `None`.
    /// Counts its work in `c` when `COUNT`.
    #[inline]
    pub fn closest<const COUNT: bool>(
        &self,
        o: Vec3,
        d: Vec3,
        tmin: f32,
        tmax: f32,
        c: &mut Traversal,
    ) -> Option<(f32, u32)> {
        let bvh = self.bvh.as_ref()?;
        let ray = ray(o, d, tmin, tmax);
        let prims = &self.prims;
        let mut best = (f32::INFINITY, u32::MAX);
        if self.depth >= STACK {
            return self.closest_obvhs(o, d, tmin, tmax);
        }
        self.traverse::<COUNT>(bvh, ray, c, |r, range, c| {
            if COUNT {
                c.prims += range.len() as u64;
            }
            for id in range {
                let limit = tie_limit(best, r.tmax);
                let t = prims[id].shape.intersect(o, d, r.tmin, limit);
                if t < limit && nearer(t, id as u32, best) {
                    r.tmax = t;
                    best = (t, id as u32);
                }
            }
            true
        });
        (best.1 != u32::MAX).then_some(best)
    }

    /// True when some non-emitting primitive blocks the segment `(tmin, tmax)` of the ray.
    /// Stops at the first blocker found. Area lights never block shadow rays. Counts its
    /// work in `c` when `COUNT`.
    #[inline]
    pub fn occluded<const COUNT: bool>(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32, c: &mut Traversal) -> bool {
        let Some(bvh) = self.bvh.as_ref() else { return false };
        let ray = ray(o, d, tmin, tmax);
        let prims = &self.prims;
        let blocks = |p: &Primitive, r: &Ray| p.light == NO_LIGHT && p.shape.intersect(o, d, r.tmin, r.tmax) < r.tmax;
        if self.depth >= STACK {
            return self.occluded_obvhs(o, d, tmin, tmax);
        }
        let mut hit = false;
        self.traverse::<COUNT>(bvh, ray, c, |r, range, c| {
            for id in range {
                if COUNT {
                    c.prims += 1;
                }
                if blocks(&prims[id], r) {
                    hit = true;
                    return false;
                }
            }
            true
        });
        hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;

    fn sphere(x: f32, light: u32) -> Primitive {
        Primitive { shape: Shape::Sphere { center: Vec3::new(x, 0.0, 0.0), radius: 0.5 }, material: 0, light }
    }

    #[test]
    fn closest_and_occluded_agree_with_brute_force() {
        let prims: Vec<Primitive> = (0..50).map(|i| sphere(i as f32 * 2.0, NO_LIGHT)).collect();
        let accel = Accel::build(prims.clone());
        let mut c = Traversal::default();
        for i in 0..50 {
            let o = Vec3::new(i as f32 * 2.0 + 0.1, 5.0, 0.05);
            let hit = accel.closest::<true>(o, Vec3::NEG_Y, 0.0, f32::INFINITY, &mut c).expect("hit");
            let brute = prims
                .iter()
                .map(|p| p.shape.intersect(o, Vec3::NEG_Y, 0.0, f32::INFINITY))
                .fold(f32::INFINITY, f32::min);
            assert_eq!(hit.0, brute);
            assert!(accel.occluded::<true>(o, Vec3::NEG_Y, 0.0, 10.0, &mut c));
            assert!(!accel.occluded::<true>(o, Vec3::NEG_Y, 0.0, 4.0, &mut c), "tmax stops before the sphere");
        }
        assert!(c.nodes > 0 && c.prims > 0, "work is counted: {c:?}");
        // Along the row: the first sphere is closest.
        let hit = accel.closest::<true>(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, 0.0, f32::INFINITY, &mut c).unwrap();
        assert!((hit.1 as usize) < accel.prims.len());
        assert!((hit.0 - 4.5).abs() < 1e-5);
    }

    #[test]
    fn lights_do_not_occlude_and_empty_scene_misses() {
        let accel = Accel::build(vec![sphere(0.0, 0)]);
        let mut c = Traversal::default();
        assert!(accel.closest::<true>(Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y, 0.0, f32::INFINITY, &mut c).is_some());
        assert!(!accel.occluded::<true>(Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y, 0.0, 10.0, &mut c));
        let empty = Accel::build(Vec::new());
        assert!(empty.closest::<true>(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY, &mut c).is_none());
        assert!(!empty.occluded::<true>(Vec3::ZERO, Vec3::X, 0.0, 1.0, &mut c));
    }
}
