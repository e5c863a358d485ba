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
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;

use super::bvh2::{subtree, STACK_DEPTH};
use super::packet::Columns;
use super::shapes::{gamma, Shape};
use super::{inv_dir_lanes, lanes_of, nearer, slab, Accel, Ray, SlabRay, Traversal, WIDEN};
use crate::motion::Motion;
use crate::simd::LANES;
use wide::f32x16;

/// One moving object.
pub struct Instance {
    /// Its motion, object space to world.
    pub motion: Motion,
    /// Its primitives in object space (ids local to it).
    pub accel: Accel,
    /// The world box it sweeps over the shutter ([`Motion::bound`] of its tree's box).
    /// (Boxes per quarter of the shutter, Embree's multi-segment motion blur, were
    /// measured not to pay: docs/performance.md.)
    pub bounds: (Vec3, Vec3),
    /// The id its first primitive has in the scene (after every static primitive and the
    /// objects before it).
    pub first: u32,
}

/// The moving objects of a scene, in id order, with a binary tree over the boxes they
/// sweep when there are more than a few.
pub struct Moving {
    /// The objects.
    pub instances: Vec<Instance>,
    /// The shutter their boxes cover.
    shutter: [f32; 2],
    /// obvhs's PLOC tree over the objects' swept boxes (one object per leaf); `None` for
    /// a few objects (tested one by one) or a tree too deep for the walk's stack.
    top: Option<Bvh2>,
    /// Primitives of every object, counted once: [`Accel::len`](super::Accel::len) and
    /// every moving-or-not test per shaded point subtract it.
    prims: usize,
    /// Its key in the threads' pose memos ([`Moving::with_pose`]).
    serial: u64,
}

/// Objects up to which a ray tests every swept box instead of walking a tree over them.
const SCAN: usize = 4;

/// An object's transform at one time and its inverse: [`Motion::at`] and
/// `DAffine3::inverse` of it, bit for bit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Object space to world.
    pub to_world: DAffine3,
    /// World to object space.
    pub to_object: DAffine3,
}

/// Slots of a thread's pose memo ([`Moving::with_pose`]): four lane groups.
const POSES: usize = 64;

/// A memo slot: the [`Moving`]'s serial (0 for none), the object, the time's bits, the
/// pose then.
type PoseSlot = (u64, u32, u32, Pose);

thread_local! {
    /// The poses this thread computed last. A moving hit asks for its object's pose at
    /// its path's time four or five times (the intersect stage, the shape, its error
    /// bound, the shading normal, its shadow rays), each a slerp's two f64 sines and a
    /// 3×3 inverse; kept here they are computed once.
    static POSE_MEMO: std::cell::RefCell<[PoseSlot; POSES]> = const {
        std::cell::RefCell::new([(0, 0, 0, Pose { to_world: DAffine3::IDENTITY, to_object: DAffine3::IDENTITY }); POSES])
    };
}

/// Serials of [`Moving`] sets, one each, so a memo never answers for another scene's.
static SERIAL: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

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

/// `ray` taken into the space of an object by `inv`, the inverse of its world transform
/// ([`Pose::to_object`]).
#[inline]
pub fn object_ray(inv: &DAffine3, ray: &Ray) -> ObjectRay {
    let o = inv.transform_point3(ray.origin.as_dvec3());
    let d = inv.transform_vector3(ray.dir.as_dvec3());
    let len = d.length();
    ObjectRay { o: o.as_vec3(), d: (d / len).as_vec3(), scale: len as f32 }
}

impl Instance {
    /// An object moving from `motion` over `shutter`, its primitives `accel` in object
    /// space, its first primitive's scene id `first`.
    pub fn new(motion: Motion, accel: Accel, first: u32, shutter: [f32; 2]) -> Instance {
        let (lo, hi) = accel.bounds();
        Instance { bounds: motion.bound(lo, hi, shutter), motion, accel, first }
    }

    /// May `ray` meet the object (its swept box) before `tmax`?
    #[inline]
    fn may_hit(&self, ray: &SlabRay, tmax: f32) -> bool {
        let (lo, hi) = self.bounds;
        let near = slab(&Aabb::new(lo.into(), hi.into()), ray);
        near.is_finite() && near <= tmax
    }

    /// [`Instance::may_hit`] for 16 rays (origins `o`, reciprocal directions `inv`,
    /// limits `tmax`), with its arithmetic: the lanes (a bit mask) that may meet it.
    #[inline(always)]
    fn may_hit_lanes(&self, o: &[f32x16; 3], inv: &[f32x16; 3], tmax: f32x16) -> u32 {
        let (lo, hi) = self.bounds;
        let (mut near, mut far) = (f32x16::splat(f32::NEG_INFINITY), f32x16::splat(f32::INFINITY));
        for j in 0..3 {
            let t1 = (f32x16::splat(lo[j]) - o[j]) * inv[j];
            let t2 = (f32x16::splat(hi[j]) - o[j]) * inv[j];
            near = near.fast_max(t1.fast_min(t2));
            far = far.fast_min(t1.fast_max(t2));
        }
        let far = far * f32x16::splat(WIDEN);
        (far.simd_ge(near) & far.simd_ge(f32x16::splat(0.0)) & near.is_finite() & near.simd_le(tmax)).to_bitmask()
    }
}

impl Moving {
    /// The moving objects, with the tree over them when there are more than [`SCAN`].
    pub fn new(instances: Vec<Instance>, shutter: [f32; 2]) -> Moving {
        let top = (instances.len() > SCAN).then(|| {
            let boxes: Vec<Aabb> = instances.iter().map(|i| Aabb::new(i.bounds.0.into(), i.bounds.1.into())).collect();
            let params = obvhs::BvhBuildParams::medium_build();
            obvhs::ploc::PlocBuilder::with_capacity(boxes.len()).build(
                params.ploc_search_distance,
                &boxes,
                (0..boxes.len() as u32).collect(),
                params.sort_precision,
                params.search_depth_threshold,
            )
        });
        let top = top.filter(|t| !t.nodes[0].is_leaf() && t.depth(0) < STACK_DEPTH);
        let prims = instances.iter().map(|i| i.accel.len()).sum();
        let serial = SERIAL.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Moving { instances, shutter, top, prims, serial }
    }

    /// `time` moved into the shutter, where the swept boxes hold the objects: rays
    /// without a time (a queue that never drew one reads 0) see them at the nearest
    /// shutter time. Every query takes its time through here.
    #[inline]
    pub fn clamp(&self, time: f32) -> f32 {
        time.clamp(self.shutter[0], self.shutter[1])
    }

    /// Calls `visit` with each object (its index and itself) whose swept box `ray` may
    /// enter before its `tmax` (which `visit` may lower, to `f32::INFINITY`'s next float
    /// down at most), nearer subtrees first, until `visit` returns false.
    #[inline]
    fn candidates<const COUNT: bool>(
        &self,
        ray: SlabRay,
        c: &mut Traversal,
        mut visit: impl FnMut(usize, &Instance, &mut SlabRay, &mut Traversal) -> bool,
    ) {
        let Some(top) = &self.top else {
            let mut ray = ray;
            for (k, inst) in self.instances.iter().enumerate() {
                if inst.may_hit(&ray, ray.tmax) && !visit(k, inst, &mut ray, c) {
                    return;
                }
            }
            return;
        };
        let root = top.nodes[0].aabb();
        if !slab(root, &ray).is_finite() {
            return;
        }
        subtree::<COUNT>(&top.nodes, top.nodes[0].first_index as usize, 0.0, ray, c, |r, range, c| {
            for k in range {
                let k = top.primitive_indices[k] as usize;
                let inst = &self.instances[k];
                if inst.may_hit(r, r.tmax) && !visit(k, inst, r, c) {
                    return false;
                }
            }
            true
        });
    }

    /// Every object's candidates in a queue's rays (origins and directions as its
    /// `rays` columns): `lists[k]` (one list per object, each cleared first) gets, in
    /// index order, every ray `i` that may enter object k's swept box before `limit(i)`
    /// (`None` skips it), the objects [`Moving::closest`] would take the ray into. The tracer then
    /// traces each object's candidates together ([`Tracer`](super::tracer::Tracer)).
    /// With a few objects ([`SCAN`]) 16 rays are tested at a time on lanes
    /// ([`Instance::may_hit_lanes`]).
    pub fn gather_queue<const COUNT: bool>(
        &self,
        rays: Columns<'_>,
        limit: impl Fn(usize) -> Option<f32>,
        lists: &mut Vec<Vec<u32>>,
        c: &mut Traversal,
    ) {
        let Columns([ox, oy, oz, dx, dy, dz]) = rays;
        let n = ox.len();
        lists.resize_with(self.instances.len(), Vec::new);
        lists.iter_mut().for_each(Vec::clear);
        if self.top.is_some() {
            for i in 0..n {
                if let Some(tmax) = limit(i) {
                    let o = Vec3::new(ox[i], oy[i], oz[i]);
                    let mut r = Ray::infinite(o, Vec3::new(dx[i], dy[i], dz[i])).slab();
                    r.tmax = tmax;
                    self.candidates::<COUNT>(r, c, |k, _, _, _| {
                        lists[k].push(i as u32);
                        true
                    });
                }
            }
            return;
        }
        for base in (0..n).step_by(LANES) {
            // Limit per lane; lanes skipped or past the queue fail.
            let (mut tmax, mut used) = ([0.0f32; LANES], 0u32);
            for (l, t) in tmax.iter_mut().enumerate().take(n - base) {
                if let Some(limit) = limit(base + l) {
                    *t = limit;
                    used |= 1 << l;
                }
            }
            if used == 0 {
                continue;
            }
            // Straight from the queue's columns: a whole group is one load per column.
            let column = |v: &[f32]| match <[f32; LANES]>::try_from(&v[base..(base + LANES).min(n)]) {
                Ok(a) => f32x16::from(a),
                Err(_) => {
                    let mut a = [0.0f32; LANES];
                    a[..n - base].copy_from_slice(&v[base..]);
                    f32x16::from(a)
                }
            };
            let o = [column(ox), column(oy), column(oz)];
            let inv = [column(dx), column(dy), column(dz)].map(inv_dir_lanes);
            let tmax = f32x16::from(tmax);
            for (k, inst) in self.instances.iter().enumerate() {
                let hit = inst.may_hit_lanes(&o, &inv, tmax);
                lanes_of(hit & used).for_each(|l| lists[k].push((base + l) as u32));
            }
        }
    }

    /// Primitives of every moving object.
    pub fn len(&self) -> usize {
        self.prims
    }

    /// True when there is no moving primitive.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The object of primitive `id` (a scene id of a moving primitive): its index, itself
    /// and the primitive's local id.
    #[inline]
    pub fn instance(&self, id: u32) -> (usize, &Instance, u32) {
        let k = self.instances.partition_point(|i| i.first <= id) - 1;
        let inst = &self.instances[k];
        (k, inst, id - inst.first)
    }

    /// `f` of object `k`'s pose at `time` (in the shutter: [`Moving::clamp`]), read in
    /// place from this thread's memo when it computed it last (the same bits either way:
    /// a pure function of the object and the time). What a caller needs of the pose is
    /// computed where the memo keeps it: a 192-byte pose copied out and read back at once
    /// waited on its own stores (a fifth of the shadow rays' moving-object time under
    /// `perf`).
    #[inline]
    pub fn with_pose<R>(&self, k: usize, time: f32, f: impl FnOnce(&Pose) -> R) -> R {
        let bits = time.to_bits();
        let slot = (bits ^ (bits >> 13) ^ (k as u32).wrapping_mul(0x9e37_79b9)) as usize % POSES;
        POSE_MEMO.with(|memo| {
            let mut memo = memo.borrow_mut();
            let s = &mut memo[slot];
            if (s.0, s.1, s.2) != (self.serial, k as u32, bits) {
                let to_world = self.instances[k].motion.at(time);
                *s = (self.serial, k as u32, bits, Pose { to_world, to_object: to_world.inverse() });
            }
            f(&s.3)
        })
    }

    /// `f` of the pose of primitive `id`'s object at `time` (clamped into the shutter).
    #[inline]
    fn with_pose_of<R>(&self, id: u32, time: f32, f: impl FnOnce(&Pose) -> R) -> R {
        self.with_pose(self.instance(id).0, self.clamp(time), f)
    }

    /// Lowers `best` (`(t, id)`, `(∞, u32::MAX)` for none) to the closest hit of `ray` at
    /// `time` on a moving object, by the tie rule: one ray alone, the reference the
    /// tracer's queues (which trace each object's candidates together) are tested against.
    #[inline]
    pub fn closest<const COUNT: bool>(&self, ray: Ray, time: f32, best: &mut (f32, u32), c: &mut Traversal) {
        let time = self.clamp(time);
        // A hit exactly as far as `best` may still win the tie: boxes are tested a step
        // past it.
        let mut search = ray.slab();
        search.tmax = best.0.min(ray.tmax).next_up();
        self.candidates::<COUNT>(search, c, |k, inst, r, c| {
            let local = self.with_pose(k, time, |p| object_ray(&p.to_object, &ray));
            // The object's distances, a little past the world limit so rounding loses no
            // tie; the world distances decide.
            let tmax = (best.0.min(ray.tmax) * local.scale) * (1.0 + 4.0 * f32::EPSILON);
            let obj = Ray::new(local.o, local.d, ray.tmin * local.scale, tmax);
            if let Some((t, id)) = inst.accel.closest::<COUNT>(obj, c) {
                let t = t / local.scale;
                let id = inst.first + id;
                if t > ray.tmin && t < ray.tmax && nearer(t, id, *best) {
                    *best = (t, id);
                    r.tmax = t.next_up();
                }
            }
            true
        });
    }

    /// True when a moving object blocks the shadow segment `ray` at `time`: one ray alone,
    /// as [`Moving::closest`].
    #[inline]
    pub fn occluded<const COUNT: bool>(&self, ray: Ray, time: f32, c: &mut Traversal) -> bool {
        let time = self.clamp(time);
        let mut blocked = false;
        self.candidates::<COUNT>(ray.slab(), c, |k, inst, _, c| {
            let local = self.with_pose(k, time, |p| object_ray(&p.to_object, &ray));
            let obj = Ray::new(local.o, local.d, ray.tmin * local.scale, ray.tmax * local.scale);
            blocked = inst.accel.occluded::<COUNT>(obj, c);
            !blocked
        });
        blocked
    }

    /// Primitive `id`'s shape in the world at `time`: its object-space shape under the
    /// transform then, computed in f64 and rounded once, so every ray and shading point
    /// at that time sees the same bits. A sphere's radius scales by the cube root of the
    /// determinant (its motion is a uniform scale times a rotation at both ends).
    #[inline]
    pub fn shape_at(&self, id: u32, time: f32) -> Shape {
        let (k, inst, local) = self.instance(id);
        let shape = inst.accel.prim(local).shape;
        self.with_pose(k, self.clamp(time), |pose| {
            let m = &pose.to_world;
            let p = |v: Vec3| m.transform_point3(v.as_dvec3()).as_vec3();
            let v = |v: Vec3| m.transform_vector3(v.as_dvec3()).as_vec3();
            match shape {
                Shape::Triangle { v0, v1, v2 } => Shape::Triangle { v0: p(v0), v1: p(v1), v2: p(v2) },
                Shape::Quad { corner, u, v: e } => Shape::Quad { corner: p(corner), u: v(u), v: v(e) },
                Shape::Sphere { center, radius } => Shape::Sphere {
                    center: p(center),
                    radius: (radius as f64 * m.matrix3.determinant().abs().cbrt()) as f32,
                },
            }
        })
    }

    /// What a point `x` of primitive `id` at `time` adds to its rounding error bound:
    /// the object-space point a ray from near it is taken back to rounds by a step of its
    /// own size (`γ₂` of |L|·|p| in the world, L the linear part), and the moved shape's
    /// vertices by a step of theirs.
    #[inline]
    pub fn extra_error(&self, id: u32, time: f32, x: Vec3) -> Vec3 {
        self.with_pose_of(id, time, |pose| {
            let m = &pose.to_world;
            let p = pose.to_object.transform_point3(x.as_dvec3()).abs();
            let l = m.matrix3;
            let lp = DVec3::new(l.row(0).abs().dot(p), l.row(1).abs().dot(p), l.row(2).abs().dot(p));
            ((lp + x.as_dvec3().abs() + m.translation.abs()) * gamma(4) as f64).as_vec3()
        })
    }

    /// `n`, a normal of primitive `id` in object space, in the world at `time`
    /// (the inverse transpose), not normalised.
    #[inline]
    pub fn normal_at(&self, id: u32, time: f32, n: Vec3) -> Vec3 {
        // The inverse's linear part is the linear part's inverse (glam's affine inverse).
        self.with_pose_of(id, time, |pose| (pose.to_object.matrix3.transpose() * n.as_dvec3()).as_vec3())
    }

    /// World point `x` of primitive `id` at `time` in the object's own space (where
    /// texture coordinates are defined).
    #[inline]
    pub fn to_object(&self, id: u32, time: f32, x: Vec3) -> Vec3 {
        self.with_pose_of(id, time, |pose| pose.to_object.transform_point3(x.as_dvec3()).as_vec3())
    }

    /// Primitive `id`'s shape in its object's space.
    #[inline]
    pub fn object_shape(&self, id: u32) -> Shape {
        let (_, inst, local) = self.instance(id);
        inst.accel.prim(local).shape
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{Primitive, NO_LIGHT};
    use glam::{DMat4, DQuat};

    /// Forty small moving spheres, object `k` with id `k`.
    fn objects() -> Vec<Instance> {
        let mut seed = 7u32;
        let mut next = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f64 / (1u32 << 24) as f64
        };
        (0..40)
            .map(|k| {
                let p = DVec3::new(next() * 8.0 - 4.0, next() * 8.0 - 4.0, next() * 8.0 - 4.0);
                let d = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 2.0;
                let turn = DQuat::from_axis_angle(DVec3::Y, next() * 2.0);
                let motion =
                    Motion::new(DMat4::from_translation(p), DMat4::from_rotation_translation(turn, p + d)).unwrap();
                let shape = Shape::Sphere { center: Vec3::new(0.3, 0.0, 0.0), radius: 0.2 + 0.3 * next() as f32 };
                let accel = Accel::build(vec![Primitive { shape, material: 0, light: NO_LIGHT }]);
                Instance::new(motion, accel, k, [0.0, 1.0])
            })
            .collect()
    }

    /// A pose from the thread's memo is the motion's transform and its inverse bit for
    /// bit, whichever scene or object asked for that slot before: two scenes whose
    /// objects move differently asked in turn at the same times, more times than the
    /// memo has slots, and the same times again.
    #[test]
    fn poses_from_the_memo_are_the_motions_own() {
        let a = Moving::new(objects(), [0.0, 1.0]);
        let b = Moving::new(objects().into_iter().rev().collect(), [0.0, 1.0]);
        let times: Vec<f32> =
            (0..3 * POSES as u32).map(|i| (i % 100) as f32 / 99.0 + (i / 100) as f32 * 1e-3).collect();
        for round in 0..2 {
            for &time in &times {
                for (m, name) in [(&a, "a"), (&b, "b")] {
                    for k in [0, 1, 39] {
                        let want = m.instances[k].motion.at(time);
                        let got = m.with_pose(k, time, |p| *p);
                        assert!(
                            got.to_world == want && got.to_object == want.inverse(),
                            "round {round}, scene {name}, object {k}, time {time}"
                        );
                    }
                }
            }
        }
        assert!(a.instances[0].motion.at(0.5) != b.instances[0].motion.at(0.5), "the scenes' objects differ");
    }

    #[test]
    fn the_tree_over_moving_objects_finds_what_testing_each_one_finds() {
        let tree = Moving::new(objects(), [0.0, 1.0]);
        assert!(tree.top.is_some(), "40 objects get a tree");
        let each = Moving { top: None, ..Moving::new(objects(), [0.0, 1.0]) };
        let mut c = Traversal::default();
        let (mut hits, mut blocked) = (0, 0);
        for i in 0..4000u32 {
            let f = |k: u32| ((i.wrapping_mul(2_654_435_761) ^ k.wrapping_mul(40_503)) % 10_000) as f32 / 10_000.0;
            let o = Vec3::new(f(1) * 12.0 - 6.0, f(2) * 12.0 - 6.0, 7.0);
            let d = (Vec3::new(f(3) * 8.0 - 4.0, f(4) * 8.0 - 4.0, 0.0) - o).normalize();
            let time = f(5);
            let (mut a, mut b) = ((f32::INFINITY, u32::MAX), (f32::INFINITY, u32::MAX));
            tree.closest::<false>(Ray::infinite(o, d), time, &mut a, &mut c);
            each.closest::<false>(Ray::infinite(o, d), time, &mut b, &mut c);
            assert_eq!(a, b, "ray {i}");
            hits += (a.1 != u32::MAX) as u32;
            let segment = Ray::new(o, d, 0.0, 3.0 + f(6) * 6.0);
            let blocks = tree.occluded::<false>(segment, time, &mut c);
            assert_eq!(blocks, each.occluded::<false>(segment, time, &mut c), "shadow ray {i}");
            blocked += blocks as u32;
        }
        assert!(hits > 400 && blocked > 100, "too few hits to compare: {hits}, {blocked}");
    }

    /// A queue's candidates, tested 16 rays at a time on lanes (a few objects) or through
    /// the tree (many), are exactly the objects each ray's own search visits, in index
    /// order, skipped rays left out; rays along the axes and through the boxes' faces
    /// included.
    #[test]
    fn a_queues_candidates_are_each_rays_own() {
        for few in [3usize, 40] {
            let m = Moving::new(objects().into_iter().take(few).collect(), [0.0, 1.0]);
            assert_eq!(m.top.is_some(), few > SCAN);
            let mut rays = Vec::new();
            for i in 0..3001u32 {
                let f = |k: u32| ((i.wrapping_mul(2_654_435_761) ^ k.wrapping_mul(40_503)) % 10_000) as f32 / 10_000.0;
                let o = Vec3::new(f(1) * 12.0 - 6.0, f(2) * 12.0 - 6.0, 7.0);
                let d = match i % 7 {
                    0 => Vec3::NEG_Z,
                    1 => Vec3::new(1.0, 0.0, 0.0),
                    // Half the rest at an object's box.
                    k if k % 2 == 0 => {
                        let (lo, hi) = m.instances[i as usize % few].bounds;
                        (lo + (hi - lo) * Vec3::new(f(3), f(4), 0.5) - o).normalize()
                    }
                    _ => (Vec3::new(f(3) * 8.0 - 4.0, f(4) * 8.0 - 4.0, 0.0) - o).normalize(),
                };
                // A face's plane as the origin: a slab distance of exactly 0.
                let o = if i % 11 == 0 { Vec3::new(m.instances[0].bounds.0.x, o.y, o.z) } else { o };
                let tmax = if i % 5 == 0 { f32::INFINITY } else { f(6) * 12.0 };
                rays.push((i % 13 != 0).then_some((o, d, tmax)));
            }
            let mut c = Traversal::default();
            let mut lists = vec![vec![7u32]; 2];
            // A skipped ray's origin and direction are in the columns all the same.
            let at = |i: usize, f: fn((Vec3, Vec3, f32)) -> f32| rays[i].map_or(1.0, f);
            let column = |f: fn((Vec3, Vec3, f32)) -> f32| (0..rays.len()).map(|i| at(i, f)).collect::<Vec<f32>>();
            let cols = [
                column(|r| r.0.x),
                column(|r| r.0.y),
                column(|r| r.0.z),
                column(|r| r.1.x),
                column(|r| r.1.y),
                column(|r| r.1.z),
            ];
            let cols = Columns([&cols[0][..], &cols[1], &cols[2], &cols[3], &cols[4], &cols[5]]);
            m.gather_queue::<false>(cols, |i| rays[i].map(|r| r.2), &mut lists, &mut c);
            let mut want = vec![Vec::new(); few];
            for (i, r) in rays.iter().enumerate() {
                if let Some((o, d, tmax)) = *r {
                    let mut ray = Ray::infinite(o, d).slab();
                    ray.tmax = tmax;
                    m.candidates::<false>(ray, &mut c, |k, _, _, _| {
                        want[k].push(i as u32);
                        true
                    });
                }
            }
            let found: usize = want.iter().map(Vec::len).sum();
            assert!(found > 500, "{few} objects: too few candidates to compare: {found}");
            assert_eq!(lists, want, "{few} objects");
        }
    }
}
