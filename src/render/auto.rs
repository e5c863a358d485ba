//! The auto modes (`render.aa.mode` and `render.shadows.mode = "auto"`): a pilot pass
//! over one pixel of every 8×8 block of the whole image (whatever the crop, so every
//! crop and thread count makes the same choice), whose pixel errors choose the
//! anti-aliasing sampler's samples and whose shadow counts choose the shadow mode; then
//! the plan the other passes render.

use std::sync::Mutex;

use super::variance::Rounds;
use super::{for_tiles, lock, Ctx, PerThread};
use crate::film::Tile;
use crate::light::probes_light;
use crate::scene::{AaMode, Scene, ShadowMode};
use crate::stats::{AutoChoice, ShadowChoice, Stats};

/// Camera samples per pilot pixel when only the shadow mode is auto (anti-aliasing's
/// auto mode pilots with its `min_samples`).
const SHADOW_PILOT_SAMPLES: u32 = 4;

/// Adaptive shadows are chosen when the pilot's probe and penumbra rays are at most this
/// share of uniform mode's rays for the same points: at equal `samples` the two give the
/// same error (a point outside the penumbra has none either way). The probe and
/// penumbra stages cost more per ray than uniform's lanes; the 10% is a chosen margin
/// that keeps near-ties uniform, not a measured cost.
pub const SHADOW_MARGIN: f64 = 0.9;

/// How the pixel tiles sample the film.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Sampling {
    /// As the scene's `render.aa` says (uniform or adaptive).
    Scene,
    /// Uniform, at this many samples a pixel (auto's choice).
    Uniform(u32),
    /// Variance-driven rounds.
    Rounds(Rounds),
}

/// What the render's passes do after the pilot.
pub(super) struct Plan {
    /// The pixel tiles' sampler.
    pub sampling: Sampling,
    /// The shadow mode every pass renders (never `Auto`).
    pub shadows: ShadowMode,
    /// Anti-aliasing's auto choice.
    pub aa: Option<AutoChoice>,
    /// The shadows' auto choice.
    pub shadow: Option<ShadowChoice>,
}

/// Whether anti-aliasing's auto mode needs the pilot: when it is on and `samples` leaves
/// it a choice. At `samples` ≤ `min_samples` every pilot gives uniform sampling at
/// `samples` ([`AutoChoice::without_pilot`]), so none is rendered.
fn aa_pilot(scene: &Scene) -> bool {
    let s = &scene.settings;
    matches!(s.aa_mode, AaMode::Auto { min_samples, .. } if s.aa_samples > min_samples)
}

/// Whether the shadows' auto mode needs the pilot: some light the adaptive test would
/// probe at these samples (otherwise adaptive mode samples every light as uniform does).
fn shadow_pilot(scene: &Scene) -> bool {
    let s = &scene.settings;
    match s.shadow_mode {
        ShadowMode::Auto(probe) => scene.lights.iter().any(|l| probes_light(l, probe, s.shadow_samples)),
        _ => false,
    }
}

/// Whether the render runs a pilot.
pub(super) fn needs_pilot(scene: &Scene) -> bool {
    aa_pilot(scene) || shadow_pilot(scene)
}

/// The shadow mode the pilot renders: adaptive for the shadows' auto mode (to count its
/// penumbra), the scene's otherwise.
pub(super) fn pilot_shadows(scene: &Scene) -> ShadowMode {
    match scene.settings.shadow_mode {
        ShadowMode::Auto(probe) => ShadowMode::Adaptive(probe),
        mode => mode,
    }
}

/// The shadows' auto choice from the pilot's counters: adaptive when its probe and
/// penumbra rays are at most [`SHADOW_MARGIN`] of uniform's for the same points.
pub fn shadows_pay(pilot: &Stats) -> ShadowChoice {
    let adaptive_rays = pilot.shadow_corner_rays + pilot.penumbra_rays;
    let uniform_rays = pilot.shadow_uniform_rays;
    let points = pilot.shadow_points;
    let penumbra_fraction = if points > 0 { pilot.penumbra_points as f64 / points as f64 } else { 0.0 };
    let pays = points > 0 && (adaptive_rays as f64) <= SHADOW_MARGIN * uniform_rays as f64;
    let (chose, why) = match (points, pays) {
        (0, _) => ("uniform", "no pilot point saw a light the probes test"),
        (_, true) => ("adaptive", "the probes and the penumbra's samples cast fewer rays than uniform"),
        (_, false) => ("uniform", "the penumbra is too large for the probes to save rays"),
    };
    ShadowChoice { chose, why, pilot_points: points, penumbra_fraction, adaptive_rays, uniform_rays }
}

/// Runs the pilot over `tiles` (the whole image's, or none) and returns its counters and
/// the plan. `ctx` renders the pilot's shadows ([`pilot_shadows`]).
pub(super) fn pilot_pass(ctx: &Ctx, tiles: &[Tile]) -> (PerThread, Plan) {
    let scene = ctx.scene;
    let s = &scene.settings;
    let n0 = match s.aa_mode {
        AaMode::Auto { min_samples, .. } => min_samples,
        _ => SHADOW_PILOT_SAMPLES,
    };
    let errors = Mutex::new(Vec::new());
    let stats = if tiles.is_empty() {
        Vec::new()
    } else {
        for_tiles(ctx, tiles, |wk, tile| lock(&errors).extend(wk.pilot_tile(scene, tile, n0)), |_, _| {})
    };
    let mut errors = errors.into_inner().unwrap_or_else(|e| e.into_inner());
    // In image order, whatever order the threads finished in: the same sums, the same choice.
    errors.sort_unstable_by_key(|&(pixel, _)| pixel);
    let errors: Vec<f32> = errors.into_iter().map(|(_, e)| e).collect();

    let (sampling, aa) = match s.aa_mode {
        AaMode::Variance { threshold, min_samples } => {
            (Sampling::Rounds(Rounds { threshold, min_samples, max: s.aa_samples }), None)
        }
        AaMode::Auto { threshold, min_samples } => {
            let choice = match aa_pilot(scene) {
                true => AutoChoice::from_pilot(&errors, min_samples, threshold, s.aa_samples),
                false => AutoChoice::without_pilot(s.aa_samples),
            };
            let sampling = match choice.chose {
                "uniform" => Sampling::Uniform(choice.max),
                _ => Sampling::Rounds(Rounds::of(&choice)),
            };
            (sampling, Some(choice))
        }
        AaMode::Uniform | AaMode::Adaptive { .. } => (Sampling::Scene, None),
    };
    let (shadows, shadow) = match s.shadow_mode {
        ShadowMode::Auto(probe) => {
            let mut pilot = Stats::default();
            stats.iter().for_each(|(t, _)| pilot.merge(t));
            let choice = if shadow_pilot(scene) {
                shadows_pay(&pilot)
            } else {
                let why =
                    "every light's probes cost more than 0.8 of its samples: adaptive mode would sample it uniformly";
                ShadowChoice { chose: "uniform", why, ..shadows_pay(&Stats::default()) }
            };
            let mode = if choice.chose == "adaptive" { ShadowMode::Adaptive(probe) } else { ShadowMode::Uniform };
            (mode, Some(choice))
        }
        mode => (mode, None),
    };
    (stats, Plan { sampling, shadows, aa, shadow })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shadows_pay_at_most_the_margin_of_uniforms_rays() {
        let pilot = |corner: u64, penumbra: u64, uniform: u64| Stats {
            shadow_points: 100,
            penumbra_points: 10,
            shadow_corner_rays: corner,
            penumbra_rays: penumbra,
            shadow_uniform_rays: uniform,
            ..Stats::default()
        };
        // 9 probes and 10% of points in a 64-ray penumbra against 64 rays each.
        let c = shadows_pay(&pilot(900, 640, 6400));
        assert_eq!((c.chose, c.penumbra_fraction, c.adaptive_rays, c.uniform_rays), ("adaptive", 0.1, 1540, 6400));
        // Exactly the margin still pays; one ray more does not.
        assert_eq!(shadows_pay(&pilot(900, 540, 1600)).chose, "adaptive");
        assert_eq!(shadows_pay(&pilot(900, 541, 1600)).chose, "uniform");
        // No tested point: nothing to go on, uniform.
        let none = shadows_pay(&Stats::default());
        assert_eq!((none.chose, none.pilot_points, none.penumbra_fraction), ("uniform", 0, 0.0));
    }
}
