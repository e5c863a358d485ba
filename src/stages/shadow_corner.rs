//! The shadow-corner test (paper §2.2): a few any-hit probe rays from each queued
//! shading point to a quad light. If all reach the light the point is lit (its
//! unoccluded contribution goes to the film); if none does it is dark; otherwise it
//! goes to the penumbra queue.

use glam::Vec3;

use crate::geometry::tracer::Tracer;
use crate::light::SHADOW_TMAX_SCALE;
use crate::queue::{FilmQueue, HitQueue, IndexQueue, RayQueue, ShadowPointQueue};
use crate::sampling::{dim, hash, to_unit};
use crate::scene::{Light, Probe, Scene, ShadowMode};
use crate::surface::diffuse_surface;

/// The probe targets on quad light `li` for a shading point whose path is named by
/// `key` (its point key hashed with its sample index); the
/// first `probe.rays()` entries are used.
#[inline]
pub fn probe_targets(scene: &Scene, probe: Probe, li: usize, key: u32) -> [Vec3; 9] {
    let mut t = [Vec3::ZERO; 9];
    let Light::Quad { corner, u, v, .. } = scene.lights[li] else { return t };
    let at = |a: f32, b: f32| corner + a * u + b * v;
    match probe {
        Probe::Corners | Probe::CornersCenter => {
            t[..5].copy_from_slice(&[at(0.0, 0.0), at(1.0, 0.0), at(0.0, 1.0), at(1.0, 1.0), at(0.5, 0.5)]);
        }
        Probe::Jittered => {
            let h = |q: u32, d: u32| to_unit(hash(&[key, li as u32, q, d, dim::PROBE]));
            for i in 0..4u32 {
                t[i as usize] = at(0.5 * ((i & 1) as f32 + h(i, 0)), 0.5 * ((i >> 1) as f32 + h(i, 1)));
            }
        }
        Probe::Grid3 => {
            for (i, p) in t.iter_mut().enumerate() {
                *p = at(0.5 * (i % 3) as f32, 0.5 * (i / 3) as f32);
            }
        }
    }
    t
}

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
        let targets = probe_targets(scene, probe, points.light[k] as usize, hash(&[surf.key, surf.sample]));
        let n = probe.rays() as usize;
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
