//! The wavefront of one worker: a pass's camera rays cut into waves of bounded size,
//! each wave through the stages, and the bounces each wave spawns traced depth first.

use glam::Vec2;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use super::meter::{Kind, Meter};
use crate::accel::tracer::{Coherence, Tracer};
use crate::film::Accumulator;
use crate::queue::{RayQueue, ShadowPoints, WaveQueues};
use crate::scene::{Scene, ShadowMode, Transport};
use crate::stages::shade::Shaded;
use crate::stages::{
    bounce, camera, film, focus, intersect, penumbra, roulette, scatter, shade, shadow, shadow_corner,
};
use crate::stats::Stage;

/// A worker's wavefront: its queues, tracer, meter and the pass being accumulated.
pub(super) struct Pipeline<'a> {
    /// The queues of a wave.
    pub q: WaveQueues,
    /// Rays still to trace per bounce level (level 0: the camera batch), and how far
    /// each level has been traced.
    levels: Vec<RayQueue>,
    cursors: Vec<usize>,
    /// The acceleration structure and the kernel that traverses it.
    pub tracer: Tracer<'a>,
    /// Counters and spans.
    pub meter: Meter,
    /// The pass being accumulated.
    pub acc: Accumulator,
    /// The path transport: the weight of each slot's camera rays in this pass, against
    /// which Russian roulette measures a path's throughput.
    camera_weight: Vec<f32>,
    /// Camera rays per wave for this scene.
    wave: u64,
    /// The render's cancel flag, and whether this worker saw it mid-tile.
    cancel: Option<Arc<AtomicBool>>,
    pub aborted: bool,
    /// The render's shadow mode: the scene's, or what its auto mode chose (never `Auto`).
    shadows: ShadowMode,
}

impl<'a> Pipeline<'a> {
    /// A pipeline with empty queues.
    pub fn new(
        tracer: Tracer<'a>,
        meter: Meter,
        (wave, shadows): (u64, ShadowMode),
        cancel: Option<Arc<AtomicBool>>,
    ) -> Self {
        Pipeline {
            q: WaveQueues::default(),
            levels: Vec::new(),
            cursors: Vec::new(),
            tracer,
            meter,
            acc: Accumulator::default(),
            camera_weight: Vec::new(),
            wave,
            cancel,
            aborted: false,
            shadows,
        }
    }

    /// True once the render was asked to stop; the worker then marks itself aborted.
    fn stop_requested(&mut self) -> bool {
        self.aborted = self.cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed));
        self.aborted
    }

    /// Runs `total` camera samples of a pass through the pipeline in waves of at most
    /// `wave` camera rays; `generate` writes the rays of a range of sample indices.
    /// `order` says whether the camera rays come coherent (`Camera`: every pixel of a
    /// tile in turn) or scattered over the tile (`Bounce`: the few pixels a round or a
    /// pilot samples), for the tracer to choose its kernel as for a bounce queue.
    pub fn run(
        &mut self,
        scene: &Scene,
        total: u64,
        (kind, order): (Kind, Coherence),
        generate: impl Fn(Range<u64>, &mut RayQueue),
    ) {
        let mut k0 = 0;
        while k0 < total {
            if self.stop_requested() {
                return;
            }
            let k1 = (k0 + self.wave).min(total);
            let t = Instant::now();
            generate(k0..k1, &mut self.q.rays);
            camera::shutter_times(scene, &mut self.q.rays);
            if scene.settings.path() {
                self.camera_weights();
            }
            self.meter.camera(kind, self.q.rays.len(), t);
            self.drain(scene, order);
            k0 = k1;
        }
    }

    /// Records the weight of the camera rays in `q.rays` per slot (every ray of a slot
    /// has the same, the same in each channel).
    fn camera_weights(&mut self) {
        let (rays, weights) = (&self.q.rays, &mut self.camera_weight);
        if weights.len() < self.acc.sums.len() {
            weights.resize(self.acc.sums.len(), 0.0);
        }
        for (&slot, &w) in rays.slot.iter().zip(&rays.wr) {
            weights[slot as usize] = w;
        }
    }

    /// Traces the camera batch in `q.rays` and every bounce it spawns, depth first: the
    /// deepest pending level is traced next, a wave at a time, so level d holds at most
    /// the two waves' worth of rays spawned from one wave of level d - 1, and the queues
    /// stay bounded however many rays dielectrics split into.
    fn drain(&mut self, scene: &Scene, order: Coherence) {
        let wave = self.wave as usize;
        self.levels.resize_with(scene.settings.max_depth as usize + 2, Default::default);
        self.cursors.resize(self.levels.len(), 0);
        std::mem::swap(&mut self.levels[0], &mut self.q.rays);
        self.cursors[0] = 0;
        while let Some(d) = (0..self.levels.len()).rev().find(|&d| self.cursors[d] < self.levels[d].len()) {
            let (start, end) = (self.cursors[d], (self.cursors[d] + wave).min(self.levels[d].len()));
            if start == 0 && end == self.levels[d].len() {
                // The whole level is one wave (the usual camera batch): take its buffers
                // instead of copying its rays.
                std::mem::swap(&mut self.q.rays, &mut self.levels[d]);
                self.levels[d].clear();
            } else {
                self.q.rays.clear();
                self.q.rays.append_range(&self.levels[d], start..end);
                self.cursors[d] = end;
                if end == self.levels[d].len() {
                    self.levels[d].clear();
                    self.cursors[d] = 0;
                }
            }
            if let Transport::Path { rr_depth, .. } = scene.settings.transport {
                if d as u32 >= rr_depth {
                    let t = Instant::now();
                    let ended = roulette::roulette(&self.q.rays, &self.camera_weight, &mut self.q.next);
                    std::mem::swap(&mut self.q.rays, &mut self.q.next);
                    self.q.next.clear();
                    self.meter.roulette(self.q.rays.len(), ended, t);
                }
            }
            self.wave(scene, if d == 0 { order } else { Coherence::Bounce });
            // The wave's scattered rays are the next level, empty until now.
            if !self.q.next.is_empty() {
                std::mem::swap(&mut self.levels[d + 1], &mut self.q.next);
                self.cursors[d + 1] = 0;
            }
        }
    }

    /// One wave (paper §2): intersect, shade, the shadows (uniform rays; or corners, then
    /// penumbra), reflection/refraction (and the light samples of rough surfaces), film. Each stage call is followed by the meter's
    /// record of it.
    fn wave(&mut self, scene: &Scene, coherence: Coherence) {
        let (q, tr, m, acc) = (&mut self.q, &mut self.tracer, &mut self.meter, &mut self.acc);
        let (heat, shadows) = (&mut acc.heat, self.shadows);
        q.film.clear();
        let mut t = Instant::now();

        intersect::intersect(tr, &q.rays, coherence, &mut q.hits);
        t = m.intersect(q, heat, tr, t);

        let out = Shaded {
            shadow: &mut q.shadow,
            points: &mut q.points,
            surfaces: &mut q.surfaces,
            specular: &mut q.specular,
            film: &mut q.film,
        };
        let counts = shade::shade(scene, shadows, &q.rays, &q.hits, out);
        t = m.shade(q, counts, t);

        let lit = shadow::occlusion(tr, &q.shadow, &mut q.film);
        t = m.shadow(q, heat, lit, tr, t);

        if let ShadowMode::Adaptive(probe) = shadows {
            let shading = ShadowPoints { surfaces: &q.surfaces, points: &q.points };
            let (probes, film, pen) = (&mut q.probes, &mut q.film, &mut q.penumbra);
            let cast = shadow_corner::shadow_corners((scene, probe), tr, shading, probes, film, pen);
            // Probe rays per point depend on the light's shape (a triangle's 3x3 set is 7).
            let probes = |li: u32| crate::light::probe_count(&scene.lights[li as usize], probe) as f32;
            t = m.shadow_corners(q, heat, (cast, &probes), tr, t);

            let shading = ShadowPoints { surfaces: &q.surfaces, points: &q.points };
            let pen = penumbra::penumbra(scene, tr, shading, &q.penumbra, &mut q.penumbra_rays, &mut q.film);
            t = m.penumbra(q, heat, pen, tr, t);
        }

        // A scene without used mirrors or dielectrics never enters the scatter stage
        // (and its next level stays empty) unless its diffuse surfaces scatter too.
        let path = scene.settings.path();
        if scene.has_specular || path {
            scatter::scatter(scene, &q.rays, &q.hits, &q.specular, &mut q.next, &mut q.shadow);
            if path {
                bounce::bounce(scene, shadows, &q.rays, &q.surfaces, &mut q.next);
            }
            t = m.scatter(q, t);

            // Rough surfaces' light samples (multiple importance sampling).
            if !q.shadow.is_empty() {
                let lit = shadow::occlusion(tr, &q.shadow, &mut q.film);
                t = m.shadow(q, heat, lit, tr, t);
            }
        }

        let dropped = film::accumulate(&q.film, &mut acc.sums);
        m.film(q, dropped, t);
    }

    /// DOF-aware AA: traces a pinhole depth probe through film position `film(i)` of each
    /// point i < `n` and leaves the points' blur radii (pixels) in `sharp` (for the eps)
    /// and `lens` (for the lens count).
    pub fn focus(
        &mut self,
        scene: &Scene,
        n: usize,
        film: impl Fn(u32) -> Vec2,
        sharp: &mut Vec<f32>,
        lens: &mut Vec<f32>,
    ) {
        for b in [&mut *sharp, &mut *lens] {
            b.clear();
            b.resize(n, 0.0);
        }
        let mut k0 = 0;
        while k0 < n as u64 {
            if self.stop_requested() {
                return;
            }
            let k1 = (k0 + self.wave).min(n as u64);
            let t = Instant::now();
            let q = &mut self.q;
            focus::generate(scene, k0..k1, &film, &mut q.rays);
            intersect::intersect(&mut self.tracer, &q.rays, Coherence::Camera, &mut q.hits);
            focus::blur(scene, &q.rays, &q.hits, k0 as usize, sharp, lens);
            self.meter.stats.dof_probe_rays += k1 - k0;
            let probes = (k1 - k0) as usize;
            self.meter.lap(Stage::Focus, probes, probes, self.tracer.take_work(), t);
            k0 = k1;
        }
    }

    /// Bytes held by the queues, levels, pass buffers and tracer scratch (capacities).
    pub fn bytes(&self) -> usize {
        self.q.bytes()
            + self.camera_weight.capacity() * 4
            + self.levels.iter().map(RayQueue::bytes).sum::<usize>()
            + self.acc.bytes()
            + self.tracer.bytes()
    }
}
