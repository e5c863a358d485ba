//! The adaptive anti-aliasing passes of a tile (paper §2.1): the shared corner grid,
//! the centres, the first decision and one pass per refinement level; with DOF-aware AA
//! (the paper's §5) also the depth probes and each point's lens count.

use glam::{Vec2, Vec3};
use std::time::Instant;

use super::{Kind, Worker};
use crate::scene::{AaMode, Scene};
use crate::stages::camera::{self, Lens};
use crate::stages::{focus, intersect, refine, Tile};
use crate::stats::Stage;

impl Worker {
    /// Traces a pinhole depth probe through film position `film(i)` of each point
    /// i < `n` and leaves the points' blur radii (pixels) in `self.blur` (for the eps)
    /// and `self.blur_lens` (for the lens count).
    pub(super) fn focus(&mut self, scene: &Scene, n: usize, film: impl Fn(u32) -> Vec2) {
        for b in [&mut self.blur, &mut self.blur_lens] {
            b.clear();
            b.resize(n, 0.0);
        }
        let mut k0 = 0;
        while k0 < n as u64 {
            if self.cancelled() {
                self.aborted = true;
                return;
            }
            let k1 = (k0 + self.wave).min(n as u64);
            let t = Instant::now();
            self.rays.clear();
            focus::generate(scene, k0..k1, &film, &mut self.rays);
            intersect::intersect(scene, &self.rays, &mut self.hits, &mut self.work, self.count, &mut self.order);
            focus::blur(scene, &self.rays, &self.hits, k0 as usize, &mut self.blur, &mut self.blur_lens);
            self.stats.dof_probe_rays += k1 - k0;
            self.lap(Stage::Focus, (k1 - k0) as usize, (k1 - k0) as usize, t);
            k0 = k1;
        }
    }

    /// Fills `self.starts` with the lens-ray prefix sums of points whose lens counts are
    /// `count(i)`, i < `n`.
    fn lens_starts(&mut self, n: usize, count: impl Fn(usize) -> u64) {
        self.starts.clear();
        self.starts.push(0);
        for i in 0..n {
            let last = self.starts[i];
            self.starts.push(last + count(i));
        }
    }

    /// The shared corner grid's pass over one grid tile; `blur` is the corners' blur (for
    /// their lens counts) with DOF-aware AA.
    pub(super) fn corner_grid_tile(&mut self, scene: &Scene, tile: &Tile, blur: Option<&[f32]>) {
        let dof = scene.settings.dof_samples;
        let gw = scene.settings.width + 1;
        let tw = tile.x1 - tile.x0;
        self.begin_pass(tile.pixels());
        if let Some(blur) = blur {
            self.lens_starts(tile.pixels(), |i| {
                let ci = (tile.y0 + i as u32 / tw) * gw + tile.x0 + i as u32 % tw;
                focus::lens_samples(blur[ci as usize], dof) as u64
            });
        }
        let starts = std::mem::take(&mut self.starts);
        let lens = if blur.is_some() { Lens::PerPoint(&starts) } else { Lens::Fixed(dof as u64) };
        self.run(scene, lens.total(tile.pixels()), Kind::Corner, |ks, rays| {
            camera::generate_corner_grid(scene, tile, lens, ks, rays)
        });
        self.starts = starts;
    }

    /// Adaptive AA on one tile; `grid` is the shared corner grid, if corners are shared,
    /// and `blur` the corners' blur radii (over the whole corner grid; for the eps, and
    /// for the lens counts) with DOF-aware AA.
    pub(super) fn adaptive_tile(
        &mut self,
        scene: &Scene,
        tile: &Tile,
        grid: Option<&[Vec3]>,
        blur: Option<(&[f32], &[f32])>,
        eps: f32,
    ) {
        let s = &scene.settings;
        let AaMode::Adaptive { min_level, max_level, .. } = s.aa_mode else { return };
        let (np, dof) = (tile.pixels(), s.dof_samples);
        let tw = (tile.x1 - tile.x0) as usize;
        let gw = s.width as usize + 1;
        let corner =
            |p: usize, c: usize| (tile.y0 as usize + p / tw + (c >> 1)) * gw + tile.x0 as usize + p % tw + (c & 1);

        // Each pixel's eps and lens counts: the same for all, unless DOF-aware.
        self.eps.clear();
        self.pixel_lens.clear();
        let dof_aware = s.dof_radius.zip(blur);
        if let Some((radius, (sharp, lens))) = dof_aware {
            self.focus(scene, np, |p| {
                let p = p as usize;
                Vec2::new((tile.x0 as usize + p % tw) as f32 + 0.5, (tile.y0 as usize + p / tw) as f32 + 0.5)
            });
            if self.aborted {
                return;
            }
            for p in 0..np {
                // The sharpest point in the pixel decides whether it needs anti-aliasing;
                // the blurriest decides how many lens rays its refinement points need.
                let lo = (0..4).map(|c| sharp[corner(p, c)]).fold(self.blur[p], f32::min);
                let hi = (0..4).map(|c| lens[corner(p, c)]).fold(self.blur_lens[p], f32::max);
                self.eps.push(focus::pixel_eps(eps, lo, radius));
                self.pixel_lens.push(focus::lens_samples(hi, dof));
            }
            let centre_lens = std::mem::take(&mut self.blur_lens);
            self.lens_starts(np, |p| focus::lens_samples(centre_lens[p], dof) as u64);
            self.blur_lens = centre_lens;
        } else {
            self.eps.resize(np, eps);
        }

        self.begin_pass(np);
        let starts = std::mem::take(&mut self.starts);
        let lens = if dof_aware.is_some() { Lens::PerPoint(&starts) } else { Lens::Fixed(dof as u64) };
        self.run(scene, lens.total(np), Kind::Camera, |ks, rays| camera::generate_centres(scene, tile, lens, ks, rays));
        self.starts = starts;
        self.centre.clone_from(&self.sums);
        self.collect_heat(1);

        self.corner_mean.clear();
        match grid {
            Some(grid) => {
                for p in 0..np {
                    let c = |c: usize| grid[corner(p, c)];
                    self.corner_mean.push((c(0) + c(1) + c(2) + c(3)) * 0.25);
                }
            }
            None => {
                self.begin_pass(4 * np);
                if let Some((_, (_, lens))) = dof_aware {
                    self.lens_starts(4 * np, |k| focus::lens_samples(lens[corner(k / 4, k % 4)], dof) as u64);
                }
                let starts = std::mem::take(&mut self.starts);
                let lens = if dof_aware.is_some() { Lens::PerPoint(&starts) } else { Lens::Fixed(dof as u64) };
                self.run(scene, lens.total(4 * np), Kind::Corner, |ks, rays| {
                    camera::generate_pixel_corners(scene, tile, lens, ks, rays)
                });
                self.starts = starts;
                self.corner_mean.extend(self.sums.chunks_exact(4).map(|c| (c[0] + c[1] + c[2] + c[3]) * 0.25));
                self.collect_heat(4);
            }
        }

        let t = Instant::now();
        refine::start(&self.eps, &self.centre, &self.corner_mean, &mut self.refine, &mut self.queue, &mut self.out);
        self.lap(Stage::Refine, np, self.queue.len(), t);
        self.stats.aa_pixels += np as u64;
        self.stats.aa_refined_pixels += self.queue.len() as u64;
        self.stats.aa_uniform_rays += np as u64 * (1u64 << max_level) * dof as u64;

        for level in 2..=max_level {
            if self.queue.is_empty() {
                break;
            }
            let queue = std::mem::take(&mut self.queue);
            self.begin_pass(np);
            if dof_aware.is_some() {
                let pixel_lens = std::mem::take(&mut self.pixel_lens);
                self.lens_starts(queue.len(), |i| (pixel_lens[queue[i] as usize] as u64) << level);
                self.pixel_lens = pixel_lens;
            }
            let starts = std::mem::take(&mut self.starts);
            let lens = if dof_aware.is_some() { Lens::PerPoint(&starts) } else { Lens::Fixed((dof as u64) << level) };
            self.run(scene, lens.total(queue.len()), Kind::Refine, |ks, rays| {
                camera::generate_refine(scene, tile, &queue, level, lens, ks, rays)
            });
            self.starts = starts;
            self.queue = queue;
            self.collect_heat(1);
            let t = Instant::now();
            let before = self.queue.len();
            let may_stop = level >= min_level;
            refine::step(&self.eps, level, may_stop, &self.sums, &mut self.refine, &mut self.queue, &mut self.out);
            self.lap(Stage::Refine, before, self.queue.len(), t);
        }
        self.heat.level.copy_from_slice(&self.refine.level);
    }
}
