//! Diffuse shading points: the surface a ray hit and its BRDF, computed in one place for
//! the shade, shadow-corner and penumbra stages so that they agree bit for bit.

use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

use crate::geometry::offset::offset_ray_origin;
use crate::geometry::{Shape, NO_LIGHT};
use crate::queue::{HitQueue, RayQueue};
use crate::scene::{Material, Scene};

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
    /// Camera sample index of the incoming ray's path.
    pub sample: u32,
}

/// The shading normal at point `x` of primitive `prim`, on the side of the unit geometric
/// normal `n` (the side the ray arrived on): the triangle's vertex normals interpolated by
/// `x`'s barycentric coordinates and normalised (Mitsuba's smooth shading) for a smooth
/// mesh, else `n` itself. Ray origins keep the geometric normal.
#[inline]
pub fn shading_normal(scene: &Scene, prim: usize, x: Vec3, n: Vec3) -> Vec3 {
    let Some(&vn) = scene.normals.get(prim) else { return n };
    let Shape::Triangle { v0, v1, v2 } = scene.accel.prims[prim].shape else { return n };
    if vn[0] == Vec3::ZERO {
        return n;
    }
    let (e1, e2) = (v1 - v0, v2 - v0);
    let c = e1.cross(e2);
    let w = c / c.length_squared();
    let q = x - v0;
    let (b1, b2) = (w.dot(q.cross(e2)), w.dot(e1.cross(q)));
    let ns = ((1.0 - b1 - b2) * vn[0] + b1 * vn[1] + b2 * vn[2]).normalize_or_zero();
    if ns == Vec3::ZERO {
        n
    } else if ns.dot(n) < 0.0 {
        -ns
    } else {
        ns
    }
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
        n: shading_normal(scene, hits.prim[i] as usize, x, n),
        wo: -d,
        color,
        specular,
        shininess,
        w: rays.weight(i),
        slot: rays.slot[i],
        key: rays.key[i],
        sample: rays.sample[i],
    })
}
