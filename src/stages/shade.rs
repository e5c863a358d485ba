//! Shading: reads the ray and hit queues; sends escaped rays and visible emitters to
//! the film queue, mirror or dielectric hits to the specular list for the scatter
//! stage, and diffuse hits' direct lighting to the shadow queue (one ray per point
//! light; per area light `shadows.samples` stratified rays in uniform mode, or one entry
//! in the shadow-corner queue in adaptive mode).

use glam::Vec3;

use crate::geometry::NO_LIGHT;
use crate::light::{emitted, uniform_shadow_rays, unoccluded};
use crate::queue::{FilmQueue, HitQueue, IndexQueue, RayQueue, ShadowPointQueue, ShadowQueue, MISS};
use crate::scene::{Scene, ShadowMode};
use crate::surface::diffuse_surface;

/// Shades every ray of `rays` at its hit in `hits`: fills `shadow`, `points` and
/// `specular` (cleared first) and appends to `film`. Returns the number of shadow rays
/// uniform mode would have cast for the points put in the shadow-corner queue.
#[allow(clippy::too_many_arguments)] // a stage names every queue it reads and writes
pub fn shade(
    scene: &Scene,
    rays: &RayQueue,
    hits: &HitQueue,
    shadow: &mut ShadowQueue,
    points: &mut ShadowPointQueue,
    specular: &mut IndexQueue,
    film: &mut FilmQueue,
) -> u64 {
    shadow.clear();
    points.clear();
    specular.clear();
    let adaptive = matches!(scene.settings.shadow_mode, ShadowMode::Adaptive(_));
    let mut uniform_equivalent = 0u64;
    for i in 0..rays.len() {
        if hits.prim[i] == MISS {
            if scene.background != Vec3::ZERO {
                film.push(rays.slot[i], rays.weight(i) * scene.background);
            }
            continue;
        }
        let Some(surf) = diffuse_surface(scene, rays, hits, i) else {
            let prim = &scene.accel.prims[hits.prim[i] as usize];
            if prim.light != NO_LIGHT {
                if let Some(radiance) = emitted(&scene.lights[prim.light as usize], rays.dir(i)) {
                    film.push(rays.slot[i], rays.weight(i) * radiance);
                }
            } else if rays.depth[i] < scene.settings.max_depth {
                specular.push(i as u32);
            }
            continue;
        };
        for li in 0..scene.lights.len() {
            // An area light in adaptive mode: its unoccluded contribution costs no rays;
            // the shadow-corner stage decides whether it reaches the film. Count the rays
            // uniform mode would have cast, for the stats.
            match adaptive.then(|| unoccluded(scene, &surf, li)).flatten() {
                Some((_, 0)) => {}
                Some((sum, n)) => {
                    points.push(i as u32, li as u32, surf.slot, sum);
                    uniform_equivalent += n;
                }
                None => {
                    uniform_shadow_rays(scene, &surf, li, |wi, tmax, l| shadow.push(surf.o, wi, tmax, surf.slot, l))
                }
            }
        }
    }
    uniform_equivalent
}
