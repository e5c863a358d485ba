//! Shading: reads the ray and hit queues; sends escaped rays and visible emitters to
//! the film queue, diffuse hits' direct lighting to the shadow queue (one ray per
//! point light, `shadows.samples` stratified rays per quad light), and mirror or
//! dielectric hits to the specular list for the scatter stage.

use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

use crate::geometry::offset::offset_ray_origin;
use crate::geometry::NO_LIGHT;
use crate::queue::{FilmQueue, HitQueue, RayQueue, ShadowQueue, MISS};
use crate::sampling::{cmj, dim, hash};
use crate::scene::{Light, Material, Scene};

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

/// Shades every ray of `rays` at its hit in `hits`.
pub fn shade(
    scene: &Scene,
    rays: &RayQueue,
    hits: &HitQueue,
    shadow: &mut ShadowQueue,
    specular: &mut Vec<u32>,
    film: &mut FilmQueue,
) {
    shadow.clear();
    specular.clear();
    film.clear();
    let s = &scene.settings;
    for i in 0..rays.len() {
        let (d, w, pixel) = (rays.dir(i), rays.weight(i), rays.pixel[i]);
        if hits.prim[i] == MISS {
            if scene.background != Vec3::ZERO {
                film.push(pixel, w * scene.background);
            }
            continue;
        }
        let prim = &scene.accel.prims[hits.prim[i] as usize];
        let x = rays.origin(i) + hits.t[i] * d;
        let ng = prim.shape.normal(x).normalize();
        if prim.light != NO_LIGHT {
            // One-sided emitter: radiance on the front, black from behind.
            if let Light::Quad { radiance, .. } = scene.lights[prim.light as usize] {
                if ng.dot(d) < 0.0 {
                    film.push(pixel, w * radiance);
                }
            }
            continue;
        }
        let (color, spec, shininess) = match scene.materials[prim.material as usize] {
            Material::Diffuse { color, specular, shininess } => (color, specular, shininess),
            _ => {
                if rays.depth[i] < s.max_depth {
                    specular.push(i as u32);
                }
                continue;
            }
        };
        // Diffuse surfaces are two-sided: light the side the ray arrived on.
        let n = if ng.dot(d) < 0.0 { ng } else { -ng };
        let o = offset_ray_origin(x, n);
        let wo = -d;
        for (li, light) in scene.lights.iter().enumerate() {
            match *light {
                // A dark light adds nothing: it costs no shadow rays either.
                Light::Point { intensity, .. } | Light::Quad { radiance: intensity, .. } if intensity == Vec3::ZERO => {
                }
                Light::Point { position, intensity } => {
                    let to = position - o;
                    let dist2 = to.length_squared();
                    let dist = dist2.sqrt();
                    let wi = to / dist;
                    let cos = n.dot(wi);
                    if cos <= 0.0 || dist2 == 0.0 {
                        continue;
                    }
                    let f = diffuse_brdf(color, spec, shininess, n, wi, wo);
                    shadow.push(o, wi, dist * SHADOW_TMAX_SCALE, pixel, w * f * intensity * (cos / dist2));
                }
                Light::Quad { corner, u, v, normal, area, radiance } => {
                    let count = s.shadow_samples;
                    let pattern = hash(&[rays.key[i], li as u32, dim::LIGHT]);
                    let scale = area / count as f32;
                    for j in 0..count {
                        let uv = cmj(j, count, pattern);
                        let to = corner + uv.x * u + uv.y * v - o;
                        let dist2 = to.length_squared();
                        let dist = dist2.sqrt();
                        let wi = to / dist;
                        let cos_x = n.dot(wi);
                        let cos_y = -normal.dot(wi);
                        if cos_x <= 0.0 || cos_y <= 0.0 {
                            continue;
                        }
                        let f = diffuse_brdf(color, spec, shininess, n, wi, wo);
                        let l = w * f * radiance * (cos_x * cos_y * scale / dist2);
                        shadow.push(o, wi, dist * SHADOW_TMAX_SCALE, pixel, l);
                    }
                }
            }
        }
    }
}
