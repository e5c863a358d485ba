//! Robust ray origins, as pbrt-v3/v4 do it (Pharr, Jakob and Humphreys, "Physically
//! Based Rendering", §3.9): the hit point is recomputed on the surface from the shape's
//! own data (`Shape::surface_point`) together with a bound on its rounding error, and
//! the new origin is pushed along the normal just past that bound, then one float step
//! further. The push thus scales with the scene and with the distance from the origin.
//! It can be a single denormal step: a triangle in the plane x = 0 has a point error of 0
//! across it. The triangle test's own rounding, about ε times the triangle's size, is
//! covered by that test, which reports only distances conservatively above 0 (PBRT's
//! other half of the method: [`triangle_t_error`](super::shapes::triangle_t_error)).
//! (Wächter and Binder's fixed-ulp offset, tried first, left acne at scale 1e4 and
//! pushed 2 units off a unit sphere at 1e5: tests/extremes/offsets.rs.)

use glam::Vec3;

use crate::simd::{Real, V3};

/// Moves `p`, a surface point with per-component absolute error bound `err`, off the
/// surface to the side `n` points to: by the error bound projected on `n`, then one more
/// float step per component, so the result is strictly on that side (PBRT's
/// OffsetRayOrigin). `n` need not be unit length but must be finite and non-zero.
#[inline]
pub fn offset_ray_origin(p: Vec3, err: Vec3, n: Vec3) -> Vec3 {
    offset_lanes(V3::from_vec(p), V3::from_vec(err), V3::from_vec(n)).vec()
}

/// [`offset_ray_origin`] on lanes.
#[inline(always)]
pub fn offset_lanes<R: Real>(p: V3<R>, err: V3<R>, n: V3<R>) -> V3<R> {
    let n = n.normalize();
    let q = p + n.scale(n.abs().dot(err));
    V3 { x: q.x.step(n.x), y: q.y.step(n.y), z: q.z.step(n.z) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_moves_to_the_normal_side_at_every_scale() {
        for &s in &[1e-4f32, 1.0, 1e4, 1e6] {
            for &n in &[Vec3::Y, Vec3::NEG_Y, Vec3::new(1.0, 1.0, 0.0)] {
                let p = Vec3::new(0.3 * s, 0.7 * s, -0.2 * s);
                let q = offset_ray_origin(p, p.abs() * 1e-7, n);
                assert!((q - p).dot(n) > 0.0, "scale {s}, n {n}: {p} -> {q}");
                assert!((q - p).length() < 1e-3 * s.max(1.0), "offset too large at scale {s}");
            }
        }
    }
}
