//! DOF-aware adaptive anti-aliasing (the paper's §5 proposal): a pinhole depth probe
//! through each pixel corner and centre, the circle of confusion its first hit gives,
//! and the mapping from that blur to a pixel's eps and to each point's lens samples.
//!
//! Reads film points; writes depth-probe rays, then two blur radii (pixels) per point:
//! the one its eps uses and the one its lens count uses. They differ only at mirrors and
//! glass, whose surface may be in focus while what they show is not. Touches no pixel
//! state. The mapping is documented in docs/paper.md.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use std::ops::Range;
use wide::f32x16;

use crate::accel::{Ray, Traversal, NO_LIGHT};
use crate::queue::{HitQueue, RayQueue, MISS};
use crate::scene::{Material, Scene};
use crate::simd::{LaneIds, Real, LANES, V3};

/// Pinhole rays through the film positions `film(i)` of points `range`, for their first
/// hit's depth only (they are intersected, never shaded). Slot: the point index minus
/// `range.start`. No randomness: a point's probe depends only on its film position (and
/// under motion blur sees moving objects at mid-shutter). The
/// directions are computed 16 at a time on lanes ([`Camera::pinhole_dirs`]).
pub fn generate(scene: &Scene, range: Range<u64>, film: impl Fn(u32) -> Vec2, rays: &mut RayQueue) {
    rays.clear();
    let s = &scene.settings;
    let cam = &scene.camera;
    let first = range.start;
    // Under motion blur a probe sees moving objects at mid-shutter (the camera as at time
    // 0: the blur radii use its view axis).
    let [open, close] = s.shutter;
    let time = scene.motion_blur().then_some(open + 0.5 * (close - open));
    for i0 in range.clone().step_by(LANES) {
        let count = (range.end - i0).min(LANES as u64) as usize;
        // Lanes past the last point repeat it and are not written.
        let (mut fx, mut fy) = ([0.0f32; LANES], [0.0f32; LANES]);
        for k in 0..LANES {
            let p = film((i0 + k.min(count - 1) as u64) as u32);
            (fx[k], fy[k]) = (p.x, p.y);
        }
        let d = cam.pinhole_dirs(f32x16::from(fx), f32x16::from(fy), s.width, s.height);
        let (dx, dy, dz) = (d.x.to_array(), d.y.to_array(), d.z.to_array());
        for k in 0..count {
            let slot = (i0 + k as u64 - first) as u32;
            rays.push(cam.position, Vec3::new(dx[k], dy[k], dz[k]), slot, Vec3::ZERO, 0, 0, 0, 0.0, time);
        }
    }
}

/// The blur radii, in pixels, of every probe in `rays` from its hit in `hits`, written to
/// `sharp[first + slot]` (for the eps) and `lens[first + slot]` (for the lens count).
/// Both are the circle of confusion of the first hit, except at a mirror or dielectric:
/// there the surface (and its silhouette) may be in focus while the reflected or
/// refracted image comes from far away, and through a curved surface the lens rays of
/// one film point fan out to places the first-hit depth says nothing about. Such a
/// probe keeps its own blur for the eps but asks for every lens sample. The radii are
/// computed 16 probes at a time on lanes.
pub fn blur(scene: &Scene, rays: &RayQueue, hits: &HitQueue, first: usize, sharp: &mut [f32], lens: &mut [f32]) {
    let forward = V3::splat(scene.camera.forward);
    for i0 in (0..rays.len()).step_by(LANES) {
        let ids: [u32; LANES] = std::array::from_fn(|k| (i0 + k).min(rays.len() - 1) as u32);
        let lanes = LaneIds::new(&ids);
        let d = V3 { x: lanes.gather(&rays.dx), y: lanes.gather(&rays.dy), z: lanes.gather(&rays.dz) };
        // Depth along the view axis: the thin lens focuses planes, not spheres.
        let r = coc_pixels(scene, lanes.gather(&hits.t) * d.dot(forward)).to_array();
        for (k, &r) in r.iter().enumerate().take(rays.len() - i0) {
            let i = i0 + k;
            let specular = hits.prim[i] != MISS && {
                let prim = hits.prim[i];
                scene.accel.light(prim) == NO_LIGHT
                    && !matches!(scene.materials[scene.accel.material(prim) as usize], Material::Diffuse { .. })
            };
            let at = first + rays.slot[i] as usize;
            sharp[at] = r;
            lens[at] = if specular { f32::INFINITY } else { r };
        }
    }
}

/// Radius in pixels of the circle of confusion of a point at depth `z` (infinite for a
/// miss). A lens of radius A focused at distance f spreads a point at depth z over a
/// disk of radius A·|z − f|/z on the focus plane, where one pixel is 2·f·tan(fov_y/2)/H
/// high, so r = A·H/(2·tan(fov_y/2)) · |1/f − 1/z|. One formula for lanes and for a
/// single value (`R = f32`).
pub fn coc_pixels<R: Real>(scene: &Scene, z: R) -> R {
    let cam = &scene.camera;
    let scale = cam.aperture * scene.settings.height as f32 / (2.0 * cam.tan_half_fov);
    R::splat(scale) * (R::splat(1.0 / cam.focus_distance) - R::splat(1.0) / z).abs()
}

/// What the centre of pixel (`x`, `y`) sees through a pinhole: the depth of its first
/// hit along the view axis (infinite for a miss) and the primitive hit. The study's
/// features and auto mode's lens test read a scene's blur from it.
pub fn pinhole_depth(scene: &Scene, x: u32, y: u32, trav: &mut Traversal) -> (f32, Option<u32>) {
    let (cam, s) = (&scene.camera, &scene.settings);
    let dir = cam.pinhole_dir(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), s.width, s.height);
    match scene.accel.closest::<false>(Ray::infinite(cam.position, dir), trav) {
        Some((t, id)) => (t * dir.dot(cam.forward), Some(id)),
        None => (f32::INFINITY, None),
    }
}

/// Lens samples for a point blurred over `r` pixels: one per pixel of the circle of
/// confusion's area, ⌈π·r²⌉, between 1 and `max` (render.dof.samples). Below one pixel of
/// blur the pixel's own samples already cover the circle, so one lens sample per point
/// suffices; a wide circle needs as many as the user allowed.
pub fn lens_samples(r: f32, max: u32) -> u32 {
    let area = (PI * r * r).ceil();
    if area.is_nan() || area >= max as f32 {
        max
    } else {
        (area as u32).clamp(1, max)
    }
}

/// The eps of a pixel whose sharpest point is blurred over `r` pixels: eps / w(r), with
/// w the raised cosine ½·(1 + cos(π·min(r/radius, 1))): eps itself at r = 0, growing with
/// the blur, and infinite (never refined) from r = `radius` on. A blurred image has no
/// sub-pixel detail to anti-alias; what differs between its centre and corners is lens
/// noise, which refinement would chase at 2^level rays a level.
pub fn pixel_eps(eps: f32, r: f32, radius: f32) -> f32 {
    if r <= 0.0 {
        return eps;
    }
    let w = 0.5 * (1.0 + (PI * (r / radius).min(1.0)).cos());
    if w <= 1e-6 || r.is_nan() {
        f32::INFINITY
    } else {
        eps / w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lens_samples_follow_the_circle_area() {
        assert_eq!(lens_samples(0.0, 70), 1);
        assert_eq!(lens_samples(0.5, 70), 1);
        assert_eq!(lens_samples(1.0, 70), 4);
        assert_eq!(lens_samples(2.0, 70), 13);
        assert_eq!(lens_samples(5.0, 70), 70);
        assert_eq!(lens_samples(f32::INFINITY, 70), 70);
        assert_eq!(lens_samples(3.0, 1), 1);
    }

    #[test]
    fn pixel_eps_is_a_raised_cosine() {
        assert_eq!(pixel_eps(0.01, 0.0, 2.0), 0.01);
        assert!((pixel_eps(0.01, 1.0, 2.0) - 0.02).abs() < 1e-7, "half the radius: w = 1/2");
        assert!(pixel_eps(0.01, 0.2, 2.0) > 0.01);
        assert_eq!(pixel_eps(0.01, 2.0, 2.0), f32::INFINITY);
        assert_eq!(pixel_eps(0.01, f32::INFINITY, 2.0), f32::INFINITY);
    }
}
