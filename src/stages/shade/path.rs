//! Next-event estimation of the path transport, 16 (point, light sample) pairs at a time:
//! the light picked and the point on it sampled as [`gloss_light_sample`] does, weighted
//! by the power heuristic against the cosine density of the point's bounce ray.

use glam::Vec3;
use std::f32::consts::FRAC_1_PI;
use wide::{f32x16, u32x16};

use crate::emitter::sphere::sphere_sample_lanes;
use crate::light::{light_seed_lanes, pick_light, uniform_shadow_rays, SHADOW_TMAX_SCALE};
use crate::queue::{sparse_opt, ShadowQueue, SurfaceQueue};
use crate::sampling::{dim, hash_lanes, sobol_owen_lanes};
use crate::scene::{AreaLights, Light, Scene};
use crate::simd::{LaneIds, Word, LANES, V3};
use crate::surface::{diffuse_brdf, queued_surface};

/// Next-event estimation at every point of `surfaces`: a ray to each point light, and
/// `shadows.samples` points on the area lights (light sample j of the path's camera
/// sample i is sample i·n + j of its sequences, so a pixel's samples are stratified
/// together), each light chosen uniformly and the point uniformly over its area,
/// weighted by the power heuristic against the density with which the point's bounce
/// ray (stage `bounce`) could have found the same point.
pub(super) fn path_lights(scene: &Scene, surfaces: &SurfaceQueue, shadow: &mut ShadowQueue) {
    // Delta lights (points, directions) get one ray each: no other strategy finds them.
    for li in scene.delta_lights.iter().map(|&li| li as usize) {
        for p in 0..surfaces.len() {
            let (surf, time) = (queued_surface(surfaces, p), sparse_opt(&surfaces.time, p));
            uniform_shadow_rays(scene, &surf, li, |wi, tmax, l| shadow.push(surf.o, wi, tmax, surf.slot, l, time));
        }
    }
    if scene.samples_environment() {
        environment_lights(scene, surfaces, shadow);
    }
    for &li in &scene.sphere_lights {
        sphere_lights(scene, li, surfaces, shadow);
    }
    if scene.gloss_lights.is_empty() {
        return;
    }
    pairs(surfaces.len(), scene.settings.shadow_samples, |point, sample, count| {
        area_lanes(scene, &scene.area_lights, surfaces, (point, sample, count), shadow);
    });
}

/// Calls `f(point, sample, count)` for every (point, light sample) pair of `points`
/// points with `n` samples each, 16 pairs at a time in order: pair k is sample
/// `sample[k]` of point `point[k]`, the first `count` real (lanes past the last pair
/// repeat it and are not written).
fn pairs(points: usize, n: u32, mut f: impl FnMut(&[u32; LANES], &[u32; LANES], usize)) {
    let n = n as usize;
    let total = points * n;
    let mut start = 0;
    while start < total {
        let count = (total - start).min(LANES);
        let pair = |k: usize| start + k.min(count - 1);
        let point: [u32; LANES] = std::array::from_fn(|k| (pair(k) / n) as u32);
        let sample: [u32; LANES] = std::array::from_fn(|k| (pair(k) % n) as u32);
        f(&point, &sample, count);
        start += count;
    }
}

/// Next-event estimation of the environment at every point of `surfaces`:
/// `shadows.samples` directions each (sample j of camera sample i is point i·n + j of the
/// path's [`dim::ENVIRONMENT`] sequence), beside the area lights' samples. The shadow
/// rays reach to infinity.
fn environment_lights(scene: &Scene, surfaces: &SurfaceQueue, shadow: &mut ShadowQueue) {
    let n = scene.settings.shadow_samples;
    pairs(surfaces.len(), n, |point, sample, count| {
        let lanes = LaneIds::new(point);
        let index = lanes.gather_words(&surfaces.sample).wmul(u32x16::splat(n)).wadd(u32x16::from(*sample));
        let seed = hash_lanes([lanes.gather_words(&surfaces.key), u32x16::splat(dim::ENVIRONMENT)]);
        let u = sobol_owen_lanes(index, seed);
        let e = scene.background.sample_lanes([u.0, u.1], count);
        let normal = V3 { x: lanes.gather(&surfaces.nx), y: lanes.gather(&surfaces.ny), z: lanes.gather(&surfaces.nz) };
        let live = f32x16::from(std::array::from_fn::<f32, LANES, _>(|k| {
            if e.valid & (1 << k) != 0 {
                f32::from_bits(!0)
            } else {
                0.0
            }
        }));
        let sample = LaneSamples {
            wi: e.wi,
            cos: normal.dot(e.wi),
            tmax: f32x16::splat(f32::MAX),
            radiance: e.radiance,
            pdf: e.pdf * f32x16::splat(n as f32),
            live,
        };
        weighted_lanes(surfaces, (point, count), sample, shadow);
    });
}

/// Next-event estimation of sphere light `li` at every point of `surfaces`:
/// `shadows.samples` directions each in the cone it subtends (stratified as the area
/// lights' samples).
fn sphere_lights(scene: &Scene, li: u32, surfaces: &SurfaceQueue, shadow: &mut ShadowQueue) {
    let Light::Sphere { center, radius, radiance } = scene.lights[li as usize] else { return };
    let n = scene.settings.shadow_samples;
    pairs(surfaces.len(), n, |point, sample, count| {
        let lanes = LaneIds::new(point);
        let index = lanes.gather_words(&surfaces.sample).wmul(u32x16::splat(n)).wadd(u32x16::from(*sample));
        let seed = light_seed_lanes(lanes.gather_words(&surfaces.key), u32x16::splat(li));
        let u = sobol_owen_lanes(index, seed);
        let o = V3 { x: lanes.gather(&surfaces.ox), y: lanes.gather(&surfaces.oy), z: lanes.gather(&surfaces.oz) };
        let normal = V3 { x: lanes.gather(&surfaces.nx), y: lanes.gather(&surfaces.ny), z: lanes.gather(&surfaces.nz) };
        let (wi, dist, pdf, live) = sphere_sample_lanes(center, radius, o, [u.0, u.1]);
        let sample = LaneSamples {
            wi,
            cos: normal.dot(wi),
            tmax: dist * f32x16::splat(SHADOW_TMAX_SCALE),
            radiance: V3::splat(radiance),
            pdf: pdf * f32x16::splat(n as f32),
            live,
        };
        weighted_lanes(surfaces, (point, count), sample, shadow);
    });
}

/// The light samples of one lane group: pair k is sample `sample[k]` of point
/// `point[k]`, the first `count` real; `table` holds the area lights.
fn area_lanes(
    scene: &Scene,
    table: &AreaLights,
    q: &SurfaceQueue,
    (point, sample, count): (&[u32; LANES], &[u32; LANES], usize),
    shadow: &mut ShadowQueue,
) {
    let lanes = LaneIds::new(point);
    let f = |v: &[f32]| lanes.gather(v);
    let v3 = |x: &[f32], y: &[f32], z: &[f32]| V3 { x: f(x), y: f(y), z: f(z) };
    let (o, normal) = (v3(&q.ox, &q.oy, &q.oz), v3(&q.nx, &q.ny, &q.nz));
    let n = scene.settings.shadow_samples;
    let key = lanes.gather_words(&q.key);
    let index = lanes.gather_words(&q.sample).wmul(u32x16::splat(n)).wadd(u32x16::from(*sample));
    // The light: one, or picked by the path's sequence.
    let lights = &scene.gloss_lights;
    let pick: [u32; LANES] = if lights.len() == 1 {
        [0; LANES]
    } else {
        let (u, _) = sobol_owen_lanes(index, hash_lanes([key, u32x16::splat(dim::GLOSS_LIGHT_PICK)]));
        u.to_array().map(|u| pick_light(scene, u) as u32)
    };
    let li = pick.map(|j| lights[j as usize]);
    let seed = hash_lanes([key, u32x16::from(li), u32x16::splat(dim::GLOSS_LIGHT)]);
    let (s, l) = table.sample(&pick, o, normal, index, seed);
    // Density of the point per solid angle (n samples).
    let zero = f32x16::ZERO;
    let live = s.cos_y.simd_gt(zero) & s.dist2.simd_gt(zero);
    let light_pdf = s.dist2 / (s.cos_y * l.area) * f32x16::splat(n as f32);
    let tmax = s.dist * f32x16::splat(SHADOW_TMAX_SCALE);
    let sample = LaneSamples { wi: s.wi, cos: s.cos_x, tmax, radiance: l.radiance, pdf: light_pdf, live };
    weighted_lanes(q, (point, count), sample, shadow);
}

/// Light samples of 16 diffuse points, on lanes.
struct LaneSamples {
    /// Unit directions towards the lights.
    wi: V3<f32x16>,
    /// Their cosines with the points' normals.
    cos: f32x16,
    /// The shadow rays' reach.
    tmax: f32x16,
    radiance: V3<f32x16>,
    /// The densities per solid angle, over the points' n samples.
    pdf: f32x16,
    /// Lanes with a sample.
    live: f32x16,
}

/// The shadow rays of light samples `s` at points `point` of `q` (the first `count`
/// real), each weighted by the power heuristic against the density of its point's
/// cosine bounce ray; none below a surface or for no light.
fn weighted_lanes(q: &SurfaceQueue, (point, count): (&[u32; LANES], usize), s: LaneSamples, shadow: &mut ShadowQueue) {
    let lanes = LaneIds::new(point);
    let f = |v: &[f32]| lanes.gather(v);
    let v3 = |x: &[f32], y: &[f32], z: &[f32]| V3 { x: f(x), y: f(y), z: f(z) };
    let zero = f32x16::ZERO;
    let live = s.live & s.cos.simd_gt(zero);
    let (light_pdf, l) = (s.pdf, &s);
    let bsdf_pdf = s.cos * f32x16::splat(FRAC_1_PI);
    let r = bsdf_pdf / light_pdf;
    // Power heuristic over the light density, cos_x / light_pdf folded in.
    let factor = s.cos / (light_pdf * (f32x16::ONE + r * r));
    let factor = live.select(factor, zero);
    let w = v3(&q.wr, &q.wg, &q.wb);
    let brdf = v3(&q.cr, &q.cg, &q.cb).scale(f32x16::splat(FRAC_1_PI));
    let c = |w: f32x16, b: f32x16, r: f32x16| (w * b * r * factor).to_array();
    let (mut lr, mut lg, mut lb) =
        (c(w.x, brdf.x, l.radiance.x), c(w.y, brdf.y, l.radiance.y), c(w.z, brdf.z, l.radiance.z));
    let spec = v3(&q.sr, &q.sg, &q.sb);
    let phong = !(spec.x.simd_eq(zero) & spec.y.simd_eq(zero) & spec.z.simd_eq(zero)).to_bitmask();
    let (wx, wy, wz) = (s.wi.x.to_array(), s.wi.y.to_array(), s.wi.z.to_array());
    let (live, fa) = (live.to_bitmask(), factor.to_array());
    let (rx, ry, rz) = (l.radiance.x.to_array(), l.radiance.y.to_array(), l.radiance.z.to_array());
    let (mut keep, mut m) = ([0usize; LANES], 0);
    for k in (0..count).filter(|&k| live & (1 << k) != 0) {
        if phong & (1 << k) != 0 {
            let p = point[k] as usize;
            let wi = Vec3::new(wx[k], wy[k], wz[k]);
            let brdf = diffuse_brdf(q.color(p), q.specular(p), q.shininess[p], q.normal(p), wi, q.wo(p));
            let v = q.weight(p) * brdf * Vec3::new(rx[k], ry[k], rz[k]) * fa[k];
            (lr[k], lg[k], lb[k]) = (v.x, v.y, v.z);
        }
        if lr[k] != 0.0 || lg[k] != 0.0 || lb[k] != 0.0 {
            keep[m] = k;
            m += 1;
        }
    }
    let o = v3(&q.ox, &q.oy, &q.oz);
    let slot = point.map(|p| q.slot[p as usize]);
    let time = (!q.time.is_empty()).then(|| point.map(|p| q.time[p as usize]));
    shadow.push_picked(o.lanes(), [wx, wy, wz], s.tmax.to_array(), slot, [lr, lg, lb], time.as_ref(), &keep[..m]);
}
