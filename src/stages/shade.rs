//! Shading: reads the ray and hit queues; sends escaped rays and visible emitters to
//! the film queue, mirror or dielectric hits to the specular list for the scatter
//! stage, and diffuse hits' direct lighting to the shadow queue (one ray per point
//! light; per quad light `shadows.samples` stratified rays in uniform mode, or one entry
//! in the shadow-corner queue in adaptive mode).

use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

use crate::geometry::offset::offset_ray_origin;
use crate::geometry::NO_LIGHT;
use crate::queue::{FilmQueue, HitQueue, RayQueue, ShadowPointQueue, ShadowQueue, MISS};
use crate::sampling::{cmj_cell, dim, hash};
use crate::scene::{Light, Material, Scene, ShadowMode};

/// Shadow rays stop this fraction short of the light, so a surface the light lies on
/// (a lamp flush with a ceiling) does not shadow it.
pub const SHADOW_TMAX_SCALE: f32 = 1.0 - 1e-4;

/// Lambert plus normalised Phong: `color/π + specular·(n+2)/(2π)·max(0, r·wo)^n`,
/// with `r` the mirror direction of `wi` about `n`.
#[inline]
pub fn diffuse_brdf(color: Vec3, specular: Vec3, shininess: f32, n: Vec3, wi: Vec3, wo: Vec3) -> Vec3 {
    let mut f = color * FRAC_1_PI;
    if specular != Vec3::ZERO {
        let r = 2.0 * n.dot(wi) * n - wi;
        let c = r.dot(wo).max(0.0);
        f += specular * ((shininess + 2.0) / (2.0 * PI) * c.powf(shininess));
    }
    f
}

/// A diffuse shading point: what direct lighting needs, computed in one place for the
/// shade, shadow-corner and penumbra stages so they agree bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    /// Ray origin for shadow rays: the hit point offset off the surface.
    pub o: Vec3,
    /// Unit normal on the side the ray arrived from.
    pub n: Vec3,
    /// Unit direction back along the incoming ray.
    pub wo: Vec3,
    /// Albedo.
    pub color: Vec3,
    /// Phong reflectance.
    pub specular: Vec3,
    /// Phong exponent.
    pub shininess: f32,
    /// Path throughput of the incoming ray.
    pub w: Vec3,
    /// Accumulation slot of the incoming ray.
    pub slot: u32,
    /// Path key of the incoming ray.
    pub key: u32,
}

/// The diffuse surface that ray `i` hit, or `None` if it hit something else.
#[inline]
pub fn diffuse_surface(scene: &Scene, rays: &RayQueue, hits: &HitQueue, i: usize) -> Option<Surface> {
    let prim = scene.accel.prims.get(hits.prim[i] as usize)?;
    if prim.light != NO_LIGHT {
        return None;
    }
    let Material::Diffuse { color, specular, shininess } = scene.materials[prim.material as usize] else {
        return None;
    };
    let d = rays.dir(i);
    let (x, err) = prim.shape.surface_point(rays.origin(i), d, hits.t[i]);
    let ng = prim.shape.normal(x).normalize();
    // Diffuse surfaces are two-sided: light the side the ray arrived on.
    let n = if ng.dot(d) < 0.0 { ng } else { -ng };
    Some(Surface {
        o: offset_ray_origin(x, err, n),
        n,
        wo: -d,
        color,
        specular,
        shininess,
        w: rays.weight(i),
        slot: rays.slot[i],
        key: rays.key[i],
    })
}

/// The CMJ pattern of quad light `li`'s samples seen from a point whose path key is `key`.
#[inline]
pub fn light_pattern(key: u32, li: usize) -> u32 {
    hash(&[key, li as u32, dim::LIGHT])
}

/// Visits the stratified samples of quad light `li` seen from `surf` that can contribute
/// (both cosines positive), calling `f(cell, direction, distance, contribution)`, where
/// `cell` is the sample's cell in the pattern's grid ([`crate::sampling::cmj_cell`]).
/// Contributions are already divided by the sample count, so unoccluded ones sum to the
/// estimate.
#[inline]
pub fn quad_light_samples(scene: &Scene, surf: &Surface, li: usize, mut f: impl FnMut(u32, Vec3, f32, Vec3)) {
    let Light::Quad { corner, u, v, normal, area, radiance } = scene.lights[li] else { return };
    let count = scene.settings.shadow_samples;
    let pattern = light_pattern(surf.key, li);
    let scale = area / count as f32;
    for j in 0..count {
        let (uv, cell) = cmj_cell(j, count, pattern);
        let to = corner + uv.x * u + uv.y * v - surf.o;
        let dist2 = to.length_squared();
        let dist = dist2.sqrt();
        let wi = to / dist;
        let cos_x = surf.n.dot(wi);
        let cos_y = -normal.dot(wi);
        if cos_x <= 0.0 || cos_y <= 0.0 {
            continue;
        }
        let brdf = diffuse_brdf(surf.color, surf.specular, surf.shininess, surf.n, wi, surf.wo);
        f(cell, wi, dist, surf.w * brdf * radiance * (cos_x * cos_y * scale / dist2));
    }
}

/// Irradiance at `o` (unit normal `n`) from a parallelogram of unit radiance with
/// corners `c, c+u, c+u+v, c+v`, by Lambert's polygon formula
/// E = ½ Σ θ_k (n · γ_k), with the polygon first clipped to the hemisphere above `o`.
/// Angles come from atan2, which keeps its precision for small, distant lights.
pub fn quad_irradiance(o: Vec3, n: Vec3, c: Vec3, u: Vec3, v: Vec3) -> f32 {
    let quad = [c - o, c + u - o, c + u + v - o, c + v - o];
    // Sutherland–Hodgman against the tangent plane: at most 5 vertices remain.
    let mut poly = [Vec3::ZERO; 5];
    let mut len = 0;
    for k in 0..4 {
        let (a, b) = (quad[k], quad[(k + 1) % 4]);
        let (da, db) = (n.dot(a), n.dot(b));
        if da > 0.0 {
            poly[len] = a;
            len += 1;
        }
        if (da > 0.0) != (db > 0.0) {
            poly[len] = a + (b - a) * (da / (da - db));
            len += 1;
        }
    }
    let mut sum = 0.0;
    for k in 0..len {
        let (a, b) = (poly[k].normalize(), poly[(k + 1) % len].normalize());
        let cross = a.cross(b);
        let sin = cross.length();
        if sin > 0.0 {
            sum += sin.atan2(a.dot(b)) * n.dot(cross / sin);
        }
    }
    0.5 * sum.abs()
}

/// Shades every ray of `rays` at its hit in `hits`. Returns the number of shadow rays
/// uniform mode would have cast for the points put in the shadow-corner queue.
pub fn shade(
    scene: &Scene,
    rays: &RayQueue,
    hits: &HitQueue,
    shadow: &mut ShadowQueue,
    points: &mut ShadowPointQueue,
    specular: &mut Vec<u32>,
    film: &mut FilmQueue,
) -> u64 {
    shadow.clear();
    points.clear();
    specular.clear();
    film.clear();
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
                // A dark light adds nothing: it costs no shadow rays either.
                Light::Point { intensity, .. } | Light::Quad { radiance: intensity, .. } if intensity == Vec3::ZERO => {
                }
                Light::Point { position, intensity } => {
                    let to = position - surf.o;
                    let dist2 = to.length_squared();
                    let dist = dist2.sqrt();
                    let wi = to / dist;
                    let cos = surf.n.dot(wi);
                    if cos <= 0.0 || dist2 == 0.0 {
                        continue;
                    }
                    let f = diffuse_brdf(surf.color, surf.specular, surf.shininess, surf.n, wi, surf.wo);
                    shadow.push(
                        surf.o,
                        wi,
                        dist * SHADOW_TMAX_SCALE,
                        surf.slot,
                        surf.w * f * intensity * (cos / dist2),
                    );
                }
                Light::Quad { corner, u, v, normal, radiance, .. } if adaptive => {
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
                    points.push(i as u32, li as u32, sum);
                    uniform_equivalent += n;
                }
                Light::Quad { .. } => quad_light_samples(scene, &surf, li, |_, wi, dist, l| {
                    shadow.push(surf.o, wi, dist * SHADOW_TMAX_SCALE, surf.slot, l)
                }),
            }
        }
    }
    uniform_equivalent
}
