//! Per-stage counters: rays in, rays out and time per stage, and rays by kind.
//! Each worker counts into its own [`Stats`] once per stage call; the driver merges
//! them at the end, so counting costs nothing per ray.

use serde::Serialize;
use std::collections::BTreeMap;

/// The stages of the wavefront, in pipeline order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Stage {
    /// Camera ray generation (pixel and lens sampling).
    Camera,
    /// Closest-hit intersection of camera and secondary rays.
    Intersect,
    /// Shading: emitters, background, direct-light shadow rays, specular hand-off.
    Shade,
    /// Any-hit occlusion of shadow rays.
    Shadow,
    /// Reflection/refraction ray generation at mirrors and dielectrics.
    Scatter,
    /// Adding radiance to the tile's pixels.
    Film,
}

impl Stage {
    /// All stages in pipeline order.
    pub const ALL: [Stage; 6] =
        [Stage::Camera, Stage::Intersect, Stage::Shade, Stage::Shadow, Stage::Scatter, Stage::Film];

    /// Name used in tables and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Camera => "camera",
            Stage::Intersect => "intersect",
            Stage::Shade => "shade",
            Stage::Shadow => "shadow",
            Stage::Scatter => "scatter",
            Stage::Film => "film",
        }
    }
}

/// Counters of one stage.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StageCounters {
    /// Items read (rays, hits or contributions).
    pub rays_in: u64,
    /// Items written.
    pub rays_out: u64,
    /// Seconds spent in the stage, summed over threads.
    pub seconds: f64,
}

/// Counters of one worker, or of the whole render once merged.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    /// Per-stage counters, indexed by `Stage as usize`.
    pub stages: [StageCounters; 6],
    /// Camera rays traced.
    pub camera_rays: u64,
    /// Shadow rays traced.
    pub shadow_rays: u64,
    /// Reflection and refraction rays traced.
    pub secondary_rays: u64,
    /// Tiles rendered.
    pub tiles: u64,
}

impl Stats {
    /// Records one call of `stage`.
    #[inline]
    pub fn record(&mut self, stage: Stage, rays_in: usize, rays_out: usize, seconds: f64) {
        let c = &mut self.stages[stage as usize];
        c.rays_in += rays_in as u64;
        c.rays_out += rays_out as u64;
        c.seconds += seconds;
    }

    /// Adds another worker's counters.
    pub fn merge(&mut self, o: &Stats) {
        for (a, b) in self.stages.iter_mut().zip(o.stages.iter()) {
            a.rays_in += b.rays_in;
            a.rays_out += b.rays_out;
            a.seconds += b.seconds;
        }
        self.camera_rays += o.camera_rays;
        self.shadow_rays += o.shadow_rays;
        self.secondary_rays += o.secondary_rays;
        self.tiles += o.tiles;
    }

    /// All rays traced: the kinds are disjoint, so this is their sum.
    pub fn total_rays(&self) -> u64 {
        self.camera_rays + self.shadow_rays + self.secondary_rays
    }

    /// Counters of one stage.
    pub fn stage(&self, s: Stage) -> &StageCounters {
        &self.stages[s as usize]
    }
}

/// The whole report of a render, as written by `--stats-json` (schema in docs/stats.md).
#[derive(Serialize, Debug, Clone)]
pub struct Report {
    /// Schema version of this JSON.
    pub version: u32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Worker threads.
    pub threads: usize,
    /// Wall-clock seconds of the render (BVH build and file output excluded).
    pub seconds: f64,
    /// Rays traced, all kinds.
    pub total_rays: u64,
    /// total_rays / seconds / 1e6.
    pub mrays_per_s: f64,
    /// Rays by kind: camera, shadow, secondary.
    pub rays: BTreeMap<&'static str, u64>,
    /// Per-stage counters, seconds summed over threads.
    pub stages: BTreeMap<&'static str, StageCounters>,
    /// Facts about the scene.
    pub scene: SceneReport,
    /// Per-thread ray totals and busy seconds, in thread order.
    pub per_thread: Vec<ThreadReport>,
}

/// Scene facts in the report.
#[derive(Serialize, Debug, Clone)]
pub struct SceneReport {
    /// Primitives in the BVH.
    pub primitives: usize,
    /// Mesh triangles.
    pub triangles: usize,
    /// Zero-area triangles skipped.
    pub degenerate_triangles: usize,
    /// BVH build seconds.
    pub bvh_seconds: f64,
    /// Seconds to parse, validate and load the scene, meshes and BVH included.
    pub load_seconds: f64,
}

/// One thread's share.
#[derive(Serialize, Debug, Clone)]
pub struct ThreadReport {
    /// Rays this thread traced.
    pub rays: u64,
    /// Tiles this thread rendered.
    pub tiles: u64,
    /// Seconds spent in stages.
    pub busy_seconds: f64,
}

impl Report {
    /// Builds the report from merged and per-thread stats.
    pub fn new(
        width: u32,
        height: u32,
        seconds: f64,
        total: &Stats,
        per_thread: &[Stats],
        scene: SceneReport,
    ) -> Report {
        let total_rays = total.total_rays();
        Report {
            version: 1,
            width,
            height,
            threads: per_thread.len(),
            seconds,
            total_rays,
            mrays_per_s: if seconds > 0.0 { total_rays as f64 / seconds / 1e6 } else { 0.0 },
            rays: BTreeMap::from([
                ("camera", total.camera_rays),
                ("shadow", total.shadow_rays),
                ("secondary", total.secondary_rays),
            ]),
            stages: Stage::ALL.iter().map(|&s| (s.name(), *total.stage(s))).collect(),
            scene,
            per_thread: per_thread
                .iter()
                .map(|t| ThreadReport {
                    rays: t.total_rays(),
                    tiles: t.tiles,
                    busy_seconds: t.stages.iter().map(|c| c.seconds).sum(),
                })
                .collect(),
        }
    }

    /// The short summary printed after every render.
    pub fn summary(&self) -> String {
        format!(
            "{}x{}: {} rays (camera {}, shadow {}, secondary {}) in {:.3} s on {} threads = {:.2} Mrays/s",
            self.width,
            self.height,
            self.total_rays,
            self.rays["camera"],
            self.rays["shadow"],
            self.rays["secondary"],
            self.seconds,
            self.threads,
            self.mrays_per_s
        )
    }

    /// The per-stage table of `--stats`.
    pub fn table(&self) -> String {
        let mut s = format!("{:<10} {:>14} {:>14} {:>10}\n", "stage", "rays in", "rays out", "seconds");
        for st in Stage::ALL {
            let c = &self.stages[st.name()];
            s += &format!("{:<10} {:>14} {:>14} {:>10.3}\n", st.name(), c.rays_in, c.rays_out, c.seconds);
        }
        for (kind, n) in &self.rays {
            s += &format!("rays {:<9} {:>14}\n", kind, n);
        }
        s += &format!(
            "total {:>22} rays, {:.3} s wall, {:.2} Mrays/s, {} threads\n",
            self.total_rays, self.seconds, self.mrays_per_s, self.threads
        );
        s += &format!(
            "scene: {} primitives ({} triangles, {} degenerate skipped), BVH {:.3} s, load {:.3} s",
            self.scene.primitives,
            self.scene.triangles,
            self.scene.degenerate_triangles,
            self.scene.bvh_seconds,
            self.scene.load_seconds
        );
        s
    }
}
