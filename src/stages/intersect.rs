//! Closest-hit intersection. Reads the ray queue; writes one hit (or miss) per ray.
//!
//! With packets on, rays go through the packet kernel in groups that share a direction
//! octant; a group that does not is traced one ray at a time. Camera rays keep their
//! generation order (already coherent: a pixel's samples, then its neighbours); bounce
//! rays are first grouped by direction octant (their origins are already in pixel order).

use glam::Vec3;

use crate::geometry::order::{octant, packet_order, Order};
use crate::geometry::packet::{Packet, PacketConfig, PacketWork, Simd, MAX};
use crate::geometry::Traversal;
use crate::queue::{HitQueue, RayQueue, MISS};
use crate::scene::Scene;

/// Finds the closest hit of every ray in `rays`, in order. When `count`, BVH nodes and
/// primitives tested are added to `work`; when not, the traversal has no counting code.
/// `order` is scratch space for the packet order.
pub fn intersect(
    scene: &Scene,
    rays: &RayQueue,
    hits: &mut HitQueue,
    work: &mut Traversal,
    count: bool,
    order: &mut Vec<(u64, u32)>,
) {
    if scene.settings.packets {
        return packets::<Packet>(scene, rays, hits, work, order, PacketConfig::RENDER, count);
    }
    if count {
        single::<true>(scene, rays, hits, work)
    } else {
        single::<false>(scene, rays, hits, work)
    }
}

/// The single-ray path of [`intersect`] (public so that `wavetrace bench` can measure it
/// whatever `render.packets` says).
pub fn single<const COUNT: bool>(scene: &Scene, rays: &RayQueue, hits: &mut HitQueue, work: &mut Traversal) {
    hits.clear();
    for i in 0..rays.len() {
        match scene.accel.closest::<COUNT>(rays.origin(i), rays.dir(i), 0.0, f32::INFINITY, work) {
            Some((t, prim)) => hits.push(t, prim),
            None => hits.push(f32::INFINITY, MISS),
        }
    }
}

/// The packet path of [`intersect`]: rays in packets of `S::LANES`, formed and traced as
/// `cfg` says; work per lane is added to `work` when `count`. Public so that
/// `wavetrace bench` can measure other widths and settings.
pub fn packets<S: Simd>(
    scene: &Scene,
    rays: &RayQueue,
    hits: &mut HitQueue,
    work: &mut Traversal,
    order: &mut Vec<(u64, u32)>,
    cfg: PacketConfig,
    count: bool,
) {
    let n = rays.len();
    hits.t.clear();
    hits.t.resize(n, f32::INFINITY);
    hits.prim.clear();
    hits.prim.resize(n, MISS);
    let camera = rays.depth.first().is_some_and(|&d| d == 0);
    let how = if camera { Order::Keep } else { cfg.bounce_order };
    packet_order(&scene.accel, n, |i| rays.origin(i), |i| rays.dir(i), how, order);
    let mut pw = PacketWork::default();
    let (mut o, mut d, mut out) = ([Vec3::ZERO; MAX], [Vec3::ZERO; MAX], [(0.0f32, 0u32); MAX]);
    for group in order.chunks(S::LANES) {
        for (l, &(_, i)) in group.iter().enumerate() {
            o[l] = rays.origin(i as usize);
            d[l] = rays.dir(i as usize);
        }
        let k = group.len();
        let oct = octant(d[0]);
        if k > 1 && !(cfg.split_mixed && d[..k].iter().any(|&x| octant(x) != oct)) {
            scene.accel.closest_packet::<S>(&o[..k], &d[..k], 0.0, cfg.min_active, &mut out, &mut pw);
            work.packet_rays += k as u64;
        } else {
            for l in 0..k {
                out[l] =
                    scene.accel.closest::<false>(o[l], d[l], 0.0, f32::INFINITY, work).unwrap_or((f32::INFINITY, MISS));
            }
        }
        for (l, &(_, i)) in group.iter().enumerate() {
            hits.t[i as usize] = out[l].0;
            hits.prim[i as usize] = out[l].1;
        }
    }
    work.packet_steps += pw.steps;
    work.packet_lanes += pw.lanes;
    if count {
        work.nodes += pw.nodes;
        work.prims += pw.prims;
    }
}
