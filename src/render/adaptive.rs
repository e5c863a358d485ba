//! The adaptive anti-aliasing passes of a tile (paper §2.1): the shared corner grid,
//! the centres, the first decision and one pass per refinement level; with DOF-aware AA
//! (the paper's §5) also the depth probes and each point's lens count.

use glam::{Vec2, Vec3};
use std::time::Instant;

use super::meter::Kind;
use super::Worker;
use crate::accel::tracer::Coherence;
use crate::accel::Traversal;
use crate::film::Tile;
use crate::queue::RefineQueues;
use crate::scene::Scene;
use crate::stages::camera::{self, Lens, RefinePass};
use crate::stages::{focus, refine};
use crate::stats::Stage;

/// The paper's corner method as a pass renders it: `render.aa.mode = "adaptive"`'s
/// settings, or auto mode's choice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Corners {
    /// Display-value tolerance of the decisions.
    pub eps: f32,
    /// First level whose agreement may stop refinement.
    pub min_level: u32,
    /// Last level (2^level rays).
    pub max_level: u32,
    /// The (W+1)×(H+1) corner grid traced once.
    pub share: bool,
}

/// DOF-aware AA: the blur radii (pixels) of the (W+1)×(H+1) pixel corners, from one
/// depth probe each: `sharp` decides the eps, `lens` the lens counts.
#[derive(Clone, Copy)]
pub(super) struct CornerBlur<'a> {
    pub sharp: &'a [f32],
    pub lens: &'a [f32],
}

/// DOF-aware AA's one value, handed to every pass of a tile: the blur radius (pixels)
/// from which a pixel is not refined, and the corners' blur.
#[derive(Clone, Copy)]
struct DofAware<'a> {
    radius: f32,
    blur: CornerBlur<'a>,
}

/// A worker's adaptive-AA buffers, reused from tile to tile.
#[derive(Default)]
pub(super) struct AaState {
    /// Per tile pixel: the centre estimate and the mean of the corners.
    centre: Vec<Vec3>,
    corner_mean: Vec<Vec3>,
    /// Per tile pixel: refinement state; the pixels still being refined.
    refine: RefineQueues,
    /// Per tile pixel: the eps of its decisions.
    eps: Vec<f32>,
    /// DOF-aware AA: blur radii (pixels) of each depth probe of the last focus pass (for
    /// the eps, and for the lens count), lens-ray prefix sums of the points of a pass, and
    /// each pixel's refinement lens count.
    pub blur: Vec<f32>,
    pub blur_lens: Vec<f32>,
    starts: Vec<u64>,
    pixel_lens: Vec<u32>,
}

impl AaState {
    /// Bytes held (capacities).
    pub fn bytes(&self) -> usize {
        let v3 = std::mem::size_of::<Vec3>();
        v3 * (self.centre.capacity() + self.corner_mean.capacity())
            + self.refine.bytes()
            + 4 * (self.eps.capacity() + self.blur.capacity() + self.blur_lens.capacity() + self.pixel_lens.capacity())
            + 8 * self.starts.capacity()
    }
}

/// Fills `starts` with the lens-ray prefix sums of `n` points whose lens counts are
/// `count(i)`.
pub(super) fn lens_starts(starts: &mut Vec<u64>, n: usize, count: impl Fn(usize) -> u64) {
    starts.clear();
    starts.push(0);
    for i in 0..n {
        let last = starts[i];
        starts.push(last + count(i));
    }
}

/// Index in the (W+1)-wide corner grid of corner `c` (0 top-left, 1 top-right,
/// 2 bottom-left, 3 bottom-right) of pixel `p` of `tile`.
fn corner(scene: &Scene, tile: &Tile, p: usize, c: usize) -> usize {
    let tw = (tile.x1 - tile.x0) as usize;
    let gw = scene.settings.width as usize + 1;
    (tile.y0 as usize + p / tw + (c >> 1)) * gw + tile.x0 as usize + p % tw + (c & 1)
}

impl Worker<'_> {
    /// The shared corner grid's pass over one grid tile; `blur` is the corners' blur (for
    /// their lens counts) with DOF-aware AA.
    pub(super) fn corner_grid_tile(&mut self, scene: &Scene, tile: &Tile, blur: Option<&[f32]>) {
        let dof = scene.settings.dof_samples;
        let gw = scene.settings.width + 1;
        let tw = tile.x1 - tile.x0;
        self.pipe.acc.begin(tile.pixels());
        if let Some(blur) = blur {
            lens_starts(&mut self.aa.starts, tile.pixels(), |i| {
                let ci = (tile.y0 + i as u32 / tw) * gw + tile.x0 + i as u32 % tw;
                focus::lens_samples(blur[ci as usize], dof) as u64
            });
        }
        let lens = if blur.is_some() { Lens::PerPoint(&self.aa.starts) } else { Lens::Fixed(dof as u64) };
        self.pipe.run(scene, lens.total(tile.pixels()), (Kind::Corner, Coherence::Camera), |ks, rays| {
            camera::generate_corner_grid(scene, tile, lens, ks, rays)
        });
    }

    /// Adaptive AA on one tile with `corners`' settings; `grid` is the shared corner
    /// grid, if corners are shared, and `blur` the corners' blur radii (over the whole
    /// corner grid; for the eps, and for the lens counts) with DOF-aware AA.
    pub(super) fn adaptive_tile(
        &mut self,
        scene: &Scene,
        tile: &Tile,
        corners: Corners,
        grid: Option<&[Vec3]>,
        blur: Option<CornerBlur>,
    ) {
        let Corners { eps, min_level, max_level, .. } = corners;
        let np = tile.pixels();
        let dof = scene.settings.dof_radius.zip(blur).map(|(radius, blur)| DofAware { radius, blur });
        if !self.decide_eps(scene, tile, dof, eps) {
            return;
        }
        self.centres(scene, tile, dof);
        self.corner_means(scene, tile, grid, dof);

        let t = Instant::now();
        let aa = &mut self.aa;
        refine::start(&aa.eps, &aa.centre, &aa.corner_mean, &mut aa.refine, &mut self.tile.out);
        self.pipe.meter.lap(Stage::Refine, np, aa.refine.active.len(), Traversal::default(), t);
        let stats = &mut self.pipe.meter.stats;
        stats.aa_pixels += np as u64;
        stats.aa_refined_pixels += aa.refine.active.len() as u64;
        stats.aa_uniform_rays += np as u64 * (1u64 << max_level) * scene.settings.dof_samples as u64;

        for level in 2..=max_level {
            if self.aa.refine.active.is_empty() {
                break;
            }
            self.refine_level(scene, tile, level, level >= min_level, dof);
        }
        self.tile.heat.level.copy_from_slice(&self.aa.refine.state.level);
    }

    /// Each tile pixel's eps and, with DOF-aware AA, its lens counts (from depth probes
    /// through the pixel centres and the corners' blur). False when cancelled.
    fn decide_eps(&mut self, scene: &Scene, tile: &Tile, dof_aware: Option<DofAware>, eps: f32) -> bool {
        let (np, dof) = (tile.pixels(), scene.settings.dof_samples);
        let aa = &mut self.aa;
        aa.eps.clear();
        aa.pixel_lens.clear();
        let Some(DofAware { radius, blur: CornerBlur { sharp, lens } }) = dof_aware else {
            aa.eps.resize(np, eps);
            return true;
        };
        let tw = (tile.x1 - tile.x0) as usize;
        self.pipe.focus(
            scene,
            np,
            |p| {
                let p = p as usize;
                Vec2::new((tile.x0 as usize + p % tw) as f32 + 0.5, (tile.y0 as usize + p / tw) as f32 + 0.5)
            },
            &mut aa.blur,
            &mut aa.blur_lens,
        );
        if self.pipe.aborted {
            return false;
        }
        for p in 0..np {
            // The sharpest point in the pixel decides whether it needs anti-aliasing;
            // the blurriest decides how many lens rays its refinement points need.
            let lo = (0..4).map(|c| sharp[corner(scene, tile, p, c)]).fold(aa.blur[p], f32::min);
            let hi = (0..4).map(|c| lens[corner(scene, tile, p, c)]).fold(aa.blur_lens[p], f32::max);
            aa.eps.push(focus::pixel_eps(eps, lo, radius));
            aa.pixel_lens.push(focus::lens_samples(hi, dof));
        }
        lens_starts(&mut aa.starts, np, |p| focus::lens_samples(aa.blur_lens[p], dof) as u64);
        true
    }

    /// The centre pass: one camera point per pixel (its lens rays as `aa.starts` says
    /// with DOF-aware AA).
    fn centres(&mut self, scene: &Scene, tile: &Tile, dof: Option<DofAware>) {
        let per_point = dof.is_some();
        let np = tile.pixels();
        let dof = scene.settings.dof_samples;
        self.pipe.acc.begin(np);
        let lens = if per_point { Lens::PerPoint(&self.aa.starts) } else { Lens::Fixed(dof as u64) };
        self.pipe.run(scene, lens.total(np), (Kind::Camera, Coherence::Camera), |ks, rays| {
            camera::generate_centres(scene, tile, lens, ks, rays)
        });
        self.aa.centre.clone_from(&self.pipe.acc.sums);
        self.tile.collect_heat(&self.pipe.acc.heat, 1);
    }

    /// Each pixel's corner mean: from the shared grid, or from a pass over its own four
    /// corners (with DOF-aware AA, the corners' blur gives their lens counts).
    fn corner_means(&mut self, scene: &Scene, tile: &Tile, grid: Option<&[Vec3]>, dof: Option<DofAware>) {
        let lens = dof.map(|d| d.blur.lens);
        let np = tile.pixels();
        let dof = scene.settings.dof_samples;
        let aa = &mut self.aa;
        aa.corner_mean.clear();
        if let Some(grid) = grid {
            for p in 0..np {
                let c = |c: usize| grid[corner(scene, tile, p, c)];
                aa.corner_mean.push((c(0) + c(1) + c(2) + c(3)) * 0.25);
            }
            return;
        }
        self.pipe.acc.begin(4 * np);
        if let Some(blur) = lens {
            lens_starts(&mut aa.starts, 4 * np, |k| {
                focus::lens_samples(blur[corner(scene, tile, k / 4, k % 4)], dof) as u64
            });
        }
        let lens = if lens.is_some() { Lens::PerPoint(&aa.starts) } else { Lens::Fixed(dof as u64) };
        self.pipe.run(scene, lens.total(4 * np), (Kind::Corner, Coherence::Camera), |ks, rays| {
            camera::generate_pixel_corners(scene, tile, lens, ks, rays)
        });
        // Saturating, as the film's sums are (stages::film::accumulate).
        let max = Vec3::splat(f32::MAX);
        aa.corner_mean.extend(self.pipe.acc.sums.chunks_exact(4).map(|c| (c[0] + c[1] + c[2] + c[3]).min(max) * 0.25));
        self.tile.collect_heat(&self.pipe.acc.heat, 4);
    }

    /// Refinement level `level`: 2^level stratified points in each queued pixel, then the
    /// decision (pixels may leave the queue when `may_stop`).
    fn refine_level(&mut self, scene: &Scene, tile: &Tile, level: u32, may_stop: bool, dof: Option<DofAware>) {
        let per_point = dof.is_some();
        let np = tile.pixels();
        let dof = scene.settings.dof_samples as u64;
        let aa = &mut self.aa;
        self.pipe.acc.begin(np);
        if per_point {
            let (queue, pixel_lens) = (&aa.refine.active.index, &aa.pixel_lens);
            lens_starts(&mut aa.starts, queue.len(), |i| (pixel_lens[queue[i] as usize] as u64) << level);
        }
        let lens = if per_point { Lens::PerPoint(&aa.starts) } else { Lens::Fixed(dof << level) };
        let queue = &aa.refine.active.index;
        self.pipe.run(scene, lens.total(queue.len()), (Kind::Refine, Coherence::Camera), |ks, rays| {
            camera::generate_refine(scene, RefinePass { tile, pixels: queue, level }, lens, ks, rays)
        });
        self.tile.collect_heat(&self.pipe.acc.heat, 1);
        let t = Instant::now();
        let before = aa.refine.active.len();
        let (sums, out) = (&self.pipe.acc.sums, &mut self.tile.out);
        refine::step(&aa.eps, level, may_stop, sums, &mut aa.refine, out);
        self.pipe.meter.lap(Stage::Refine, before, aa.refine.active.len(), Traversal::default(), t);
    }
}
