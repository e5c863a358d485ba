//! Shadow occlusion: any-hit tests of shadow rays. Reads the shadow queue; writes the
//! contributions of unblocked rays to the film queue.
//!
//! With packets on, shadow rays are grouped by direction octant (they come out of the
//! shade stage a shading point's samples together, already coherent) and traced a packet
//! at a time when a group shares an octant (one at a time otherwise).

use glam::Vec3;

use crate::geometry::order::{octant, packet_order};
use crate::geometry::packet::{Packet, PacketConfig, PacketWork, Simd, MAX};
use crate::geometry::Traversal;
use crate::queue::{FilmQueue, ShadowQueue};
use crate::scene::Scene;

/// Traces every shadow ray; those that reach their light add their contribution.
/// Returns the number of unblocked rays. Work is counted in `work` when `count`.
/// `order` is scratch space for the packet order.
pub fn occlusion(
    scene: &Scene,
    shadow: &ShadowQueue,
    film: &mut FilmQueue,
    work: &mut Traversal,
    count: bool,
    order: &mut Vec<(u64, u32)>,
) -> usize {
    if scene.settings.packets {
        return packets::<Packet>(scene, shadow, film, work, order, PacketConfig::RENDER, count);
    }
    if count {
        single::<true>(scene, shadow, film, work)
    } else {
        single::<false>(scene, shadow, film, work)
    }
}

/// The single-ray path of [`occlusion`] (public so that `wavetrace bench` can measure it
/// whatever `render.packets` says).
pub fn single<const COUNT: bool>(
    scene: &Scene,
    shadow: &ShadowQueue,
    film: &mut FilmQueue,
    work: &mut Traversal,
) -> usize {
    let mut lit = 0;
    for i in 0..shadow.len() {
        if !scene.accel.occluded::<COUNT>(shadow.origin(i), shadow.dir(i), 0.0, shadow.tmax[i], work) {
            film.push(shadow.slot[i], shadow.radiance(i));
            lit += 1;
        }
    }
    lit
}

/// The packet path of [`occlusion`]: shadow rays in packets of `S::LANES`, formed and
/// traced as `cfg` says; work per lane is added to `work` when `count`. Public so that
/// `wavetrace bench` can measure other settings.
pub fn packets<S: Simd>(
    scene: &Scene,
    shadow: &ShadowQueue,
    film: &mut FilmQueue,
    work: &mut Traversal,
    order: &mut Vec<(u64, u32)>,
    cfg: PacketConfig,
    count: bool,
) -> usize {
    packet_order(&scene.accel, shadow.len(), |i| shadow.origin(i), |i| shadow.dir(i), cfg.shadow_order, order);
    let mut pw = PacketWork::default();
    let (mut o, mut d, mut t) = ([Vec3::ZERO; MAX], [Vec3::ZERO; MAX], [0.0f32; MAX]);
    let mut blocked = [false; MAX];
    // Unblocked rays reach the film in queue order, not packet order, so the film sums
    // in the same order as the single-ray path: packets change no pixel's bits.
    let mut reaches = vec![false; shadow.len()];
    for group in order.chunks(S::LANES) {
        let k = group.len();
        for (l, &(_, i)) in group.iter().enumerate() {
            let i = i as usize;
            (o[l], d[l], t[l]) = (shadow.origin(i), shadow.dir(i), shadow.tmax[i]);
        }
        let oct = octant(d[0]);
        if k > 1 && !(cfg.split_mixed && d[..k].iter().any(|&x| octant(x) != oct)) {
            scene.accel.occluded_packet::<S>(&o[..k], &d[..k], &t[..k], cfg.min_active, &mut blocked, &mut pw);
            work.packet_rays += k as u64;
        } else {
            for l in 0..k {
                blocked[l] = scene.accel.occluded::<false>(o[l], d[l], 0.0, t[l], work);
            }
        }
        for (l, &(_, i)) in group.iter().enumerate() {
            reaches[i as usize] = !blocked[l];
        }
    }
    let mut lit = 0;
    for (i, _) in reaches.iter().enumerate().filter(|r| *r.1) {
        film.push(shadow.slot[i], shadow.radiance(i));
        lit += 1;
    }
    work.packet_steps += pw.steps;
    work.packet_lanes += pw.lanes;
    if count {
        work.nodes += pw.nodes;
        work.prims += pw.prims;
    }
    lit
}
