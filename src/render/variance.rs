//! The variance-driven anti-aliasing rounds of a tile: a first round of `min_samples`
//! in every pixel, then rounds of up to `min_samples` more in the pixels the converge
//! stage keeps, until none is left or every one has `render.aa.samples`.
//!
//! `render.aa.mode = "auto"` runs a pilot (`render/auto.rs`, one round in one pixel of
//! every 8×8 block, `Worker::pilot_tile`) whose errors [`variance_samples`] and
//! [`uniform_samples`] turn into each method's samples, and renders the cheaper
//! ([`AutoChoice::from_pilot`]): variance's rounds, or uniform mode's tiles at N.

use std::time::Instant;

use super::adaptive::lens_starts;
use super::meter::Kind;
use super::Worker;
use crate::accel::tracer::Coherence;
use crate::accel::Traversal;
use crate::film::Tile;
use crate::queue::VarianceQueues;
use crate::scene::Scene;
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

/// Auto mode, uniform: the samples every pixel gets, from the pilot's errors (each
/// pixel's [`converge::pixel_error`] after `n0` samples, in a fixed order). Error falls
/// as 1/√n, so the threshold asks for n*_p = n0·(e_p/threshold)² samples in pixel p (in
/// n0..=max), which leave it a squared error of e_p²·n0/n*_p; uniform sampling has the
/// same mean squared error with N = mean(e²) / mean(e²/n*_p) samples everywhere (in
/// n0..=max). A noiseless pilot gives n0.
pub fn uniform_samples(errors: &[f32], n0: u32, threshold: f32, max: u32) -> f64 {
    let e2: Vec<f64> = errors.iter().map(|&e| if e.is_finite() { (e as f64).powi(2) } else { 0.0 }).collect();
    let mean_e2 = e2.iter().sum::<f64>();
    let kept = e2.iter().zip(errors).map(|(&e2, &e)| e2 / samples_asked(e, n0, threshold, max)).sum::<f64>();
    let n = if mean_e2 > 0.0 { mean_e2 / kept } else { n0 as f64 };
    n.clamp(n0.min(max) as f64, max as f64)
}

/// Auto mode: the mean samples a pixel variance sampling would spend, from the pilot's
/// errors: n*_p of [`uniform_samples`] in whole rounds of [`auto_round`] (at most
/// `max`), averaged. One round for an empty pilot.
pub fn variance_samples(errors: &[f32], n0: u32, threshold: f32, max: u32) -> f64 {
    let round = auto_round(n0, max) as f64;
    let spent = |e| ((samples_asked(e, n0, threshold, max) / round).ceil() * round).min(max as f64);
    match errors.len() {
        0 => round,
        n => errors.iter().map(|&e| spent(e)).sum::<f64>() / n as f64,
    }
}

/// n*_p: the samples the threshold asks for in a pixel whose error after `n0` samples is
/// `e`, in n0..=max (a non-finite error counts as none).
fn samples_asked(e: f32, n0: u32, threshold: f32, max: u32) -> f64 {
    let e = if e.is_finite() { e as f64 } else { 0.0 };
    let n = if threshold > 0.0 { n0 as f64 * (e / threshold as f64).powi(2) } else { f64::INFINITY };
    n.clamp(n0.min(max) as f64, max as f64)
}

/// Samples a round of auto mode's variance sampling adds: [`AUTO_ROUND`] when `max`
/// leaves four such rounds ([`room_to_adapt`]) and the pilot's `n0` is no more, else
/// `n0`. Fewer, larger rounds: each round is a pass of the tile, and its rays, spent
/// in the few pixels left (edges, penumbrae), cost more than the first round's.
pub fn auto_round(n0: u32, max: u32) -> u32 {
    if n0 < AUTO_ROUND && room_to_adapt(max, AUTO_ROUND) {
        AUTO_ROUND
    } else {
        n0
    }
}

/// Auto mode's variance rounds, where `samples` allows ([`auto_round`]). Measured on
/// the bunny (96×72, 4 shadow rays, rounds to 64 samples at threshold 0.05, 2 threads,
/// 5 runs each): rounds of 4 reached FLIP 0.0048 and rounds of 8 0.0042 in the same
/// time (0.19–0.24 s); the rays of the later rounds, in edge pixels scattered over the
/// tile, cost 2–3.5× the first round's (shade 2×, intersect 3.4× the node visits).
pub const AUTO_ROUND: u32 = 8;

/// Whether `samples` leaves variance sampling at least four rounds of `min_samples` to
/// adapt in: with fewer it took 1.4–1.7× uniform's time to the study's 4-spp targets.
fn room_to_adapt(samples: u32, min_samples: u32) -> bool {
    samples as u64 >= 4 * min_samples as u64
}

/// Auto mode: variance sampling is chosen when the pilot predicts it spends at most this
/// share of the samples uniform sampling needs for the same mean squared error (and
/// `samples` leaves four rounds). Chosen, not measured: it keeps near-ties uniform,
/// whose single pass has no rounds to schedule.
pub const VARIANCE_MARGIN: f64 = 0.8;

impl Rounds {
    /// The rounds an auto choice renders.
    pub fn of(c: &AutoChoice) -> Rounds {
        Rounds { threshold: c.threshold, min_samples: c.min_samples, max: c.max }
    }
}

impl AutoChoice {
    /// Uniform sampling at `max` samples, chosen without a pilot: `max` is at most the
    /// pilot's `min_samples`, where [`AutoChoice::from_pilot`] can choose nothing else.
    pub fn without_pilot(max: u32) -> AutoChoice {
        AutoChoice {
            chose: "uniform",
            why: "samples at most min_samples, or threshold 0: one uniform pass at samples, no pilot needed",
            threshold: 0.0,
            min_samples: max,
            max,
            pilot_pixels: 0,
            uniform_spp: max as f64,
            variance_spp: max as f64,
            dithered: false,
            blurred: 0.0,
        }
    }

    /// From the pilot's `errors` (after `n0` samples): variance sampling in rounds of
    /// [`auto_round`] when it spends at most [`VARIANCE_MARGIN`] of uniform's samples
    /// ([`variance_samples`] against [`uniform_samples`]) and `max` leaves four rounds,
    /// else uniform sampling at the samples the errors call for.
    pub fn from_pilot(errors: &[f32], n0: u32, threshold: f32, max: u32) -> AutoChoice {
        let (spp, mean_np) =
            (uniform_samples(errors, n0, threshold, max), variance_samples(errors, n0, threshold, max));
        let (pilot_pixels, uniform_spp, variance_spp) = (errors.len(), spp, mean_np);
        let round = auto_round(n0, max);
        if room_to_adapt(max, round) && mean_np <= VARIANCE_MARGIN * spp.ceil() {
            let why = "uneven noise: the pilot's variance sampling needs at most 0.8 of uniform's samples";
            return AutoChoice {
                chose: "variance",
                why,
                threshold,
                min_samples: round,
                max,
                pilot_pixels,
                uniform_spp,
                variance_spp,
                dithered: false,
                blurred: 0.0,
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
            dithered: false,
            blurred: 0.0,
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
        let pilot = |p: &u32| {
            let (x, y) = at(*p);
            x % PILOT_BLOCK == half && y % PILOT_BLOCK == half
        };
        converge::start_some(np, (0..np as u32).filter(pilot), &mut v.queues);
        let queue = &v.queues.active.index;
        if queue.is_empty() {
            return Vec::new();
        }
        lens_starts(&mut v.starts, queue.len(), |_| n0 as u64 * dof);
        self.pipe.acc.begin(2 * np);
        let pass = VariancePass { tile, pixels: queue, state: &v.queues.state };
        let lens = Lens::PerPoint(&v.starts);
        // One pixel in 64: scattered rays.
        self.pipe.run(scene, lens.total(queue.len()), (Kind::Camera, Coherence::Bounce), |ks, rays| {
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
            // The first round samples every pixel in turn; later ones the pixels left,
            // scattered over the tile.
            let order = if queue.len() == np { Coherence::Camera } else { Coherence::Bounce };
            self.pipe.run(scene, lens.total(queue.len()), (Kind::Camera, order), |ks, rays| {
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
        // Even error twice the threshold: the threshold asks for 4·16 everywhere.
        assert_eq!(uniform_samples(&[0.02; 100], 16, 0.01, 256), 64.0);
        // 1 pixel in 100 ten times the threshold: it asks for 256 (max), the others for
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
        // A pilot of more samples than the cap (min_samples 2, samples 1) asks for the cap.
        assert_eq!(uniform_samples(&[0.05; 10], 2, 0.01, 1), 1.0);
        assert_eq!(variance_samples(&[0.05; 10], 2, 0.01, 1), 1.0);
        // Asked for 20 where variance's rounds of 16 would spend 32: uniform matches what
        // the threshold asks for, not the rounds' overshoot.
        let e = 0.01 * (20.0f32 / 16.0).sqrt();
        assert!((uniform_samples(&[e; 10], 16, 0.01, 256) - 20.0).abs() < 1e-3);
        assert_eq!(variance_samples(&[e; 10], 16, 0.01, 256), 32.0);
    }

    #[test]
    fn the_pilot_picks_variance_where_its_rounds_spend_under_the_margin_of_uniforms_samples() {
        // Even error: variance spends what uniform does (64 a pixel), so uniform.
        let c = AutoChoice::from_pilot(&[0.02; 100], 16, 0.01, 256);
        assert_eq!((c.chose, Rounds::of(&c)), ("uniform", Rounds { threshold: 0.0, min_samples: 64, max: 64 }));
        assert_eq!((c.uniform_spp, c.variance_spp), (64.0, 64.0));
        // One pixel in 100 ten times the threshold: variance 18.4 a pixel on average,
        // uniform 223: variance, in rounds of 16 to the threshold.
        let mut errors = vec![0.001; 99];
        errors.push(0.1);
        let c = AutoChoice::from_pilot(&errors, 16, 0.01, 256);
        assert_eq!((c.chose, Rounds::of(&c)), ("variance", Rounds { threshold: 0.01, min_samples: 16, max: 256 }));
        assert_eq!(c.variance_spp, (99.0 * 16.0 + 256.0) / 100.0);
        // The same errors with room for three rounds only: uniform.
        assert_eq!(AutoChoice::from_pilot(&errors, 16, 0.01, 48).chose, "uniform");
        // A pilot of 4 samples: rounds of 8 where `samples` leaves four of them, its
        // predictions in whole rounds of 8 (the noisy pixel's 400 capped at 256).
        let c = AutoChoice::from_pilot(&errors, 4, 0.01, 256);
        assert_eq!((c.chose, Rounds::of(&c)), ("variance", Rounds { threshold: 0.01, min_samples: 8, max: 256 }));
        assert_eq!(c.variance_spp, (99.0 * 8.0 + 256.0) / 100.0);
        // With 16 samples at most, rounds of the pilot's 4.
        let c = AutoChoice::from_pilot(&errors, 4, 0.01, 16);
        assert_eq!((c.chose, Rounds::of(&c)), ("variance", Rounds { threshold: 0.01, min_samples: 4, max: 16 }));
    }

    #[test]
    fn without_a_pilot_is_what_any_pilot_gives_at_samples_up_to_min_samples() {
        // Whatever the pilot's errors and threshold, `samples` ≤ `min_samples` leaves
        // uniform at `samples`: the choice auto makes without rendering a pilot.
        let pilots: [&[f32]; 5] = [&[], &[0.0; 8], &[0.02; 8], &[0.001, 0.5, f32::NAN, 3.0], &[f32::INFINITY]];
        for (n0, max) in [(2, 1), (2, 2), (4, 3), (4, 4), (16, 16), (64, 9)] {
            let none = AutoChoice::without_pilot(max);
            for errors in pilots {
                for threshold in [0.0, 0.01, 0.1, 10.0] {
                    let c = AutoChoice::from_pilot(errors, n0, threshold, max);
                    assert_eq!((c.chose, Rounds::of(&c)), (none.chose, Rounds::of(&none)), "{n0} {max} {errors:?}");
                }
            }
        }
    }

    #[test]
    fn auto_rounds_are_eight_where_samples_leave_four_of_them() {
        assert_eq!((auto_round(4, 31), auto_round(4, 32), auto_round(2, 256)), (4, 8, 8));
        // A pilot of 8 or more: its own rounds.
        assert_eq!((auto_round(8, 256), auto_round(16, 256), auto_round(12, 40)), (8, 16, 12));
    }
}
