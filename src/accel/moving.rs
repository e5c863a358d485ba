//! Moving objects: each one's primitives in its own space with their own tree (an
//! [`Accel`], walked by the same kernels as the static scene), its [`Motion`], and the
//! box it sweeps over the shutter in the world. A ray with a time is taken into an
//! object's space at that time (as pbrt's `AnimatedPrimitive` does), so a rigid motion
//! costs no looser bounds inside the object: only the world box it sweeps grows. The
//! static scene's tree is left as it is.
//!
//! Distances: the object-space ray's direction is normalised (a sphere's test needs unit
//! directions), so an object-space distance is the world one times the direction's
//! length under the inverse transform, converted back before the tie rule ([`nearer`])
//! compares it with the static scene's hits.

use glam::{DAffine3, DVec3, Vec3};

use super::shapes::{gamma, Shape};
use super::{nearer, slab, Accel, Ray, Traversal};
use crate::motion::Motion;

/// One moving object.
pub struct Instance {
    /// Its motion, object space to world.
    pub motion: Motion,
    /// Its primitives in object space (ids local to it).
    pub accel: Accel,
    /// The world box it sweeps over the shutter ([`Motion::bound`] of its tree's box).
    pub bounds: (Vec3, Vec3),
    /// The id its first primitive has in the scene (after every static primitive and the
    /// objects before it).
    pub first: u32,
}

/// The moving objects of a scene, in id order.
pub struct Moving {
    /// The objects.
    pub instances: Vec<Instance>,
}

/// A world ray taken into an object's space at a time: the origin, the unit direction,
/// and the factor that turns world distances into object ones.
#[derive(Clone, Copy, Debug)]
pub struct ObjectRay {
    /// Origin.
    pub o: Vec3,
    /// Unit direction.
    pub d: Vec3,
    /// Object distance per world distance.
    pub scale: f32,
}

/// `ray` taken into the space of the object whose world transform is `m`.
#[inline]
pub fn object_ray(m: &DAffine3, ray: &Ray) -> ObjectRay {
    let inv = m.inverse();
    let o = inv.transform_point3(ray.origin.as_dvec3());
    let d = inv.transform_vector3(ray.dir.as_dvec3());
    let len = d.length();
    ObjectRay { o: o.as_vec3(), d: (d / len).as_vec3(), scale: len as f32 }
}

impl Instance {
    /// The world box test of `ray` against the swept bound: may the ray meet the object
    /// before `tmax`?
    #[inline]
    fn may_hit(&self, ray: &Ray, tmax: f32) -> bool {
        let b = obvhs::aabb::Aabb::new(self.bounds.0.into(), self.bounds.1.into());
        let near = slab(&b, &ray.slab());
        near.is_finite() && near <= tmax
    }
}

impl Moving {
    /// Primitives of every moving object.
    pub fn len(&self) -> usize {
        self.instances.iter().map(|i| i.accel.len()).sum()
    }

    /// True when there is no moving primitive.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The object of primitive `id` (a scene id of a moving primitive) and its local id.
    #[inline]
    pub fn instance(&self, id: u32) -> (&Instance, u32) {
        let k = self.instances.partition_point(|i| i.first <= id) - 1;
        let inst = &self.instances[k];
        (inst, id - inst.first)
    }

    /// Lowers `best` (`(t, id)`, `(∞, u32::MAX)` for none) to the closest hit of `ray` at
    /// `time` on a moving object, by the tie rule.
    #[inline]
    pub fn closest<const COUNT: bool>(&self, ray: Ray, time: f32, best: &mut (f32, u32), c: &mut Traversal) {
        for inst in &self.instances {
            // A hit exactly as far as `best` may still win the tie: look a step past it.
            if !inst.may_hit(&ray, best.0.min(ray.tmax).next_up()) {
                continue;
            }
            let local = object_ray(&inst.motion.at(time), &ray);
            // The object's distances, a little past the world limit so rounding loses no
            // tie; the world distances decide.
            let tmax = (best.0.min(ray.tmax) * local.scale) * (1.0 + 4.0 * f32::EPSILON);
            let r = Ray::new(local.o, local.d, ray.tmin * local.scale, tmax);
            if let Some((t, id)) = inst.accel.closest_wide::<COUNT>(r, c) {
                let t = t / local.scale;
                let id = inst.first + id;
                if t > ray.tmin && t < ray.tmax && nearer(t, id, *best) {
                    *best = (t, id);
                }
            }
        }
    }

    /// True when a moving object blocks the shadow segment `ray` at `time`.
    #[inline]
    pub fn occluded<const COUNT: bool>(&self, ray: Ray, time: f32, c: &mut Traversal) -> bool {
        self.instances.iter().any(|inst| {
            if !inst.may_hit(&ray, ray.tmax) {
                return false;
            }
            let local = object_ray(&inst.motion.at(time), &ray);
            let r = Ray::new(local.o, local.d, ray.tmin * local.scale, ray.tmax * local.scale);
            inst.accel.occluded_wide::<COUNT>(r, c)
        })
    }

    /// Primitive `id`'s shape in the world at `time`: its object-space shape under the
    /// transform then, computed in f64 and rounded once, so every ray and shading point
    /// at that time sees the same bits. A sphere's radius scales by the cube root of the
    /// determinant (its motion is a uniform scale times a rotation at both ends).
    #[inline]
    pub fn shape_at(&self, id: u32, time: f32) -> Shape {
        let (inst, local) = self.instance(id);
        let m = inst.motion.at(time);
        let p = |v: Vec3| m.transform_point3(v.as_dvec3()).as_vec3();
        let v = |v: Vec3| m.transform_vector3(v.as_dvec3()).as_vec3();
        match inst.accel.prim(local).shape {
            Shape::Triangle { v0, v1, v2 } => Shape::Triangle { v0: p(v0), v1: p(v1), v2: p(v2) },
            Shape::Quad { corner, u, v: e } => Shape::Quad { corner: p(corner), u: v(u), v: v(e) },
            Shape::Sphere { center, radius } => Shape::Sphere {
                center: p(center),
                radius: (radius as f64 * m.matrix3.determinant().abs().cbrt()) as f32,
            },
        }
    }

    /// What a point `x` of primitive `id` at `time` adds to its rounding error bound:
    /// the object-space point a ray from near it is taken back to rounds by a step of its
    /// own size (`γ₂` of |L|·|p| in the world, L the linear part), and the moved shape's
    /// vertices by a step of theirs.
    #[inline]
    pub fn extra_error(&self, id: u32, time: f32, x: Vec3) -> Vec3 {
        let (inst, _) = self.instance(id);
        let m = inst.motion.at(time);
        let p = m.inverse().transform_point3(x.as_dvec3()).abs();
        let l = m.matrix3;
        let lp = DVec3::new(l.row(0).abs().dot(p), l.row(1).abs().dot(p), l.row(2).abs().dot(p));
        ((lp + x.as_dvec3().abs() + m.translation.abs()) * gamma(4) as f64).as_vec3()
    }

    /// `n`, a normal of primitive `id` in object space, in the world at `time`
    /// (the inverse transpose), not normalised.
    #[inline]
    pub fn normal_at(&self, id: u32, time: f32, n: Vec3) -> Vec3 {
        let (inst, _) = self.instance(id);
        let m = inst.motion.at(time);
        (m.matrix3.inverse().transpose() * n.as_dvec3()).as_vec3()
    }

    /// World point `x` of primitive `id` at `time` in the object's own space (where
    /// texture coordinates are defined).
    #[inline]
    pub fn to_object(&self, id: u32, time: f32, x: Vec3) -> Vec3 {
        let (inst, _) = self.instance(id);
        inst.motion.at(time).inverse().transform_point3(x.as_dvec3()).as_vec3()
    }

    /// Primitive `id`'s shape in its object's space.
    #[inline]
    pub fn object_shape(&self, id: u32) -> Shape {
        let (inst, local) = self.instance(id);
        inst.accel.prim(local).shape
    }
}
