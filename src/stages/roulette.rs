//! Russian roulette of the path transport: reads a level's rays and keeps each with a
//! probability that follows its throughput, as Mitsuba's `path` integrator does.

use crate::queue::RayQueue;
use crate::sampling::{dim, hash, sobol_owen};

/// Copies into `out` (cleared first) the rays of `rays` that survive: a ray whose path
/// throughput (its weight over its camera ray's, `camera[slot]`) has largest channel t
/// goes on with probability q = min(t, 0.95), its weight divided by q. The decision is
/// point `sample` of the path's Owen-scrambled Sobol sequence keyed by its key and
/// [`dim::ROULETTE`]. Returns the number of rays ended.
pub fn roulette(rays: &RayQueue, camera: &[f32], out: &mut RayQueue) -> u64 {
    out.clear();
    let mut ended = 0;
    for i in 0..rays.len() {
        let w = rays.weight(i);
        let t = w.max_element() / camera[rays.slot[i] as usize];
        let q = t.min(0.95);
        let u = sobol_owen(rays.sample[i], hash(&[rays.key[i], dim::ROULETTE])).x;
        // NaN throughput (a broken path) ends too.
        if u >= q || q.is_nan() {
            ended += 1;
            continue;
        }
        out.append_range(rays, i..i + 1);
        let k = out.len() - 1;
        (out.wr[k], out.wg[k], out.wb[k]) = (w.x / q, w.y / q, w.z / q);
    }
    ended
}
