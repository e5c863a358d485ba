//! The driver: splits the image into tiles, and for each tile runs the stages wave by
//! wave until no ray is left. Workers own their queues and reuse them.
//!
//! Uniform AA is one pass per tile. Adaptive AA (paper §2.1) is a corner-grid pass over
//! the whole image (when corners are shared), then per tile a centre pass, the corner
//! decision, and one pass of the refinement queue per level (`render/adaptive.rs`). DOF-aware AA
//! adds a pass of depth probes over the corner grid first.

mod adaptive;

use glam::{Vec2, Vec3};
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use crate::film::{copy_tile, Heat, Image};
use crate::geometry::Traversal;
use crate::queue::{FilmQueue, HitQueue, RayQueue, ShadowPointQueue, ShadowQueue};
use crate::scene::{AaMode, Light, Scene, ShadowMode};
use crate::stages::penumbra::Batches;
use crate::stages::refine::RefineState;
use crate::stages::{camera, film, intersect, penumbra, scatter, shade, shadow, shadow_corner, Tile};
use crate::stats::{Span, Stage, Stats};
use crate::{Error, Result};

/// Tile edge in pixels: small enough to balance load, large enough for coherent waves.
pub const TILE: u32 = 16;
/// Most rays one wave traces (camera rays of a batch, or a chunk of a deeper level); a
/// scene with many shadow samples per hit uses smaller waves (see [`wave_size`]).
pub const WAVE_RAYS: u64 = 4096;

/// Most shadow rays (or probes plus penumbra rays) one wave may queue.
pub const SHADOW_RAYS_PER_WAVE: u64 = 1 << 18;

/// The wave size of a scene: WAVE_RAYS, or fewer when each hit can queue many shadow
/// rays, so that the shadow queues stay below SHADOW_RAYS_PER_WAVE entries. Together
/// with depth-first draining of the bounce levels this bounds every queue: a worker
/// holds at most (max_depth + 1) levels of at most 2 waves each.
pub fn wave_size(scene: &Scene) -> u64 {
    let s = &scene.settings;
    let per_hit: u64 = scene
        .lights
        .iter()
        .map(|l| match (l, s.shadow_mode) {
            (Light::Point { .. }, _) => 1,
            (Light::Quad { .. }, ShadowMode::Uniform) => s.shadow_samples as u64,
            (Light::Quad { .. }, ShadowMode::Adaptive(p)) => p.rays() as u64 + s.shadow_samples as u64,
        })
        .sum();
    (SHADOW_RAYS_PER_WAVE / per_hit.max(1)).clamp(1, WAVE_RAYS)
}

/// How to render.
#[derive(Clone, Debug, Default)]
pub struct RenderOptions {
    /// Worker threads; `None` uses every core.
    pub threads: Option<usize>,
    /// A progress bar to advance once per tile (its message shows Mrays/s).
    pub progress: Option<indicatif::ProgressBar>,
    /// Leave out the BVH node and primitive counters (for measuring their overhead).
    pub no_counters: bool,
    /// Record one span per stage call per thread for a Chrome trace.
    pub trace: bool,
    /// Set from elsewhere (a Ctrl-C handler) to stop: tiles already finished are kept,
    /// the one in progress is dropped, and the output is marked partial.
    pub cancel: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
}

/// What a render produces.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// The image.
    pub image: Image,
    /// Where the rays went.
    pub heat: Heat,
    /// Counters merged over threads.
    pub stats: Stats,
    /// Counters per thread.
    pub per_thread: Vec<Stats>,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Stage spans per thread, when `RenderOptions::trace`.
    pub spans: Vec<Vec<Span>>,
    /// True when the render was cancelled before every tile was finished: unfinished
    /// tiles are black.
    pub partial: bool,
}

/// The kind of camera ray a pass starts, for the stats.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Camera,
    Corner,
    Refine,
}

/// Per-slot counters of one pass (the heatmap data before slots are mapped to pixels).
#[derive(Default)]
struct SlotHeat {
    rays: Vec<f32>,
    points: Vec<f32>,
    penumbra: Vec<f32>,
}

impl SlotHeat {
    fn reset(&mut self, n: usize) {
        for v in [&mut self.rays, &mut self.points, &mut self.penumbra] {
            v.clear();
            v.resize(n, 0.0);
        }
    }
}

/// One worker's reusable queues and buffers.
#[derive(Default)]
struct Worker {
    rays: RayQueue,
    next: RayQueue,
    hits: HitQueue,
    shadow: ShadowQueue,
    points: ShadowPointQueue,
    penumbra: Vec<u32>,
    penumbra_rays: ShadowQueue,
    /// Penumbra early stopping: per-point state, the batch being traced, and the
    /// occlusion stage's output for it.
    batches: Batches,
    batch: ShadowQueue,
    through: FilmQueue,
    specular: Vec<u32>,
    film: FilmQueue,
    /// Accumulated radiance per slot of the current pass.
    sums: Vec<Vec3>,
    slot_heat: SlotHeat,
    /// Tile results: final radiance and heat per tile pixel.
    out: Vec<Vec3>,
    heat: Heat,
    /// Rays still to trace per bounce level (level 0: the camera batch), and how far
    /// each level has been traced.
    levels: Vec<RayQueue>,
    cursors: Vec<usize>,
    /// Rays per wave for this scene.
    wave: u64,
    /// Adaptive AA buffers.
    centre: Vec<Vec3>,
    corner_mean: Vec<Vec3>,
    refine: RefineState,
    queue: Vec<u32>,
    /// Per tile pixel: the eps of its decisions.
    eps: Vec<f32>,
    /// DOF-aware AA: blur radii (pixels) of each depth probe of the last focus pass (for
    /// the eps, and for the lens count), lens-ray prefix sums of the points of a pass, and
    /// each pixel's refinement lens count.
    blur: Vec<f32>,
    blur_lens: Vec<f32>,
    starts: Vec<u64>,
    pixel_lens: Vec<u32>,
    stats: Stats,
    /// Traversal work of the stage being run.
    work: Traversal,
    /// Scratch: the order rays are grouped into packets.
    order: Vec<(u64, u32)>,
    count: bool,
    /// Stage spans, when tracing: `Some(render start)`.
    trace: Option<Instant>,
    spans: Vec<Span>,
    /// The render's cancel flag, and whether this worker saw it mid-tile.
    cancel: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    aborted: bool,
}

impl Worker {
    /// Starts a pass with `slots` accumulation slots.
    fn begin_pass(&mut self, slots: usize) {
        self.sums.clear();
        self.sums.resize(slots, Vec3::ZERO);
        self.slot_heat.reset(slots);
    }

    /// Runs `total` camera samples of a pass through the pipeline in waves of at most
    /// WAVE_RAYS camera rays; `generate` writes the rays of a range of sample indices.
    fn run(&mut self, scene: &Scene, total: u64, kind: Kind, generate: impl Fn(Range<u64>, &mut RayQueue)) {
        let mut k0 = 0;
        while k0 < total {
            if self.cancelled() {
                self.aborted = true;
                return;
            }
            let k1 = (k0 + self.wave).min(total);
            let t = Instant::now();
            self.rays.clear();
            generate(k0..k1, &mut self.rays);
            let n = self.rays.len() as u64;
            self.lap(Stage::Camera, 0, n as usize, t);
            match kind {
                Kind::Camera => self.stats.camera_rays += n,
                Kind::Corner => self.stats.aa_corner_rays += n,
                Kind::Refine => self.stats.aa_refine_rays += n,
            }
            self.drain(scene);
            k0 = k1;
        }
    }

    /// Traces the camera batch in `self.rays` and every bounce it spawns, depth first:
    /// the deepest pending level is traced next, a wave at a time, so level d holds at
    /// most the two waves' worth of rays spawned from one wave of level d - 1, and the
    /// queues stay bounded however many rays dielectrics split into.
    fn drain(&mut self, scene: &Scene) {
        let wave = self.wave as usize;
        self.levels.resize_with(scene.settings.max_depth as usize + 2, Default::default);
        self.cursors.resize(self.levels.len(), 0);
        std::mem::swap(&mut self.levels[0], &mut self.rays);
        self.cursors[0] = 0;
        while let Some(d) = (0..self.levels.len()).rev().find(|&d| self.cursors[d] < self.levels[d].len()) {
            let (start, end) = (self.cursors[d], (self.cursors[d] + wave).min(self.levels[d].len()));
            self.rays.clear();
            self.rays.append_range(&self.levels[d], start..end);
            self.cursors[d] = end;
            if end == self.levels[d].len() {
                self.levels[d].clear();
                self.cursors[d] = 0;
            }
            self.wave(scene);
            // The wave's output (its scattered rays) is the next level, empty until now.
            if !self.rays.is_empty() {
                std::mem::swap(&mut self.levels[d + 1], &mut self.rays);
                self.cursors[d + 1] = 0;
            }
        }
    }

    /// One wave: intersect the current rays, shade, resolve shadows, scatter, accumulate.
    fn wave(&mut self, scene: &Scene) {
        let n = self.rays.len();
        for &s in &self.rays.slot {
            self.slot_heat.rays[s as usize] += 1.0;
        }
        self.peak_rays(n);
        let t = Instant::now();
        intersect::intersect(scene, &self.rays, &mut self.hits, &mut self.work, self.count, &mut self.order);
        let t = self.lap(Stage::Intersect, n, n, t);

        let uniform_equivalent = shade::shade(
            scene,
            &self.rays,
            &self.hits,
            &mut self.shadow,
            &mut self.points,
            &mut self.specular,
            &mut self.film,
        );
        let shaded_out = self.shadow.len() + self.points.len() + self.specular.len() + self.film.len();
        let p = &mut self.stats.peak;
        p.shadow = p.shadow.max(self.shadow.len() as u64);
        p.shadow_points = p.shadow_points.max(self.points.len() as u64);
        p.specular = p.specular.max(self.specular.len() as u64);
        let t = self.lap(Stage::Shade, n, shaded_out, t);

        let lit = shadow::occlusion(scene, &self.shadow, &mut self.film, &mut self.work, self.count, &mut self.order);
        self.stats.shadow_rays += self.shadow.len() as u64;
        for &s in &self.shadow.slot {
            self.slot_heat.rays[s as usize] += 1.0;
        }
        let mut t = self.lap(Stage::Shadow, self.shadow.len(), lit, t);

        if let ShadowMode::Adaptive(probe) = scene.settings.shadow_mode {
            let cast = shadow_corner::shadow_corners(
                scene,
                probe,
                &self.rays,
                &self.hits,
                &self.points,
                &mut self.film,
                &mut self.penumbra,
                &mut self.work,
                self.count,
            );
            self.stats.shadow_corner_rays += cast as u64;
            self.stats.shadow_points += self.points.len() as u64;
            self.stats.penumbra_points += self.penumbra.len() as u64;
            self.stats.shadow_uniform_rays += uniform_equivalent;
            let per_point = probe.rays() as f32;
            for &r in &self.points.ray {
                let s = self.rays.slot[r as usize] as usize;
                self.slot_heat.points[s] += 1.0;
                self.slot_heat.rays[s] += per_point;
            }
            for &k in &self.penumbra {
                self.slot_heat.penumbra[self.rays.slot[self.points.ray[k as usize] as usize] as usize] += 1.0;
            }
            t = self.lap(Stage::ShadowCorner, self.points.len(), self.penumbra.len(), t);

            let stop = scene.settings.penumbra_stop;
            penumbra::penumbra(
                scene,
                &self.rays,
                &self.hits,
                &self.points,
                &self.penumbra,
                &mut self.penumbra_rays,
                stop.is_some().then_some(&mut self.batches),
            );
            let p = &mut self.stats.peak;
            p.penumbra_rays = p.penumbra_rays.max(self.penumbra_rays.len() as u64);
            let lit = match stop {
                None => {
                    for &s in &self.penumbra_rays.slot {
                        self.slot_heat.rays[s as usize] += 1.0;
                    }
                    self.stats.penumbra_rays += self.penumbra_rays.len() as u64;
                    shadow::occlusion(
                        scene,
                        &self.penumbra_rays,
                        &mut self.film,
                        &mut self.work,
                        self.count,
                        &mut self.order,
                    )
                }
                Some(stop) => {
                    // Batches until every point has stopped; the film gets the
                    // contributions afterwards, in the fixed-n order.
                    loop {
                        penumbra::next_batch(&mut self.batches, stop.batch, &self.penumbra_rays, &mut self.batch);
                        if self.batch.is_empty() {
                            break;
                        }
                        self.through.clear();
                        shadow::occlusion(
                            scene,
                            &self.batch,
                            &mut self.through,
                            &mut self.work,
                            self.count,
                            &mut self.order,
                        );
                        self.stats.penumbra_stopped += penumbra::record(&mut self.batches, &self.through, stop);
                        self.stats.penumbra_rays += self.batch.len() as u64;
                        for &r in &self.batch.slot {
                            self.slot_heat.rays[self.penumbra_rays.slot[r as usize] as usize] += 1.0;
                        }
                    }
                    let traced: u32 = self.batches.taken.iter().sum();
                    self.stats.penumbra_saved_rays += self.penumbra_rays.len() as u64 - traced as u64;
                    penumbra::resolve(&self.batches, &self.penumbra_rays, &mut self.film)
                }
            };
            t = self.lap(Stage::Penumbra, self.penumbra.len(), lit, t);
        }

        self.next.clear();
        // A scene without used mirrors or dielectrics never enters the scatter stage.
        if scene.has_specular {
            scatter::scatter(scene, &self.rays, &self.hits, &self.specular, &mut self.next);
            self.stats.secondary_rays += self.next.len() as u64;
            t = self.lap(Stage::Scatter, self.specular.len(), self.next.len(), t);
        }

        self.stats.peak.film = self.stats.peak.film.max(self.film.len() as u64);
        let dropped = film::accumulate(&self.film, &mut self.sums);
        self.stats.nonfinite += dropped as u64;
        self.lap(Stage::Film, self.film.len(), self.film.len() - dropped, t);
        std::mem::swap(&mut self.rays, &mut self.next);
    }

    /// Ends a stage call begun at `since`: records its counts, time and traversal work,
    /// and its span when tracing.
    fn lap(&mut self, stage: Stage, rays_in: usize, rays_out: usize, since: Instant) -> Instant {
        let now = Instant::now();
        self.stats.record(stage, rays_in, rays_out, (now - since).as_secs_f64());
        let c = &mut self.stats.stages[stage as usize];
        c.nodes += self.work.nodes;
        c.prims += self.work.prims;
        c.packet_rays += self.work.packet_rays;
        c.packet_steps += self.work.packet_steps;
        c.packet_lanes += self.work.packet_lanes;
        self.work = Traversal::default();
        if let Some(t0) = self.trace {
            let start_us = (since - t0).as_secs_f64() * 1e6;
            self.spans.push(Span { stage, start_us, dur_us: (now - since).as_secs_f64() * 1e6 });
        }
        now
    }

    fn cancelled(&self) -> bool {
        self.cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed))
    }

    fn peak_rays(&mut self, n: usize) {
        self.stats.peak.rays = self.stats.peak.rays.max(n as u64);
    }

    /// Bytes held by the worker's queues and buffers (capacities).
    fn bytes(&self) -> u64 {
        let v3 = std::mem::size_of::<Vec3>();
        let sh = |q: &ShadowQueue| 11 * 4 * q.ox.capacity();
        let b = self.rays.bytes()
            + self.next.bytes()
            + self.levels.iter().map(RayQueue::bytes).sum::<usize>()
            + 8 * self.hits.t.capacity()
            + sh(&self.shadow)
            + sh(&self.penumbra_rays)
            + sh(&self.batch)
            + 16 * self.through.slot.capacity()
            + 21 * self.batches.point.capacity()
            + 16 * self.batches.start.capacity()
            + 4 * (self.eps.capacity() + self.blur.capacity() + self.blur_lens.capacity() + self.pixel_lens.capacity())
            + 8 * self.starts.capacity()
            + 20 * self.points.ray.capacity()
            + 4 * (self.penumbra.capacity() + self.specular.capacity() + self.queue.capacity())
            + 16 * self.film.slot.capacity()
            + v3 * (self.sums.capacity() + self.out.capacity() + self.centre.capacity() + self.corner_mean.capacity());
        b as u64
    }

    /// Starts the tile's results: radiance and heat per tile pixel.
    fn begin_tile(&mut self, n: usize) {
        self.out.clear();
        self.out.resize(n, Vec3::ZERO);
        let h = &mut self.heat;
        for v in [&mut h.rays, &mut h.points, &mut h.penumbra] {
            v.clear();
            v.resize(n, 0.0);
        }
        h.level.clear();
        h.level.resize(n, 0);
    }

    /// Adds the pass's slot heat to the tile pixels; slot s belongs to pixel s / group.
    fn collect_heat(&mut self, group: usize) {
        for s in 0..self.slot_heat.rays.len() {
            let p = s / group;
            self.heat.rays[p] += self.slot_heat.rays[s];
            self.heat.points[p] += self.slot_heat.points[s];
            self.heat.penumbra[p] += self.slot_heat.penumbra[s];
        }
    }

    /// Uniform AA: every pixel gets aa_samples × dof_samples camera rays.
    fn uniform_tile(&mut self, scene: &Scene, tile: &Tile) {
        let spp = scene.settings.aa_samples as u64 * scene.settings.dof_samples as u64;
        self.begin_pass(tile.pixels());
        self.run(scene, tile.pixels() as u64 * spp, Kind::Camera, |ks, rays| camera::generate(scene, tile, ks, rays));
        self.out.copy_from_slice(&self.sums);
        self.collect_heat(1);
    }
}

/// The tiles of a `width`×`height` raster, row-major. The tiling never depends on the
/// thread count, and each tile sums its samples in a fixed order, so the image is
/// bit-identical for any number of threads.
pub fn tiles(width: u32, height: u32) -> Vec<Tile> {
    let mut out = Vec::new();
    for y0 in (0..height).step_by(TILE as usize) {
        for x0 in (0..width).step_by(TILE as usize) {
            out.push(Tile { x0, y0, x1: (x0 + TILE).min(width), y1: (y0 + TILE).min(height) });
        }
    }
    out
}

/// Runs `work` on every tile in parallel, each worker thread reusing one [`Worker`];
/// `store` copies a finished tile's results out. Returns per-thread stats.
fn for_tiles(
    pool: &rayon::ThreadPool,
    tiles: &[Tile],
    ctx: &Pass,
    work: impl Fn(&mut Worker, &Tile) + Sync,
    store: impl Fn(&Worker, &Tile) + Sync,
) -> Vec<(Stats, Vec<Span>)> {
    let next = AtomicUsize::new(0);
    pool.broadcast(|_| {
        let mut w = Worker {
            count: !ctx.opts.no_counters,
            trace: ctx.opts.trace.then_some(ctx.start),
            cancel: ctx.opts.cancel.clone(),
            wave: ctx.wave,
            ..Default::default()
        };
        while let Some(tile) = tiles.get(next.fetch_add(1, Ordering::Relaxed)) {
            let before = w.stats.total_rays();
            work(&mut w, tile);
            if w.aborted {
                break; // cancelled mid-tile: the tile is incomplete, keep it out
            }
            w.stats.tiles += 1;
            store(&w, tile);
            let done =
                ctx.rays.fetch_add(w.stats.total_rays() - before, Ordering::Relaxed) + w.stats.total_rays() - before;
            if let Some(pb) = &ctx.opts.progress {
                pb.inc(1);
                let secs = ctx.start.elapsed().as_secs_f64().max(1e-9);
                pb.set_message(format!("{:.1} Mrays/s", done as f64 / secs / 1e6));
            }
        }
        w.stats.queue_bytes = w.bytes();
        (w.stats, w.spans)
    })
}

/// What every tile pass of one render shares: options, start time, rays so far.
struct Pass<'a> {
    opts: &'a RenderOptions,
    wave: u64,
    start: Instant,
    rays: std::sync::atomic::AtomicU64,
}

/// Renders `scene`.
pub fn render(scene: &Scene, opts: &RenderOptions) -> Result<RenderOutput> {
    let s = &scene.settings;
    let threads = opts.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if threads == 0 {
        return Err(Error::input("--threads must be at least 1"));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::Internal(format!("cannot start {threads} threads: {e}")))?;
    let (w, h) = (s.width, s.height);
    let n = (w * h) as usize;
    let pixel_tiles = tiles(w, h);
    let shared_grid = matches!(s.aa_mode, AaMode::Adaptive { share_corners: true, .. });
    let grid_tiles = if shared_grid { tiles(w + 1, h + 1) } else { Vec::new() };
    let focus_tiles = if s.dof_radius.is_some() { tiles(w + 1, h + 1) } else { Vec::new() };
    if let Some(pb) = &opts.progress {
        pb.set_length((pixel_tiles.len() + grid_tiles.len() + focus_tiles.len()) as u64);
    }
    let start = Instant::now();
    let ctx = Pass { opts, wave: wave_size(scene), start, rays: std::sync::atomic::AtomicU64::new(0) };

    // DOF-aware AA: the blur of every pixel corner, from one depth probe each, before
    // any corner or pixel decides its lens rays.
    let corners = focus_tiles.len().min(1) * ((w + 1) * (h + 1)) as usize;
    let corner_blur = Mutex::new((vec![0.0f32; corners], vec![0.0f32; corners]));
    let focus_pass = for_tiles(
        &pool,
        &focus_tiles,
        &ctx,
        |wk, tile| {
            let tw = tile.x1 - tile.x0;
            wk.focus(scene, tile.pixels(), |i| Vec2::new((tile.x0 + i % tw) as f32, (tile.y0 + i / tw) as f32));
        },
        |wk, tile| {
            let mut b = corner_blur.lock().unwrap_or_else(|e| e.into_inner());
            copy_tile(&mut b.0, w + 1, tile, &wk.blur);
            copy_tile(&mut b.1, w + 1, tile, &wk.blur_lens);
        },
    );
    let (corner_sharp, corner_lens) = corner_blur.into_inner().unwrap_or_else(|e| e.into_inner());
    let blur = s.dof_radius.is_some().then_some((&corner_sharp[..], &corner_lens[..]));

    // Adaptive AA with shared corners: trace the (W+1)×(H+1) corner grid once.
    let grid =
        Mutex::new((vec![Vec3::ZERO; grid_tiles.len().min(1) * ((w + 1) * (h + 1)) as usize], SlotHeat::default()));
    if shared_grid {
        grid.lock().unwrap_or_else(|e| e.into_inner()).1.reset(((w + 1) * (h + 1)) as usize);
    }
    let grid_pass = for_tiles(
        &pool,
        &grid_tiles,
        &ctx,
        |wk, tile| wk.corner_grid_tile(scene, tile, blur.map(|b| b.1)),
        |wk, tile| {
            let mut g = grid.lock().unwrap_or_else(|e| e.into_inner());
            let (radiance, heat) = &mut *g;
            copy_tile(radiance, w + 1, tile, &wk.sums);
            copy_tile(&mut heat.rays, w + 1, tile, &wk.slot_heat.rays);
            copy_tile(&mut heat.points, w + 1, tile, &wk.slot_heat.points);
            copy_tile(&mut heat.penumbra, w + 1, tile, &wk.slot_heat.penumbra);
        },
    );
    let (grid, grid_heat) = grid.into_inner().unwrap_or_else(|e| e.into_inner());

    let result = Mutex::new((vec![Vec3::ZERO; n], Heat::default()));
    {
        let mut r = result.lock().unwrap_or_else(|e| e.into_inner());
        let heat = &mut r.1;
        heat.rays.resize(n, 0.0);
        heat.points.resize(n, 0.0);
        heat.penumbra.resize(n, 0.0);
        heat.level.resize(n, 0);
    }
    let main = for_tiles(
        &pool,
        &pixel_tiles,
        &ctx,
        |wk, tile| {
            wk.begin_tile(tile.pixels());
            match s.aa_mode {
                AaMode::Uniform => wk.uniform_tile(scene, tile),
                AaMode::Adaptive { eps, .. } => {
                    wk.adaptive_tile(scene, tile, shared_grid.then_some(&grid[..]), blur, eps)
                }
            }
        },
        |wk, tile| {
            let mut r = result.lock().unwrap_or_else(|e| e.into_inner());
            let (img, heat) = &mut *r;
            copy_tile(img, w, tile, &wk.out);
            copy_tile(&mut heat.rays, w, tile, &wk.heat.rays);
            copy_tile(&mut heat.points, w, tile, &wk.heat.points);
            copy_tile(&mut heat.penumbra, w, tile, &wk.heat.penumbra);
            copy_tile(&mut heat.level, w, tile, &wk.heat.level);
        },
    );
    let seconds = start.elapsed().as_secs_f64();
    let (pixels, mut heat) = result.into_inner().unwrap_or_else(|e| e.into_inner());

    // A shared corner's rays belong equally to the pixels around it.
    if shared_grid {
        for cy in 0..=h {
            for cx in 0..=w {
                let ci = (cy * (w + 1) + cx) as usize;
                let xs = cx.saturating_sub(1)..cx.min(w - 1) + 1;
                let ys = cy.saturating_sub(1)..cy.min(h - 1) + 1;
                let share = 1.0 / (xs.len() * ys.len()) as f32;
                for y in ys {
                    for x in xs.clone() {
                        let p = (y * w + x) as usize;
                        heat.rays[p] += grid_heat.rays[ci] * share;
                        heat.points[p] += grid_heat.points[ci] * share;
                        heat.penumbra[p] += grid_heat.penumbra[ci] * share;
                    }
                }
            }
        }
    }

    // Thread i of every pass is the same pool thread.
    let mut per_thread = focus_pass;
    for pass in [grid_pass, main] {
        for (a, b) in per_thread.iter_mut().zip(pass) {
            // The passes' workers live one after the other: peak bytes, not the sum.
            let bytes = a.0.queue_bytes.max(b.0.queue_bytes);
            a.0.merge(&b.0);
            a.0.queue_bytes = bytes;
            a.1.extend(b.1);
        }
    }
    let mut stats = Stats::default();
    per_thread.iter().for_each(|t| stats.merge(&t.0));
    let (per_thread, spans) = per_thread.into_iter().unzip();
    let partial = stats.tiles < (pixel_tiles.len() + grid_tiles.len() + focus_tiles.len()) as u64;
    Ok(RenderOutput { image: Image { width: w, height: h, pixels }, heat, stats, per_thread, seconds, spans, partial })
}
