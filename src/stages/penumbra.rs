//! The penumbra stage: for each point the shadow-corner test could not decide, the
//! `shadows.samples` stratified shadow rays of uniform mode (the same rays, so the two
//! modes agree wherever the test is right). Writes a shadow queue for the occlusion stage.

use super::shade::{diffuse_surface, quad_light_samples, SHADOW_TMAX_SCALE};
use crate::queue::{HitQueue, RayQueue, ShadowPointQueue, ShadowQueue};
use crate::scene::Scene;

/// Generates the shadow rays of every penumbra point (indices into `points`).
pub fn penumbra(
    scene: &Scene,
    rays: &RayQueue,
    hits: &HitQueue,
    points: &ShadowPointQueue,
    penumbra: &[u32],
    shadow: &mut ShadowQueue,
) {
    shadow.clear();
    for &k in penumbra {
        let k = k as usize;
        let Some(surf) = diffuse_surface(scene, rays, hits, points.ray[k] as usize) else { continue };
        quad_light_samples(scene, &surf, points.light[k] as usize, |wi, dist, l| {
            shadow.push(surf.o, wi, dist * SHADOW_TMAX_SCALE, surf.slot, l)
        });
    }
}
