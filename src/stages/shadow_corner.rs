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
use crate::queue::{sparse_opt, FilmQueue, IndexQueue, ShadowPoints, ShadowQueue};
use crate::sampling::hash;
use crate::scene::{Probe, Scene};

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
    for k in 0..points.len() {
        let s = points.surface[k] as usize;
        let o = surfaces.origin(s);
        // The point's probes carry its path's time.
        let time = sparse_opt(&surfaces.time, s);
        let li = points.light[k] as usize;
        let targets = probe_targets(scene, probe, li, hash(&[surfaces.key[s], surfaces.sample[s]]));
        let n = probe_count(&scene.lights[li], probe) as usize;
        for target in &targets[..n] {
            let to = *target - o;
            let dist = to.length();
            probes.push(o, to / dist, dist * SHADOW_TMAX_SCALE, k as u32, Vec3::ZERO, time);
        }
    }
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
