//! Shading: reads the ray and hit queues; sends escaped rays and visible emitters to
//! the film queue, mirror or dielectric hits to the specular list for the scatter
//! stage, and diffuse hits' direct lighting to the shadow queue (one ray per point
//! light; per quad light `shadows.samples` stratified rays in uniform mode, or one entry
//! in the shadow-corner queue in adaptive mode). Uniform shadow rays to quad lights are
//! computed on 16 lanes at a time, in the order and with the bits of the scalar loop.

use glam::Vec3;
use std::f32::consts::FRAC_1_PI;
use wide::{f32x16, u32x16};

use crate::geometry::NO_LIGHT;
use crate::light::{
    light_seed_lanes, quad_irradiance, quad_light_samples, quad_sample, uniform_shadow_rays, QuadLanes,
    SHADOW_TMAX_SCALE,
};
use crate::queue::{FilmQueue, HitQueue, IndexQueue, RayQueue, ShadowPointQueue, ShadowQueue, SurfaceQueue, MISS};
use crate::scene::{Light, Scene, ShadowMode};
use crate::simd::{Word, LANES, V3};
use crate::surface::{diffuse_brdf, diffuse_surface};

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
    surfaces: &mut SurfaceQueue,
    specular: &mut IndexQueue,
    film: &mut FilmQueue,
) -> u64 {
    shadow.clear();
    points.clear();
    surfaces.clear();
    specular.clear();
    let adaptive = matches!(scene.settings.shadow_mode, ShadowMode::Adaptive(_));
    // Uniform shadows go on lanes when every light is a quad (a point light's one ray
    // would interleave with them, and keeps the scalar loop).
    let lanes = !adaptive && scene.lights.iter().all(|l| matches!(l, Light::Quad { .. }));
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
        if lanes {
            surfaces.push(
                surf.o,
                surf.n,
                surf.wo,
                surf.color,
                surf.specular,
                surf.shininess,
                surf.w,
                surf.slot,
                surf.key,
                surf.sample,
            );
            continue;
        }
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
    if lanes {
        quad_shadow_lanes(scene, surfaces, shadow);
    }
    uniform_equivalent
}

/// Uniform shadow rays from every point of `surfaces` to every lit quad light, 16
/// (point, light, sample) triples at a time, in the scalar loop's order (point, then
/// light, then sample): the queue, and every sum taken over it later, keeps its bits.
fn quad_shadow_lanes(scene: &Scene, surfaces: &SurfaceQueue, shadow: &mut ShadowQueue) {
    let n = scene.settings.shadow_samples;
    let lit = |li: usize| matches!(scene.lights[li], Light::Quad { radiance, .. } if radiance != Vec3::ZERO);
    let next_lit = |from: usize| (from..scene.lights.len()).find(|&li| lit(li));
    let Some(first) = next_lit(0) else { return };
    let (mut s, mut li, mut j) = (0, first, 0);
    let mut lanes = [(0u32, 0u32, 0u32); LANES];
    while s < surfaces.len() {
        let mut count = 0;
        while count < LANES && s < surfaces.len() {
            lanes[count] = (s as u32, li as u32, j);
            count += 1;
            j += 1;
            if j == n {
                j = 0;
                li = next_lit(li + 1).unwrap_or_else(|| {
                    s += 1;
                    first
                });
            }
        }
        // Lanes past the last triple repeat it and are not written.
        let last = lanes[count - 1];
        lanes[count..].fill(last);
        quad_lanes(scene, surfaces, &lanes, count, shadow);
    }
}

/// The shadow rays of `count` (point, light, sample) `triples` on lanes: the scalar
/// formulas of [`quad_light_samples`] (through [`quad_sample`]), Lambert on the
/// lanes and a Phong point's BRDF by the scalar function.
fn quad_lanes(
    scene: &Scene,
    q: &SurfaceQueue,
    triples: &[(u32, u32, u32); LANES],
    count: usize,
    shadow: &mut ShadowQueue,
) {
    let n = scene.settings.shadow_samples;
    let si = triples.map(|t| t.0 as usize);
    // A run of consecutive points (one sample, one light) loads straight from the queue.
    let run = (si[LANES - 1] == si[0] + LANES - 1).then_some(si[0]);
    let f = |v: &[f32]| match run {
        Some(a) => f32x16::from(&v[a..a + LANES]),
        None => f32x16::from(si.map(|i| v[i])),
    };
    let v3 = |x: &[f32], y: &[f32], z: &[f32]| V3 { x: f(x), y: f(y), z: f(z) };
    let u = |v: &[u32]| u32x16::from(si.map(|i| v[i]));
    // Per lane: corner, edges, normal, area / n, radiance.
    type Params = (Vec3, Vec3, Vec3, Vec3, f32, Vec3);
    let lights: [Params; LANES] = triples.map(|t| match scene.lights[t.1 as usize] {
        Light::Quad { corner, u, v, normal, area, radiance } => (corner, u, v, normal, area / n as f32, radiance),
        Light::Point { .. } => (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0.0, Vec3::ZERO),
    });
    let lv = |g: fn(&Params) -> Vec3| {
        let p = lights.map(|l| g(&l));
        V3 { x: f32x16::from(p.map(|p| p.x)), y: f32x16::from(p.map(|p| p.y)), z: f32x16::from(p.map(|p| p.z)) }
    };
    let quad = QuadLanes { corner: lv(|l| l.0), u: lv(|l| l.1), v: lv(|l| l.2), normal: lv(|l| l.3) };
    let (o, normal) = (v3(&q.ox, &q.oy, &q.oz), v3(&q.nx, &q.ny, &q.nz));
    let index = u(&q.sample).wmul(u32x16::splat(n)).wadd(u32x16::from(triples.map(|t| t.2)));
    let seed = light_seed_lanes(u(&q.key), u32x16::from(triples.map(|t| t.1)));
    let s = quad_sample(&quad, o, normal, index, seed);
    let factor = s.cos_x * s.cos_y * f32x16::from(lights.map(|l| l.4)) / s.dist2;
    let (w, brdf, radiance) =
        (v3(&q.wr, &q.wg, &q.wb), v3(&q.cr, &q.cg, &q.cb).scale(f32x16::splat(FRAC_1_PI)), lv(|l| l.5));
    let l = |w: f32x16, b: f32x16, r: f32x16| (w * b * r * factor).to_array();
    let (lr, lg, lb) = (l(w.x, brdf.x, radiance.x), l(w.y, brdf.y, radiance.y), l(w.z, brdf.z, radiance.z));
    let (wx, wy, wz) = (s.wi.x.to_array(), s.wi.y.to_array(), s.wi.z.to_array());
    let tmax = (s.dist * f32x16::splat(SHADOW_TMAX_SCALE)).to_array();
    let (factor, dark) =
        (factor.to_array(), (s.cos_x.simd_le(f32x16::ZERO) | s.cos_y.simd_le(f32x16::ZERO)).to_bitmask());
    for k in (0..count).filter(|&k| dark & (1 << k) == 0) {
        let (p, wi) = (si[k], Vec3::new(wx[k], wy[k], wz[k]));
        let mut l = Vec3::new(lr[k], lg[k], lb[k]);
        if q.specular(p) != Vec3::ZERO {
            let brdf = diffuse_brdf(q.color(p), q.specular(p), q.shininess[p], q.normal(p), wi, q.wo(p));
            l = q.weight(p) * brdf * lights[k].5 * factor[k];
        }
        shadow.push(q.origin(p), wi, tmax[k], q.slot[p], l);
    }
}
