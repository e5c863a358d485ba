//! Instrumentation, in one place: after each stage call the driver hands the meter the
//! stage's queues, and the meter records the call's time and traversal work, its rays by
//! kind, the queues' peak lengths, the heat per slot, and the stage's span for a trace.
//! Counting happens once per stage call, never per ray in a stage.

use std::time::Instant;

use crate::accel::tracer::Tracer;
use crate::accel::Traversal;
use crate::film::SlotHeat;
use crate::queue::WaveQueues;
use crate::stages::penumbra::PenumbraCounts;
use crate::stages::shade::ShadeCounts;
use crate::stats::{Span, Stage, Stats};

/// The kind of camera ray a pass starts, for the stats.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Kind {
    /// Uniform samples, or adaptive AA's centres.
    Camera,
    /// Adaptive AA's pixel corners.
    Corner,
    /// Adaptive AA's refinement samples.
    Refine,
}

/// One worker's counters and stage spans.
#[derive(Default)]
pub(super) struct Meter {
    /// Counters of every stage call so far.
    pub stats: Stats,
    /// Stage spans, when tracing.
    pub spans: Vec<Span>,
    /// `Some(render start)` when tracing.
    trace: Option<Instant>,
}

impl Meter {
    /// A meter that records spans relative to `trace` when given.
    pub fn new(trace: Option<Instant>) -> Meter {
        Meter { trace, ..Default::default() }
    }

    /// Ends a stage call begun at `since`: records its counts, time and traversal work,
    /// and its span when tracing. Returns the end, where the next stage call begins.
    pub fn lap(&mut self, stage: Stage, rays_in: usize, rays_out: usize, work: Traversal, since: Instant) -> Instant {
        let now = Instant::now();
        self.stats.record(stage, rays_in, rays_out, (now - since).as_secs_f64());
        let c = &mut self.stats.stages[stage as usize];
        c.nodes += work.nodes;
        c.prims += work.prims;
        c.packet_rays += work.packet_rays;
        c.packet_steps += work.packet_steps;
        c.packet_lanes += work.packet_lanes;
        if let Some(t0) = self.trace {
            let start_us = (since - t0).as_secs_f64() * 1e6;
            self.spans.push(Span { stage, start_us, dur_us: (now - since).as_secs_f64() * 1e6 });
        }
        now
    }

    /// Camera generation wrote `n` rays of `kind`.
    pub fn camera(&mut self, kind: Kind, n: usize, since: Instant) -> Instant {
        match kind {
            Kind::Camera => self.stats.camera_rays += n as u64,
            Kind::Corner => self.stats.aa_corner_rays += n as u64,
            Kind::Refine => self.stats.aa_refine_rays += n as u64,
        }
        self.lap(Stage::Camera, 0, n, Traversal::default(), since)
    }

    /// Intersection of the wave's rays (which count towards their slots' heat).
    pub fn intersect(&mut self, q: &WaveQueues, heat: &mut SlotHeat, tr: &mut Tracer, since: Instant) -> Instant {
        count_slots(&mut heat.rays, &q.rays.slot);
        let n = q.rays.len();
        self.stats.peak.rays = self.stats.peak.rays.max(n as u64);
        self.lap(Stage::Intersect, n, n, tr.take_work(), since)
    }

    /// Shading; `counts` is what shade returned.
    pub fn shade(&mut self, q: &WaveQueues, counts: ShadeCounts, since: Instant) -> Instant {
        let p = &mut self.stats.peak;
        p.shadow = p.shadow.max(q.shadow.len() as u64);
        p.shadow_points = p.shadow_points.max(q.points.len() as u64);
        p.specular = p.specular.max(q.specular.len() as u64);
        self.stats.shadow_uniform_rays += counts.uniform_equivalent;
        self.stats.shadow_uniform_fallback += counts.uniform_fallback;
        let out = q.shadow.len() + q.points.len() + q.specular.len() + q.film.len();
        self.lap(Stage::Shade, q.rays.len(), out, Traversal::default(), since)
    }

    /// Shadow occlusion; `lit` rays got through.
    pub fn shadow(
        &mut self,
        q: &WaveQueues,
        heat: &mut SlotHeat,
        lit: usize,
        tr: &mut Tracer,
        since: Instant,
    ) -> Instant {
        self.stats.shadow_rays += q.shadow.len() as u64;
        count_slots(&mut heat.rays, &q.shadow.slot);
        self.lap(Stage::Shadow, q.shadow.len(), lit, tr.take_work(), since)
    }

    /// The shadow-corner test: `cast` probe rays, `probes(light)` per point on that light.
    pub fn shadow_corners(
        &mut self,
        q: &WaveQueues,
        heat: &mut SlotHeat,
        (cast, probes): (usize, &dyn Fn(u32) -> f32),
        tr: &mut Tracer,
        since: Instant,
    ) -> Instant {
        self.stats.shadow_corner_rays += cast as u64;
        self.stats.shadow_points += q.points.len() as u64;
        self.stats.penumbra_points += q.penumbra.len() as u64;
        for (&s, &li) in q.points.slot.iter().zip(&q.points.light) {
            heat.points[s as usize] += 1.0;
            heat.rays[s as usize] += probes(li);
        }
        for &k in &q.penumbra.index {
            heat.penumbra[q.points.slot[k as usize] as usize] += 1.0;
        }
        self.lap(Stage::ShadowCorner, q.points.len(), q.penumbra.len(), tr.take_work(), since)
    }

    /// The penumbra stage.
    pub fn penumbra(
        &mut self,
        q: &WaveQueues,
        heat: &mut SlotHeat,
        counts: PenumbraCounts,
        tr: &mut Tracer,
        since: Instant,
    ) -> Instant {
        let pen = &q.penumbra_rays;
        let p = &mut self.stats.peak;
        p.penumbra_rays = p.penumbra_rays.max(pen.rays.len() as u64);
        self.stats.penumbra_rays += counts.traced;
        self.stats.penumbra_stopped += counts.stopped;
        self.stats.penumbra_saved_rays += counts.saved;
        // A point's rays all go to its slot: add the ones it traced.
        for (i, &k) in q.penumbra.index.iter().enumerate() {
            heat.rays[q.points.slot[k as usize] as usize] += pen.points.taken[i] as f32;
        }
        self.lap(Stage::Penumbra, q.penumbra.len(), counts.lit, tr.take_work(), since)
    }

    /// Scattering at mirrors and dielectrics.
    pub fn scatter(&mut self, q: &WaveQueues, since: Instant) -> Instant {
        self.stats.secondary_rays += q.next.len() as u64;
        self.lap(Stage::Scatter, q.specular.len(), q.next.len(), Traversal::default(), since)
    }

    /// Russian roulette (timed with the scatter stage that spawned the rays): `kept`
    /// rays go on, `ended` were ended and are never traced.
    pub fn roulette(&mut self, kept: usize, ended: u64, since: Instant) -> Instant {
        self.stats.secondary_rays -= ended;
        self.lap(Stage::Scatter, kept + ended as usize, kept, Traversal::default(), since)
    }

    /// Film accumulation; `dropped` non-finite contributions.
    pub fn film(&mut self, q: &WaveQueues, dropped: usize, since: Instant) -> Instant {
        self.stats.peak.film = self.stats.peak.film.max(q.film.len() as u64);
        self.stats.nonfinite += dropped as u64;
        self.lap(Stage::Film, q.film.len(), q.film.len() - dropped, Traversal::default(), since)
    }
}

/// Adds one to `heat[s]` for every slot `s` in `slots`: once per run of equal slots (a
/// pixel's rays come together), adding the run's length. Counts stay exact integers
/// below 2^24, so the sums have the bits of adding ones, without a store and reload of
/// the slot per ray.
fn count_slots(heat: &mut [f32], slots: &[u32]) {
    let mut i = 0;
    while i < slots.len() {
        let s = slots[i];
        let run = slots[i..].iter().take_while(|&&x| x == s).count();
        heat[s as usize] += run as f32;
        i += run;
    }
}
