//! The shadow-corner test (paper §2.2): a few any-hit probe rays from each queued
//! shading point to an area light. If all reach the light the point is lit (its
//! unoccluded contribution goes to the film); if none does it is dark; otherwise it
//! goes to the penumbra queue.

use crate::geometry::tracer::Tracer;
use crate::light::{probe_count, probe_targets, SHADOW_TMAX_SCALE};
use crate::queue::{FilmQueue, HitQueue, IndexQueue, RayQueue, ShadowPointQueue};
use crate::sampling::hash;
use crate::scene::{Scene, ShadowMode};
use crate::surface::diffuse_surface;

/// Tests every queued point against its light, with the probe set of
/// `render.shadows.probe`; lit points append their unoccluded contribution to `film`,
/// penumbra points go to `penumbra` (cleared first; indices into `points`). Returns the
/// number of probe rays cast.
#[allow(clippy::too_many_arguments)] // a stage names every queue it reads and writes
pub fn shadow_corners(
    scene: &Scene,
    tracer: &mut Tracer,
    rays: &RayQueue,
    hits: &HitQueue,
    points: &ShadowPointQueue,
    film: &mut FilmQueue,
    penumbra: &mut IndexQueue,
) -> usize {
    penumbra.clear();
    let ShadowMode::Adaptive(probe) = scene.settings.shadow_mode else { return 0 };
    let mut cast = 0;
    for k in 0..points.len() {
        let Some(surf) = diffuse_surface(scene, rays, hits, points.ray[k] as usize) else { continue };
        let li = points.light[k] as usize;
        let targets = probe_targets(scene, probe, li, hash(&[surf.key, surf.sample]));
        let n = probe_count(&scene.lights[li], probe) as usize;
        let mut visible = 0;
        for target in &targets[..n] {
            let to = *target - surf.o;
            let dist = to.length();
            if !tracer.occluded_one(surf.o, to / dist, dist * SHADOW_TMAX_SCALE) {
                visible += 1;
            }
        }
        cast += n;
        if visible == n {
            film.push(surf.slot, points.unoccluded(k));
        } else if visible > 0 {
            penumbra.push(k as u32);
        }
    }
    cast
}
