//! Shapes (sphere, triangle, parallelogram) and scalar ray intersection.
//!
//! Every test returns the distance `t` of the nearest hit in the open interval
//! `(tmin, tmax)`, or `f32::INFINITY` for a miss, so a caller keeps the minimum.

use glam::Vec3;
use obvhs::aabb::Aabb;

use crate::simd::{Real, V3};

/// Light index of a primitive that is not an emitter.
pub const NO_LIGHT: u32 = u32::MAX;

/// A geometric shape in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// A sphere; the normal points outwards.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius (> 0).
        radius: f32,
    },
    /// A triangle; the normal is `(v1 - v0) × (v2 - v0)` (counter-clockwise front).
    /// Vertices are stored as given, never rebuilt from edges, so triangles that share
    /// an edge test exactly the same edge (watertightness depends on it).
    Triangle {
        /// First vertex.
        v0: Vec3,
        /// Second vertex.
        v1: Vec3,
        /// Third vertex.
        v2: Vec3,
    },
    /// A parallelogram `corner + a·u + b·v`, a, b in [0,1]; the normal is `u × v`.
    Quad {
        /// One corner.
        corner: Vec3,
        /// First edge.
        u: Vec3,
        /// Second edge.
        v: Vec3,
    },
}

/// A shape with what it is made of.
#[derive(Clone, Copy, Debug)]
pub struct Primitive {
    /// The shape.
    pub shape: Shape,
    /// Index into the scene's materials (unused for emitters).
    pub material: u32,
    /// Index into the scene's lights when this primitive is an area light, else [`NO_LIGHT`].
    pub light: u32,
}

impl Shape {
    /// Distance to the nearest hit in `(tmin, tmax)`, or infinity.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> f32 {
        let t = match *self {
            Shape::Sphere { center, radius } => intersect_sphere(center, radius, o, d, tmin, tmax),
            Shape::Triangle { v0, v1, v2 } => intersect_triangle(v0, v1, v2, o, d),
            Shape::Quad { corner, u, v } => intersect_quad(corner, u, v, o, d),
        };
        if t > tmin && t < tmax {
            t
        } else {
            f32::INFINITY
        }
    }

    /// Unnormalised geometric normal at point `p` on the shape (outward for spheres).
    #[inline]
    pub fn normal(&self, p: Vec3) -> Vec3 {
        match *self {
            Shape::Sphere { center, .. } => p - center,
            Shape::Triangle { v0, v1, v2 } => (v1 - v0).cross(v2 - v0),
            Shape::Quad { u, v, .. } => u.cross(v),
        }
    }

    /// The hit point of the ray `o + t·d`, recomputed on the surface from the shape's own
    /// data (so its error no longer depends on the ray origin), and a per-component bound on
    /// its absolute rounding error (PBRT's γ bounds).
    #[inline]
    pub fn surface_point(&self, o: Vec3, d: Vec3, t: f32) -> (Vec3, Vec3) {
        let x = V3::from_vec(o + t * d);
        let (p, err) = match *self {
            Shape::Sphere { center, radius } => sphere_point(V3::from_vec(center), radius, x),
            Shape::Quad { corner, u, v } => quad_point(V3::from_vec(corner), V3::from_vec(u), V3::from_vec(v), x),
            Shape::Triangle { v0, v1, v2 } => triangle_point(V3::from_vec(v0), V3::from_vec(v1), V3::from_vec(v2), x),
        };
        (p.vec(), err.vec())
    }

    /// Axis-aligned bounds.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match *self {
            Shape::Sphere { center, radius } => (center - Vec3::splat(radius), center + Vec3::splat(radius)),
            Shape::Triangle { v0, v1, v2 } => (v0.min(v1).min(v2), v0.max(v1).max(v2)),
            Shape::Quad { corner, u, v } => {
                let pts = [corner, corner + u, corner + v, corner + u + v];
                let lo = pts.iter().fold(Vec3::splat(f32::INFINITY), |a, &p| a.min(p));
                let hi = pts.iter().fold(Vec3::splat(f32::NEG_INFINITY), |a, &p| a.max(p));
                (lo, hi)
            }
        }
    }
}

impl obvhs::Boundable for Primitive {
    fn aabb(&self) -> Aabb {
        let (lo, hi) = self.shape.bounds();
        Aabb::new(lo.into(), hi.into())
    }
}

/// Ray–sphere intersection with the numerically careful discriminant of Haines et al.,
/// "Precision Improvements for Ray/Sphere Intersection" (Ray Tracing Gems, 2019):
/// `r² - |f - (f·d)d|²` keeps its precision for distant spheres where `b² - c` cancels.
/// `d` must be unit length.
#[inline]
pub fn intersect_sphere(center: Vec3, radius: f32, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> f32 {
    let f = o - center;
    let b = -f.dot(d);
    let l = f + b * d;
    let r2 = radius * radius;
    let disc = r2 - l.length_squared();
    if disc < 0.0 {
        return f32::INFINITY;
    }
    let c = f.length_squared() - r2;
    let q = b + b.signum() * disc.sqrt();
    // q = 0 only when b = 0 and disc = 0: a tangent ray from the sphere's centre plane.
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (c / q, q) };
    let (near, far) = if t0 < t1 { (t0, t1) } else { (t1, t0) };
    if near > tmin && near < tmax {
        near
    } else if far > tmin && far < tmax {
        far
    } else {
        f32::INFINITY
    }
}

/// The watertight triangle test's frame for direction `d`: `kz` the axis of largest |d|
/// (x over y over z on ties, as the comparisons below decide), `kx`, `ky` the next two
/// cyclically. Shared by every kernel so all shear exactly alike. Woop et al. swap `kx`
/// and `ky` when `d[kz] < 0` to keep the winding; the swap only negates the three edge
/// functions, their sum and the distance's numerator, each exactly (IEEE subtraction and
/// rounding are symmetric), so the distance and every test on it come out the same, bit
/// for bit, and hits from both sides count: it is left out, and with it a per-ray select.
#[inline(always)]
pub(crate) fn shear_axes(d: Vec3) -> [usize; 3] {
    // Arithmetic, not branches: on incoherent rays the dominant axis changes from one ray
    // to the next.
    let ad = d.abs();
    let (xy, xz, yz) = (ad.x > ad.y, ad.x > ad.z, ad.y > ad.z);
    let kz = 2 - 2 * (xy & xz) as usize - (!xy & yz) as usize;
    [(kz + 1) % 3, (kz + 2) % 3, kz]
}

/// Watertight ray–triangle intersection (Woop, Benthin and Wald, "Watertight
/// Ray/Triangle Intersection", JCGT 2013). The ray is sheared so it points along +z and
/// the edge functions are evaluated in 2D; a point exactly on an edge is claimed by both
/// triangles sharing it (ties at zero recompute in f64), so rays through shared edges and
/// vertices of a closed mesh never slip through. Hits from both sides count. A distance
/// within its rounding error of zero ([`triangle_t_error`]) is no hit: only distances
/// conservatively greater than 0 are returned.
#[inline]
pub fn intersect_triangle(v0: Vec3, v1: Vec3, v2: Vec3, o: Vec3, d: Vec3) -> f32 {
    let [kx, ky, kz] = shear_axes(d);
    let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    let (a, b, c) = (v0 - o, v1 - o, v2 - o);
    let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
    let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
    let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let (ax, ay, bx, by, cx, cy) = (ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64);
        u = (cx * by - cy * bx) as f32;
        v = (ax * cy - ay * cx) as f32;
        w = (bx * ay - by * ax) as f32;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return f32::INFINITY;
    }
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() {
        return f32::INFINITY;
    }
    let t = (u * sz * a[kz] + v * sz * b[kz] + w * sz * c[kz]) / det;
    // The bound only for a distance it can reject (its lane versions test every lane).
    if !(t > 0.0 && t.is_finite()) {
        return f32::INFINITY;
    }
    if t > triangle_t_error([ax, bx, cx], [ay, by, cy], [a[kz], b[kz], c[kz]], sz, [u, v, w], det) {
        t
    } else {
        f32::INFINITY
    }
}

/// The bound δt on the rounding error of [`intersect_triangle`]'s distance, from its
/// sheared vertices `x`, `y` (relative to the origin), their unsheared `z` (unscaled),
/// the scale `sz = 1 / d[kz]`, the edge functions `e` and their sum `det`: PBRT-v4's
/// (Triangle::Intersect, "ensure that computed triangle t is conservatively greater than
/// zero"; Pharr, Jakob and Humphreys §6.8.7), with the unscaled z in δx and δy, which
/// keeps it a bound for a direction of any length. A computed t ≤ δt may come from an
/// exact t ≤ 0, and so is no hit.
///
/// Ray origins are pushed off a surface by the bound on the hit point's own error
/// ([`offset_ray_origin`](super::offset::offset_ray_origin)), which is 0 across a
/// triangle lying in a plane x = 0 (every vertex's x is 0), so such an origin moves one
/// denormal step while the distance's rounding is about ε times the triangle's size:
/// without this check a 550-unit OBJ wall at x = 0 found itself again at t ≈ 10⁻⁶ on 30%
/// of its shadow rays (tests/irradiance.rs). Written once over lanes: every kernel
/// rejects the same distances, bit for bit.
#[inline(always)]
pub fn triangle_t_error<R: Real>(x: [R; 3], y: [R; 3], z: [R; 3], sz: R, e: [R; 3], det: R) -> R {
    let max = |a: R, b: R| -(-a).min(-b);
    let max_abs = |v: [R; 3]| max(max(v[0].abs(), v[1].abs()), v[2].abs());
    let (max_x, max_y, max_z, max_e) = (max_abs(x), max_abs(y), max_abs(z), max_abs(e));
    let max_zt = max_z * sz.abs();
    let (g2, g3, g5) = (R::splat(gamma(2)), R::splat(gamma(3)), R::splat(gamma(5)));
    let delta_z = g3 * max_zt;
    let (delta_x, delta_y) = (g5 * (max_x + max_z), g5 * (max_y + max_z));
    let delta_e = R::splat(2.0) * (g2 * max_x * max_y + delta_y * max_x + delta_x * max_y);
    R::splat(3.0) * (g3 * max_e * max_zt + delta_e * max_zt + delta_z * max_e) / det.abs()
}

/// γ(n) = nε / (1 − nε), ε = 2⁻²⁴: the relative error bound of n rounded operations.
#[inline]
pub fn gamma(n: u32) -> f32 {
    let e = n as f32 * f32::EPSILON * 0.5;
    e / (1.0 - e)
}

/// [`Shape::surface_point`] of a sphere for the point `x` near it, on lanes.
#[inline(always)]
pub fn sphere_point<R: Real>(center: V3<R>, radius: R, x: V3<R>) -> (V3<R>, V3<R>) {
    let v = x - center;
    let len = v.dot(v).sqrt();
    // A point that rounds onto the centre (a sphere below the hit point's rounding error,
    // found by fuzzing: a far lens camera and a tiny sphere) has no direction from it, and
    // radius / 0 made a NaN point; it goes to the sphere's +z pole instead. Where the
    // length is positive (`-len < 0`) this is the plain projection, bit for bit.
    let (zero, one) = (R::splat(0.0), R::splat(1.0));
    let v = V3 {
        x: R::if_negative(-len, v.x, zero),
        y: R::if_negative(-len, v.y, zero),
        z: R::if_negative(-len, v.z, one),
    };
    let r = v.scale(radius / R::if_negative(-len, len, one));
    let p = center + r;
    (p, p.abs().scale(R::splat(gamma(1))) + r.abs().scale(R::splat(gamma(5))))
}

/// [`Shape::surface_point`] of a parallelogram for the point `x` near it, on lanes.
#[inline(always)]
pub fn quad_point<R: Real>(corner: V3<R>, u: V3<R>, v: V3<R>, x: V3<R>) -> (V3<R>, V3<R>) {
    let n = u.cross(v);
    let w = n.over(n.dot(n));
    let q = x - corner;
    let (a, b) = (w.dot(q.cross(v)), w.dot(u.cross(q)));
    let p = corner + u.scale(a) + v.scale(b);
    (p, (corner.abs() + u.scale(a).abs() + v.scale(b).abs()).scale(R::splat(gamma(3))))
}

/// [`Shape::surface_point`] of a triangle for the point `x` near it, on lanes.
#[inline(always)]
pub fn triangle_point<R: Real>(v0: V3<R>, v1: V3<R>, v2: V3<R>, x: V3<R>) -> (V3<R>, V3<R>) {
    let (e1, e2) = (v1 - v0, v2 - v0);
    let n = e1.cross(e2);
    let w = n.over(n.dot(n));
    let q = x - v0;
    let (b1, b2) = (w.dot(q.cross(e2)), w.dot(e1.cross(q)));
    let b0 = R::splat(1.0) - b1 - b2;
    let p = v0.scale(b0) + v1.scale(b1) + v2.scale(b2);
    (p, (v0.scale(b0).abs() + v1.scale(b1).abs() + v2.scale(b2).abs()).scale(R::splat(gamma(7))))
}

/// Ray–parallelogram intersection. Hits from both sides count.
#[inline]
pub fn intersect_quad(corner: Vec3, u: Vec3, v: Vec3, o: Vec3, d: Vec3) -> f32 {
    let n = u.cross(v);
    let denom = n.dot(d);
    if denom == 0.0 || !denom.is_finite() {
        return f32::INFINITY;
    }
    let t = n.dot(corner - o) / denom;
    let p = o + t * d - corner;
    let w = n / n.length_squared();
    let a = w.dot(p.cross(v));
    let b = w.dot(u.cross(p));
    if (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b) {
        t
    } else {
        f32::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const INF: f32 = f32::INFINITY;

    fn sphere() -> Shape {
        Shape::Sphere { center: Vec3::ZERO, radius: 1.0 }
    }

    #[test]
    fn sphere_hit_from_outside_inside_tangent_and_miss() {
        let s = sphere();
        let t = s.intersect(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z, 0.0, INF);
        assert!((t - 4.0).abs() < 1e-6, "outside: {t}");
        let t = s.intersect(Vec3::ZERO, Vec3::X, 0.0, INF);
        assert!((t - 1.0).abs() < 1e-6, "inside: {t}");
        // Tangent: grazes the sphere at x = 1.
        let t = s.intersect(Vec3::new(1.0, 0.0, 5.0), Vec3::NEG_Z, 0.0, INF);
        assert!((t - 5.0).abs() < 1e-3, "tangent: {t}");
        let t = s.intersect(Vec3::new(1.001, 0.0, 5.0), Vec3::NEG_Z, 0.0, INF);
        assert_eq!(t, INF, "just outside the tangent");
        let t = s.intersect(Vec3::new(0.0, 0.0, 5.0), Vec3::Z, 0.0, INF);
        assert_eq!(t, INF, "pointing away");
        // tmax before the sphere.
        assert_eq!(s.intersect(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z, 0.0, 3.9), INF);
    }

    #[test]
    fn distant_sphere_keeps_precision() {
        // A small sphere far away: the naive b² - c form loses it entirely.
        let s = Shape::Sphere { center: Vec3::new(0.0, 0.0, -1.0e5), radius: 0.01 };
        let t = s.intersect(Vec3::ZERO, Vec3::NEG_Z, 0.0, INF);
        assert!((t - (1.0e5 - 0.01)).abs() < 0.02, "{t}");
    }

    #[test]
    fn triangle_hits_edges_and_misses() {
        let tri = Shape::Triangle { v0: Vec3::ZERO, v1: Vec3::X, v2: Vec3::Y };
        let t = tri.intersect(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, INF);
        assert!((t - 1.0).abs() < 1e-6);
        // From behind.
        let t = tri.intersect(Vec3::new(0.25, 0.25, -2.0), Vec3::Z, 0.0, INF);
        assert!((t - 2.0).abs() < 1e-6);
        // Outside the hypotenuse.
        assert_eq!(tri.intersect(Vec3::new(0.6, 0.6, 1.0), Vec3::NEG_Z, 0.0, INF), INF);
        // Parallel to the plane.
        assert_eq!(tri.intersect(Vec3::new(0.1, 0.1, 0.0), Vec3::X, 0.0, INF), INF);
        // A vertex is inside.
        assert!(tri.intersect(Vec3::new(0.0, 0.0, 1.0), Vec3::NEG_Z, 0.0, INF).is_finite());
    }

    #[test]
    fn shared_edges_and_vertices_of_a_closed_mesh_let_no_ray_through() {
        // An octahedron: rays from inside aimed exactly at vertices and edge midpoints.
        let p = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z].map(|v| v * 1.3 + Vec3::splat(0.1));
        let mut tris = Vec::new();
        for &a in &[0, 1] {
            for &b in &[2, 3] {
                for &c in &[4, 5] {
                    tris.push(Shape::Triangle { v0: p[a], v1: p[b], v2: p[c] });
                }
            }
        }
        let centre = Vec3::splat(0.1) + Vec3::new(0.013, -0.021, 0.007);
        let mut targets: Vec<Vec3> = p.to_vec();
        for i in 0..6 {
            for j in i + 1..6 {
                targets.push((p[i] + p[j]) * 0.5);
            }
        }
        for target in targets {
            let d = (target - centre).normalize();
            let hit = tris.iter().map(|t| t.intersect(centre, d, 0.0, INF)).fold(INF, f32::min);
            assert!(hit.is_finite(), "ray to {target} escaped");
        }
    }

    #[test]
    fn quad_hits_inside_and_misses_outside() {
        let q = Shape::Quad { corner: Vec3::ZERO, u: Vec3::new(2.0, 0.0, 0.0), v: Vec3::new(0.0, 0.0, 1.0) };
        let t = q.intersect(Vec3::new(1.9, 3.0, 0.9), Vec3::NEG_Y, 0.0, INF);
        assert!((t - 3.0).abs() < 1e-6);
        let t = q.intersect(Vec3::new(1.0, -1.0, 0.5), Vec3::Y, 0.0, INF);
        assert!((t - 1.0).abs() < 1e-6, "from below");
        assert_eq!(q.intersect(Vec3::new(2.1, 3.0, 0.5), Vec3::NEG_Y, 0.0, INF), INF);
        assert_eq!(q.intersect(Vec3::new(1.0, 3.0, -0.1), Vec3::NEG_Y, 0.0, INF), INF);
        assert_eq!(q.intersect(Vec3::new(1.0, 3.0, 0.5), Vec3::Y, 0.0, INF), INF, "behind origin");
        assert!(q.normal(Vec3::ZERO).normalize().abs_diff_eq(Vec3::NEG_Y, 1e-6));
    }
}
