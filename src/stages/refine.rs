//! Adaptive anti-aliasing decisions (paper §2.1): compares a pixel's centre with the
//! mean of its corners, then each refinement level's estimate with the previous one,
//! and keeps in the refinement queue only the pixels whose estimates still differ by
//! more than eps in display values.
//!
//! Final values: a pixel never refined gets 2/3·centre + 1/3·corner mean (the 2D
//! midpoint/trapezoid combination, exact for quadratic variation across the pixel; the
//! two differ by at most eps anyway). A refined pixel gets the mean of all its
//! refinement samples, which are stratified over the whole pixel: the centre and the
//! corners (boundary points, shared with neighbours) only decide, they are not averaged
//! in, so the estimate is not biased towards the corners.

use glam::Vec3;

use crate::color::srgb_encode;
use crate::queue::RefineQueues;

/// The difference the paper's eps is compared with: the maximum over R, G, B of the
/// absolute difference of display values (the PNG's sRGB transform, clamped to [0, 1]).
#[inline]
pub fn display_diff(a: Vec3, b: Vec3) -> f32 {
    let d = |x: f32, y: f32| (srgb_encode(x) - srgb_encode(y)).abs();
    d(a.x, b.x).max(d(a.y, b.y)).max(d(a.z, b.z))
}

/// The first decision. Pixels whose centre differs from their corner mean by more than
/// their `eps` (one per tile pixel: `render.aa.eps`, or more for a blurred pixel with
/// DOF-aware AA) are put in `q.active` (tile pixel indices, ascending); the others get
/// their final value in `out`. `q.state` gets every pixel's starting state.
pub fn start(eps: &[f32], centre: &[Vec3], corner_mean: &[Vec3], q: &mut RefineQueues, out: &mut [Vec3]) {
    let n = centre.len();
    let (state, queue) = (&mut q.state, &mut q.active);
    state.clear();
    queue.clear();
    for p in 0..n {
        state.push(corner_mean[p], Vec3::ZERO, 0, 0);
        if display_diff(centre[p], corner_mean[p]) > eps[p] {
            queue.push(p as u32);
        } else {
            // Saturating: the two rounded weights sum to just above 1, so two values
            // at f32::MAX would overflow.
            out[p] = (centre[p] * (2.0 / 3.0) + corner_mean[p] * (1.0 / 3.0)).min(Vec3::splat(f32::MAX));
        }
    }
}

/// The decision after level `level`: `estimates[p]` holds the level's mean for each
/// queued pixel p. Every queued pixel's samples are added to its value in `out`; when
/// `may_stop`, pixels whose estimate agrees with the previous one within their `eps`
/// leave `q.active`.
pub fn step(eps: &[f32], level: u32, may_stop: bool, estimates: &[Vec3], q: &mut RefineQueues, out: &mut [Vec3]) {
    let (state, queue) = (&mut q.state, &mut q.active);
    let n = 1u32 << level;
    queue.index.retain(|&p| {
        let p = p as usize;
        let e = estimates[p];
        // Saturating, as the film's sums are (stages::film::accumulate).
        // The product saturates too: a mean near f32::MAX times 2^level overflows alone.
        let max = Vec3::splat(f32::MAX);
        state.sum[p] = (state.sum[p] + (e * n as f32).min(max)).min(max);
        state.count[p] += n;
        state.level[p] = level as u8;
        out[p] = state.sum[p] / state.count[p] as f32;
        let settled = may_stop && display_diff(e, state.prev[p]) <= eps[p];
        state.prev[p] = e;
        !settled
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_diff_uses_clamped_srgb_max_channel() {
        assert_eq!(display_diff(Vec3::splat(2.0), Vec3::splat(5.0)), 0.0, "both clamp to white");
        let d = display_diff(Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.2));
        assert!((d - srgb_encode(0.2)).abs() < 1e-6);
    }

    #[test]
    fn start_and_step_follow_the_paper() {
        let centre = [Vec3::ZERO, Vec3::ONE];
        let corners = [Vec3::splat(0.001), Vec3::ZERO];
        let (mut rq, mut out) = (RefineQueues::default(), [Vec3::splat(-1.0); 2]);
        let eps = [0.05; 2];
        start(&eps, &centre, &corners, &mut rq, &mut out);
        assert_eq!(rq.active.index, vec![1], "only the pixel whose centre differs");
        assert!((out[0] - Vec3::splat(0.001 / 3.0)).length() < 1e-7);
        // Level 2 differs from the corner mean (0): stays. Level 3 agrees with level 2: leaves.
        step(&eps, 2, true, &[Vec3::ZERO, Vec3::splat(0.5)], &mut rq, &mut out);
        assert_eq!(rq.active.index, vec![1]);
        step(&eps, 3, true, &[Vec3::ZERO, Vec3::splat(0.5)], &mut rq, &mut out);
        assert!(rq.active.is_empty());
        assert_eq!(rq.state.count[1], 12);
        assert_eq!(rq.state.level[1], 3);
        assert!((out[1] - Vec3::splat(0.5)).length() < 1e-6);
    }
}
