//! The map across scenes: which method wins which target, set against the scene features
//! (among the methods that do not pick: auto, which applies the map, is left out),
//! and a check of how well the features predict it. The fitted scenes are those not
//! `held_out`; each held-out scene's winners are predicted from its nearest fitted scene
//! in feature space (features scaled to [0, 1] over the fitted scenes), target by target
//! in order (the i-th target of both: the same uniform spp by default).

use serde::Serialize;

use super::{Features, SceneResult};

/// A feature's name and how to read it (0 where it was not measured).
type Feature = (&'static str, fn(&Features) -> f64);

/// The features the map uses, in table order.
pub const FEATURES: [Feature; 6] = [
    ("edge_density", |f| f.edge_density.unwrap_or(0.0)),
    ("penumbra_fraction", |f| f.penumbra_fraction.unwrap_or(0.0)),
    ("coc_spread", |f| f.coc_spread),
    ("glossy_fraction", |f| f.glossy_fraction),
    ("noise_unevenness", |f| f.noise_unevenness.unwrap_or(0.0)),
    ("path", |f| f.path as u8 as f64),
];

/// One scene in the map.
#[derive(Clone, Debug, Serialize)]
pub struct MapRow {
    /// The scene.
    pub scene: String,
    /// Kept out of the fit.
    pub held_out: bool,
    /// The feature values, in [`FEATURES`] order.
    pub features: Vec<f64>,
    /// Per target: its label and the winner in seconds and in rays among the methods
    /// that do not pick (auto, which applies the map, is left out of it).
    pub winners: Vec<(String, Option<&'static str>, Option<&'static str>)>,
    /// Per target: each method's seconds to it (its cheapest setting that reaches it).
    pub seconds: Vec<Vec<(&'static str, f64)>>,
}

/// A held-out prediction is near when the predicted method reaches the target within
/// this factor of the winner's seconds: the tolerance auto mode is held to, and about
/// this machine's run-to-run noise.
pub const NEAR: f64 = 1.1;

/// Where one method wins (in seconds), over the fitted scenes.
#[derive(Clone, Debug, Serialize)]
pub struct MethodWins {
    /// The method.
    pub method: &'static str,
    /// Targets it wins in seconds.
    pub wins_seconds: usize,
    /// Targets it wins in rays.
    pub wins_rays: usize,
    /// The scenes where it wins a target in seconds.
    pub scenes: Vec<String>,
    /// Per feature, the (least, greatest) value over those scenes; `None` without a win.
    pub ranges: Vec<Option<(f64, f64)>>,
}

/// A held-out scene's winners against those the nearest fitted scene predicts.
#[derive(Clone, Debug, Serialize)]
pub struct Prediction {
    /// The held-out scene.
    pub scene: String,
    /// The fitted scene nearest in feature space.
    pub nearest: Option<String>,
    /// Per target of the held-out scene: (predicted, actual) winner in seconds.
    pub targets: Vec<(Option<&'static str>, Option<&'static str>)>,
    /// Targets predicted right.
    pub hits: usize,
    /// Targets where the predicted method takes at most [`NEAR`] × the winner's seconds
    /// (the right ones included).
    pub near: usize,
}

/// The map.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Map {
    /// The feature names, in column order.
    pub features: Vec<&'static str>,
    /// One row per scene.
    pub rows: Vec<MapRow>,
    /// Per method that wins anything, over the fitted scenes, in the study's method order.
    pub wins: Vec<MethodWins>,
    /// The held-out scenes' predictions.
    pub predictions: Vec<Prediction>,
}

impl Map {
    /// The map of the study's scenes.
    pub fn new(scenes: &[SceneResult]) -> Map {
        let rows: Vec<MapRow> = scenes
            .iter()
            .map(|s| MapRow {
                scene: s.name.clone(),
                held_out: s.held_out,
                features: FEATURES.iter().map(|(_, f)| f(&s.features)).collect(),
                winners: s.targets.iter().map(|t| (t.label.clone(), t.fixed_seconds, t.fixed_rays)).collect(),
                seconds: s
                    .targets
                    .iter()
                    .map(|t| {
                        t.choices.iter().filter_map(|c| Some((c.method, c.by_seconds.as_ref()?.seconds))).collect()
                    })
                    .collect(),
            })
            .collect();
        let fitted: Vec<&MapRow> = rows.iter().filter(|r| !r.held_out).collect();
        let mut methods: Vec<&'static str> = Vec::new();
        for s in scenes {
            for t in &s.targets {
                for c in &t.choices {
                    if !methods.contains(&c.method) {
                        methods.push(c.method);
                    }
                }
            }
        }
        let wins = methods.iter().map(|&m| wins_of(m, &fitted)).filter(|w| w.wins_seconds + w.wins_rays > 0).collect();
        let predictions = rows.iter().filter(|r| r.held_out).map(|r| predict(r, &fitted)).collect();
        Map { features: FEATURES.iter().map(|f| f.0).collect(), rows, wins, predictions }
    }
}

/// Where `method` wins among the fitted rows.
fn wins_of(method: &'static str, fitted: &[&MapRow]) -> MethodWins {
    let mut w =
        MethodWins { method, wins_seconds: 0, wins_rays: 0, scenes: Vec::new(), ranges: vec![None; FEATURES.len()] };
    for r in fitted {
        let by_secs = r.winners.iter().filter(|t| t.1 == Some(method)).count();
        w.wins_seconds += by_secs;
        w.wins_rays += r.winners.iter().filter(|t| t.2 == Some(method)).count();
        if by_secs > 0 {
            w.scenes.push(r.scene.clone());
            for (range, &v) in w.ranges.iter_mut().zip(&r.features) {
                *range = Some(range.map_or((v, v), |(lo, hi)| (lo.min(v), hi.max(v))));
            }
        }
    }
    w
}

/// The nearest fitted row to `row` in scaled feature space (Euclidean; ties: the first).
pub fn nearest<'a>(row: &MapRow, fitted: &[&'a MapRow]) -> Option<&'a MapRow> {
    let n = FEATURES.len();
    let lo: Vec<f64> = (0..n).map(|i| fitted.iter().map(|r| r.features[i]).fold(f64::INFINITY, f64::min)).collect();
    let hi: Vec<f64> = (0..n).map(|i| fitted.iter().map(|r| r.features[i]).fold(f64::NEG_INFINITY, f64::max)).collect();
    let scale = |i: usize, v: f64| if hi[i] > lo[i] { (v - lo[i]) / (hi[i] - lo[i]) } else { 0.0 };
    let dist =
        |r: &MapRow| -> f64 { (0..n).map(|i| (scale(i, r.features[i]) - scale(i, row.features[i])).powi(2)).sum() };
    let mut best: Option<(&MapRow, f64)> = None;
    for &r in fitted {
        let d = dist(r);
        if best.is_none_or(|(_, bd)| d < bd) {
            best = Some((r, d));
        }
    }
    best.map(|b| b.0)
}

/// A held-out row's prediction from its nearest fitted row.
fn predict(row: &MapRow, fitted: &[&MapRow]) -> Prediction {
    let near = nearest(row, fitted);
    let targets: Vec<_> = row
        .winners
        .iter()
        .enumerate()
        .map(|(i, t)| (near.and_then(|n| n.winners.get(i)).and_then(|w| w.1), t.1))
        .collect();
    let hits = targets.iter().filter(|(p, a)| p.is_some() && p == a).count();
    let time = |i: usize, m: Option<&str>| row.seconds.get(i)?.iter().find(|c| Some(c.0) == m).map(|c| c.1);
    let near_enough = |(i, (p, a)): (usize, &(Option<&str>, Option<&str>))| match (time(i, *p), time(i, *a)) {
        _ if p.is_some() && p == a => true,
        (Some(p), Some(a)) => p <= NEAR * a,
        _ => false,
    };
    let near_hits = targets.iter().enumerate().filter(|&t| near_enough(t)).count();
    Prediction { scene: row.scene.clone(), nearest: near.map(|n| n.scene.clone()), targets, hits, near: near_hits }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(scene: &str, held_out: bool, features: [f64; 6], winners: &[&'static str]) -> MapRow {
        MapRow {
            scene: scene.into(),
            held_out,
            features: features.to_vec(),
            winners: winners.iter().map(|&w| (String::new(), Some(w), Some(w))).collect(),
            seconds: Vec::new(),
        }
    }

    #[test]
    fn nearest_scene_predicts_held_out_winners() {
        let a = row("edges", false, [0.3, 0.0, 0.0, 0.0, 0.5, 0.0], &["adaptive-aa", "adaptive-aa"]);
        let b = row("shadows", false, [0.02, 0.4, 0.0, 0.0, 0.3, 0.0], &["uniform", "adaptive-shadows"]);
        let h = row("held", true, [0.25, 0.05, 0.0, 0.0, 0.45, 0.0], &["adaptive-aa", "uniform"]);
        let fitted = [&a, &b];
        assert_eq!(nearest(&h, &fitted).map(|r| r.scene.as_str()), Some("edges"));
        let p = predict(&h, &fitted);
        assert_eq!(p.targets, [(Some("adaptive-aa"), Some("adaptive-aa")), (Some("adaptive-aa"), Some("uniform"))]);
        assert_eq!((p.hits, p.near), (1, 1), "no seconds: only the exact hit");
        // Adaptive AA within 10% of uniform's seconds on the second target: near.
        let h = MapRow { seconds: vec![vec![("adaptive-aa", 1.0)], vec![("uniform", 2.0), ("adaptive-aa", 2.2)]], ..h };
        assert_eq!((predict(&h, &fitted).hits, predict(&h, &fitted).near), (1, 2));
        let h =
            MapRow { seconds: vec![vec![("adaptive-aa", 1.0)], vec![("uniform", 2.0), ("adaptive-aa", 2.21)]], ..h };
        assert_eq!(predict(&h, &fitted).near, 1);
        let w = wins_of("adaptive-shadows", &fitted);
        assert_eq!((w.wins_seconds, w.scenes.clone()), (1, vec!["shadows".to_string()]));
        assert_eq!(w.ranges[1], Some((0.4, 0.4)));
        assert_eq!(nearest(&h, &[]).map(|r| r.scene.clone()), None);
    }
}
