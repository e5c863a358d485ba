//! The variance-driven anti-aliasing rounds of a tile: a first round of `min_samples`
//! in every pixel, then rounds of up to `min_samples` more in the pixels the converge
//! stage keeps, until none is left or every one has `render.aa.samples`.
//!
//! `render.aa.mode = "auto"` renders variance's rounds where the study's map says they
//! pay without a pilot ([`variance_pays`]); elsewhere its pilot (`render/auto.rs`, one
//! round in one pixel of every 8×8 block, `Worker::pilot_tile`) gives errors from which
//! [`variance_samples`] and [`uniform_samples`] predict each method's samples, and the
//! cheaper is rendered ([`AutoChoice::from_pilot`]): variance's rounds, or uniform
//! mode's tiles at N.

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
use crate::stats::{AutoChoice, Stage};

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

/// The rounds of a variance-driven render: a pixel stops once its error is below
/// `threshold` or it has `max` samples; rounds add up to `min_samples`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rounds {
    /// The error below which a pixel stops.
    pub threshold: f32,
    /// Samples per round.
    pub min_samples: u32,
    /// The most samples a pixel gets.
    pub max: u32,
}

/// Side of the blocks the pilot takes one pixel of.
pub const PILOT_BLOCK: u32 = 8;

/// The auto mode's rule without a pilot, from the study's map (docs/adaptive.md):
/// variance sampling wins where a pixel's noise comes from more than its area (paths
/// that bounce, a lens), which stratifying the film position does not reduce, when
/// `samples` leaves it at least four rounds to adapt in ([`room_to_adapt`]). Elsewhere
/// (a pinhole through a Whitted render) the pilot decides ([`AutoChoice::from_pilot`]).
/// Returns why variance is chosen without a pilot, or `None`.
pub fn variance_pays(scene: &Scene) -> Option<&'static str> {
    let s = &scene.settings;
    let AaMode::Auto { min_samples, .. } = s.aa_mode else { return None };
    if !room_to_adapt(s.aa_samples, min_samples) {
        None
    } else if s.path() {
        Some("the path transport: noise from every bounce")
    } else if scene.camera.aperture > 0.0 {
        Some("an open aperture: noise from the lens")
    } else {
        None
    }
}

/// Auto mode, uniform: the samples every pixel gets, from the pilot's errors (each
/// pixel's [`converge::pixel_error`] after `n0` samples, in a fixed order). Error falls
/// as 1/√n, so variance sampling to `threshold` would give pixel p n_p = n0·(e_p/threshold)²
/// samples (whole rounds, in n0..=max) and leave it a squared error of e_p²·n0/n_p;
/// uniform sampling has the same mean squared error with N = mean(e²) / mean(e²/n_p)
/// samples everywhere (in n0..=max). A noiseless pilot gives n0.
pub fn uniform_samples(errors: &[f32], n0: u32, threshold: f32, max: u32) -> f64 {
    let e2: Vec<f64> = errors.iter().map(|&e| if e.is_finite() { (e as f64).powi(2) } else { 0.0 }).collect();
    let mean_e2 = e2.iter().sum::<f64>();
    let kept = e2.iter().zip(errors).map(|(&e2, &e)| e2 / samples_needed(e, n0, threshold, max)).sum::<f64>();
    let n = if mean_e2 > 0.0 { mean_e2 / kept } else { n0 as f64 };
    n.clamp(n0 as f64, max as f64)
}

/// Auto mode: the mean samples a pixel variance sampling would spend, from the pilot's
/// errors (n_p of [`uniform_samples`], averaged). n0 for an empty pilot.
pub fn variance_samples(errors: &[f32], n0: u32, threshold: f32, max: u32) -> f64 {
    match errors.len() {
        0 => n0 as f64,
        n => errors.iter().map(|&e| samples_needed(e, n0, threshold, max)).sum::<f64>() / n as f64,
    }
}

/// n_p: the samples variance sampling gives a pixel whose error after `n0` samples is
/// `e`, in whole rounds of `n0`, at most `max` (a non-finite error counts as none).
fn samples_needed(e: f32, n0: u32, threshold: f32, max: u32) -> f64 {
    let e = if e.is_finite() { e as f64 } else { 0.0 };
    let n = if threshold > 0.0 { n0 as f64 * (e / threshold as f64).powi(2) } else { f64::INFINITY };
    let rounds = (n / n0 as f64).ceil().max(1.0);
    (rounds * n0 as f64).min(max as f64)
}

/// Whether `samples` leaves variance sampling at least four rounds of `min_samples` to
/// adapt in: with fewer it took 1.4–1.7× uniform's time to the study's 4-spp targets.
fn room_to_adapt(samples: u32, min_samples: u32) -> bool {
    samples as u64 >= 4 * min_samples as u64
}

/// Auto mode through a pinhole under Whitted transport: variance sampling is chosen when
/// the pilot predicts it spends at most this share of the samples uniform sampling needs
/// for the same mean squared error (and `samples` leaves four rounds). Chosen, not
/// measured: it keeps near-ties uniform, whose single pass has no rounds to schedule.
pub const VARIANCE_MARGIN: f64 = 0.8;

impl Rounds {
    /// The rounds an auto choice renders.
    pub fn of(c: &AutoChoice) -> Rounds {
        Rounds { threshold: c.threshold, min_samples: c.min_samples, max: c.max }
    }
}

impl AutoChoice {
    /// Variance sampling to `threshold` in rounds of `n0`, up to `max`, for `why`.
    pub fn variance(why: &'static str, threshold: f32, n0: u32, max: u32) -> AutoChoice {
        let (pilot_pixels, uniform_spp, variance_spp) = (0, None, None);
        AutoChoice { chose: "variance", why, threshold, min_samples: n0, max, pilot_pixels, uniform_spp, variance_spp }
    }

    /// From the pilot's `errors`: variance sampling in rounds of `n0` when it spends at
    /// most [`VARIANCE_MARGIN`] of uniform's samples ([`variance_samples`] against
    /// [`uniform_samples`]) and `max` leaves four rounds, else uniform sampling at the
    /// samples the errors call for.
    pub fn from_pilot(errors: &[f32], n0: u32, threshold: f32, max: u32) -> AutoChoice {
        let (spp, mean_np) =
            (uniform_samples(errors, n0, threshold, max), variance_samples(errors, n0, threshold, max));
        let (pilot_pixels, uniform_spp, variance_spp) = (errors.len(), Some(spp), Some(mean_np));
        if room_to_adapt(max, n0) && mean_np <= VARIANCE_MARGIN * spp.ceil() {
            let why = "uneven noise: the pilot's variance sampling needs at most 0.8 of uniform's samples";
            return AutoChoice {
                pilot_pixels,
                uniform_spp,
                variance_spp,
                ..AutoChoice::variance(why, threshold, n0, max)
            };
        }
        let n = spp.ceil() as u32;
        let why = "even noise: uniform's one stratified pattern needs no more samples than variance's rounds";
        AutoChoice {
            chose: "uniform",
            why,
            threshold: 0.0,
            min_samples: n,
            max: n,
            pilot_pixels,
            uniform_spp,
            variance_spp,
        }
    }
}

impl Worker<'_> {
    /// The auto mode's pilot over one tile: one round of `n0` samples in the tile's
    /// pilot pixels (one per 8×8 block of the image). Returns (image pixel, error) pairs.
    pub(super) fn pilot_tile(&mut self, scene: &Scene, tile: &Tile, n0: u32) -> Vec<(u32, f32)> {
        let (np, dof) = (tile.pixels(), scene.settings.dof_samples as u64);
        let tw = tile.x1 - tile.x0;
        let at = |p: u32| (tile.x0 + p % tw, tile.y0 + p / tw);
        let half = PILOT_BLOCK / 2;
        let v = &mut self.var;
        converge::start(np, &mut v.queues);
        v.queues.active.index.retain(|&p| {
            let (x, y) = at(p);
            x % PILOT_BLOCK == half && y % PILOT_BLOCK == half
        });
        let queue = &v.queues.active.index;
        if queue.is_empty() {
            return Vec::new();
        }
        lens_starts(&mut v.starts, queue.len(), |_| n0 as u64 * dof);
        self.pipe.acc.begin(2 * np);
        let pass = VariancePass { tile, pixels: queue, state: &v.queues.state };
        let lens = Lens::PerPoint(&v.starts);
        self.pipe.run(scene, lens.total(queue.len()), Kind::Camera, |ks, rays| {
            camera::generate_variance(scene, pass, lens, ks, rays)
        });
        let sums = &self.pipe.acc.sums;
        queue
            .iter()
            .map(|&p| {
                let (x, y) = at(p);
                let p = p as usize;
                (y * scene.settings.width + x, converge::pixel_error(sums[2 * p], sums[2 * p + 1], n0))
            })
            .collect()
    }

    /// Variance-driven AA on one tile, in `rounds`.
    pub(super) fn variance_tile(&mut self, scene: &Scene, tile: &Tile, rounds: Rounds) {
        let Rounds { threshold, min_samples, max } = rounds;
        let (np, dof) = (tile.pixels(), scene.settings.dof_samples as u64);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_samples_match_variance_samplings_mean_squared_error() {
        // Even error twice the threshold: variance gives every pixel 4 rounds, so does
        // uniform.
        assert_eq!(uniform_samples(&[0.02; 100], 16, 0.01, 256), 64.0);
        // 1 pixel in 100 ten times the threshold: variance gives it 256 (max), the others
        // 16, leaving squared errors 0.01·16/256 and 1e-6; uniform matches their mean
        // (223 samples).
        let mut errors = vec![0.001; 99];
        errors.push(0.1);
        let want = (99.0 * 1e-6 + 0.01) / (99.0 * 1e-6 / 16.0 + 0.01 / 256.0);
        let got = uniform_samples(&errors, 16, 0.01, 256);
        assert!((got / want - 1.0).abs() < 1e-5, "{got} vs {want}");
        // Noiseless: the pilot's count; a threshold of 0: the most.
        assert_eq!(uniform_samples(&[0.0; 10], 16, 0.01, 256), 16.0);
        assert_eq!(uniform_samples(&[0.05; 10], 16, 0.0, 256), 256.0);
    }

    #[test]
    fn the_pilot_picks_variance_where_its_rounds_spend_under_the_margin_of_uniforms_samples() {
        // Even error: variance spends what uniform does (64 a pixel), so uniform.
        let c = AutoChoice::from_pilot(&[0.02; 100], 16, 0.01, 256);
        assert_eq!((c.chose, Rounds::of(&c)), ("uniform", Rounds { threshold: 0.0, min_samples: 64, max: 64 }));
        assert_eq!((c.uniform_spp, c.variance_spp), (Some(64.0), Some(64.0)));
        // One pixel in 100 ten times the threshold: variance 18.4 a pixel on average,
        // uniform 223: variance, in rounds of 16 to the threshold.
        let mut errors = vec![0.001; 99];
        errors.push(0.1);
        let c = AutoChoice::from_pilot(&errors, 16, 0.01, 256);
        assert_eq!((c.chose, Rounds::of(&c)), ("variance", Rounds { threshold: 0.01, min_samples: 16, max: 256 }));
        assert_eq!(c.variance_spp, Some((99.0 * 16.0 + 256.0) / 100.0));
        // The same errors with room for three rounds only: uniform.
        assert_eq!(AutoChoice::from_pilot(&errors, 16, 0.01, 48).chose, "uniform");
    }
}
