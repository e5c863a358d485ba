//! The path transport's diffuse bounces: reads the diffuse shading points of a wave and
//! writes the ray each one scatters into the next level's queue, 16 points at a time.
//!
//! Lambert's lobe is drawn by cosine (Malley's method), so a Lambertian point's ray
//! carries its albedo; a Phong point's ray carries f·cos/density, its highlight
//! included. Under uniform shadows the point's light samples are weighted against this
//! density by the power heuristic (shade), so the ray carries its density for the
//! emitter it may hit; under adaptive shadows the light samples take the whole of the
//! emitters' light and the ray is marked to see none.

use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};
use wide::{f32x16, u32x16};

use crate::bsdf::microfacet::tangents_lanes;
use crate::queue::{RayQueue, SurfaceQueue};
use crate::sampling::{concentric_disk_lanes, dim, hash_lanes, sobol_owen_lanes};
use crate::scene::{Scene, ShadowMode};
use crate::simd::{LaneIds, LANES, V3};
use crate::surface::diffuse_brdf;

/// Appends to `next` the bounce ray of every point of `surfaces` (the diffuse hits of
/// `rays` that may still scatter): a cosine-distributed direction about the shading
/// normal, from point `sample` of the path's Owen-scrambled Sobol sequence keyed by its
/// key and [`dim::BOUNCE`] (stratified over the pixel's samples). `shadows` is the
/// render's shadow mode (never `Auto`).
pub fn bounce(scene: &Scene, shadows: ShadowMode, rays: &RayQueue, surfaces: &SurfaceQueue, next: &mut RayQueue) {
    let mut start = 0;
    while start < surfaces.len() {
        let count = (surfaces.len() - start).min(LANES);
        let ids: [u32; LANES] = std::array::from_fn(|k| (start + k.min(count - 1)) as u32);
        bounce_lanes((scene, shadows), rays, surfaces, &ids, count, next);
        start += count;
    }
}

/// The bounce rays of surface points `ids` (the first `count` real).
fn bounce_lanes(
    (scene, shadows): (&Scene, ShadowMode),
    rays: &RayQueue,
    q: &SurfaceQueue,
    ids: &[u32; LANES],
    count: usize,
    next: &mut RayQueue,
) {
    let s = &scene.settings;
    let lanes = LaneIds::new(ids);
    let f = |v: &[f32]| lanes.gather(v);
    let v3 = |x: &[f32], y: &[f32], z: &[f32]| V3 { x: f(x), y: f(y), z: f(z) };
    let normal = v3(&q.nx, &q.ny, &q.nz);
    let (key, sample) = (lanes.gather_words(&q.key), lanes.gather_words(&q.sample));
    let (ux, uy) = sobol_owen_lanes(sample, hash_lanes([key, u32x16::splat(dim::BOUNCE)]));
    let (dx, dy) = concentric_disk_lanes(ux, uy);
    let dz = (f32x16::ONE - dx * dx - dy * dy).max(f32x16::ZERO).sqrt();
    let (ts, tt) = tangents_lanes(normal);
    let wi = (ts.scale(dx) + tt.scale(dy) + normal.scale(dz)).normalize();
    let cos = normal.dot(wi);
    // Lambert's ray carries its albedo: f·cos / (cos/π).
    let w = v3(&q.wr, &q.wg, &q.wb);
    let c = v3(&q.cr, &q.cg, &q.cb);
    let (mut wr, mut wg, mut wb) = ((w.x * c.x).to_array(), (w.y * c.y).to_array(), (w.z * c.z).to_array());
    let live = cos.simd_gt(f32x16::ZERO).to_bitmask();
    let spec = v3(&q.sr, &q.sg, &q.sb);
    let zero = f32x16::ZERO;
    let phong = !(spec.x.simd_eq(zero) & spec.y.simd_eq(zero) & spec.z.simd_eq(zero)).to_bitmask();
    let (wx, wy, wz) = (wi.x.to_array(), wi.y.to_array(), wi.z.to_array());
    let (mut keep, mut m) = ([0usize; LANES], 0);
    for k in (0..count).filter(|&k| live & (1 << k) != 0) {
        let p = ids[k] as usize;
        if phong & (1 << k) != 0 {
            let d = Vec3::new(wx[k], wy[k], wz[k]);
            let v = q.weight(p) * diffuse_brdf(q.color(p), q.specular(p), q.shininess[p], q.normal(p), d, q.wo(p)) * PI;
            (wr[k], wg[k], wb[k]) = (v.x, v.y, v.z);
        }
        if wr[k] != 0.0 || wg[k] != 0.0 || wb[k] != 0.0 {
            keep[m] = k;
            m += 1;
        }
    }
    // The density over the light samples' count (their weights are for n samples), or
    // -1: the light samples took the emitters' whole weight.
    let pdf = match shadows {
        ShadowMode::Uniform | ShadowMode::Auto(_) => {
            (cos * f32x16::splat(FRAC_1_PI / s.shadow_samples as f32)).to_array()
        }
        ShadowMode::Adaptive(_) => [-1.0; LANES],
    };
    let o = v3(&q.ox, &q.oy, &q.oz).lanes();
    let slot = ids.map(|p| q.slot[p as usize]);
    let depth = ids.map(|p| rays.depth[q.ray[p as usize] as usize] + 1);
    let key1 = hash_lanes([key, u32x16::ONE]).to_array();
    let time = (!q.time.is_empty()).then(|| ids.map(|p| q.time[p as usize]));
    next.push_picked(
        o,
        [wx, wy, wz],
        slot,
        [wr, wg, wb],
        depth,
        key1,
        sample.to_array(),
        pdf,
        time.as_ref(),
        &keep[..m],
    );
}
