//! The driver: splits the image into tiles, and for each tile runs the stages wave by
//! wave until no ray is left. Workers own their queues and reuse them.
//!
//! Uniform AA is one pass per tile. Adaptive AA (paper §2.1) is a corner-grid pass over
//! the whole image (when corners are shared), then per tile a centre pass, the corner
//! decision, and one pass of the refinement queue per level (`render/adaptive.rs`). DOF-aware AA
//! adds a pass of depth probes over the corner grid first. Variance-driven AA is one pass
//! per round per tile (`render/variance.rs`).

mod adaptive;
mod auto;
mod meter;
mod pipeline;
mod variance;

use glam::{Vec2, Vec3};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use adaptive::{AaState, CornerBlur};
use auto::Sampling;
pub use auto::{shadows_pay, SHADOW_MARGIN};
use meter::{Kind, Meter};
use pipeline::Pipeline;
use variance::VarianceState;
pub use variance::{uniform_samples, PILOT_BLOCK};

use crate::accel::tracer::{Coherence, Kernel, Tracer};
use crate::film::{copy_tile, tiles, Heat, Image, SlotHeat, Tile, TileFilm, TILE};
use crate::scene::{AaMode, Light, Scene, ShadowMode};
use crate::stages::camera;
use crate::stats::{AutoChoice, ShadowChoice, Span, Stats};
use crate::{Error, Result};

/// Most rays one wave traces (camera rays of a batch, or a chunk of a deeper level); a
/// scene with many shadow samples per hit uses smaller waves (see [`wave_size`]).
pub const WAVE_RAYS: u64 = 4096;

/// Most shadow rays (or probes plus penumbra rays) one wave may queue.
pub const SHADOW_RAYS_PER_WAVE: u64 = 1 << 18;

/// The wave size of a scene: WAVE_RAYS, or fewer when each hit can queue many shadow
/// rays, so that the shadow queues stay below SHADOW_RAYS_PER_WAVE entries. Together
/// with depth-first draining of the bounce levels this bounds every queue: a worker
/// holds at most (max_depth + 1) levels of at most 2 waves each.
pub fn wave_size(scene: &Scene, shadows: ShadowMode) -> u64 {
    let s = &scene.settings;
    let per_hit: u64 = scene
        .lights
        .iter()
        .map(|l| match (l, shadows) {
            (Light::Point { .. } | Light::Directional { .. }, _) => 1,
            (_, ShadowMode::Uniform | ShadowMode::Auto(_)) => s.shadow_samples as u64,
            (l, ShadowMode::Adaptive(p)) if crate::light::probes_light(l, p, s.shadow_samples) => {
                crate::light::probe_count(l, p) as u64 + s.shadow_samples as u64
            }
            (_, ShadowMode::Adaptive(_)) => s.shadow_samples as u64,
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
    /// Leave out the per-pixel heat ([`RenderOutput::heat`] is then empty): for a render
    /// that draws no heatmap, which need not fill 13 bytes a pixel it never reads.
    pub no_heat: bool,
    /// Set from elsewhere (a Ctrl-C handler) to stop: tiles already finished are kept,
    /// the one in progress is dropped, and the output is marked partial.
    pub cancel: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    /// Render only these pixels (half-open, in the full image's raster); the output
    /// image is the crop. Each pixel is bit-identical to the full render's: the crop
    /// runs the full render's tiles that touch it, unchanged (`pass_tiles`).
    pub crop: Option<Tile>,
}

/// What a render produces.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// The image (the crop, with [`RenderOptions::crop`]).
    pub image: Image,
    /// Where the rays went (over the crop).
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
    /// Pixels of the image (the crop) that finished pixel tiles cover: all of them
    /// unless `partial`. Corner-grid and focus tiles do not count; no pixel is final
    /// before its pixel tile is.
    pub finished_pixels: u64,
    /// `render.aa.mode = "auto"`: what the pilot chose.
    pub auto: Option<AutoChoice>,
    /// `render.shadows.mode = "auto"`: what the pilot chose.
    pub auto_shadows: Option<ShadowChoice>,
}

/// One worker: its wavefront, its adaptive-AA buffers and the tile it is finishing.
struct Worker<'a> {
    pipe: Pipeline<'a>,
    aa: AaState,
    var: VarianceState,
    tile: TileFilm,
}

impl Worker<'_> {
    /// Uniform AA: every pixel gets `aa` × dof_samples camera rays.
    fn uniform_tile(&mut self, scene: &Scene, tile: &Tile, pass: camera::UniformPass) {
        let spp = pass.samples as u64 * scene.settings.dof_samples as u64;
        self.pipe.acc.begin(tile.pixels());
        self.pipe.run(scene, tile.pixels() as u64 * spp, (Kind::Camera, Coherence::Camera), |ks, rays| {
            camera::generate(scene, tile, pass, ks, rays)
        });
        self.tile.out.copy_from_slice(&self.pipe.acc.sums);
        self.tile.collect_heat(&self.pipe.acc.heat, 1);
    }

    /// Bytes held by every queue and buffer (capacities).
    fn bytes(&self) -> u64 {
        (self.pipe.bytes() + self.aa.bytes() + self.var.bytes() + self.tile.bytes()) as u64
    }
}

/// What every tile pass of one render shares: the scene, options, start time, rays so far.
struct Ctx<'a> {
    scene: &'a Scene,
    opts: &'a RenderOptions,
    /// The render's own pool, or `None` to run on rayon's global pool, which already has
    /// the threads asked for (the command line sizes it for the load).
    pool: Option<rayon::ThreadPool>,
    wave: u64,
    /// The shadow mode of the passes (the pilot's, then the plan's; never `Auto`).
    shadows: ShadowMode,
    start: Instant,
    rays: AtomicU64,
}

/// One pass's counters and spans, per pool thread.
type PerThread = Vec<(Stats, Vec<Span>)>;

/// Runs `work` on every tile in parallel, each pool thread reusing one [`Worker`];
/// `store` copies a finished tile's results out. Returns per-thread counters.
fn for_tiles(
    ctx: &Ctx,
    tiles: &[Tile],
    work: impl Fn(&mut Worker, &Tile) + Sync,
    store: impl Fn(&Worker, &Tile) + Sync,
) -> PerThread {
    let next = AtomicUsize::new(0);
    let each = |_: rayon::BroadcastContext| {
        let mut w = new_worker(ctx);
        while let Some(tile) = tiles.get(next.fetch_add(1, Ordering::Relaxed)) {
            let before = w.pipe.meter.stats.total_rays();
            work(&mut w, tile);
            if w.pipe.aborted {
                break; // cancelled mid-tile: the tile is incomplete, keep it out
            }
            w.pipe.meter.stats.tiles += 1;
            store(&w, tile);
            let traced = w.pipe.meter.stats.total_rays() - before;
            let done = ctx.rays.fetch_add(traced, Ordering::Relaxed) + traced;
            if let Some(pb) = &ctx.opts.progress {
                pb.inc(1);
                let secs = ctx.start.elapsed().as_secs_f64().max(1e-9);
                pb.set_message(format!("{:.1} Mrays/s", done as f64 / secs / 1e6));
            }
        }
        w.pipe.meter.stats.queue_bytes = w.bytes();
        (w.pipe.meter.stats, w.pipe.meter.spans)
    };
    match &ctx.pool {
        Some(pool) => pool.broadcast(each),
        None => rayon::broadcast(each),
    }
}

/// A pool thread's worker, on the heap: the stages' stack frames below it then sit at
/// the same depth whatever the size of the queues. On the stack, fields added to the
/// queues moved those frames, and cornell's shade stage took 4-6% longer with no
/// instruction more (docs/performance.md, "Motion blur").
#[inline(never)]
fn new_worker<'a>(ctx: &'a Ctx) -> Box<Worker<'a>> {
    let kernel = Kernel::render(ctx.scene.settings.packets);
    let tracer = Tracer::new(&ctx.scene.accel, kernel, !ctx.opts.no_counters);
    let meter = Meter::new(ctx.opts.trace.then_some(ctx.start));
    let pipe = Pipeline::new(tracer, meter, (ctx.wave, ctx.shadows), ctx.opts.cancel.clone());
    Box::new(Worker { pipe, aa: AaState::default(), var: VarianceState::default(), tile: TileFilm::default() })
}

/// Locks a mutex whose holder may have panicked (the data is still what was stored).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// DOF-aware AA: the blur of every pixel corner, from one depth probe each, before any
/// corner or pixel decides its lens rays. Returns (sharp, lens) blur radii over the
/// (W+1)×(H+1) corner grid.
fn focus_pass(ctx: &Ctx, tiles: &[Tile]) -> (PerThread, Vec<f32>, Vec<f32>) {
    let gw = ctx.scene.settings.width + 1;
    let corners = tiles.len().min(1) * (gw * (ctx.scene.settings.height + 1)) as usize;
    let blur = Mutex::new((vec![0.0f32; corners], vec![0.0f32; corners]));
    let stats = for_tiles(
        ctx,
        tiles,
        |wk, tile| {
            let tw = tile.x1 - tile.x0;
            let film = |i| Vec2::new((tile.x0 + i % tw) as f32, (tile.y0 + i / tw) as f32);
            wk.pipe.focus(ctx.scene, tile.pixels(), film, &mut wk.aa.blur, &mut wk.aa.blur_lens);
        },
        |wk, tile| {
            let mut b = lock(&blur);
            copy_tile(&mut b.0, gw, tile, &wk.aa.blur);
            copy_tile(&mut b.1, gw, tile, &wk.aa.blur_lens);
        },
    );
    let (sharp, lens) = blur.into_inner().unwrap_or_else(|e| e.into_inner());
    (stats, sharp, lens)
}

/// Adaptive AA with shared corners: traces the (W+1)×(H+1) corner grid once (`lens`:
/// the corners' blur for their lens counts, with DOF-aware AA). Returns the corners'
/// radiance and heat.
fn grid_pass(ctx: &Ctx, tiles: &[Tile], lens: Option<&[f32]>) -> (PerThread, Vec<Vec3>, SlotHeat) {
    let gw = ctx.scene.settings.width + 1;
    let n = tiles.len().min(1) * (gw * (ctx.scene.settings.height + 1)) as usize;
    let grid = Mutex::new((vec![Vec3::ZERO; n], SlotHeat::zeroed(n)));
    let stats = for_tiles(
        ctx,
        tiles,
        |wk, tile| wk.corner_grid_tile(ctx.scene, tile, lens),
        |wk, tile| {
            let mut g = lock(&grid);
            let (radiance, heat) = &mut *g;
            copy_tile(radiance, gw, tile, &wk.pipe.acc.sums);
            heat.copy_tile(gw, tile, &wk.pipe.acc.heat);
        },
    );
    let (radiance, heat) = grid.into_inner().unwrap_or_else(|e| e.into_inner());
    (stats, radiance, heat)
}

/// The pixel tiles: uniform or adaptive AA, with the shared corner grid and the corners'
/// blur when there are. Returns the image's pixels and heat.
fn pixel_pass(
    ctx: &Ctx,
    tiles: &[Tile],
    (grid, blur): (Option<&[Vec3]>, Option<CornerBlur>),
    sampling: Sampling,
) -> (PerThread, Vec<Vec3>, Heat, Vec<Tile>) {
    let s = &ctx.scene.settings;
    let n = (s.width * s.height) as usize;
    let with_heat = !ctx.opts.no_heat;
    let result = Mutex::new((vec![Vec3::ZERO; n], Heat::zeroed(if with_heat { n } else { 0 })));
    let finished = Mutex::new(Vec::new());
    let stats = for_tiles(
        ctx,
        tiles,
        |wk, tile| {
            wk.tile.begin(tile.pixels());
            match sampling {
                Sampling::Uniform(pass) => wk.uniform_tile(ctx.scene, tile, pass),
                Sampling::Rounds(rounds) => wk.variance_tile(ctx.scene, tile, rounds),
                Sampling::Corners(corners) => wk.adaptive_tile(ctx.scene, tile, corners, grid, blur),
            }
        },
        |wk, tile| {
            let mut r = lock(&result);
            let (img, heat) = &mut *r;
            copy_tile(img, s.width, tile, &wk.tile.out);
            if with_heat {
                heat.copy_tile(s.width, tile, &wk.tile.heat);
            }
            lock(&finished).push(*tile);
        },
    );
    let (pixels, heat) = result.into_inner().unwrap_or_else(|e| e.into_inner());
    (stats, pixels, heat, finished.into_inner().unwrap_or_else(|e| e.into_inner()))
}

/// Splits each shared corner's heat equally between the pixels around it.
fn share_corner_heat(heat: &mut Heat, grid: &SlotHeat, w: u32, h: u32) {
    for cy in 0..=h {
        for cx in 0..=w {
            let ci = (cy * (w + 1) + cx) as usize;
            let xs = cx.saturating_sub(1)..cx.min(w - 1) + 1;
            let ys = cy.saturating_sub(1)..cy.min(h - 1) + 1;
            let share = 1.0 / (xs.len() * ys.len()) as f32;
            for y in ys {
                for x in xs.clone() {
                    let p = (y * w + x) as usize;
                    heat.rays[p] += grid.rays[ci] * share;
                    heat.points[p] += grid.points[ci] * share;
                    heat.penumbra[p] += grid.penumbra[ci] * share;
                }
            }
        }
    }
}

/// Merges the passes' per-thread counters (thread i of every pass is the same pool
/// thread) and sums them over threads.
fn merge_passes<const N: usize>(passes: [PerThread; N]) -> (Stats, Vec<Stats>, Vec<Vec<Span>>) {
    let mut passes = passes.into_iter().filter(|p| !p.is_empty());
    let mut per_thread = passes.next().unwrap_or_default();
    for pass in passes {
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
    (stats, per_thread, spans)
}

/// The tiles of each pass of a render of the pixels in `window`: (focus, grid, pixel).
/// These are the full render's tiles that the window's pixels need: the pixel tiles
/// that touch it, and the corner-grid tiles that hold those tiles' pixel corners, each
/// traced whole. The tiling and each tile's work are the full render's, so the window's
/// pixels, and the corners they share, have the full render's bits. `shared_grid`: the
/// pixel pass renders the corner method with shared corners.
fn pass_tiles(s: &crate::scene::Settings, window: &Tile, shared_grid: bool) -> (Vec<Tile>, Vec<Tile>, Vec<Tile>) {
    let (w, h) = (s.width, s.height);
    let pixel: Vec<Tile> = tiles(w, h).into_iter().filter(|t| t.overlaps(window)).collect();
    let block = Tile {
        x0: window.x0 / TILE * TILE,
        y0: window.y0 / TILE * TILE,
        x1: (window.x1.div_ceil(TILE) * TILE).min(w),
        y1: (window.y1.div_ceil(TILE) * TILE).min(h),
    }
    .corners();
    let corner_tiles = || tiles(w + 1, h + 1).into_iter().filter(|t| t.overlaps(&block)).collect::<Vec<_>>();
    let grid = if shared_grid { corner_tiles() } else { Vec::new() };
    let focus = if s.dof_radius.is_some() { corner_tiles() } else { Vec::new() };
    (focus, grid, pixel)
}

/// The crop of a render: `opts.crop` checked against the image, or the whole image.
fn window(s: &crate::scene::Settings, opts: &RenderOptions) -> Result<Tile> {
    let full = Tile { x0: 0, y0: 0, x1: s.width, y1: s.height };
    let Some(c) = opts.crop else { return Ok(full) };
    crate::film::Crop::Pixels(c).resolve(s.width, s.height).map_err(Error::input)
}

/// The render's own pool of `threads`, or `None` to run on rayon's global pool. A second
/// pool of the global one's size would only cost its threads' start (a fixed cost of
/// every small render); from inside a pool, or at another size, the render has its own.
fn own_pool(threads: usize) -> Result<Option<rayon::ThreadPool>> {
    if rayon::current_thread_index().is_none() && rayon::current_num_threads() == threads {
        return Ok(None);
    }
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build();
    pool.map(Some).map_err(|e| Error::Internal(format!("cannot start {threads} threads: {e}")))
}

/// Renders `scene`: the depth probes (DOF-aware AA), the shared corner grid (adaptive
/// AA), then the pixel tiles, each pass's tiles spread over the worker threads.
pub fn render(scene: &Scene, opts: &RenderOptions) -> Result<RenderOutput> {
    let s = &scene.settings;
    let threads = opts.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if threads == 0 {
        return Err(Error::input("--threads must be at least 1"));
    }
    let pool = own_pool(threads)?;
    let (w, h) = (s.width, s.height);
    let window = window(s, opts)?;
    // The auto modes' pilot, over the whole image whatever the crop, when one is needed.
    let pilot_tiles = if auto::needs_pilot(scene) { tiles(w, h) } else { Vec::new() };
    let count = |(f, g, p): &(Vec<Tile>, Vec<Tile>, Vec<Tile>)| pilot_tiles.len() + f.len() + g.len() + p.len();
    let scene_grid = matches!(s.aa_mode, AaMode::Adaptive { share_corners: true, .. });
    if let Some(pb) = &opts.progress {
        pb.set_length(count(&pass_tiles(s, &window, scene_grid)) as u64);
    }
    let start = Instant::now();
    let shadows = auto::pilot_shadows(scene);
    let mut ctx = Ctx { scene, opts, pool, wave: wave_size(scene, shadows), shadows, start, rays: AtomicU64::new(0) };

    let (pilot_stats, plan) = auto::pilot_pass(&ctx, &pilot_tiles);
    (ctx.shadows, ctx.wave) = (plan.shadows, wave_size(scene, plan.shadows));
    // Auto mode may choose the corner method, whose grid the scene's mode did not ask for.
    let shared_grid = matches!(plan.sampling, Sampling::Corners(c) if c.share);
    let passes = pass_tiles(s, &window, shared_grid);
    let all_tiles = count(&passes);
    if let (Some(pb), true) = (&opts.progress, shared_grid != scene_grid) {
        pb.set_length(all_tiles as u64);
    }
    let (focus_tiles, grid_tiles, pixel_tiles) = passes;
    let (focus_stats, sharp, lens) = focus_pass(&ctx, &focus_tiles);
    let blur = s.dof_radius.is_some().then_some(CornerBlur { sharp: &sharp, lens: &lens });
    let (grid_stats, grid, grid_heat) = grid_pass(&ctx, &grid_tiles, blur.map(|b| b.lens));
    let (main_stats, pixels, mut heat, finished) =
        pixel_pass(&ctx, &pixel_tiles, (shared_grid.then_some(&grid[..]), blur), plan.sampling);
    let seconds = start.elapsed().as_secs_f64();
    if shared_grid && !opts.no_heat {
        share_corner_heat(&mut heat, &grid_heat, w, h);
    }

    let (stats, per_thread, spans) = merge_passes([pilot_stats, focus_stats, grid_stats, main_stats]);
    let partial = stats.tiles < all_tiles as u64;
    let inside = |t: &Tile| {
        (t.x1.min(window.x1).saturating_sub(t.x0.max(window.x0)) as u64)
            * (t.y1.min(window.y1).saturating_sub(t.y0.max(window.y0)) as u64)
    };
    let finished_pixels = finished.iter().map(inside).sum();
    let image = Image { width: w, height: h, pixels };
    let (image, heat) = if window.pixels() == image.pixels.len() {
        (image, heat)
    } else {
        let heat = if opts.no_heat { heat } else { heat.crop(w, &window) };
        (image.crop(&window), heat)
    };
    let (auto, auto_shadows) = (plan.aa, plan.shadow);
    Ok(RenderOutput { image, heat, stats, per_thread, seconds, spans, partial, finished_pixels, auto, auto_shadows })
}
