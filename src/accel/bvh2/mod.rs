//! obvhs's binary tree: its build (PLOC, reinsertion, leaf collapse) and the binary
//! single-ray walk over its nodes, which counts nodes and primitives tested for the
//! profiling stats. Trees deeper than the walk's fixed stack take obvhs's own traversal.

use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::Bvh2;
use obvhs::ray::RayHit;
use obvhs::BvhBuildParams;

use super::shapes::{Primitive, NO_LIGHT};
use super::{cull_at, nearer, slab, tie_limit, Accel, BuildPhases, Lap, Ray, SlabRay, Traversal};

/// Deepest tree the fixed-size traversal stack handles; deeper trees (never seen from
/// obvhs's builders on real meshes) fall back to obvhs's own traversal.
pub(crate) const STACK_DEPTH: usize = 128;

/// The node indices a traversal still has to visit (fixed size, see [`STACK_DEPTH`]).
pub(crate) struct NodeStack {
    items: [u32; STACK_DEPTH],
    len: usize,
}

impl NodeStack {
    pub(crate) fn new() -> NodeStack {
        NodeStack { items: [0; STACK_DEPTH], len: 0 }
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
/// `first` (children adjacent, nearer child first), with the culling `slack` of [`CULL`](crate::accel::CULL).
/// `leaf` tests a leaf's primitives, may shrink `ray.tmax`, and returns false to stop.
#[inline(always)]
pub(crate) fn subtree<const COUNT: bool>(
    nodes: &[Bvh2Node],
    first: usize,
    slack: f32,
    mut ray: SlabRay,
    c: &mut Traversal,
    mut leaf: impl FnMut(&mut SlabRay, std::ops::Range<usize>, &mut Traversal) -> bool,
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
            if t >= cull_at(ray.tmax, slack) {
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

/// obvhs's `build_bvh2` up to its leaf collapse: PLOC and reinsertion, giving the tree
/// with one primitive per leaf from which the wide BVH chooses its own nodes and leaves
/// ([`collapse`] makes the binary tree of it where one is kept). Without obvhs's closing
/// debug self-check, which asserts the tree is shallower than the default traversal stack
/// before [`Accel::build_with`] can size the stack to the tree.
pub(crate) fn build(prims: &[Primitive], params: &BvhBuildParams, phases: &mut BuildPhases) -> Bvh2 {
    let mut lap = Lap::start();
    let indices = (0..prims.len() as u32).collect();
    let mut bvh = obvhs::ploc::PlocBuilder::with_capacity(prims.len()).build(
        params.ploc_search_distance,
        prims,
        indices,
        params.sort_precision,
        params.search_depth_threshold,
    );
    phases.ploc = lap.next();
    let mut reinsertion = obvhs::bvh2::reinsertion::ReinsertionOptimizer::default();
    reinsertion.run(&mut bvh, params.reinsertion_batch_ratio, None);
    phases.reinsertion = lap.next();
    bvh
}

/// The binary tree: obvhs's SAH leaf collapse of a copy of `fine`. obvhs's second
/// reinsertion, after the collapse, is left out: it would serve only this tree, which
/// only the tests' reference walks, and it cost a fifth of the build on sphere 8 (2.23 ->
/// 1.78 s) (docs/performance.md).
pub(crate) fn collapse(fine: &Bvh2, params: &BvhBuildParams) -> Bvh2 {
    let mut bvh = fine.clone();
    obvhs::bvh2::leaf_collapser::collapse(&mut bvh, max_prims(params), params.collapse_traversal_cost);
    bvh
}

/// The largest leaf obvhs's collapse may make.
fn max_prims(params: &BvhBuildParams) -> u32 {
    params.max_prims_per_leaf.clamp(1, 255)
}

/// The order [`collapse`] leaves `fine`'s primitives in (its `primitive_indices`),
/// without collapsing or copying the tree: obvhs 0.4's SAH decisions bottom-up, the same
/// float expressions, then its layout: the final leaves in node order, a collapsed leaf's
/// primitives in the order of its subtree's leaves, and the order unchanged where obvhs
/// changes nothing or the whole tree becomes one leaf. Primitive ids, which the tie rule
/// ranks, are this order, so a renderer that keeps no binary tree keeps the ids (and the
/// images' bits) without the collapse (tested against obvhs's).
pub(crate) fn collapsed_order(fine: &Bvh2, params: &BvhBuildParams) -> Vec<u32> {
    let (nodes, max_prims, cost) = (&fine.nodes, max_prims(params), params.collapse_traversal_cost);
    let n = nodes.len();
    let few = !fine.primitive_indices.is_empty() && fine.primitive_indices.len() as u32 <= max_prims;
    if max_prims <= 1 || n as u32 <= max_prims * 2 + 1 || few || nodes[0].is_leaf() {
        return fine.primitive_indices.clone();
    }
    // Per node, bottom-up: its primitives when it ends as a leaf, else 0.
    let mut count = vec![0u32; n];
    bottom_up(fine, |k| {
        let node = &nodes[k];
        if node.is_leaf() {
            count[k] = node.prim_count;
            return;
        }
        let l = node.first_index as usize;
        let (left, right) = (&nodes[l], &nodes[l + 1]);
        let total = count[l] + count[l + 1];
        if count[l] > 0 && count[l + 1] > 0 && total <= max_prims {
            let collapse_cost = node.aabb().half_area() * (total as f32 - cost);
            let base_cost = left.aabb().half_area() * count[l] as f32 + right.aabb().half_area() * count[l + 1] as f32;
            let same_prim = left.first_index == right.first_index && total == 2;
            if collapse_cost <= base_cost || same_prim {
                (count[k], count[l], count[l + 1]) = (total, 0, 0);
            }
        }
    });
    if count[0] > 0 {
        // The root became the one leaf: obvhs keeps the primitives where they were.
        return fine.primitive_indices.clone();
    }
    let mut order = Vec::with_capacity(fine.primitive_indices.len());
    let mut below = Vec::new();
    for k in (0..n).filter(|&k| count[k] > 0) {
        below.push(k);
        while let Some(j) = below.pop() {
            let node = &nodes[j];
            let first = node.first_index as usize;
            if node.is_leaf() {
                order.extend_from_slice(&fine.primitive_indices[first..first + node.prim_count as usize]);
            } else {
                below.extend([first + 1, first]);
            }
        }
    }
    order
}

/// Calls `visit` on every node of `fine` after both its children. Nodes are taken in index
/// order backwards: obvhs lays a tree out with most children after their parents, so
/// memory is mostly read in order (a random walk from the root, as before, took the plan
/// of the wide collapse a third longer on the bunny). A node whose children come before
/// it has its subtree visited there and then, by an explicit stack (fuzzed meshes build
/// very deep trees). Every node of obvhs's trees is reachable (PLOC makes 2n − 1 nodes
/// for n primitives; reinsertion relinks them).
pub(crate) fn bottom_up(fine: &Bvh2, mut visit: impl FnMut(usize)) {
    let nodes = &fine.nodes;
    let mut done = vec![false; nodes.len()];
    let mut stack = Vec::new();
    for top in (0..nodes.len()).rev() {
        if done[top] {
            continue;
        }
        // Most nodes: a leaf, or both children visited already.
        let node = &nodes[top];
        let l = node.first_index as usize;
        if node.is_leaf() || (done[l] && done[l + 1]) {
            visit(top);
            done[top] = true;
            continue;
        }
        stack.push((top, false));
        while let Some((k, ready)) = stack.pop() {
            let node = &nodes[k];
            if ready || node.is_leaf() {
                visit(k);
                done[k] = true;
                continue;
            }
            let l = node.first_index as usize;
            stack.push((k, true));
            stack.extend([l + 1, l].into_iter().filter(|&c| !done[c]).map(|c| (c, false)));
        }
    }
}

/// Stack-based walk of the obvhs `Bvh2` nodes from the root (children adjacent, nearer
/// child first), counting work when `COUNT`. `leaf` tests a leaf's primitives, may shrink
/// `ray.tmax`, and returns false to stop (any-hit).
#[inline(always)]
fn traverse<const COUNT: bool>(
    accel: &Accel,
    bvh: &Bvh2,
    mut ray: SlabRay,
    c: &mut Traversal,
    mut leaf: impl FnMut(&mut SlabRay, std::ops::Range<usize>, &mut Traversal) -> bool,
) {
    let nodes = &bvh.nodes;
    let root = &nodes[0];
    if COUNT {
        c.nodes += 1;
    }
    if slab(root.aabb(), &ray) >= cull_at(ray.tmax, accel.slack) {
        return;
    }
    if root.is_leaf() {
        let first = root.first_index as usize;
        leaf(&mut ray, first..first + root.prim_count as usize, c);
        return;
    }
    subtree::<COUNT>(nodes, root.first_index as usize, accel.slack, ray, c, leaf);
}

/// Closest hit through obvhs's own `Bvh2::ray_traverse` (the fallback of [`closest`] for
/// trees deeper than [`STACK_DEPTH`]), with the tie rule applied in its callback. Culls boxes at `tmax` exactly, so on a tie within rounding it may return
/// another hit than the other kernels (see [`CULL`](crate::accel::CULL)).
pub(crate) fn closest_obvhs(accel: &Accel, ray: Ray) -> Option<(f32, u32)> {
    let bvh = accel.bvh.as_ref()?;
    let (o, d) = (ray.origin, ray.dir);
    let mut hit = RayHit::none();
    let mut best = (f32::INFINITY, u32::MAX);
    // obvhs keeps the strictly nearer hit; the tie rule is applied here.
    bvh.ray_traverse(ray.slab(), &mut hit, |r, id| {
        let limit = tie_limit(best, r.tmax);
        let t = accel.prim(id as u32).shape.intersect(o, d, r.tmin, limit);
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

/// Any hit through obvhs's own `Bvh2::ray_traverse_miss` (the fallback of [`occluded`]).
pub(crate) fn occluded_obvhs(accel: &Accel, ray: Ray) -> bool {
    let Some(bvh) = accel.bvh.as_ref() else { return false };
    let (o, d) = (ray.origin, ray.dir);
    !bvh.ray_traverse_miss(ray.slab(), |r, id| {
        let p = accel.prim(id as u32);
        if p.light == NO_LIGHT && p.shape.intersect(o, d, r.tmin, r.tmax) < r.tmax {
            0.0
        } else {
            f32::INFINITY
        }
    })
}

/// [`Accel::closest`] through the binary tree: its own walk, or obvhs's for a tree deeper than [`STACK_DEPTH`].
#[inline]
pub(crate) fn closest<const COUNT: bool>(accel: &Accel, ray: Ray, c: &mut Traversal) -> Option<(f32, u32)> {
    let bvh = accel.bvh.as_ref()?;
    if accel.depth >= STACK_DEPTH {
        return closest_obvhs(accel, ray);
    }
    let (o, d) = (ray.origin, ray.dir);
    let mut best = (f32::INFINITY, u32::MAX);
    traverse::<COUNT>(accel, bvh, ray.slab(), c, |r, range, c| {
        if COUNT {
            c.prims += range.len() as u64;
        }
        for id in range {
            let limit = tie_limit(best, r.tmax);
            let t = accel.prim(id as u32).shape.intersect(o, d, r.tmin, limit);
            if t < limit && nearer(t, id as u32, best) {
                r.tmax = t;
                best = (t, id as u32);
            }
        }
        true
    });
    (best.1 != u32::MAX).then_some(best)
}

/// [`Accel::occluded`] through the binary tree: its own walk, or obvhs's for a tree deeper than [`STACK_DEPTH`].
#[inline]
pub(crate) fn occluded<const COUNT: bool>(accel: &Accel, ray: Ray, c: &mut Traversal) -> bool {
    let Some(bvh) = accel.bvh.as_ref() else { return false };
    if accel.depth >= STACK_DEPTH {
        return occluded_obvhs(accel, ray);
    }
    let (o, d) = (ray.origin, ray.dir);
    let blocks = |p: &Primitive, r: &SlabRay| p.light == NO_LIGHT && p.shape.intersect(o, d, r.tmin, r.tmax) < r.tmax;
    let mut hit = false;
    traverse::<COUNT>(accel, bvh, ray.slab(), c, |r, range, c| {
        for id in range {
            if COUNT {
                c.prims += 1;
            }
            if blocks(&accel.prim(id as u32), r) {
                hit = true;
                return false;
            }
        }
        true
    });
    hit
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{BuildPhases, Ray, Shape};
    use glam::Vec3;

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
            let hit = accel.closest::<true>(Ray::new(o, Vec3::NEG_Y, 0.0, f32::INFINITY), &mut c).expect("hit");
            let brute = prims
                .iter()
                .map(|p| p.shape.intersect(o, Vec3::NEG_Y, 0.0, f32::INFINITY))
                .fold(f32::INFINITY, f32::min);
            assert_eq!(hit.0, brute);
            assert!(accel.occluded::<true>(Ray::new(o, Vec3::NEG_Y, 0.0, 10.0), &mut c));
            assert!(
                !accel.occluded::<true>(Ray::new(o, Vec3::NEG_Y, 0.0, 4.0), &mut c),
                "tmax stops before the sphere"
            );
        }
        assert!(c.nodes > 0 && c.prims > 0, "work is counted: {c:?}");
        // Along the row: the first sphere is closest.
        let hit =
            accel.closest::<true>(Ray::new(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, 0.0, f32::INFINITY), &mut c).unwrap();
        assert!((hit.1 as usize) < accel.len());
        assert!((hit.0 - 4.5).abs() < 1e-5);
    }

    /// `collapsed_order` is the order obvhs's collapse leaves, on trees of 1 to 3000
    /// primitives (clustered and spread, so some subtrees collapse and some do not) and
    /// every leaf limit the renderer allows, at each build quality.
    #[test]
    fn collapsed_order_is_obvhs_collapse_order() {
        let mut seed = 7u32;
        let mut rnd = move || {
            seed = crate::sampling::hash(&[seed]);
            crate::sampling::to_unit(seed)
        };
        // Configurations where the collapse moved primitives (else the test proves little).
        let mut reordered = 0;
        for count in [1, 2, 3, 17, 300, 3000] {
            let prims: Vec<Primitive> = (0..count)
                .map(|i| {
                    // Clusters of ten along x, spread in y.
                    let c = Vec3::new((i / 10) as f32 * 3.0 + rnd(), rnd() * 40.0, rnd());
                    let mut e = |s: f32| Vec3::new(rnd(), rnd(), rnd()) * s;
                    let shape = Shape::Triangle { v0: c, v1: c + e(0.5), v2: c + e(0.5) };
                    Primitive { shape, material: 0, light: NO_LIGHT }
                })
                .collect();
            for preset in [BvhBuildParams::fast_build(), BvhBuildParams::medium_build(), BvhBuildParams::slow_build()] {
                for leaf in [1, 2, 4, 8, 16, 64] {
                    let params = BvhBuildParams { max_prims_per_leaf: leaf, pre_split: false, ..preset };
                    let fine = build(&prims, &params, &mut BuildPhases::default());
                    let collapsed = collapse(&fine, &params);
                    assert_eq!(
                        collapsed_order(&fine, &params),
                        collapsed.primitive_indices,
                        "{count} prims, leaf {leaf}"
                    );
                    reordered += (collapsed.primitive_indices != fine.primitive_indices) as u32;
                }
            }
        }
        assert!(reordered >= 20, "the collapse reordered primitives in only {reordered} configurations");
    }

    #[test]
    fn lights_do_not_occlude_and_empty_scene_misses() {
        let accel = Accel::build(vec![sphere(0.0, 0)]);
        let mut c = Traversal::default();
        assert!(accel
            .closest::<true>(Ray::new(Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y, 0.0, f32::INFINITY), &mut c)
            .is_some());
        assert!(!accel.occluded::<true>(Ray::new(Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y, 0.0, 10.0), &mut c));
        let empty = Accel::build(Vec::new());
        assert!(empty.closest::<true>(Ray::new(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY), &mut c).is_none());
        assert!(!empty.occluded::<true>(Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0), &mut c));
    }
}
