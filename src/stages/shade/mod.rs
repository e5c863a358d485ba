//! Shading: reads the ray and hit queues; sends escaped rays and visible emitters to
//! the film queue, mirror or dielectric hits to the specular list for the scatter
//! stage, and diffuse hits' direct lighting to the shadow queue (one ray per point
//! light; per area light `shadows.samples` stratified rays in uniform mode, or one entry
//! in the shadow-corner queue in adaptive mode when the light's probes cost at most 0.8
//! of its samples, else the uniform rays). Uniform shadow rays are computed on 16 lanes
//! at a time ([`crate::light::lanes`]) in the order and with the bits of the scalar loop,
//! which serves scenes with a sphere light.

use glam::Vec3;

mod path;
use path::path_lights;

use crate::accel::NO_LIGHT;
use crate::light::lanes;
use crate::light::{emitted, hit_light_pdf, probes_light, uniform_shadow_rays, unoccluded_lanes};
use crate::queue::{
    sparse_opt, FilmQueue, HitQueue, IndexQueue, RayQueue, ShadowPointQueue, ShadowQueue, SurfaceQueue, MISS,
};
use crate::sampling::power_heuristic;
use crate::scene::{Scene, ShadowMode, Transport};
use crate::simd::{LaneIds, LANES, V3};
use crate::surface::{diffuse_material, diffuse_surfaces, queued_surface};

/// What the shade stage counted for the adaptive shadow test's stats.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShadeCounts {
    /// Shadow rays uniform mode would have cast for the points put in the shadow-corner
    /// queue.
    pub uniform_equivalent: u64,
    /// (point, area light) pairs of adaptive mode sampled uniformly because the light's
    /// probes would cost more than 0.8 of its samples ([`probes_light`]).
    pub uniform_fallback: u64,
}

/// The queues the shade stage writes: every one cleared first but `film`, which collects
/// the wave's contributions and is appended to.
pub struct Shaded<'a> {
    /// Uniform shadow rays (point lights, quad lights not probed).
    pub shadow: &'a mut ShadowQueue,
    /// (point, area light) pairs for the adaptive shadow test.
    pub points: &'a mut ShadowPointQueue,
    /// The diffuse shading points.
    pub surfaces: &'a mut SurfaceQueue,
    /// Rays that hit a mirror or a dielectric (indices into the ray queue).
    pub specular: &'a mut IndexQueue,
    /// Background and emitters seen.
    pub film: &'a mut FilmQueue,
}

/// Shades every ray of `rays` at its hit in `hits`: sorts the hits ([`sort_hits`]), then
/// casts the diffuse points' shadow rays or queues them for the adaptive test
/// ([`light_points`]) as `shadows` (the render's mode, never `Auto`) says.
pub fn shade(scene: &Scene, shadows: ShadowMode, rays: &RayQueue, hits: &HitQueue, out: Shaded) -> ShadeCounts {
    let Shaded { shadow, points, surfaces, specular, film } = out;
    shadow.clear();
    points.clear();
    surfaces.clear();
    specular.clear();
    sort_hits(scene, rays, hits, surfaces, specular, film);
    light_points(scene, shadows, surfaces, shadow, points)
}

/// Settles every hit that needs no shadow ray (the background of a miss, an emitter seen,
/// into `film`), queues mirrors and dielectrics in `specular`, and fills `surfaces` with
/// the diffuse hits, 16 at a time in ray order.
fn sort_hits(
    scene: &Scene,
    rays: &RayQueue,
    hits: &HitQueue,
    surfaces: &mut SurfaceQueue,
    specular: &mut IndexQueue,
    film: &mut FilmQueue,
) {
    let (mut group, mut len) = ([0u32; LANES], 0);
    let s = &scene.settings;
    // The path transport: `hide_emitters` blacks out what camera rays see of emitters and
    // the background, and a diffuse hit past the last bounce only adds what it emits
    // (nothing).
    let (path, hide) = match s.transport {
        Transport::Path { hide_emitters, .. } => (true, hide_emitters),
        Transport::Whitted => (false, false),
    };
    let hidden = |i: usize| hide && rays.depth[i] == 0;
    let (environment, sampled) = (!scene.background.is_black(), scene.samples_environment());
    // Rays that escape and share the environment with their light samples, 16 at a time.
    let (mut escaped, mut escapes) = ([0u32; LANES], 0);
    for i in 0..rays.len() {
        if hits.prim[i] == MISS {
            if environment && !hidden(i) {
                // A surface's ray shares the environment with its light samples (MIS); an
                // adaptive-shadow bounce (negative density) has no environment sample
                // beside it, and takes all.
                if sampled && rays.pdf[i] > 0.0 {
                    escaped[escapes] = i as u32;
                    escapes += 1;
                    if escapes == LANES {
                        shared_environment(scene, rays, &escaped, film);
                        escapes = 0;
                    }
                } else {
                    film.push(rays.slot[i], rays.weight(i) * scene.background.eval(rays.dir(i)));
                }
            }
            continue;
        }
        if diffuse_material(scene, hits.prim[i]).is_some() {
            if path && rays.depth[i] >= s.max_depth {
                continue;
            }
            group[len] = i as u32;
            len += 1;
            if len == LANES {
                diffuse_surfaces(scene, rays, hits, &group, surfaces);
                len = 0;
            }
            continue;
        }
        let light = scene.accel.light(hits.prim[i]);
        if light != NO_LIGHT {
            if hidden(i) {
                continue;
            }
            if let Some(radiance) = emitted(&scene.lights[light as usize], rays.origin(i), rays.dir(i)) {
                // A surface's ray shares this light with its light samples (MIS), or
                // leaves it to them (a negative density: weight 0).
                let pdf = rays.pdf[i];
                let mis = if pdf != 0.0 {
                    power_heuristic(pdf, hit_light_pdf(scene, light, rays.origin(i), rays.dir(i), hits.t[i]))
                } else {
                    1.0
                };
                film.push(rays.slot[i], rays.weight(i) * radiance * mis);
            }
        } else if rays.depth[i] < s.max_depth {
            specular.push(i as u32);
        }
    }
    diffuse_surfaces(scene, rays, hits, &group[..len], surfaces);
    if escapes > 0 {
        shared_environment(scene, rays, &escaped[..escapes], film);
    }
}

/// The environment seen by rays `ids` (1 to 16, escaped), each weighted by the power
/// heuristic against the density with which its surface's light samples draw it.
fn shared_environment(scene: &Scene, rays: &RayQueue, ids: &[u32], film: &mut FilmQueue) {
    let lanes = LaneIds::new(ids);
    let d = V3 { x: lanes.gather(&rays.dx), y: lanes.gather(&rays.dy), z: lanes.gather(&rays.dz) };
    let (radiance, env_pdf) = scene.background.eval_pdf_lanes(d, ids.len());
    let (radiance, env_pdf) = (radiance.lanes(), env_pdf.to_array());
    for (k, &i) in ids.iter().enumerate() {
        let i = i as usize;
        let l = Vec3::new(radiance[0][k], radiance[1][k], radiance[2][k]);
        film.push(rays.slot[i], rays.weight(i) * l * power_heuristic(rays.pdf[i], env_pdf[k]));
    }
}

/// The lights of every point of `surfaces`: uniform shadow rays into `shadow`, or, for an
/// area light the adaptive test probes, the (point, light) pair into `points` (its
/// unoccluded contribution costs no ray; the shadow-corner stage decides whether it
/// reaches the film).
fn light_points(
    scene: &Scene,
    shadows: ShadowMode,
    surfaces: &SurfaceQueue,
    shadow: &mut ShadowQueue,
    points: &mut ShadowPointQueue,
) -> ShadeCounts {
    let s = &scene.settings;
    // The lights the adaptive test probes; the others are sampled as in uniform mode.
    let probed = |li: usize| match shadows {
        ShadowMode::Adaptive(probe) => probes_light(&scene.lights[li], probe, s.shadow_samples),
        ShadowMode::Uniform | ShadowMode::Auto(_) => false,
    };
    let mut counts = ShadeCounts::default();
    if s.path() && shadows == ShadowMode::Uniform {
        path_lights(scene, surfaces, shadow);
        return counts;
    }
    if let ShadowMode::Adaptive(probe) = shadows {
        let fallback = scene.lights.iter().filter(|l| l.lit_area() && !probes_light(l, probe, s.shadow_samples));
        counts.uniform_fallback = fallback.count() as u64 * surfaces.len() as u64;
    }
    // Uniform shadows go on lanes unless a light is probed or a sphere.
    let any_probed = (0..scene.lights.len()).any(probed);
    if !any_probed && scene.lights.iter().all(lanes::on_lanes) {
        lanes::shadow_lanes(scene, surfaces, shadow);
        return counts;
    }
    // The probed lights' unoccluded light, 16 points at a time on lanes, then each
    // point's lights in the scalar loop's order.
    let probed_lights: Vec<usize> = (0..scene.lights.len()).filter(|&li| probed(li)).collect();
    let mut lit = vec![[None; LANES]; scene.lights.len()];
    for first in (0..surfaces.len()).step_by(LANES) {
        let count = (surfaces.len() - first).min(LANES);
        let ids: [u32; LANES] = std::array::from_fn(|k| (first + k.min(count - 1)) as u32);
        for &li in &probed_lights {
            unoccluded_lanes(scene, surfaces, (&ids, count), li, &mut lit[li]);
        }
        for (k, p) in (first..first + count).enumerate() {
            // The whole surface only for a light sampled uniformly.
            let mut surf = None;
            for (li, lit) in lit.iter_mut().enumerate() {
                // Count the rays uniform mode would have cast for a probed light, for the stats.
                match lit[k].take() {
                    Some((_, 0)) => {}
                    Some((sum, n)) => {
                        points.push(p as u32, li as u32, surfaces.slot[p], sum);
                        counts.uniform_equivalent += n;
                    }
                    None => {
                        let surf = surf.get_or_insert_with(|| queued_surface(surfaces, p));
                        // The point's rays carry its path's time.
                        let time = sparse_opt(&surfaces.time, p);
                        uniform_shadow_rays(scene, surf, li, |wi, tmax, l| {
                            shadow.push(surf.o, wi, tmax, surf.slot, l, time);
                        });
                    }
                }
            }
        }
    }
    counts
}
