//! Sphere lights (Mitsuba's area emitter on a `sphere`): a direction drawn uniformly in
//! the cone the sphere subtends, and its density.

use glam::Vec3;

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
