//! The shadow-corner test (paper §2.2): a few any-hit probe rays from each queued
//! shading point to an area light. If all reach the light the point is lit (its
//! unoccluded contribution goes to the film); if none does it is dark; otherwise it
//! goes to the penumbra queue.
//!
//! The probes of the whole queue are written to a shadow-ray queue (a point's probes
//! next to each other, their slot naming the point), traced in one call of the
//! occlusion kernels, and reduced per point: any-hit answers do not depend on the kernel
//! or the order, so the lit, dark and penumbra sets are those of tracing each probe alone.

use glam::Vec3;

use crate::accel::tracer::Tracer;
use crate::light::{probe_count, probe_targets, SHADOW_TMAX_SCALE};
use crate::queue::{FilmQueue, IndexQueue, ShadowPoints, ShadowQueue};
use crate::sampling::hash;
use crate::scene::{Probe, Scene};
use crate::simd::LANES;

/// Tests every queued point (`points`, whose surfaces are in `surfaces`) against its
/// light with the probe set `probe`: writes the probe rays to `probes`
/// (cleared first; slot: the point), traces them, and appends the lit points'
/// unoccluded contributions to `film`; penumbra points go to `penumbra` (cleared first;
/// indices into `points`). Returns the number of probe rays cast.
pub fn shadow_corners(
    (scene, probe): (&Scene, Probe),
    tracer: &mut Tracer,
    shading: ShadowPoints,
    probes: &mut ShadowQueue,
    film: &mut FilmQueue,
    penumbra: &mut IndexQueue,
) -> usize {
    let ShadowPoints { surfaces, points } = shading;
    penumbra.clear();
    probes.clear();
    // The probes go to the queue 16 at a time: a scalar push per ray cost as much as
    // the rest of the stage's generation.
    let mut lanes = ProbeLanes::default();
    let motion = !surfaces.time.is_empty();
    for k in 0..points.len() {
        let s = points.surface[k] as usize;
        let o = surfaces.origin(s);
        // The point's probes carry its path's time.
        let time = if motion { surfaces.time[s] } else { 0.0 };
        let li = points.light[k] as usize;
        let targets = probe_targets(scene, probe, li, hash(&[surfaces.key[s], surfaces.sample[s]]));
        let n = probe_count(&scene.lights[li], probe) as usize;
        for target in &targets[..n] {
            let to = *target - o;
            let dist = to.length();
            lanes.put(o, to / dist, dist * SHADOW_TMAX_SCALE, k as u32, time);
            if lanes.count == LANES {
                lanes.flush(probes, motion);
            }
        }
    }
    lanes.flush(probes, motion);
    let blocked = tracer.occluded(probes);
    // A point's probes are a run of equal slots: count the visible ones per run.
    let mut r = 0;
    while r < blocked.len() {
        let k = probes.slot[r];
        let start = r;
        let mut visible = 0;
        while r < blocked.len() && probes.slot[r] == k {
            visible += !blocked[r] as usize;
            r += 1;
        }
        if visible == r - start {
            film.push(points.slot[k as usize], points.unoccluded(k as usize));
        } else if visible > 0 {
            penumbra.push(k);
        }
    }
    probes.len()
}

/// Up to 16 probe rays on their way into the probe queue, by column.
#[derive(Default)]
struct ProbeLanes {
    o: [[f32; LANES]; 3],
    d: [[f32; LANES]; 3],
    tmax: [f32; LANES],
    slot: [u32; LANES],
    time: [f32; LANES],
    count: usize,
}

impl ProbeLanes {
    /// Adds a ray (the caller flushes a full set).
    #[inline(always)]
    fn put(&mut self, o: Vec3, d: Vec3, tmax: f32, slot: u32, time: f32) {
        let k = self.count;
        for c in 0..3 {
            (self.o[c][k], self.d[c][k]) = (o[c], d[c]);
        }
        (self.tmax[k], self.slot[k], self.time[k]) = (tmax, slot, time);
        self.count += 1;
    }

    /// Appends the rays held to `probes` (with their times under motion blur), in order,
    /// and empties the set.
    fn flush(&mut self, probes: &mut ShadowQueue, motion: bool) {
        let black = [[0.0; LANES]; 3];
        probes.push_lanes(self.o, self.d, self.tmax, self.slot, black, motion.then_some(&self.time), self.count);
        self.count = 0;
    }
}
