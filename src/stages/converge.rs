//! Variance-driven anti-aliasing decisions, as production renderers make them (Cycles'
//! adaptive sampling): each pixel keeps two half-buffers, the sums of its even and of its
//! odd samples; their difference estimates the error of the pixel's mean, and a round of
//! samples goes only to pixels whose estimate is above the threshold, or that border
//! one (the 3×3 neighbourhood, within the tile), so that a noisy region's edge is not
//! cut off by one lucky pixel.
//!
//! Unlike the paper's corner test, the decision needs no model of the pixel (corners,
//! centre): it sees noise from any source (edges, penumbrae, glossy and path-traced
//! light), and it never stops a pixel whose two halves disagree.

use glam::Vec3;

use crate::queue::VarianceQueues;

/// The error of a pixel's mean, from its half-buffers `even` and `odd` (sums) and its
/// sample `count` (≥ 2; the even half has the odd sample when it is odd): Cycles'
/// criterion, the difference between the whole mean and a half's mean (half the
/// difference of the two halves' means), summed over R, G, B and divided by the square
/// root of the summed mean, so that the threshold reads as a relative error that is
/// stricter in the dark, where the eye sees noise best.
#[inline]
pub fn pixel_error(even: Vec3, odd: Vec3, count: u32) -> f32 {
    let (ne, no) = (count.div_ceil(2) as f32, (count / 2) as f32);
    let diff = (even / ne - odd / no).abs() * 0.5;
    let mean = (even + odd) / count as f32;
    (diff.x + diff.y + diff.z) / (1e-4 + (mean.x + mean.y + mean.z).max(0.0).sqrt())
}

/// Starts a tile of `n` pixels: every pixel empty and queued.
pub fn start(n: usize, q: &mut VarianceQueues) {
    start_some(n, 0..n as u32, q);
}

/// Starts a tile of `n` pixels, every pixel empty, with only `queued` (ascending tile
/// pixel indices) queued: the auto pilot's one pixel per 8×8 block.
pub fn start_some(n: usize, queued: impl IntoIterator<Item = u32>, q: &mut VarianceQueues) {
    q.state.reset(n, Vec3::ZERO, Vec3::ZERO, 0, 0);
    q.active.refill(queued);
}

/// The decision after a round: `sums` holds the round's sums, slot 2p for pixel p's
/// even samples and 2p + 1 for its odd ones, and `added[i]` the samples the round gave
/// queued pixel `q.active[i]`. Adds them to the half-buffers, then queues the pixels
/// below `max` samples that have, in their 3×3 neighbourhood in the tile (`width`
/// pixels wide), one whose error is not below `threshold`. `error` is scratch space.
pub fn step(
    threshold: f32,
    max: u32,
    width: usize,
    (sums, added): (&[Vec3], &[u32]),
    q: &mut VarianceQueues,
    error: &mut Vec<f32>,
) {
    let (state, active) = (&mut q.state, &mut q.active);
    // Saturating, as the film's sums are (stages::film::accumulate).
    let max_value = Vec3::splat(f32::MAX);
    for (&p, &n) in active.index.iter().zip(added) {
        let p = p as usize;
        state.even[p] = (state.even[p] + sums[2 * p]).min(max_value);
        state.odd[p] = (state.odd[p] + sums[2 * p + 1]).min(max_value);
        state.count[p] += n;
        state.rounds[p] = state.rounds[p].saturating_add(1);
    }
    let n = state.len();
    error.clear();
    error.extend((0..n).map(|p| pixel_error(state.even[p], state.odd[p], state.count[p])));
    // NaN compares false: a pixel whose error is not a number is not converged.
    let noisy = |p: usize| error[p] >= threshold || error[p].is_nan();
    let height = n / width;
    active.clear();
    for p in 0..n {
        if state.count[p] >= max {
            continue;
        }
        let (x, y) = (p % width, p / width);
        let xs = x.saturating_sub(1)..(x + 2).min(width);
        let mut ys = y.saturating_sub(1)..(y + 2).min(height);
        if ys.any(|yy| xs.clone().any(|xx| noisy(yy * width + xx))) {
            active.push(p as u32);
        }
    }
}

/// Every pixel's final value: the mean of all its samples.
pub fn finish(q: &VarianceQueues, out: &mut [Vec3]) {
    let s = &q.state;
    for (p, o) in out.iter_mut().enumerate().take(s.len()) {
        *o = ((s.even[p] + s.odd[p]).min(Vec3::splat(f32::MAX))) / s.count[p].max(1) as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_is_half_the_halves_difference_over_the_root_of_the_mean() {
        // Means 1 and 0.5 over 4 samples: difference 0.5 a channel, error 3·0.25 / √2.25.
        let e = pixel_error(Vec3::splat(2.0), Vec3::splat(1.0), 4);
        assert!((e - 0.75 / (1e-4 + 2.25f32.sqrt())).abs() < 1e-6, "{e}");
        assert_eq!(pixel_error(Vec3::splat(3.0), Vec3::splat(3.0), 6), 0.0);
        // An odd count: the even half has 2 samples, the odd half 1.
        assert_eq!(pixel_error(Vec3::splat(2.0), Vec3::splat(1.0), 3), 0.0);
    }

    #[test]
    fn a_noisy_pixel_keeps_its_neighbours_and_stops_at_max() {
        // A 4×3 tile; pixel 5 (x 1, y 1) is noisy, the rest agree.
        let (mut q, mut err) = (VarianceQueues::default(), Vec::new());
        start(12, &mut q);
        let mut sums = vec![Vec3::ONE; 24];
        sums[10] = Vec3::splat(4.0);
        step(0.01, 8, 4, (&sums, &[4; 12]), &mut q, &mut err);
        assert_eq!(q.active.index, vec![0, 1, 2, 4, 5, 6, 8, 9, 10], "the 3×3 around pixel 5");
        assert_eq!(q.state.count[3], 4);
        // The queued pixels get 4 more and reach max: nothing is left, whatever the error.
        let added = vec![4; q.active.len()];
        step(0.01, 8, 4, (&sums, &added), &mut q, &mut err);
        assert!(q.active.is_empty());
        assert_eq!((q.state.count[5], q.state.rounds[5], q.state.rounds[3]), (8, 2, 1));
        let mut out = vec![Vec3::ZERO; 12];
        finish(&q, &mut out);
        assert!((out[5] - Vec3::splat(10.0 / 8.0)).length() < 1e-6);
        assert!((out[3] - Vec3::splat(0.5)).length() < 1e-6);
    }

    #[test]
    fn threshold_zero_samples_every_pixel_to_max() {
        let (mut q, mut err) = (VarianceQueues::default(), Vec::new());
        start(6, &mut q);
        step(0.0, 16, 3, (&[Vec3::ONE; 12], &[8; 6]), &mut q, &mut err);
        assert_eq!(q.active.len(), 6, "an error of 0 is not below a threshold of 0");
    }
}
