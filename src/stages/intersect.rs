//! Closest-hit intersection. Reads the ray queue; writes one hit (or miss) per ray.

use crate::geometry::Traversal;
use crate::queue::{HitQueue, RayQueue, MISS};
use crate::scene::Scene;

/// Finds the closest hit of every ray in `rays`, in order. When `count`, BVH nodes and
/// primitives tested are added to `work`; when not, the traversal has no counting code.
pub fn intersect(scene: &Scene, rays: &RayQueue, hits: &mut HitQueue, work: &mut Traversal, count: bool) {
    if count {
        run::<true>(scene, rays, hits, work)
    } else {
        run::<false>(scene, rays, hits, work)
    }
}

fn run<const COUNT: bool>(scene: &Scene, rays: &RayQueue, hits: &mut HitQueue, work: &mut Traversal) {
    hits.clear();
    for i in 0..rays.len() {
        match scene.accel.closest::<COUNT>(rays.origin(i), rays.dir(i), 0.0, f32::INFINITY, work) {
            Some((t, prim)) => hits.push(t, prim),
            None => hits.push(f32::INFINITY, MISS),
        }
    }
}
