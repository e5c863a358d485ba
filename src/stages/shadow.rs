//! Shadow occlusion: any-hit tests of shadow rays. Reads the shadow queue; writes the
//! contributions of unblocked rays to the film queue.
//!
//! With packets on, shadow rays are ordered by direction octant and origin, and traced
//! 8 at a time when a group shares an octant (one at a time otherwise).

use glam::Vec3;

use super::intersect::packet_order;
use crate::geometry::packet::{octant, PacketWork, LANES};
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
        return packets(scene, shadow, film, work, order);
    }
    if count {
        run::<true>(scene, shadow, film, work)
    } else {
        run::<false>(scene, shadow, film, work)
    }
}

fn run<const COUNT: bool>(scene: &Scene, shadow: &ShadowQueue, film: &mut FilmQueue, work: &mut Traversal) -> usize {
    let mut lit = 0;
    for i in 0..shadow.len() {
        if !scene.accel.occluded::<COUNT>(shadow.origin(i), shadow.dir(i), 0.0, shadow.tmax[i], work) {
            film.push(shadow.slot[i], shadow.radiance(i));
            lit += 1;
        }
    }
    lit
}

fn packets(
    scene: &Scene,
    shadow: &ShadowQueue,
    film: &mut FilmQueue,
    work: &mut Traversal,
    order: &mut Vec<(u64, u32)>,
) -> usize {
    packet_order(scene, shadow.len(), |i| shadow.origin(i), |i| shadow.dir(i), false, order);
    let mut pw = PacketWork::default();
    let (mut o, mut d, mut t) = ([Vec3::ZERO; LANES], [Vec3::ZERO; LANES], [0.0f32; LANES]);
    let mut blocked = [false; LANES];
    let mut lit = 0;
    for group in order.chunks(LANES) {
        let k = group.len();
        for (l, &(_, i)) in group.iter().enumerate() {
            let i = i as usize;
            (o[l], d[l], t[l]) = (shadow.origin(i), shadow.dir(i), shadow.tmax[i]);
        }
        let oct = octant(d[0]);
        if k == LANES && d.iter().all(|&x| octant(x) == oct) {
            scene.accel.occluded8(&o, &d, &t, &mut blocked, &mut pw);
            work.packet_rays += k as u64;
        } else {
            for l in 0..k {
                blocked[l] = scene.accel.occluded::<false>(o[l], d[l], 0.0, t[l], work);
            }
        }
        for (l, &(_, i)) in group.iter().enumerate() {
            if !blocked[l] {
                film.push(shadow.slot[i as usize], shadow.radiance(i as usize));
                lit += 1;
            }
        }
    }
    work.packet_steps += pw.steps;
    work.packet_lanes += pw.lanes;
    lit
}
