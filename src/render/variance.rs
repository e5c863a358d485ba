//! The variance-driven anti-aliasing rounds of a tile: a first round of `min_samples`
//! in every pixel, then rounds of up to `min_samples` more in the pixels the converge
//! stage keeps, until none is left or every one has `render.aa.samples`.

use std::time::Instant;

use super::adaptive::lens_starts;
use super::meter::Kind;
use super::Worker;
use crate::accel::Traversal;
use crate::film::Tile;
use crate::queue::VarianceQueues;
use crate::scene::{AaMode, Scene};
use crate::stages::camera::{self, Lens, VariancePass};
use crate::stages::converge;
use crate::stats::Stage;

/// A worker's variance-AA buffers, reused from tile to tile.
#[derive(Default)]
pub(super) struct VarianceState {
    /// Per tile pixel: its half-buffers; the pixels still sampled.
    queues: VarianceQueues,
    /// Per queued pixel: the samples of this round.
    added: Vec<u32>,
    /// Ray prefix sums of the queued pixels.
    starts: Vec<u64>,
    /// Per tile pixel: its error after the last round.
    error: Vec<f32>,
}

impl VarianceState {
    /// Bytes held (capacities).
    pub fn bytes(&self) -> usize {
        self.queues.bytes() + 4 * (self.added.capacity() + self.error.capacity()) + 8 * self.starts.capacity()
    }
}

impl Worker<'_> {
    /// Variance-driven AA on one tile.
    pub(super) fn variance_tile(&mut self, scene: &Scene, tile: &Tile) {
        let AaMode::Variance { threshold, min_samples } = scene.settings.aa_mode else { return };
        let (np, max, dof) = (tile.pixels(), scene.settings.aa_samples, scene.settings.dof_samples as u64);
        let width = (tile.x1 - tile.x0) as usize;
        let v = &mut self.var;
        converge::start(np, &mut v.queues);
        let stats = &mut self.pipe.meter.stats;
        stats.aa_pixels += np as u64;
        stats.aa_uniform_rays += np as u64 * max as u64 * dof;
        while !v.queues.active.is_empty() {
            let (queue, count) = (&v.queues.active.index, &v.queues.state.count);
            v.added.clear();
            v.added.extend(queue.iter().map(|&p| min_samples.min(max - count[p as usize])));
            lens_starts(&mut v.starts, queue.len(), |i| v.added[i] as u64 * dof);
            self.pipe.acc.begin(2 * np);
            let pass = VariancePass { tile, pixels: queue, state: &v.queues.state };
            let lens = Lens::PerPoint(&v.starts);
            self.pipe.run(scene, lens.total(queue.len()), Kind::Camera, |ks, rays| {
                camera::generate_variance(scene, pass, lens, ks, rays)
            });
            if self.pipe.aborted {
                return;
            }
            self.tile.collect_heat(&self.pipe.acc.heat, 2);
            let t = Instant::now();
            let before = v.queues.active.len();
            converge::step(threshold, max, width, (&self.pipe.acc.sums, &v.added), &mut v.queues, &mut v.error);
            self.pipe.meter.lap(Stage::Refine, before, v.queues.active.len(), Traversal::default(), t);
        }
        let state = &v.queues.state;
        self.pipe.meter.stats.aa_refined_pixels += state.rounds.iter().filter(|&&r| r > 1).count() as u64;
        converge::finish(&v.queues, &mut self.tile.out);
        self.tile.heat.level.copy_from_slice(&state.rounds);
    }
}
