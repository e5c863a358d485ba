//! The driver: splits the image into tiles, and for each tile runs the stages wave
//! by wave until no ray is left. Workers own their queues and reuse them.

use glam::Vec3;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use crate::queue::{FilmQueue, HitQueue, RayQueue, ShadowQueue};
use crate::scene::Scene;
use crate::stages::{camera, film, intersect, scatter, shade, shadow, Tile};
use crate::stats::{Stage, Stats};
use crate::{Error, Result};

/// Tile edge in pixels: small enough to balance load, large enough for coherent waves.
pub const TILE: u32 = 16;
/// Camera rays started per wave; a tile's samples are split into batches of this size,
/// which bounds queue memory whatever the sample counts.
pub const WAVE_RAYS: usize = 4096;

/// How to render.
#[derive(Clone, Debug, Default)]
pub struct RenderOptions {
    /// Worker threads; `None` uses every core.
    pub threads: Option<usize>,
    /// A progress bar to advance once per tile.
    pub progress: Option<indicatif::ProgressBar>,
}

/// A linear RGB image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Radiance per pixel, row-major from the top-left.
    pub pixels: Vec<Vec3>,
}

/// What a render produces.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// The image.
    pub image: Image,
    /// Counters merged over threads.
    pub stats: Stats,
    /// Counters per thread.
    pub per_thread: Vec<Stats>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// One worker's reusable queues.
#[derive(Default)]
struct Worker {
    rays: RayQueue,
    next: RayQueue,
    hits: HitQueue,
    shadow: ShadowQueue,
    specular: Vec<u32>,
    film: FilmQueue,
    sums: Vec<Vec3>,
    stats: Stats,
}

impl Worker {
    /// Renders one tile into `self.sums`.
    fn render_tile(&mut self, scene: &Scene, tile: &Tile) {
        let s = &scene.settings;
        self.sums.clear();
        self.sums.resize(tile.pixels(), Vec3::ZERO);
        let spp = s.aa_samples * s.dof_samples;
        let batch = (WAVE_RAYS / tile.pixels()).max(1) as u32;
        let mut j0 = 0;
        while j0 < spp {
            let j1 = j0.saturating_add(batch).min(spp);
            let t = Instant::now();
            self.rays.clear();
            camera::generate(scene, tile, j0..j1, &mut self.rays);
            self.stats.record(Stage::Camera, 0, self.rays.len(), t.elapsed().as_secs_f64());
            self.stats.camera_rays += self.rays.len() as u64;
            while !self.rays.is_empty() {
                self.wave(scene, tile);
            }
            j0 = j1;
        }
        self.stats.tiles += 1;
    }

    /// One wave: intersect the current rays, shade, trace shadows, scatter, accumulate.
    fn wave(&mut self, scene: &Scene, tile: &Tile) {
        let n = self.rays.len();
        let t = Instant::now();
        intersect::intersect(scene, &self.rays, &mut self.hits);
        let t = self.lap(Stage::Intersect, n, n, t);

        shade::shade(scene, &self.rays, &self.hits, &mut self.shadow, &mut self.specular, &mut self.film);
        let shaded_out = self.shadow.len() + self.specular.len() + self.film.len();
        let t = self.lap(Stage::Shade, n, shaded_out, t);

        let lit = shadow::occlusion(scene, &self.shadow, &mut self.film);
        self.stats.shadow_rays += self.shadow.len() as u64;
        let t = self.lap(Stage::Shadow, self.shadow.len(), lit, t);

        self.next.clear();
        // A scene without used mirrors or dielectrics never enters the scatter stage.
        let t = if scene.has_specular {
            scatter::scatter(scene, &self.rays, &self.hits, &self.specular, &mut self.next);
            self.stats.secondary_rays += self.next.len() as u64;
            self.lap(Stage::Scatter, self.specular.len(), self.next.len(), t)
        } else {
            t
        };

        film::accumulate(&self.film, tile, scene.settings.width, &mut self.sums);
        self.lap(Stage::Film, self.film.len(), self.film.len(), t);
        std::mem::swap(&mut self.rays, &mut self.next);
    }

    fn lap(&mut self, stage: Stage, rays_in: usize, rays_out: usize, since: Instant) -> Instant {
        let now = Instant::now();
        self.stats.record(stage, rays_in, rays_out, (now - since).as_secs_f64());
        now
    }
}

/// The tiles of a `width`×`height` image, row-major. The tiling never depends on the
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
    let tiles = tiles(s.width, s.height);
    if let Some(pb) = &opts.progress {
        pb.set_length(tiles.len() as u64);
    }
    let image = Mutex::new(vec![Vec3::ZERO; (s.width * s.height) as usize]);
    let next = AtomicUsize::new(0);
    let start = Instant::now();
    let per_thread: Vec<Stats> = pool.broadcast(|_| {
        let mut w = Worker::default();
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            let Some(tile) = tiles.get(i) else { break };
            w.render_tile(scene, tile);
            let tw = (tile.x1 - tile.x0) as usize;
            let mut img = image.lock().unwrap_or_else(|e| e.into_inner());
            for (row, y) in (tile.y0..tile.y1).enumerate() {
                let at = (y * s.width + tile.x0) as usize;
                img[at..at + tw].copy_from_slice(&w.sums[row * tw..(row + 1) * tw]);
            }
            drop(img);
            if let Some(pb) = &opts.progress {
                pb.inc(1);
            }
        }
        w.stats
    });
    let seconds = start.elapsed().as_secs_f64();
    let mut stats = Stats::default();
    per_thread.iter().for_each(|t| stats.merge(t));
    let pixels = image.into_inner().unwrap_or_else(|e| e.into_inner());
    Ok(RenderOutput { image: Image { width: s.width, height: s.height, pixels }, stats, per_thread, seconds })
}
