//! The path transport's diffuse bounces: reads the diffuse shading points of a wave and
//! writes the ray each one scatters into the next level's queue.
//!
//! Lambert's lobe is drawn by cosine (Malley's method), so a Lambertian point's ray
//! carries its albedo; a Phong point's ray carries f·cos/density, its highlight
//! included. Under uniform shadows the point's light samples are weighted against this
//! density by the power heuristic (shade), so the ray carries its density for the
//! emitter it may hit; under adaptive shadows the light samples take the whole of the
//! emitters' light and the ray is marked to see none.

use std::f32::consts::PI;

use crate::microfacet::tangents;
use crate::queue::{sparse_opt, RayQueue, SurfaceQueue};
use crate::sampling::{cosine_hemisphere, dim, hash, sobol_owen};
use crate::scene::{Scene, ShadowMode};
use crate::surface::{diffuse_brdf, queued_surface};

/// Appends to `next` the bounce ray of every point of `surfaces` (the diffuse hits of
/// `rays` that may still scatter): a cosine-distributed direction about the shading
/// normal, from point `sample` of the path's Owen-scrambled Sobol sequence keyed by its
/// key and [`dim::BOUNCE`] (stratified over the pixel's samples).
pub fn bounce(scene: &Scene, rays: &RayQueue, surfaces: &SurfaceQueue, next: &mut RayQueue) {
    let s = &scene.settings;
    let mis = s.shadow_mode == ShadowMode::Uniform;
    // The light samples' count divides the density (their weights are for n samples).
    let samples = s.shadow_samples as f32;
    for p in 0..surfaces.len() {
        let surf = queued_surface(surfaces, p);
        let (ts, tt) = tangents(surf.n);
        let l = cosine_hemisphere(sobol_owen(surf.sample, hash(&[surf.key, dim::BOUNCE])));
        let wi = (ts * l.x + tt * l.y + surf.n * l.z).normalize();
        let cos = surf.n.dot(wi);
        if cos <= 0.0 {
            continue;
        }
        // f·cos / (cos/π): the albedo for Lambert.
        let f = diffuse_brdf(surf.color, surf.specular, surf.shininess, surf.n, wi, surf.wo) * PI;
        let w = surf.w * f;
        if w == glam::Vec3::ZERO {
            continue;
        }
        let pdf = if mis { cos / PI / samples } else { -1.0 };
        let ray = surfaces.ray[p] as usize;
        let time = sparse_opt(&surfaces.time, p);
        let key = hash(&[surf.key, 1]);
        next.push(surf.o, wi, surf.slot, w, rays.depth[ray] + 1, key, surf.sample, pdf, time);
    }
}
