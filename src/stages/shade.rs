//! Shading: reads the ray and hit queues; sends escaped rays and visible emitters to
//! the film queue, mirror or dielectric hits to the specular list for the scatter
//! stage, and diffuse hits' direct lighting to the shadow queue (one ray per point
//! light; per quad light `shadows.samples` stratified rays in uniform mode, or one entry
//! in the shadow-corner queue in adaptive mode).

use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

use crate::geometry::NO_LIGHT;
use crate::light::{quad_irradiance, quad_light_samples, uniform_shadow_rays};
use crate::queue::{FilmQueue, HitQueue, IndexQueue, RayQueue, ShadowPointQueue, ShadowQueue, MISS};
use crate::scene::{Light, Scene, ShadowMode};
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
                // One-sided emitter: radiance on the front, black from behind.
                if let Light::Quad { radiance, normal, .. } = scene.lights[prim.light as usize] {
                    if normal.dot(rays.dir(i)) < 0.0 {
                        film.push(rays.slot[i], rays.weight(i) * radiance);
                    }
                }
            } else if rays.depth[i] < scene.settings.max_depth {
                specular.push(i as u32);
            }
            continue;
        };
        for (li, light) in scene.lights.iter().enumerate() {
            match *light {
                Light::Quad { corner, u, v, normal, radiance, .. } if adaptive && radiance != Vec3::ZERO => {
                    // The unoccluded contribution costs no rays: exact for Lambert
                    // (the polygon irradiance), else the penumbra stage's own samples
                    // without occlusion tests. Uniform mode would cast one ray per
                    // sample facing both ways; count those for the stats.
                    if normal.dot(surf.o - corner) <= 0.0 {
                        continue; // behind the one-sided emitter
                    }
                    let (mut sum, mut n) = (Vec3::ZERO, 0u64);
                    let corners = [corner, corner + u, corner + v, corner + u + v];
                    let above = corners.iter().all(|&p| surf.n.dot(p - surf.o) > 0.0);
                    if surf.specular == Vec3::ZERO && above {
                        n = scene.settings.shadow_samples as u64;
                    } else {
                        quad_light_samples(scene, &surf, li, |_, _, _, l| {
                            sum += l;
                            n += 1;
                        });
                    }
                    if n == 0 {
                        continue;
                    }
                    if surf.specular == Vec3::ZERO {
                        let e = quad_irradiance(surf.o, surf.n, corner, u, v);
                        sum = surf.w * surf.color * FRAC_1_PI * radiance * e;
                    }
                    points.push(i as u32, li as u32, surf.slot, sum);
                    uniform_equivalent += n;
                }
                _ => uniform_shadow_rays(scene, &surf, li, |wi, tmax, l| shadow.push(surf.o, wi, tmax, surf.slot, l)),
            }
        }
    }
    uniform_equivalent
}
