//! Sphere lights (Mitsuba's area emitter on a `sphere`): a direction drawn uniformly in
//! the cone the sphere subtends, and its density.

use glam::Vec3;
use wide::f32x16;

use crate::bsdf::microfacet::tangents_lanes;
use crate::simd::V3;

type F = f32x16;

/// A direction from `x` towards a sphere light, drawn uniformly in the cone the sphere
/// subtends (pbrt's and Mitsuba's choice for a sphere seen from outside).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereSample {
    /// Unit direction.
    pub wi: Vec3,
    /// Distance to the sphere's near side along it.
    pub dist: f32,
    /// Density per unit solid angle: 1 / (2π (1 − cos θmax)).
    pub pdf: f32,
}

/// [`SphereSample`] for the square sample `u`; `None` from inside the sphere (it emits
/// outwards only: nothing reaches an inside point).
#[inline]
pub fn sphere_sample(center: Vec3, radius: f32, x: Vec3, u: glam::Vec2) -> Option<SphereSample> {
    let to = center - x;
    let d2 = to.length_squared();
    let r2 = radius * radius;
    if d2 <= r2 {
        return None;
    }
    let d = d2.sqrt();
    let axis = to / d;
    // 1 − cos θmax without cancellation for small, far spheres.
    let sin2_max = r2 / d2;
    let one_minus_max = sin2_max / (1.0 + (1.0 - sin2_max).max(0.0).sqrt());
    let one_minus_cos = u.x * one_minus_max;
    let cos = 1.0 - one_minus_cos;
    let sin = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
    let (sp, cp) = (2.0 * std::f32::consts::PI * u.y).sin_cos();
    let (s, t) = crate::bsdf::microfacet::tangents(axis);
    let wi = (s * (sin * cp) + t * (sin * sp) + axis * cos).normalize();
    // The near intersection with the sphere; at the cone's rim the root is 0.
    let b = wi.dot(to);
    let disc = (r2 - (d2 - b * b)).max(0.0);
    let dist = b - disc.sqrt();
    Some(SphereSample { wi, dist: dist.max(0.0), pdf: 1.0 / (2.0 * std::f32::consts::PI * one_minus_max) })
}

/// The density [`sphere_sample`] gives any direction in the cone of the sphere seen from
/// `x`: 0 from inside.
#[inline]
pub fn sphere_pdf(center: Vec3, radius: f32, x: Vec3) -> f32 {
    let d2 = (center - x).length_squared();
    let r2 = radius * radius;
    if d2 <= r2 {
        return 0.0;
    }
    let sin2_max = r2 / d2;
    let one_minus_max = sin2_max / (1.0 + (1.0 - sin2_max).max(0.0).sqrt());
    1.0 / (2.0 * std::f32::consts::PI * one_minus_max)
}

/// [`sphere_sample`] from 16 points `x` with square samples `u`, on lanes (`wide`'s sine
/// and cosine): the directions, the distances to the near side, the densities, and the
/// lanes outside the sphere (the others have no sample).
pub fn sphere_sample_lanes(center: Vec3, radius: f32, x: V3<F>, u: [F; 2]) -> (V3<F>, F, F, F) {
    let one = F::splat(1.0);
    let to = V3::splat(center) - x;
    let d2 = to.dot(to);
    let r2 = F::splat(radius * radius);
    let outside = d2.simd_gt(r2);
    let axis = to.scale(one / d2.sqrt());
    let sin2_max = r2 / d2;
    let one_minus_max = sin2_max / (one + (one - sin2_max).max(F::ZERO).sqrt());
    let one_minus_cos = u[0] * one_minus_max;
    let cos = one - one_minus_cos;
    let sin = (one_minus_cos * (F::splat(2.0) - one_minus_cos)).max(F::ZERO).sqrt();
    let (sp, cp) = (F::splat(2.0 * std::f32::consts::PI) * u[1]).sin_cos();
    let (s, t) = tangents_lanes(axis);
    let wi = (s.scale(sin * cp) + t.scale(sin * sp) + axis.scale(cos)).normalize();
    let b = wi.dot(to);
    let disc = (r2 - (d2 - b * b)).max(F::ZERO);
    let dist = (b - disc.sqrt()).max(F::ZERO);
    let pdf = one / (F::splat(2.0 * std::f32::consts::PI) * one_minus_max);
    (wi, dist, pdf, outside)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_agree_with_the_scalar_sampler() {
        let (center, radius) = (Vec3::new(1.0, 2.0, -3.0), 0.7);
        for i in 0..64 {
            let xs: [Vec3; 16] = std::array::from_fn(|k| {
                let t = (i * 16 + k) as f32;
                // Far, near and inside points.
                center + Vec3::new((t * 0.37).sin(), (t * 0.71).cos(), (t * 0.13).sin()) * (0.5 + (t * 0.05) % 40.0)
            });
            let us: [glam::Vec2; 16] =
                std::array::from_fn(|k| glam::Vec2::new(((i * 16 + k) as f32 * 0.618) % 1.0, (k as f32 * 0.377) % 1.0));
            let x = V3::from_fn(|k| xs[k]);
            let (wi, dist, pdf, outside) =
                sphere_sample_lanes(center, radius, x, [F::from(us.map(|u| u.x)), F::from(us.map(|u| u.y))]);
            let (wi, dist, pdf, outside) = (wi.lanes(), dist.to_array(), pdf.to_array(), outside.to_bitmask());
            for k in 0..16 {
                let scalar = sphere_sample(center, radius, xs[k], us[k]);
                assert_eq!(scalar.is_some(), outside & (1 << k) != 0, "{}", xs[k]);
                let Some(s) = scalar else { continue };
                let w = Vec3::new(wi[0][k], wi[1][k], wi[2][k]);
                assert!((s.wi - w).abs().max_element() < 1e-4, "{} vs {w}", s.wi);
                assert!((s.dist - dist[k]).abs() <= 1e-3 * s.dist.max(1.0), "{} vs {}", s.dist, dist[k]);
                assert!((s.pdf - pdf[k]).abs() <= 1e-5 * s.pdf, "{} vs {}", s.pdf, pdf[k]);
            }
        }
    }
}
