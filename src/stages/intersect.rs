//! Closest-hit intersection. Reads the ray queue; writes one hit (or miss) per ray.

use crate::queue::{HitQueue, RayQueue, MISS};
use crate::scene::Scene;

/// Finds the closest hit of every ray in `rays`, in order.
pub fn intersect(scene: &Scene, rays: &RayQueue, hits: &mut HitQueue) {
    hits.clear();
    for i in 0..rays.len() {
        match scene.accel.closest(rays.origin(i), rays.dir(i), 0.0, f32::INFINITY) {
            Some((t, prim)) => hits.push(t, prim),
            None => hits.push(f32::INFINITY, MISS),
        }
    }
}
