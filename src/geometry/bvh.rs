//! The acceleration structure: an obvhs `Bvh2` over all primitives, traversed one
//! ray at a time with obvhs's custom-primitive traversal.

use glam::Vec3;
use obvhs::bvh2::Bvh2;
use obvhs::ray::{Ray, RayHit};
use obvhs::BvhBuildParams;
use std::time::{Duration, Instant};

use super::shapes::{Primitive, NO_LIGHT};

/// Primitives reordered to the BVH's leaf order, with the BVH over them.
pub struct Accel {
    /// Primitives, in BVH order: a traversal's primitive id indexes this directly.
    pub prims: Vec<Primitive>,
    bvh: Option<Bvh2>,
    /// Seconds the BVH build took.
    pub build_seconds: f64,
}

impl Accel {
    /// Builds the BVH over `prims` (which may be empty).
    pub fn build(prims: Vec<Primitive>) -> Accel {
        let start = Instant::now();
        if prims.is_empty() {
            return Accel { prims, bvh: None, build_seconds: 0.0 };
        }
        let mut core = Duration::default();
        let bvh = obvhs::bvh2::builder::build_bvh2(&prims, BvhBuildParams::medium_build(), &mut core);
        // Reorder once so traversal needs no primitive_indices indirection.
        let prims: Vec<Primitive> = bvh.primitive_indices.iter().map(|&i| prims[i as usize]).collect();
        Accel { prims, bvh: Some(bvh), build_seconds: start.elapsed().as_secs_f64() }
    }

    /// Closest hit along the ray within `(tmin, tmax)`: `(t, primitive index)`, or `None`.
    #[inline]
    pub fn closest(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, u32)> {
        let bvh = self.bvh.as_ref()?;
        let ray = Ray::new(o.into(), d.into(), tmin, tmax);
        let mut hit = RayHit::none();
        let prims = &self.prims;
        if bvh.ray_traverse(ray, &mut hit, |r, id| {
            prims[id].shape.intersect(r.origin.into(), r.direction.into(), r.tmin, r.tmax)
        }) {
            Some((hit.t, hit.primitive_id))
        } else {
            None
        }
    }

    /// True when some non-emitting primitive blocks the segment `(tmin, tmax)` of the ray.
    /// Stops at the first blocker found. Area lights never block shadow rays.
    #[inline]
    pub fn occluded(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
        let Some(bvh) = self.bvh.as_ref() else { return false };
        let ray = Ray::new(o.into(), d.into(), tmin, tmax);
        let prims = &self.prims;
        !bvh.ray_traverse_miss(ray, |r, id| {
            let p = &prims[id];
            if p.light != NO_LIGHT {
                return f32::INFINITY;
            }
            p.shape.intersect(r.origin.into(), r.direction.into(), r.tmin, r.tmax)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;

    fn sphere(x: f32, light: u32) -> Primitive {
        Primitive { shape: Shape::Sphere { center: Vec3::new(x, 0.0, 0.0), radius: 0.5 }, material: 0, light }
    }

    #[test]
    fn closest_and_occluded_agree_with_brute_force() {
        let prims: Vec<Primitive> = (0..50).map(|i| sphere(i as f32 * 2.0, NO_LIGHT)).collect();
        let accel = Accel::build(prims.clone());
        for i in 0..50 {
            let o = Vec3::new(i as f32 * 2.0 + 0.1, 5.0, 0.05);
            let hit = accel.closest(o, Vec3::NEG_Y, 0.0, f32::INFINITY).expect("hit");
            let brute = prims
                .iter()
                .map(|p| p.shape.intersect(o, Vec3::NEG_Y, 0.0, f32::INFINITY))
                .fold(f32::INFINITY, f32::min);
            assert_eq!(hit.0, brute);
            assert!(accel.occluded(o, Vec3::NEG_Y, 0.0, 10.0));
            assert!(!accel.occluded(o, Vec3::NEG_Y, 0.0, 4.0), "tmax stops before the sphere");
        }
        // Along the row: the first sphere is closest.
        let hit = accel.closest(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, 0.0, f32::INFINITY).unwrap();
        assert!((hit.1 as usize) < accel.prims.len());
        assert!((hit.0 - 4.5).abs() < 1e-5);
    }

    #[test]
    fn lights_do_not_occlude_and_empty_scene_misses() {
        let accel = Accel::build(vec![sphere(0.0, 0)]);
        assert!(accel.closest(Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y, 0.0, f32::INFINITY).is_some());
        assert!(!accel.occluded(Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y, 0.0, 10.0));
        let empty = Accel::build(Vec::new());
        assert!(empty.closest(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY).is_none());
        assert!(!empty.occluded(Vec3::ZERO, Vec3::X, 0.0, 1.0));
    }
}
