//! The sampling methods the study compares, as data: each is a name, the settings that
//! select it, and default grids of the settings it is tuned by. A new sampler is one
//! entry here (and a name in a manifest's `methods`), nothing else.

use crate::scene::Scene;

/// A grid: keys with the `--set` values each takes; a method's settings are the cross
/// product, the first key varying slowest.
pub type Grid = &'static [(&'static str, &'static [&'static str])];

/// What a scene must have for a method to differ from one already in the study; a method
/// whose need is not met is skipped with a note instead of rendered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Needs {
    /// Nothing: it applies to every scene.
    Nothing,
    /// An open aperture (`camera.aperture` > 0): DOF-aware AA is plain adaptive AA
    /// without one.
    Aperture,
    /// An area light the shadow-corner test probes (a quad or triangle light): adaptive
    /// shadows trace exactly uniform shadows without one.
    AreaLight,
}

impl Needs {
    /// Why `scene` does not meet the need, or `None` when it does.
    pub fn unmet(self, scene: &Scene) -> Option<&'static str> {
        match self {
            Needs::Nothing => None,
            Needs::Aperture if scene.camera.aperture > 0.0 => None,
            Needs::Aperture => Some("the camera has no aperture"),
            Needs::AreaLight if scene.lights.iter().any(|l| l.planar().is_some()) => None,
            Needs::AreaLight => Some("the scene has no quad or triangle light"),
        }
    }
}

/// One sampling method of the study.
#[derive(Clone, Copy, Debug)]
pub struct Method {
    /// The name in manifests, tables and plots.
    pub name: &'static str,
    /// What it is, for the report.
    pub about: &'static str,
    /// `--set`s that select the method, applied after the scene's own sets and before a
    /// grid point's values. A scene that does not load with them (a mode this build does
    /// not know) skips the method with a note.
    pub fixed: &'static [&'static str],
    /// The default grid.
    pub grid: Grid,
    /// The grid of `--quick`: a few cheap settings.
    pub quick: Grid,
    /// What a scene needs for the method to run.
    pub needs: Needs,
    /// The method picks one of the others per render (auto): the map, which says
    /// which of them wins where, leaves it out; its own standing is the ratios table's.
    pub picks: bool,
}

/// Camera samples per pixel of the uniform grid, and the default target counts.
const SPP: &[&str] = &["1", "4", "16", "64"];
/// Blue-noise uniform's camera samples: uniform's and 3.
const BLUE_SPP: &[&str] = &["1", "3", "4", "16", "64"];
/// Shadow rays per area light per shading point (per penumbra point when adaptive).
const SHADOW: &[&str] = &["1", "4", "16"];
/// The quick grids' camera samples.
const QUICK_SPP: &[&str] = &["1", "4", "16"];
/// The quick grids' shadow rays.
const QUICK_SHADOW: &[&str] = &["1", "4"];
/// Adaptive AA's display-value tolerance: the paper's 0.01 and two looser ones.
const EPS: &[&str] = &["0.1", "0.03", "0.01"];
/// Variance and auto AA's error threshold.
const THRESHOLD: &[&str] = &["0.1", "0.03", "0.01"];
/// Adaptive AA's last level (2^level rays): 4, 16, 64.
const LEVEL: &[&str] = &["2", "4", "6"];

/// Every method the study knows, in table order. Uniform comes first: a tie goes to it
/// (`search::winner`), so an adaptive method wins only when strictly cheaper.
pub const METHODS: &[Method] = &[
    Method {
        name: "uniform",
        about: "stratified camera samples and shadow rays, the same in every pixel",
        fixed: &["render.aa.mode=uniform", "render.shadows.mode=uniform"],
        grid: &[("render.aa.samples", SPP), ("render.shadows.samples", SHADOW)],
        quick: &[("render.aa.samples", QUICK_SPP), ("render.shadows.samples", QUICK_SHADOW)],
        needs: Needs::Nothing,
        picks: false,
    },
    Method {
        name: "blue-noise",
        about: "uniform with `render.blue_noise`: a 2x2 block's pixels share their paths' sample sequences",
        fixed: &["render.aa.mode=uniform", "render.shadows.mode=uniform", "render.blue_noise=true"],
        // Uniform's counts and 3: dithering lowers FLIP by up to a third at 1-4 samples
        // where area lights or paths carry the noise (docs/adaptive.md), which only a
        // count just under the loosest target's can turn into time.
        grid: &[("render.aa.samples", BLUE_SPP), ("render.shadows.samples", SHADOW)],
        quick: &[("render.aa.samples", &["1", "3", "4", "16"]), ("render.shadows.samples", QUICK_SHADOW)],
        needs: Needs::Nothing,
        picks: false,
    },
    Method {
        name: "adaptive-aa",
        about: "the paper's corner method (§2.1): min_level 2, eps and max_level varied; uniform shadows",
        fixed: &["render.aa.mode=adaptive", "render.aa.min_level=2", "render.aa.dof_aware=false", "render.shadows.mode=uniform"],
        grid: &[("render.aa.eps", EPS), ("render.aa.max_level", LEVEL), ("render.shadows.samples", &["4", "16"])],
        quick: &[("render.aa.eps", &["0.1", "0.01"]), ("render.aa.max_level", &["2", "4"]), ("render.shadows.samples", QUICK_SHADOW)],
        needs: Needs::Nothing,
        picks: false,
    },
    Method {
        name: "dof-aware",
        about: "adaptive AA that raises eps with the blur and scales lens samples with it (§5); uniform shadows",
        fixed: &["render.aa.mode=adaptive", "render.aa.min_level=2", "render.aa.dof_aware=true", "render.shadows.mode=uniform"],
        grid: &[("render.aa.eps", EPS), ("render.aa.max_level", LEVEL), ("render.shadows.samples", &["4", "16"])],
        quick: &[("render.aa.eps", &["0.1", "0.01"]), ("render.aa.max_level", &["2", "4"])],
        needs: Needs::Aperture,
        picks: false,
    },
    Method {
        name: "adaptive-shadows",
        about: "the shadow-corner test (§2.2): 3x3 probes, samples only in the penumbra; uniform AA",
        fixed: &["render.aa.mode=uniform", "render.shadows.mode=adaptive", "render.shadows.probe=3x3", "render.shadows.tolerance=0"],
        grid: &[("render.aa.samples", SPP), ("render.shadows.samples", &["4", "16", "64"])],
        quick: &[("render.aa.samples", QUICK_SPP), ("render.shadows.samples", &["4", "16"])],
        needs: Needs::AreaLight,
        picks: false,
    },
    Method {
        name: "early-stop",
        about: "adaptive shadows whose penumbra points stop once the visible fraction is known to ± tolerance",
        fixed: &["render.aa.mode=uniform", "render.shadows.mode=adaptive", "render.shadows.probe=3x3", "render.shadows.batch=8"],
        // Up to 64 rays per penumbra point, fewer where the tolerance is met: the
        // tolerance sets the cost, so the cap stays high.
        grid: &[("render.aa.samples", SPP), ("render.shadows.samples", &["64"]), ("render.shadows.tolerance", &["0.1", "0.05"])],
        quick: &[("render.aa.samples", QUICK_SPP), ("render.shadows.samples", &["16"]), ("render.shadows.tolerance", &["0.1"])],
        needs: Needs::AreaLight,
        picks: false,
    },
    Method {
        name: "variance",
        about: "variance-driven AA: min_samples everywhere, more up to samples where the estimate's error is above threshold",
        // Rounds of 8: 4 samples a half-buffer before the first estimate.
        fixed: &["render.aa.mode=variance", "render.aa.min_samples=8", "render.aa.samples=32", "render.shadows.mode=uniform"],
        grid: &[("render.aa.threshold", THRESHOLD), ("render.aa.samples", &["32", "128"]), ("render.shadows.samples", SHADOW)],
        quick: &[("render.aa.threshold", &["0.1", "0.01"]), ("render.aa.samples", &["16"]), ("render.shadows.samples", QUICK_SHADOW)],
        needs: Needs::Nothing,
        picks: false,
    },
    Method {
        name: "auto",
        about: "`render.aa.mode=auto` and `render.shadows.mode=auto`: each picked by the pilot; samples cap both; uniform dithered",
        fixed: &[
            "render.aa.mode=auto",
            "render.aa.min_samples=4",
            "render.aa.samples=64",
            "render.shadows.mode=auto",
            "render.shadows.probe=3x3",
            "render.shadows.tolerance=0",
            "render.blue_noise=true",
        ],
        // The settings of the methods it chooses between: variance mode's thresholds
        // and 0, which asks for `samples` everywhere (uniform anti-aliasing beside auto
        // shadows); blue-noise's counts and variance's 32 and 128. At 3 samples, below
        // the pilot's 4, every threshold renders dithered uniform 3 with no pilot.
        grid: &[
            ("render.aa.threshold", &["0.1", "0.03", "0.01", "0"]),
            ("render.aa.samples", &["3", "4", "16", "32", "64", "128"]),
            ("render.shadows.samples", &["1", "4", "16", "64"]),
        ],
        quick: &[("render.aa.samples", &["4", "16"]), ("render.shadows.samples", &["1", "16"])],
        needs: Needs::Nothing,
        picks: true,
    },
];

/// The method of a name.
pub fn by_name(name: &str) -> Option<&'static Method> {
    METHODS.iter().find(|m| m.name == name)
}

/// The names, for messages.
pub fn names() -> String {
    METHODS.iter().map(|m| m.name).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_grids_well_formed() {
        for (i, m) in METHODS.iter().enumerate() {
            assert!(METHODS[..i].iter().all(|o| o.name != m.name), "{} twice", m.name);
            for grid in [m.grid, m.quick] {
                assert!(!grid.is_empty(), "{}", m.name);
                for (k, vs) in grid {
                    assert!(!vs.is_empty(), "{} {k}", m.name);
                    // A fixed value of a grid key only lets the method's settings load before
                    // a grid point sets it (variance needs samples >= min_samples): it must
                    // be one of the default grid's values.
                    let fixed = m.fixed.iter().filter_map(|f| f.strip_prefix(&format!("{k}=")));
                    for v in fixed {
                        assert!(grid == m.quick || vs.contains(&v), "{} fixes {k}={v}, not in its grid", m.name);
                    }
                }
            }
        }
        assert_eq!(METHODS[0].name, "uniform");
        assert_eq!(by_name("early-stop").map(|m| m.needs), Some(Needs::AreaLight));
        assert!(by_name("nope").is_none());
    }
}
