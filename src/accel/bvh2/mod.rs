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
pub(crate) const MAX_DEPTH: usize = 128;

/// The node indices a traversal still has to visit (fixed size, see [`MAX_DEPTH`]).
pub(crate) struct NodeStack {
    items: [u32; MAX_DEPTH],
    len: usize,
}

impl NodeStack {
    pub(crate) fn new() -> NodeStack {
        NodeStack { items: [0; MAX_DEPTH], len: 0 }
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

/// obvhs's `build_bvh2` (PLOC, reinsertion, leaf collapse) without its second
/// reinsertion (below) and without its closing debug self-check, which asserts the tree is
/// shallower than the default traversal stack before [`Accel::build_with`] can size the
/// stack to the tree. Also returns the tree as it stood before the leaf collapse (one
/// primitive per leaf), from which the wide BVH chooses its own nodes and leaves.
pub(crate) fn build(prims: &[Primitive], params: &BvhBuildParams, phases: &mut BuildPhases) -> (Bvh2, Bvh2) {
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
    let fine = bvh.clone();
    obvhs::bvh2::leaf_collapser::collapse(
        &mut bvh,
        params.max_prims_per_leaf.clamp(1, 255),
        params.collapse_traversal_cost,
    );
    phases.leaf_collapse = lap.next();
    // obvhs's second reinsertion, after the collapse, is left out: it would serve only
    // this tree, which only packets walk, and it cost a fifth of the build on sphere 8
    // (2.23 -> 1.78 s) for camera packets within noise (docs/performance.md).
    (bvh, fine)
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

/// [`Accel::closest_obvhs`]: obvhs's `Bvh2::ray_traverse`, with the tie rule applied in
/// its callback. Culls boxes at `tmax` exactly, so on a tie within rounding it may return
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

/// [`Accel::occluded_obvhs`]: obvhs's `Bvh2::ray_traverse_miss`.
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

/// [`Accel::closest`]: the binary walk, or obvhs's for a tree deeper than [`MAX_DEPTH`].
#[inline]
pub(crate) fn closest<const COUNT: bool>(accel: &Accel, ray: Ray, c: &mut Traversal) -> Option<(f32, u32)> {
    let bvh = accel.bvh.as_ref()?;
    if accel.depth >= MAX_DEPTH {
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

/// [`Accel::occluded`]: the binary walk, or obvhs's for a tree deeper than [`MAX_DEPTH`].
#[inline]
pub(crate) fn occluded<const COUNT: bool>(accel: &Accel, ray: Ray, c: &mut Traversal) -> bool {
    let Some(bvh) = accel.bvh.as_ref() else { return false };
    if accel.depth >= MAX_DEPTH {
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
    use crate::accel::{Ray, Shape};
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
