//! Moving objects in the tracer's queues: each object's candidates, the rays of a queue
//! that may enter the box it sweeps, are taken into its space at their times and traced
//! together through its tree by the tracer's own kernel, so they ride packets and
//! streams as static rays do.

use glam::Vec3;

use super::super::moving::{object_ray, Moving};
use super::super::packet::Columns;
use super::super::{nearer, Accel, Ray};
use super::{Coherence, Tracer};
use crate::queue::{self, HitQueue, RayQueue, ShadowQueue, MISS};

/// What a tracer keeps between queues to trace moving objects' candidates together.
#[derive(Default)]
pub(super) struct Scratch {
    /// Per object, its candidates: the queue's rays that may enter its swept box.
    lists: Vec<Vec<u32>>,
    /// One object's candidate rays in its space.
    rays: RayQueue,
    /// Their closest hits.
    hits: HitQueue,
    /// Object distance per world distance, per candidate ray.
    scale: Vec<f32>,
    /// One object's candidate shadow rays in its space.
    shadow: ShadowQueue,
    /// Their queue entries.
    ids: Vec<u32>,
    /// The object tracer's packet order and blocked flags.
    order: Vec<(u64, u32)>,
    /// See `order`.
    blocked: Vec<bool>,
}

impl Scratch {
    /// Bytes held by its buffers.
    pub(super) fn bytes(&self) -> usize {
        self.lists.iter().map(|l| l.capacity() * 4).sum::<usize>()
            + self.rays.bytes()
            + self.hits.bytes()
            + self.scale.capacity() * 4
            + self.shadow.bytes()
            + self.ids.capacity() * 4
            + self.order.capacity() * std::mem::size_of::<(u64, u32)>()
            + self.blocked.capacity()
    }
}

impl Tracer<'_> {
    /// Lowers every ray's hit to a moving object's where one is nearer at the ray's time
    /// (the static tree's kernels above know nothing of time). Each object's candidates,
    /// the rays that enter its swept box before their static hit, are taken into its
    /// space at their times and traced together through its tree with this tracer's
    /// kernel: the answers are [`Moving::closest`](super::moving::Moving::closest)'s, ray
    /// by ray, and a scene pays for its moving objects in proportion to the rays they
    /// may meet.
    #[inline(never)] // kept out of the static kernels' code
    pub(super) fn closest_moving(&mut self, rays: &RayQueue, coherence: Coherence, hits: &mut HitQueue) {
        let Some(m) = &self.accel.moving else { return };
        let mut s = self.moving.take().unwrap_or_default();
        // A hit exactly as far as the static one may still win the tie: boxes are tested
        // a step past it.
        let cols = Columns([&rays.ox, &rays.oy, &rays.oz, &rays.dx, &rays.dy, &rays.dz].map(|v| &v[..]));
        self.gather(m, cols, |i| Some(hits.t[i].next_up()), &mut s.lists);
        let lists = std::mem::take(&mut s.lists);
        for (k, (inst, run)) in m.instances.iter().zip(&lists).enumerate().filter(|(_, (_, run))| !run.is_empty()) {
            s.rays.clear();
            s.scale.clear();
            for &i in run {
                let i = i as usize;
                let ray = Ray::infinite(rays.origin(i), rays.dir(i));
                let local = m.with_pose(k, m.clamp(queue::sparse(&rays.time, i)), |p| object_ray(&p.to_object, &ray));
                s.rays.push(local.o, local.d, 0, Vec3::ZERO, 0, 0, 0, 0.0, None);
                s.scale.push(local.scale);
            }
            let mut sub = self.for_object(&inst.accel, &mut s.order, &mut s.blocked);
            sub.closest(&s.rays, coherence, &mut s.hits);
            self.take_object(sub, &mut s.order, &mut s.blocked);
            for (j, &i) in run.iter().enumerate() {
                let (i, prim) = (i as usize, s.hits.prim[j]);
                if prim == MISS {
                    continue;
                }
                let (t, id) = (s.hits.t[j] / s.scale[j], inst.first + prim);
                if t > 0.0 && t < f32::INFINITY && nearer(t, id, (hits.t[i], hits.prim[i])) {
                    (hits.t[i], hits.prim[i]) = (t, id);
                }
            }
        }
        s.lists = lists;
        self.moving = Some(s);
    }

    /// Blocks the shadow rays still unblocked that a moving object blocks at their time:
    /// each object's candidates traced together, as in [`Tracer::closest_moving`].
    #[inline(never)] // kept out of the static kernels' code
    pub(super) fn occluded_moving(&mut self, shadow: &ShadowQueue) {
        let Some(m) = &self.accel.moving else { return };
        let mut s = self.moving.take().unwrap_or_default();
        let blocked = std::mem::take(&mut self.blocked);
        let cols = Columns([&shadow.ox, &shadow.oy, &shadow.oz, &shadow.dx, &shadow.dy, &shadow.dz].map(|v| &v[..]));
        self.gather(m, cols, |i| (!blocked[i]).then(|| shadow.tmax[i]), &mut s.lists);
        self.blocked = blocked;
        let lists = std::mem::take(&mut s.lists);
        for (k, (inst, run)) in m.instances.iter().zip(&lists).enumerate().filter(|(_, (_, run))| !run.is_empty()) {
            s.shadow.clear();
            s.ids.clear();
            // Rays an object before this one blocked need not meet this one.
            for &i in run.iter().filter(|&&i| !self.blocked[i as usize]) {
                let i = i as usize;
                let ray = Ray::infinite(shadow.origin(i), shadow.dir(i));
                let local = m.with_pose(k, m.clamp(queue::sparse(&shadow.time, i)), |p| object_ray(&p.to_object, &ray));
                s.shadow.push(local.o, local.d, shadow.tmax[i] * local.scale, 0, Vec3::ZERO, None);
                s.ids.push(i as u32);
            }
            let mut sub = self.for_object(&inst.accel, &mut s.order, &mut s.blocked);
            sub.occluded(&s.shadow);
            for (j, &i) in s.ids.iter().enumerate() {
                self.blocked[i as usize] |= sub.blocked[j];
            }
            self.take_object(sub, &mut s.order, &mut s.blocked);
        }
        s.lists = lists;
        self.moving = Some(s);
    }

    /// Every object's candidates among a queue's rays ([`Moving::gather_queue`]).
    #[inline]
    fn gather(
        &mut self,
        m: &Moving,
        rays: Columns<'_>,
        limit: impl Fn(usize) -> Option<f32>,
        lists: &mut Vec<Vec<u32>>,
    ) {
        if self.count {
            m.gather_queue::<true>(rays, limit, lists, &mut self.work);
        } else {
            m.gather_queue::<false>(rays, limit, lists, &mut self.work);
        }
    }

    /// A tracer over a moving object's tree with this one's kernel, lent this one's
    /// scratch (given back by [`Tracer::take_object`]).
    fn for_object<'b>(&self, accel: &'b Accel, order: &mut Vec<(u64, u32)>, blocked: &mut Vec<bool>) -> Tracer<'b> {
        Tracer {
            order: std::mem::take(order),
            blocked: std::mem::take(blocked),
            ..Tracer::new(accel, self.kernel, self.count)
        }
    }

    /// Takes back the scratch and the traversal work of [`Tracer::for_object`]'s tracer.
    fn take_object(&mut self, sub: Tracer<'_>, order: &mut Vec<(u64, u32)>, blocked: &mut Vec<bool>) {
        self.work += sub.work;
        (*order, *blocked) = (sub.order, sub.blocked);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::tracer::{Kernel, PacketConfig, Width};
    use crate::accel::{Primitive, Shape, Traversal, NO_LIGHT};
    use crate::motion::Motion;
    use glam::{DMat4, DQuat, DVec3};

    /// A generator of numbers in [0, 1).
    fn numbers(mut seed: u32) -> impl FnMut() -> f32 {
        move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        }
    }

    /// `n` triangles and a sphere scattered in a box of side `size` around `at`.
    fn clutter(next: &mut impl FnMut() -> f32, n: usize, at: Vec3, size: f32) -> Vec<Primitive> {
        let mut p = |s: f32| at + (Vec3::new(next(), next(), next()) - 0.5) * s;
        let mut prims: Vec<Primitive> = (0..n)
            .map(|_| {
                let v0 = p(size);
                let shape = Shape::Triangle { v0, v1: v0 + p(size * 0.3) - at, v2: v0 + p(size * 0.3) - at };
                Primitive { shape, material: 0, light: NO_LIGHT }
            })
            .collect();
        prims.push(Primitive {
            shape: Shape::Sphere { center: p(size), radius: 0.1 * size },
            material: 0,
            light: NO_LIGHT,
        });
        prims
    }

    /// The tracer's moving objects, each object's candidates traced together through its
    /// tree, answer what [`Moving::closest`] and [`Moving::occluded`] answer ray by ray,
    /// bit for bit, with every kernel: with a few objects (each box tested) and many (a
    /// tree over them), camera-ordered and bounce queues, and shadow rays.
    #[test]
    fn moving_objects_traced_together_answer_as_each_ray_alone() {
        for objects in [3, 40] {
            let mut next = numbers(objects as u32);
            let mut accel = Accel::build(clutter(&mut next, 400, Vec3::ZERO, 8.0));
            let at: Vec<DVec3> =
                (0..objects).map(|_| DVec3::new(next() as f64, next() as f64, next() as f64) * 8.0 - 4.0).collect();
            let moving: Vec<(Motion, Accel)> = at
                .iter()
                .map(|&p| {
                    let turn = DQuat::from_axis_angle(DVec3::Y, next() as f64 * 2.0);
                    let end = DMat4::from_rotation_translation(turn, p + DVec3::X * next() as f64);
                    let motion = Motion::new(DMat4::from_translation(p), end).unwrap();
                    (motion, Accel::build(clutter(&mut next, 100, Vec3::ZERO, 2.0)))
                })
                .collect();
            accel.attach_moving(moving, [0.0, 1.0]);
            let m = accel.moving().unwrap();
            let (mut rays, mut shadow) = (RayQueue::default(), ShadowQueue::default());
            for i in 0..3000 {
                let o = Vec3::new(next() * 12.0 - 6.0, next() * 12.0 - 6.0, 9.0);
                // Half the rays aim near an object.
                let (aim, spread) = if i % 2 == 0 { (at[i % objects].as_vec3(), 0.2) } else { (Vec3::ZERO, 1.0) };
                let d = (aim + Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 8.0 * spread - o).normalize();
                // Paths' times, some shared by neighbours (a path's shadow rays), some
                // outside the shutter.
                let time = if i % 3 == 0 { (i / 9) as f32 / 333.0 } else { next() * 1.2 - 0.1 };
                rays.push(o, d, 0, Vec3::ONE, 0, 0, 0, 0.0, Some(time));
                shadow.push(o, d, 4.0 + next() * 8.0, 0, Vec3::ONE, Some(time));
            }
            let mut c = Traversal::default();
            let (mut want_hits, mut want_blocked) = (Vec::new(), Vec::new());
            for i in 0..rays.len() {
                let ray = Ray::infinite(rays.origin(i), rays.dir(i));
                let mut best = accel.closest::<false>(ray, &mut c).unwrap_or((f32::INFINITY, MISS));
                m.closest::<false>(ray, rays.time[i], &mut best, &mut c);
                want_hits.push(best);
                let seg = Ray::new(shadow.origin(i), shadow.dir(i), 0.0, shadow.tmax[i]);
                want_blocked
                    .push(accel.occluded::<false>(seg, &mut c) || m.occluded::<false>(seg, shadow.time[i], &mut c));
            }
            let moving_hits = want_hits.iter().filter(|h| h.1 != MISS && accel.is_moving(h.1)).count();
            let moving_blocks = (0..shadow.len())
                .filter(|&i| {
                    let seg = Ray::new(shadow.origin(i), shadow.dir(i), 0.0, shadow.tmax[i]);
                    want_blocked[i] && !accel.occluded::<false>(seg, &mut c)
                })
                .count();
            assert!(
                moving_hits > 200 && moving_blocks > 50,
                "{objects}: too few to compare: {moving_hits}, {moving_blocks}"
            );
            let packets = PacketConfig::RENDER;
            for kernel in [
                Kernel::Wide,
                Kernel::Interleaved,
                Kernel::Stream,
                Kernel::Packet(Width::X8, packets),
                Kernel::HYBRID,
                Kernel::Hybrid { width: Width::X16, cfg: packets, max_leaves: 0 },
            ] {
                for count in [false, true] {
                    let mut tracer = Tracer::new(&accel, kernel, count);
                    for coherence in [Coherence::Camera, Coherence::Bounce] {
                        let mut hits = HitQueue::default();
                        tracer.closest(&rays, coherence, &mut hits);
                        let got: Vec<(f32, u32)> = hits.t.iter().copied().zip(hits.prim.iter().copied()).collect();
                        assert!(got == want_hits, "{objects} objects, {kernel:?}: closest hits differ");
                    }
                    assert!(tracer.occluded(&shadow) == want_blocked, "{objects} objects, {kernel:?}: blocked differ");
                }
            }
        }
    }
}
