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
    /// Adding radiance to the pass's accumulation slots.
    Film,
    /// Adaptive shadows: probe rays to points on a quad light per shading point
    /// (`render.shadows.probe`: 9 for the default 3x3).
    ShadowCorner,
    /// Adaptive shadows: stratified shadow rays for points in the penumbra.
    Penumbra,
    /// Adaptive AA: the decisions that fill the refinement queue.
    Refine,
    /// DOF-aware adaptive AA: pinhole depth probes through corners and centres, and
    /// their circles of confusion.
    Focus,
}

impl Stage {
    /// All stages in pipeline order.
    pub const ALL: [Stage; 10] = [
        Stage::Focus,
        Stage::Camera,
        Stage::Intersect,
        Stage::Shade,
        Stage::Shadow,
        Stage::ShadowCorner,
        Stage::Penumbra,
        Stage::Scatter,
        Stage::Film,
        Stage::Refine,
    ];

    /// Name used in tables and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Camera => "camera",
            Stage::Intersect => "intersect",
            Stage::Shade => "shade",
            Stage::Shadow => "shadow",
            Stage::Scatter => "scatter",
            Stage::Film => "film",
            Stage::ShadowCorner => "shadow_corner",
            Stage::Penumbra => "penumbra",
            Stage::Refine => "refine",
            Stage::Focus => "focus",
        }
    }
}

/// One stage call on one thread, for the Chrome trace.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    /// The stage.
    pub stage: Stage,
    /// Start, microseconds since the render began.
    pub start_us: f64,
    /// Duration in microseconds.
    pub dur_us: f64,
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
    /// BVH nodes whose box was tested by the stage's traversals (0 when not counted).
    pub nodes: u64,
    /// Primitive intersection tests run by the stage's traversals.
    pub prims: u64,
    /// Rays the stage traced in SIMD packets (`render.packets`; 16 lanes, `Packet = f32x16`).
    pub packet_rays: u64,
    /// Packet node-pair tests, and the active lanes summed over them.
    pub packet_steps: u64,
    /// Active lanes summed over packet node-pair tests.
    pub packet_lanes: u64,
}

/// One stage in the report: its counters, and what an item cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StageReport {
    /// The counters.
    #[serde(flatten)]
    pub counters: StageCounters,
    /// Nanoseconds per item the stage read (per ray it wrote, for camera generation,
    /// which reads none), with the seconds summed over threads: the cost of one item on
    /// one thread. 0 for a stage that had nothing to do.
    pub ns_per_ray: f64,
}

impl StageReport {
    /// The report of `stage` from its counters.
    pub fn new(stage: Stage, c: StageCounters) -> StageReport {
        let items = if stage == Stage::Camera { c.rays_out } else { c.rays_in };
        let ns_per_ray = if items > 0 { c.seconds * 1e9 / items as f64 } else { 0.0 };
        StageReport { counters: c, ns_per_ray }
    }
}

/// Per-stage reports by stage name, in pipeline order of names.
fn stage_reports(stats: &Stats) -> BTreeMap<&'static str, StageReport> {
    Stage::ALL.iter().map(|&s| (s.name(), StageReport::new(s, *stats.stage(s)))).collect()
}

/// Counters of one worker, or of the whole render once merged.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    /// Per-stage counters, indexed by `Stage as usize`.
    pub stages: [StageCounters; 10],
    /// Camera rays: uniform-mode samples, or adaptive pixel centres.
    pub camera_rays: u64,
    /// Adaptive AA: rays through pixel corners.
    pub aa_corner_rays: u64,
    /// Adaptive AA: refinement rays.
    pub aa_refine_rays: u64,
    /// Shadow rays of point lights, and of quad lights in uniform mode.
    pub shadow_rays: u64,
    /// Adaptive shadows: probe rays of the shadow-corner test.
    pub shadow_corner_rays: u64,
    /// Adaptive shadows: stratified rays of penumbra points.
    pub penumbra_rays: u64,
    /// Reflection and refraction rays traced.
    pub secondary_rays: u64,
    /// DOF-aware AA: pinhole depth probes (intersected, never shaded).
    pub dof_probe_rays: u64,
    /// Tiles rendered (pixel tiles and corner-grid tiles).
    pub tiles: u64,
    /// Adaptive AA: pixels decided.
    pub aa_pixels: u64,
    /// Adaptive AA: pixels that entered the refinement queue.
    pub aa_refined_pixels: u64,
    /// Adaptive AA: camera rays uniform mode would cast for the same pixels at
    /// 2^max_level samples each.
    pub aa_uniform_rays: u64,
    /// Adaptive shadows: (point, quad light) pairs that entered the shadow-corner queue.
    pub shadow_points: u64,
    /// Adaptive shadows: of those, the ones that entered the penumbra queue.
    pub penumbra_points: u64,
    /// Adaptive shadows: shadow rays uniform mode would cast for the same points.
    pub shadow_uniform_rays: u64,
    /// Adaptive shadows: (point, area light) pairs sampled uniformly because the light's
    /// probes would cost more than 0.8 of its samples (`light::probes_light`).
    pub shadow_uniform_fallback: u64,
    /// Penumbra early stopping: points that stopped before all their rays.
    pub penumbra_stopped: u64,
    /// Penumbra early stopping: rays of the fixed-n method not traced.
    pub penumbra_saved_rays: u64,
    /// Longest each queue got, in entries (merged: the maximum over workers).
    pub peak: QueuePeaks,
    /// Bytes the worker's queues and buffers held at the end (merged: the sum over
    /// workers, which hold them at the same time).
    pub queue_bytes: u64,
    /// Non-finite (NaN or infinite) contributions the film stage dropped.
    pub nonfinite: u64,
}

/// The longest each queue got.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct QueuePeaks {
    /// Rays of one wave (camera or secondary).
    pub rays: u64,
    /// Shadow rays (point lights, uniform quad lights).
    pub shadow: u64,
    /// Shadow-corner queue entries.
    pub shadow_points: u64,
    /// Penumbra rays.
    pub penumbra_rays: u64,
    /// Specular hits handed to scatter.
    pub specular: u64,
    /// Film contributions of one wave.
    pub film: u64,
}

impl QueuePeaks {
    fn merge(&mut self, o: &QueuePeaks) {
        self.rays = self.rays.max(o.rays);
        self.shadow = self.shadow.max(o.shadow);
        self.shadow_points = self.shadow_points.max(o.shadow_points);
        self.penumbra_rays = self.penumbra_rays.max(o.penumbra_rays);
        self.specular = self.specular.max(o.specular);
        self.film = self.film.max(o.film);
    }
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
            a.nodes += b.nodes;
            a.prims += b.prims;
            a.packet_rays += b.packet_rays;
            a.packet_steps += b.packet_steps;
            a.packet_lanes += b.packet_lanes;
        }
        self.peak.merge(&o.peak);
        self.queue_bytes += o.queue_bytes;
        self.nonfinite += o.nonfinite;
        self.camera_rays += o.camera_rays;
        self.aa_corner_rays += o.aa_corner_rays;
        self.aa_refine_rays += o.aa_refine_rays;
        self.shadow_rays += o.shadow_rays;
        self.shadow_corner_rays += o.shadow_corner_rays;
        self.penumbra_rays += o.penumbra_rays;
        self.secondary_rays += o.secondary_rays;
        self.dof_probe_rays += o.dof_probe_rays;
        self.tiles += o.tiles;
        self.aa_pixels += o.aa_pixels;
        self.aa_refined_pixels += o.aa_refined_pixels;
        self.aa_uniform_rays += o.aa_uniform_rays;
        self.shadow_points += o.shadow_points;
        self.penumbra_points += o.penumbra_points;
        self.shadow_uniform_rays += o.shadow_uniform_rays;
        self.penumbra_stopped += o.penumbra_stopped;
        self.penumbra_saved_rays += o.penumbra_saved_rays;
        self.shadow_uniform_fallback += o.shadow_uniform_fallback;
    }

    /// Rays by kind, with their names in the report. The kinds are disjoint.
    pub fn kinds(&self) -> [(&'static str, u64); 8] {
        [
            ("camera", self.camera_rays),
            ("aa_corner", self.aa_corner_rays),
            ("aa_refine", self.aa_refine_rays),
            ("dof_probe", self.dof_probe_rays),
            ("shadow", self.shadow_rays),
            ("shadow_corner", self.shadow_corner_rays),
            ("penumbra", self.penumbra_rays),
            ("secondary", self.secondary_rays),
        ]
    }

    /// All rays traced: the kinds are disjoint, so this is their sum.
    pub fn total_rays(&self) -> u64 {
        self.kinds().iter().map(|k| k.1).sum()
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
    /// True when Ctrl-C stopped the render: unfinished tiles are black.
    pub partial: bool,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Worker threads.
    pub threads: usize,
    /// The light transport (`render.transport`): `"whitted"` or `"path"` (`direct` is
    /// `path` with `max_depth` 1).
    pub transport: &'static str,
    /// Bounces after the camera ray: mirror and glass chains under `whitted`, every
    /// scattering under `path`.
    pub max_depth: u32,
    /// Wall-clock seconds of the render (BVH build and file output excluded).
    pub seconds: f64,
    /// Rays traced, all kinds.
    pub total_rays: u64,
    /// total_rays / seconds / 1e6.
    pub mrays_per_s: f64,
    /// Rays by kind (disjoint; they sum to total_rays).
    pub rays: BTreeMap<&'static str, u64>,
    /// Adaptive queues: what entered them, what they cast, what uniform would have cast.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptive_aa: Option<QueueReport>,
    /// `render.aa.mode = "auto"`: what the pilot chose.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto_aa: Option<AutoChoice>,
    /// `render.shadows.mode = "auto"`: what the pilot chose.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto_shadows: Option<ShadowChoice>,
    /// The shadow-corner and penumbra queues, when shadows are adaptive.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptive_shadows: Option<QueueReport>,
    /// Penumbra early stopping, when `render.shadows.tolerance` is on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub penumbra_early_stop: Option<EarlyStopReport>,
    /// Per-stage counters, seconds summed over threads, and ns per ray.
    pub stages: BTreeMap<&'static str, StageReport>,
    /// Per ray BVH work of the stages that trace rays (absent when counters were off).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub traversal: BTreeMap<&'static str, TraversalReport>,
    /// Longest each queue got (entries; maximum over threads).
    pub peak_queue: QueuePeaks,
    /// Bytes held by all workers' queues and buffers at the end.
    pub queue_bytes: u64,
    /// Non-finite contributions the film stage dropped (should be 0).
    pub nonfinite_samples: u64,
    /// Facts about the scene.
    pub scene: SceneReport,
    /// Per-thread ray totals and busy seconds, in thread order.
    pub per_thread: Vec<ThreadReport>,
}

/// What an adaptive queue did, against uniform mode with the same settings.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct QueueReport {
    /// Items decided (pixels, or shading point × quad light pairs).
    pub entered: u64,
    /// Items that needed more rays (refined pixels, penumbra points).
    pub refined: u64,
    /// Rays the adaptive method cast (AA: centre + corner + refinement camera rays;
    /// shadows: corner probes + penumbra rays).
    pub rays: u64,
    /// Rays uniform mode would have cast for the same items (AA: 2^max_level camera
    /// rays per pixel; shadows: `samples` per point, counting only samples that face).
    pub uniform_rays: u64,
    /// uniform_rays - rays (negative when adaptive cost more).
    pub saved: i64,
    /// Shadows: (point, area light) pairs that did not enter the test but were sampled
    /// as in uniform mode, because the light's probes would cost more than 0.8 of its
    /// samples (they cost what uniform mode does, and are in neither count above).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uniform_fallback: Option<u64>,
}

impl QueueReport {
    fn new(entered: u64, refined: u64, rays: u64, uniform_rays: u64) -> QueueReport {
        QueueReport {
            entered,
            refined,
            rays,
            uniform_rays,
            saved: uniform_rays as i64 - rays as i64,
            uniform_fallback: None,
        }
    }
}

/// What early stopping did in the penumbra queue.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct EarlyStopReport {
    /// Penumbra points (point × quad light pairs).
    pub points: u64,
    /// Of those, the points that stopped before all `samples` rays.
    pub stopped: u64,
    /// Penumbra rays traced.
    pub rays: u64,
    /// Rays the fixed-n penumbra stage would have traced for the same points, minus `rays`.
    pub saved: u64,
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
    /// Mesh files outside the scene's folder (reached through `..` or a symlink).
    pub outside_paths: Vec<String>,
    /// What an imported scene asks for that is ignored or rendered differently (Mitsuba
    /// XML: a plugin's parameter wavetrace does not read, …), one line each.
    pub notes: Vec<String>,
}

/// What `render.aa.mode = "auto"` chose, why, and the pilot's prediction behind it (see
/// `render::uniform_samples`).
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct AutoChoice {
    /// "uniform", "variance" or "corners" (the paper's corner method).
    pub chose: &'static str,
    /// Why.
    pub why: &'static str,
    /// The rounds rendered: a pixel stops below this error (0 for uniform; the corner
    /// method's eps) ...
    pub threshold: f32,
    /// ... rounds add this many samples (uniform: one round of `max`; corners: the
    /// first refinement level's) ...
    pub min_samples: u32,
    /// ... up to this many a pixel.
    pub max: u32,
    /// Uniform: the pass is blue-noise dithered (`render.blue_noise`, at few samples).
    pub dithered: bool,
    /// The share of the pilot's pixels a lens blurs over more than one pixel (0 where
    /// it was not measured: no lens, or more samples than the corner method is tried at).
    pub blurred: f64,
    /// Pixels in the pilot (one per 8×8 block of the image).
    pub pilot_pixels: usize,
    /// The samples a pixel uniform sampling needs for the mean squared error the pilot
    /// predicts for variance sampling at `threshold`, before rounding up.
    pub uniform_spp: f64,
    /// The samples a pixel variance sampling spends on average, as the pilot predicts.
    pub variance_spp: f64,
}

/// What `render.shadows.mode = "auto"` chose, and the pilot's counts behind it (see
/// `render::shadows_pay`).
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct ShadowChoice {
    /// "adaptive" or "uniform".
    pub chose: &'static str,
    /// Why.
    pub why: &'static str,
    /// Shading point × probed light pairs the pilot tested (0 without a pilot).
    pub pilot_points: u64,
    /// The share of them in the penumbra.
    pub penumbra_fraction: f64,
    /// Probe and penumbra rays the pilot cast, against uniform mode's for its points.
    pub adaptive_rays: u64,
    /// Uniform mode's shadow rays for the pilot's points.
    pub uniform_rays: u64,
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
    /// This thread's per-stage counters and ns per ray.
    pub stages: BTreeMap<&'static str, StageReport>,
}

/// Traversal cost of a stage that traces rays, per ray.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct TraversalReport {
    /// BVH nodes tested per ray.
    pub nodes_per_ray: f64,
    /// Primitive intersection tests per ray.
    pub prims_per_ray: f64,
    /// Share of the stage's rays traced in packets.
    pub packet_share: f64,
    /// Active lanes / [`LANES`](crate::simd::LANES) over the packets' node tests (0 without packets).
    pub lane_utilisation: f64,
}

impl Report {
    /// Builds the report from merged and per-thread stats.
    pub fn new(
        settings: &crate::scene::Settings,
        seconds: f64,
        total: &Stats,
        per_thread: &[Stats],
        scene: SceneReport,
    ) -> Report {
        use crate::scene::{AaMode, ShadowMode};
        let (width, height) = (settings.width, settings.height);
        let total_rays = total.total_rays();
        let t = total;
        Report {
            version: 1,
            partial: false,
            auto_aa: None,
            auto_shadows: None,
            width,
            height,
            threads: per_thread.len(),
            transport: if settings.path() { "path" } else { "whitted" },
            max_depth: settings.max_depth,
            seconds,
            total_rays,
            mrays_per_s: if seconds > 0.0 { total_rays as f64 / seconds / 1e6 } else { 0.0 },
            rays: total.kinds().into_iter().collect(),
            adaptive_aa: (settings.aa_mode != AaMode::Uniform).then(|| {
                let rays = t.camera_rays + t.aa_corner_rays + t.aa_refine_rays + t.dof_probe_rays;
                QueueReport::new(t.aa_pixels, t.aa_refined_pixels, rays, t.aa_uniform_rays)
            }),
            adaptive_shadows: matches!(settings.shadow_mode, ShadowMode::Adaptive(_) | ShadowMode::Auto(_)).then(
                || {
                    let rays = t.shadow_corner_rays + t.penumbra_rays;
                    let report = QueueReport::new(t.shadow_points, t.penumbra_points, rays, t.shadow_uniform_rays);
                    QueueReport { uniform_fallback: Some(t.shadow_uniform_fallback), ..report }
                },
            ),
            penumbra_early_stop: settings.penumbra_stop.map(|_| EarlyStopReport {
                points: t.penumbra_points,
                stopped: t.penumbra_stopped,
                rays: t.penumbra_rays,
                saved: t.penumbra_saved_rays,
            }),
            stages: stage_reports(total),
            traversal: [Stage::Focus, Stage::Intersect, Stage::Shadow, Stage::ShadowCorner, Stage::Penumbra]
                .iter()
                .filter_map(|&st| {
                    let c = total.stage(st);
                    // Rays traced by the stage: its input, except shadow-corner and
                    // penumbra, whose inputs are points.
                    let rays = match st {
                        Stage::Focus => total.dof_probe_rays,
                        Stage::ShadowCorner => total.shadow_corner_rays,
                        Stage::Penumbra => total.penumbra_rays,
                        _ => c.rays_in,
                    };
                    (rays > 0 && (c.nodes > 0 || c.packet_steps > 0)).then(|| {
                        let r = rays as f64;
                        let lanes = if c.packet_steps > 0 {
                            c.packet_lanes as f64 / (crate::simd::LANES as u64 * c.packet_steps) as f64
                        } else {
                            0.0
                        };
                        let t = TraversalReport {
                            nodes_per_ray: c.nodes as f64 / r,
                            prims_per_ray: c.prims as f64 / r,
                            packet_share: c.packet_rays as f64 / r,
                            lane_utilisation: lanes,
                        };
                        (st.name(), t)
                    })
                })
                .collect(),
            peak_queue: total.peak,
            queue_bytes: total.queue_bytes,
            nonfinite_samples: total.nonfinite,
            scene,
            per_thread: per_thread
                .iter()
                .map(|t| ThreadReport {
                    rays: t.total_rays(),
                    tiles: t.tiles,
                    busy_seconds: t.stages.iter().map(|c| c.seconds).sum(),
                    stages: stage_reports(t),
                })
                .collect(),
        }
    }

    /// The short summary printed after every render.
    pub fn summary(&self) -> String {
        let kinds: Vec<String> = self.rays.iter().filter(|(_, &n)| n > 0).map(|(k, n)| format!("{k} {n}")).collect();
        format!(
            "{}x{} {} (max_depth {}): {} rays ({}) in {:.3} s on {} threads = {:.2} Mrays/s",
            self.width,
            self.height,
            self.transport,
            self.max_depth,
            self.total_rays,
            kinds.join(", "),
            self.seconds,
            self.threads,
            self.mrays_per_s
        )
    }

    /// The per-stage table of `--stats`.
    pub fn table(&self) -> String {
        let mut s = format!(
            "{:<14} {:>14} {:>14} {:>10} {:>9} {:>10} {:>10}\n",
            "stage", "rays in", "rays out", "seconds", "ns/ray", "nodes/ray", "prims/ray"
        );
        for st in Stage::ALL {
            let r = &self.stages[st.name()];
            let c = &r.counters;
            let (n, p) = self.traversal.get(st.name()).map_or((String::new(), String::new()), |t| {
                (format!("{:.1}", t.nodes_per_ray), format!("{:.1}", t.prims_per_ray))
            });
            s += &format!(
                "{:<14} {:>14} {:>14} {:>10.3} {:>9.1} {:>10} {:>10}\n",
                st.name(),
                c.rays_in,
                c.rays_out,
                c.seconds,
                r.ns_per_ray,
                n,
                p
            );
        }
        for (kind, n) in &self.rays {
            s += &format!("rays {:<13} {:>10}\n", kind, n);
        }
        for (name, q) in [("adaptive aa", &self.adaptive_aa), ("adaptive shadows", &self.adaptive_shadows)] {
            if let Some(q) = q {
                s += &format!(
                    "{name}: {} entered, {} refined, {} rays cast vs {} uniform ({} saved, {:.1}%)\n",
                    q.entered,
                    q.refined,
                    q.rays,
                    q.uniform_rays,
                    q.saved,
                    100.0 * q.saved as f64 / q.uniform_rays.max(1) as f64
                );
                if let Some(n) = q.uniform_fallback.filter(|&n| n > 0) {
                    s += &format!("{name}: {n} more sampled uniformly (probes would cost over 0.8 of the samples)\n");
                }
            }
        }
        if let Some(e) = &self.penumbra_early_stop {
            s += &format!(
                "penumbra early stop: {} of {} points stopped early, {} rays traced, {} saved ({:.1}%)\n",
                e.stopped,
                e.points,
                e.rays,
                e.saved,
                100.0 * e.saved as f64 / (e.rays + e.saved).max(1) as f64
            );
        }
        s += &format!(
            "total {:>22} rays, {:.3} s wall, {:.2} Mrays/s, {} threads\n",
            self.total_rays, self.seconds, self.mrays_per_s, self.threads
        );
        let q = &self.peak_queue;
        s += &format!(
            "peak queues: rays {}, shadow {}, shadow points {}, penumbra rays {}, specular {}, film {}; {:.1} MiB held\n",
            q.rays,
            q.shadow,
            q.shadow_points,
            q.penumbra_rays,
            q.specular,
            q.film,
            self.queue_bytes as f64 / (1 << 20) as f64
        );
        s += &format!(
            "scene: {} primitives ({} triangles, {} degenerate skipped), BVH {:.3} s, load {:.3} s",
            self.scene.primitives,
            self.scene.triangles,
            self.scene.degenerate_triangles,
            self.scene.bvh_seconds,
            self.scene.load_seconds
        );
        for note in &self.scene.notes {
            s += &format!("\nnote: {note}");
        }
        s
    }
}

/// A Chrome trace-event JSON document (chrome://tracing, Perfetto) with one complete
/// ("X") event per stage span; thread ids are worker indices.
pub fn chrome_trace(spans: &[Vec<Span>]) -> String {
    let events: Vec<serde_json::Value> = spans
        .iter()
        .enumerate()
        .flat_map(|(tid, list)| {
            list.iter().map(move |sp| {
                serde_json::json!({
                    "name": sp.stage.name(), "cat": "stage", "ph": "X",
                    "ts": sp.start_us, "dur": sp.dur_us, "pid": 1, "tid": tid,
                })
            })
        })
        .collect();
    serde_json::json!({ "traceEvents": events, "displayTimeUnit": "ms" }).to_string()
}
