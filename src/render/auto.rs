//! The auto modes (`render.aa.mode` and `render.shadows.mode = "auto"`): a pilot pass
//! over one pixel of every 8×8 block of the whole image (whatever the crop, so every
//! crop and thread count makes the same choice), whose pixel errors choose the
//! anti-aliasing sampler's samples and whose shadow counts choose the shadow mode; then
//! the plan the other passes render.

use std::sync::Mutex;

use super::adaptive::Corners;
use super::variance::{Rounds, PILOT_BLOCK};
use super::{for_tiles, lock, Ctx, PerThread};
use crate::accel::Traversal;
use crate::film::Tile;
use crate::light::probes_light;
use crate::scene::load::MAX_LEVEL;
use crate::scene::{AaMode, Scene, ShadowMode};
use crate::stages::camera::UniformPass;
use crate::stages::focus::{coc_pixels, pinhole_depth};
use crate::stats::{AutoChoice, ShadowChoice, Stats};

/// Camera samples per pilot pixel when only the shadow mode is auto (anti-aliasing's
/// auto mode pilots with its `min_samples`).
const SHADOW_PILOT_SAMPLES: u32 = 4;

/// Adaptive shadows are chosen when the pilot's probe and penumbra rays are at most this
/// share of uniform mode's rays for the same points: at equal `samples` the two give the
/// same error (a point outside the penumbra has none either way). An adaptive shadow
/// ray costs 1.1–1.2× a uniform one (its probes and penumbra rays are cast on lanes too,
/// but the penumbra's are the hard ones): at 16 camera samples and 16 shadow rays,
/// adaptive took 0.060 against 0.068 s for 0.78 of uniform's rays on fig03, 0.058
/// against 0.075 s for 0.68 on cornell (docs/adaptive.md), so at 0.9 the two are about
/// even and near-ties stay uniform.
pub const SHADOW_MARGIN: f64 = 0.9;

/// How the pixel tiles sample the film.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Sampling {
    /// Uniform: every pixel's samples in one pass.
    Uniform(UniformPass),
    /// Variance-driven rounds.
    Rounds(Rounds),
    /// The paper's corner method.
    Corners(Corners),
}

/// Auto mode renders the paper's corner method in place of uniform sampling at up to
/// this many samples a pixel, where a lens blurs most of the image ([`CORNER_BLUR`]).
/// In the study (docs/adaptive.md) the corner method beat uniform's time to its 4-spp
/// error on all three scenes with a lens (0.53–0.88×; eps 0.01 at level 2 reaches it on
/// each), and reached no 16-spp target on any of them.
pub const CORNER_MAX_SPP: u32 = 4;

/// The share of the pilot's pixels blurred over more than one pixel (their centres'
/// circles of confusion, `stages::focus::coc_pixels`) from which auto mode renders the
/// corner method. Shared corners serve four pixels each, and where the blur makes
/// neighbours alike the corner test refines few of them. The study's three lens scenes
/// have 0.48–0.80 by the pilot's pixels (0.53–0.80 over the whole image), every other
/// scene 0: the value lies in that gap, below the least blurred lens scene by more than
/// the pilot's sampling moves it. No study scene has a lens that blurs less.
pub const CORNER_BLUR: f64 = 0.4;

/// The fewest lens samples per point (`render.dof.samples`) with which auto mode renders
/// the corner method: a corner's value is the mean of its lens rays, and with few the
/// lens noise in it, not the image, decides the corner test. On the Mitsuba harness's
/// depth-of-field scene (320×240, one shadow ray, auto at 4 samples and threshold 0.01
/// against dithered uniform 4) the corners took 62 ms for FLIP 0.036 against 25 ms for
/// 0.022 at 1 lens sample, and were slower and worse at 2 and 4; at 8 about even (eps
/// 0.1: 71 ms for 0.0139, dithered uniform 2: 89 ms for 0.0134). The study's lens
/// scenes, where they win, all have 8.
pub const CORNER_LENS_SAMPLES: u32 = 8;

/// With `render.blue_noise`, auto mode dithers its uniform pass at up to this many
/// samples a pixel. In the study dithering lowered FLIP at 1–4 samples by up to 33%
/// where area lights or paths carry the noise, moved it by −4% to +2% through a lens and
/// not at all under a point light alone; from 16 samples it raised FLIP by 7–8% on the
/// path-traced Cornell box and by up to 8% on frosted glass (at 64).
pub const DITHER_MAX_SPP: u32 = 4;

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

/// Whether anti-aliasing's auto mode needs the pilot: when it is on and `samples` and
/// `threshold` leave it a choice. At `samples` ≤ `min_samples` every pilot gives uniform
/// sampling at `samples` ([`AutoChoice::without_pilot`]), and threshold 0 asks for
/// `samples` in every pixel, as in variance mode; so no pilot is rendered.
fn aa_pilot(scene: &Scene) -> bool {
    let s = &scene.settings;
    matches!(s.aa_mode, AaMode::Auto { min_samples, threshold } if s.aa_samples > min_samples && threshold > 0.0)
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

/// The corner method's first level that may stop refinement in auto mode: the paper's
/// rule, as the study's `adaptive-aa` method renders it.
const CORNER_MIN_LEVEL: u32 = 2;

/// Auto mode's last decisions on a uniform choice of N samples a pixel: the paper's
/// corner method where N ≤ [`CORNER_MAX_SPP`], `threshold` > 0 and a lens with at least
/// [`CORNER_LENS_SAMPLES`] samples a point blurs at least [`CORNER_BLUR`] of the pilot's
/// pixels (eps = `threshold`, last level log2 of `render.aa.samples`, from 4 samples);
/// else, with `render.blue_noise`, dithering where N ≤ [`DITHER_MAX_SPP`].
fn settle(mut c: AutoChoice, scene: &Scene, threshold: f32) -> AutoChoice {
    let s = &scene.settings;
    if c.chose != "uniform" {
        return c;
    }
    let few = c.max <= CORNER_MAX_SPP && threshold > 0.0 && s.aa_samples >= 1 << CORNER_MIN_LEVEL;
    if few && scene.camera.aperture > 0.0 && s.dof_samples >= CORNER_LENS_SAMPLES {
        c.blurred = blurred_share(scene);
        if c.blurred >= CORNER_BLUR {
            let max_level = s.aa_samples.ilog2().min(MAX_LEVEL);
            c.chose = "corners";
            c.why = "a lens blurs many pixels and few samples are asked for: shared corners serve four alike pixels";
            (c.threshold, c.min_samples, c.max) = (threshold, 1 << CORNER_MIN_LEVEL, 1 << max_level);
            return c;
        }
    }
    c.dithered = s.blue_noise && c.max <= DITHER_MAX_SPP;
    c
}

/// The share of the pilot's pixels (one per 8×8 block) whose centre, seen through a
/// pinhole, is blurred over more than one pixel by the lens.
fn blurred_share(scene: &Scene) -> f64 {
    let (w, h, half) = (scene.settings.width, scene.settings.height, PILOT_BLOCK / 2);
    let mut trav = Traversal::default();
    let (mut pixels, mut blurred) = (0u64, 0u64);
    for y in (half..h).step_by(PILOT_BLOCK as usize) {
        for x in (half..w).step_by(PILOT_BLOCK as usize) {
            let (depth, _) = pinhole_depth(scene, x, y, &mut trav);
            pixels += 1;
            blurred += (coc_pixels::<f32>(scene, depth) > 1.0) as u64;
        }
    }
    if pixels == 0 {
        0.0
    } else {
        blurred as f64 / pixels as f64
    }
}

/// The pixel pass's sampler: the scene's mode's, or auto's choice from the pilot's
/// `errors` (in image order), with the choice.
fn aa_plan(scene: &Scene, errors: &[f32]) -> (Sampling, Option<AutoChoice>) {
    let s = &scene.settings;
    match s.aa_mode {
        AaMode::Uniform => (Sampling::Uniform(UniformPass::of(s)), None),
        AaMode::Adaptive { eps, min_level, max_level, share_corners: share } => {
            (Sampling::Corners(Corners { eps, min_level, max_level, share }), None)
        }
        AaMode::Variance { threshold, min_samples } => {
            (Sampling::Rounds(Rounds { threshold, min_samples, max: s.aa_samples }), None)
        }
        AaMode::Auto { threshold, min_samples } => {
            let choice = match aa_pilot(scene) {
                true => AutoChoice::from_pilot(errors, min_samples, threshold, s.aa_samples),
                false => AutoChoice::without_pilot(s.aa_samples),
            };
            let choice = settle(choice, scene, threshold);
            let sampling = match choice.chose {
                "uniform" => Sampling::Uniform(UniformPass { samples: choice.max, dither: choice.dithered }),
                "corners" => Sampling::Corners(Corners {
                    eps: choice.threshold,
                    min_level: CORNER_MIN_LEVEL,
                    max_level: choice.max.ilog2(),
                    share: true,
                }),
                _ => Sampling::Rounds(Rounds::of(&choice)),
            };
            (sampling, Some(choice))
        }
    }
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

    let (sampling, aa) = aa_plan(scene, &errors);
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
