//! Russian roulette of the path transport: reads a level's rays and keeps each with a
//! probability that follows its throughput, as Mitsuba's `path` integrator does.

use glam::Vec3;

use crate::queue::RayQueue;
use crate::sampling::{dim, hash, sobol_owen};

/// Copies into `out` (cleared first) the rays of `rays` that survive: a ray whose path
/// throughput (its weight over its camera ray's, `camera[slot]`) has largest channel t
/// goes on with probability q = min(t, 0.95), its weight divided by q. The decision is
/// point `sample` of the path's Owen-scrambled Sobol sequence keyed by its key and
/// [`dim::ROULETTE`]. Returns the number of rays ended.
pub fn roulette(rays: &RayQueue, camera: &[f32], out: &mut RayQueue) -> u64 {
    out.clear();
    let q = |w: Vec3, slot: u32| (w.max_element() / camera[slot as usize]).min(0.95);
    let kept: Vec<u32> = (0..rays.len() as u32)
        .filter(|&i| {
            let i = i as usize;
            // NaN throughput (a broken path) ends too.
            sobol_owen(rays.sample[i], hash(&[rays.key[i], dim::ROULETTE])).x < q(rays.weight(i), rays.slot[i])
        })
        .collect();
    out.gather(rays, &kept);
    for k in 0..out.len() {
        let q = q(out.weight(k), out.slot[k]);
        (out.wr[k], out.wg[k], out.wb[k]) = (out.wr[k] / q, out.wg[k] / q, out.wb[k] / q);
    }
    (rays.len() - kept.len()) as u64
}
