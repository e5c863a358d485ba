//! Reflection and refraction: reads the specular list (indices of rays that hit a
//! mirror or dielectric) and writes the next wave's rays.
//!
//! Dielectrics follow the paper (§3): inside an object the normal is flipped and eta
//! inverted, both decided here from the geometric normal alone, so the errors of the
//! paper's Figure 5 cannot occur. Reflection and refraction are both traced, weighted
//! C and 1 - C (or by exact Fresnel); total internal reflection sends all the weight
//! to reflection.

use glam::Vec3;

use crate::geometry::offset::offset_ray_origin;
use crate::queue::{HitQueue, IndexQueue, RayQueue};
use crate::sampling::hash;
use crate::scene::{Material, ReflectRatio, Scene};
use crate::surface::shading_normal;

/// Mirror direction of `d` about the unit normal `n`.
#[inline]
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// The side of a dielectric boundary a ray is on, and the quantities that depend on it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interface {
    /// Unit normal facing the incoming ray (flipped when the ray is inside).
    pub normal: Vec3,
    /// n_incident / n_transmitted: 1/ior entering, ior leaving.
    pub eta: f32,
    /// True when the ray travels from outside to inside.
    pub entering: bool,
}

/// Orients a dielectric boundary for a ray with direction `d` hitting a surface with
/// outward geometric normal `ng` (unit) of relative index `ior`.
#[inline]
pub fn interface(d: Vec3, ng: Vec3, ior: f32) -> Interface {
    let entering = d.dot(ng) < 0.0;
    if entering {
        Interface { normal: ng, eta: 1.0 / ior, entering }
    } else {
        Interface { normal: -ng, eta: ior, entering }
    }
}

/// cos²θt = 1 − η²(1 − cos²θi), evaluated as cos²θi − (η − 1)(η + 1)(1 − cos²θi): exact
/// for η = 1 and free of the cancellation in 1 − sin²θt at grazing incidence when η ≈ 1.
#[inline]
pub fn cos2_transmitted(cos_i: f32, eta: f32) -> f32 {
    let c2 = cos_i * cos_i;
    c2 - (eta - 1.0) * (eta + 1.0) * (1.0 - c2)
}

/// Snell refraction of unit `d` through a boundary with unit normal `n` facing `d`'s
/// origin side and eta = n_i / n_t. `None` on total internal reflection.
#[inline]
pub fn refract(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = (-d.dot(n)).min(1.0);
    let cos2_t = cos2_transmitted(cos_i, eta);
    if cos2_t <= 0.0 {
        return None;
    }
    let cos_t = cos2_t.sqrt();
    Some((eta * d + (eta * cos_i - cos_t) * n).normalize())
}

/// Unpolarised Fresnel reflectance of a smooth dielectric boundary for incidence cosine
/// `cos_i` and eta = n_i / n_t; 1 under total internal reflection.
#[inline]
pub fn fresnel(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let cos2_t = cos2_transmitted(cos_i, eta);
    if cos2_t <= 0.0 {
        return 1.0;
    }
    let cos_t = cos2_t.sqrt();
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Spawns the reflection and refraction rays of every listed hit into `next` (cleared
/// first).
pub fn scatter(scene: &Scene, rays: &RayQueue, hits: &HitQueue, specular: &IndexQueue, next: &mut RayQueue) {
    next.clear();
    for &i in &specular.index {
        let i = i as usize;
        let prim = &scene.accel.prims[hits.prim[i] as usize];
        let (d, w) = (rays.dir(i), rays.weight(i));
        let (x, err) = prim.shape.surface_point(rays.origin(i), d, hits.t[i]);
        let ng = prim.shape.normal(x).normalize();
        // Directions use the shading normal (smooth meshes), origins the geometric one.
        let shading = |n: Vec3| shading_normal(scene, hits.prim[i] as usize, x, n);
        let (slot, depth, key, sample) = (rays.slot[i], rays.depth[i] + 1, rays.key[i], rays.sample[i]);
        match scene.materials[prim.material as usize] {
            Material::Mirror { color } => {
                let n = if d.dot(ng) < 0.0 { ng } else { -ng };
                let dir = reflect(d, shading(n));
                next.push(offset_ray_origin(x, err, n), dir, slot, w * color, depth, hash(&[key, 1]), sample);
            }
            Material::Dielectric { ior, ratio, tint } => {
                let side = interface(d, ng, ior);
                let n = side.normal;
                let ns = shading(n);
                let refracted = refract(d, ns, side.eta);
                let c = match (refracted, ratio) {
                    (None, _) => 1.0,
                    (Some(_), ReflectRatio::Fixed(c)) => c,
                    (Some(_), ReflectRatio::Fresnel) => fresnel(-d.dot(ns), side.eta),
                };
                if c > 0.0 {
                    next.push(
                        offset_ray_origin(x, err, n),
                        reflect(d, ns),
                        slot,
                        w * c,
                        depth,
                        hash(&[key, 1]),
                        sample,
                    );
                }
                if let Some(t) = refracted {
                    if c < 1.0 {
                        next.push(
                            offset_ray_origin(x, err, -n),
                            t,
                            slot,
                            w * tint * (1.0 - c),
                            depth,
                            hash(&[key, 2]),
                            sample,
                        );
                    }
                }
            }
            Material::Diffuse { .. } => debug_assert!(false, "diffuse hit in the specular list"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interface_flips_normal_and_eta_inside() {
        let ng = Vec3::Y;
        let outside = interface(Vec3::new(0.0, -1.0, 0.0), ng, 1.5);
        assert!(outside.entering && outside.normal == Vec3::Y && (outside.eta - 1.0 / 1.5).abs() < 1e-7);
        let inside = interface(Vec3::new(0.0, 1.0, 0.0), ng, 1.5);
        assert!(!inside.entering && inside.normal == Vec3::NEG_Y && inside.eta == 1.5);
    }

    #[test]
    fn snell_law_holds_and_tir_beyond_critical_angle() {
        let n = Vec3::Y;
        for deg in [0.0f32, 10.0, 30.0, 60.0, 85.0] {
            let th = deg.to_radians();
            let d = Vec3::new(th.sin(), -th.cos(), 0.0);
            let t = refract(d, n, 1.0 / 1.5).unwrap();
            assert!((th.sin() - 1.5 * t.x).abs() < 1e-6, "snell at {deg}");
            assert!(t.y < 0.0);
        }
        // From glass (eta 1.5) the critical angle is asin(1/1.5) = 41.81°.
        let crit = (1.0f32 / 1.5).asin();
        let below = crit - 1e-3;
        assert!(refract(Vec3::new(below.sin(), -below.cos(), 0.0), n, 1.5).is_some());
        let beyond = crit + 1e-3;
        assert!(refract(Vec3::new(beyond.sin(), -beyond.cos(), 0.0), n, 1.5).is_none());
        assert_eq!(fresnel(beyond.cos(), 1.5), 1.0);
    }

    #[test]
    fn fresnel_known_values() {
        // Normal incidence on glass: ((1.5 - 1) / (1.5 + 1))^2 = 0.04.
        assert!((fresnel(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
        // Same from inside.
        assert!((fresnel(1.0, 1.5) - 0.04).abs() < 1e-6);
        // Matched media reflect nothing.
        assert!(fresnel(0.3, 1.0).abs() < 1e-6);
        // Grazing incidence reflects everything.
        assert!(fresnel(0.0, 1.0 / 1.5) > 0.999);
    }

    #[test]
    fn ior_one_leaves_direction_unchanged() {
        let d = Vec3::new(0.3, -0.8, 0.1).normalize();
        let t = refract(d, Vec3::Y, 1.0).unwrap();
        assert!(t.abs_diff_eq(d, 1e-6), "{t} vs {d}");
    }
}
