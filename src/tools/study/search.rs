//! The study's decisions as pure functions: the cheapest setting of a method that reaches
//! a target error, and the method that wins a target. No rendering here, so the tests
//! can check them on hand-made rows whose answer is known.

use serde::Serialize;
use std::cmp::Ordering;

/// What one render of a setting measured: its error and its two costs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measure {
    /// Mean FLIP against the reference (NaN: not measured, never reaches a target).
    pub error: f64,
    /// Median wall-clock render seconds.
    pub seconds: f64,
    /// Rays traced, all kinds (exact: the renders are deterministic).
    pub rays: u64,
}

/// Which cost the search minimises.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Cost {
    /// Wall-clock seconds (what a user waits for; noisy on a shared machine).
    Seconds,
    /// Rays traced (exact, but blind to what a ray costs and to per-pixel overhead).
    Rays,
}

impl Cost {
    /// Both costs, in report order.
    pub const ALL: [Cost; 2] = [Cost::Seconds, Cost::Rays];

    /// The cost of a measure, as a number to compare; rays are exact in an f64 below 2^53.
    pub fn of(self, m: &Measure) -> f64 {
        match self {
            Cost::Seconds => m.seconds,
            Cost::Rays => m.rays as f64,
        }
    }

    /// The label in the reports.
    pub fn label(self) -> &'static str {
        match self {
            Cost::Seconds => "seconds",
            Cost::Rays => "rays",
        }
    }
}

/// The index of the cheapest measure whose error is at most `target`, or `None` when no
/// measure reaches it (none at all, a NaN target, or every error above it or NaN).
///
/// Ties, in order: the lower cost wins; at equal cost the lower error; at equal cost and
/// error the earlier measure (grid order), so the answer never depends on sorting.
/// A measure with a NaN error or a NaN cost never qualifies.
pub fn cheapest(measures: &[Measure], target: f64, cost: Cost) -> Option<usize> {
    let mut best: Option<usize> = None;
    for (i, m) in measures.iter().enumerate() {
        let c = cost.of(m);
        // A NaN error or target compares as neither less nor equal: dropped.
        let reaches = matches!(m.error.partial_cmp(&target), Some(Ordering::Less | Ordering::Equal));
        if !reaches || c.is_nan() {
            continue;
        }
        let better = match best {
            None => true,
            Some(b) => {
                let (bc, be) = (cost.of(&measures[b]), measures[b].error);
                c < bc || (c == bc && m.error < be)
            }
        };
        if better {
            best = Some(i);
        }
    }
    best
}

/// One method's answer for a target: its cheapest qualifying measure, if any.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Entry {
    /// The method's position in the study's method list.
    pub method: usize,
    /// The cheapest qualifying measure of that method.
    pub measure: Measure,
}

/// The winning method of a target under `cost`: the entry of least cost; ties go to the
/// lower error, then to the method earlier in the list (uniform comes first, so an
/// adaptive method must be strictly cheaper to win). `None` when no entry is given.
pub fn winner(entries: &[Entry], cost: Cost) -> Option<usize> {
    let measures: Vec<Measure> = entries.iter().map(|e| e.measure).collect();
    cheapest(&measures, f64::INFINITY, cost).map(|i| entries[i].method)
}

/// The measures whose seconds are within `margin` times the least of them: the
/// contenders for a target, whose single-run seconds alone cannot order them on a noisy
/// machine. NaN seconds never contend; none for no finite seconds.
pub fn contenders(measures: &[Measure], margin: f64) -> Vec<usize> {
    let least = measures.iter().map(|m| m.seconds).filter(|s| !s.is_nan()).fold(f64::INFINITY, f64::min);
    if !least.is_finite() {
        return Vec::new();
    }
    (0..measures.len()).filter(|&i| measures[i].seconds <= margin * least).collect()
}

/// How far above uniform's error a default target lies: a sampler as good as uniform
/// sampling, with other random numbers, lands a few percent either side of its FLIP, and
/// a target at uniform's exact FLIP would send it to its next, far dearer setting half
/// the time; 5% keeps such ties from deciding the winner.
pub const TARGET_SLACK: f64 = 1.05;

/// Default targets of a scene: [`TARGET_SLACK`] times the error uniform sampling reaches
/// at each of `spp` camera samples per pixel, taking the best of its renders with that
/// many samples (any shadow samples), so every target is reachable by at least one
/// uniform setting. `rows` are the uniform renders as (camera samples, error). A count
/// with no finite error gives none.
pub fn targets_from_uniform(rows: &[(u32, f64)], spp: &[u32]) -> Vec<(u32, f64)> {
    spp.iter()
        .filter_map(|&n| {
            let best = rows.iter().filter(|(s, e)| *s == n && e.is_finite()).map(|r| r.1).fold(f64::INFINITY, f64::min);
            best.is_finite().then_some((n, best * TARGET_SLACK))
        })
        .collect()
}

/// The share of the total squared error held by the worst `fraction` of pixels (at least
/// one): 0.1 for noise spread evenly over the image, near 1 when a few pixels hold it all.
/// 0 for an exact match. `errors` are per-pixel squared errors.
pub fn worst_share(errors: &[f64], fraction: f64) -> f64 {
    let total: f64 = errors.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return 0.0;
    }
    let mut sorted: Vec<f64> = errors.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    let k = ((errors.len() as f64 * fraction).ceil() as usize).clamp(1, errors.len());
    sorted[..k].iter().sum::<f64>() / total
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(error: f64, seconds: f64, rays: u64) -> Measure {
        Measure { error, seconds, rays }
    }

    #[test]
    fn cheapest_takes_the_least_cost_among_those_that_reach_the_target() {
        let rows = [m(0.10, 1.0, 100), m(0.05, 2.0, 400), m(0.02, 4.0, 300), m(0.01, 8.0, 1600)];
        assert_eq!(cheapest(&rows, 0.05, Cost::Seconds), Some(1));
        // By rays, the third reaches 0.05 with fewer rays than the second.
        assert_eq!(cheapest(&rows, 0.05, Cost::Rays), Some(2));
        assert_eq!(cheapest(&rows, 0.10, Cost::Seconds), Some(0));
        // The target is inclusive.
        assert_eq!(cheapest(&rows, 0.01, Cost::Seconds), Some(3));
        assert_eq!(cheapest(&rows, 0.009, Cost::Seconds), None);
        assert_eq!(cheapest(&[], 1.0, Cost::Rays), None);
    }

    #[test]
    fn cheapest_breaks_ties_by_error_then_order() {
        let rows = [m(0.04, 1.0, 100), m(0.03, 1.0, 100), m(0.03, 1.0, 100), m(0.01, 2.0, 100)];
        // Equal seconds: the lower error (index 1), and of equal errors the first.
        assert_eq!(cheapest(&rows, 0.05, Cost::Seconds), Some(1));
        // Equal rays for all four: the lowest error wins.
        assert_eq!(cheapest(&rows, 0.05, Cost::Rays), Some(3));
        let same = [m(0.02, 1.0, 5), m(0.02, 1.0, 5)];
        assert_eq!(cheapest(&same, 0.02, Cost::Rays), Some(0));
    }

    #[test]
    fn cheapest_skips_nan() {
        let rows = [m(f64::NAN, 0.1, 1), m(0.05, f64::NAN, 2), m(0.05, 3.0, 300)];
        assert_eq!(cheapest(&rows, 0.1, Cost::Seconds), Some(2));
        // By rays the NaN seconds do not matter.
        assert_eq!(cheapest(&rows, 0.1, Cost::Rays), Some(1));
        assert_eq!(cheapest(&rows, f64::NAN, Cost::Rays), None);
        assert_eq!(cheapest(&rows[..1], f64::INFINITY, Cost::Rays), None);
    }

    #[test]
    fn winner_prefers_cheaper_then_earlier() {
        let e = |method, error, seconds, rays| Entry { method, measure: m(error, seconds, rays) };
        let entries = [e(0, 0.02, 2.0, 200), e(3, 0.03, 1.0, 300), e(5, 0.02, 1.0, 300)];
        assert_eq!(winner(&entries, Cost::Seconds), Some(5));
        assert_eq!(winner(&entries, Cost::Rays), Some(0));
        let tie = [e(0, 0.02, 1.0, 100), e(1, 0.02, 1.0, 100)];
        assert_eq!(winner(&tie, Cost::Seconds), Some(0));
        assert_eq!(winner(&[], Cost::Seconds), None);
    }

    #[test]
    fn contenders_are_within_the_margin_of_the_least() {
        let rows = [m(0.1, 1.0, 1), m(0.1, 1.29, 1), m(0.1, 1.31, 1), m(0.1, f64::NAN, 1), m(0.1, 0.9, 1)];
        // The least is 0.9: 1.3 × 0.9 = 1.17 keeps 1.0 and 0.9 only.
        assert_eq!(contenders(&rows, 1.3), [0, 4]);
        assert_eq!(contenders(&rows[..3], 1.3), [0, 1]);
        // The margin is inclusive; a lone measure contends with itself.
        assert_eq!(contenders(&[m(0.1, 2.0, 1), m(0.1, 3.0, 1)], 1.5), [0, 1]);
        assert_eq!(contenders(&rows[3..4], 1.3), Vec::<usize>::new());
        assert_eq!(contenders(&[], 1.3), Vec::<usize>::new());
    }

    #[test]
    fn targets_are_the_best_uniform_error_per_count() {
        let rows = [(1, 0.2), (1, 0.15), (4, 0.08), (4, f64::NAN), (16, 0.03)];
        assert_eq!(targets_from_uniform(&rows, &[4, 1, 64]), [(4, 0.08 * TARGET_SLACK), (1, 0.15 * TARGET_SLACK)]);
    }

    #[test]
    fn worst_share_measures_concentration() {
        assert_eq!(worst_share(&[1.0; 10], 0.1), 0.1);
        assert_eq!(worst_share(&[0.0, 0.0, 9.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0], 0.1), 0.9);
        assert_eq!(worst_share(&[0.0; 4], 0.1), 0.0);
        assert_eq!(worst_share(&[], 0.1), 0.0);
    }
}
