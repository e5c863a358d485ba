//! Camera generation: writes camera rays for uniform pixel samples, for the adaptive
//! method's pixel corners and centres, and for refinement levels. Thin-lens sampling
//! only when the aperture is open. Reads nothing but the scene.
//!
//! Every generator takes a range of a flattened (point, sample) index, so the driver can
//! cut any amount of work into waves of bounded size.

use glam::{Vec2, Vec3};
use std::ops::Range;

use super::Tile;
use crate::queue::RayQueue;
use crate::sampling::{cmj, concentric_disk, dim, hash};
use crate::scene::Scene;

/// Pushes one camera ray through film position `film` (pixels). `lens_pattern` and
/// `lens` pick the lens sample (ignored for a pinhole).
#[allow(clippy::too_many_arguments)]
#[inline]
fn push(scene: &Scene, film: Vec2, lens_pattern: u32, lens: u32, slot: u32, w: Vec3, key: u32, rays: &mut RayQueue) {
    let s = &scene.settings;
    let cam = &scene.camera;
    let d = cam.pinhole_dir(film, s.width, s.height);
    if cam.aperture > 0.0 {
        // Thin lens: every ray through the same film point meets on the focus plane.
        let focus = cam.position + d * (cam.focus_distance / d.dot(cam.forward));
        let l = cam.aperture * concentric_disk(cmj(lens, s.dof_samples, lens_pattern));
        let o = cam.position + l.x * cam.right + l.y * cam.up;
        rays.push(o, (focus - o).normalize(), slot, w, 0, key);
    } else {
        rays.push(cam.position, d, slot, w, 0, key);
    }
}

/// Uniform mode: camera rays for the flattened (pixel, sample) indices `ks` of `tile`:
/// k is pixel k / spp of the tile in [`block_slot`] order and per-pixel sample j = k % spp, which is
/// AA sample j / dof_samples and lens sample j % dof_samples. Slot: the pixel's index in
/// the tile. Each ray carries weight 1 / spp, so a pixel's sum is its mean.
pub fn generate(scene: &Scene, tile: &Tile, ks: Range<u64>, rays: &mut RayQueue) {
    let s = &scene.settings;
    let dof = s.dof_samples;
    let spp = s.aa_samples as u64 * dof as u64;
    let w = Vec3::splat(1.0 / spp as f32);
    let tw = tile.x1 - tile.x0;
    for k in ks {
        let slot = block_slot(tile, (k / spp) as u32);
        let j = (k % spp) as u32;
        let (x, y) = (tile.x0 + slot % tw, tile.y0 + slot / tw);
        let pixel = y * s.width + x;
        let (aa, lens) = (j / dof, j % dof);
        let film = Vec2::new(x as f32, y as f32) + cmj(aa, s.aa_samples, hash(&[s.seed, pixel, dim::PIXEL]));
        let key = hash(&[s.seed, pixel, j, dim::PATH]);
        push(scene, film, hash(&[s.seed, pixel, aa, dim::LENS]), lens, slot, w, key, rays);
    }
}

/// Side of the screen blocks camera rays are generated in.
const BLOCK: u32 = 4;

/// The slot (row-major index in `tile`) of the `q`-th pixel when the tile is walked in 4×4
/// blocks: blocks row by row, pixels row by row inside a block (edge blocks are smaller).
/// Consecutive pixels then stay close on screen, so the packets the intersect stage cuts
/// from camera rays in generation order start coherent (16 consecutive pixels form a
/// square, not a strip); each pixel's samples stay in sample order, so the image does not
/// change.
pub fn block_slot(tile: &Tile, q: u32) -> u32 {
    let (tw, th) = (tile.x1 - tile.x0, tile.y1 - tile.y0);
    let band = tw * BLOCK;
    let (row, h, rest) = if q < (th / BLOCK) * band {
        (q / band, BLOCK, q % band)
    } else {
        (th / BLOCK, th % BLOCK, q - (th / BLOCK) * band)
    };
    let full = tw / BLOCK;
    let (col, bw, inner) = if rest < full * BLOCK * h {
        (rest / (BLOCK * h), BLOCK, rest % (BLOCK * h))
    } else {
        (full, tw % BLOCK, rest - full * BLOCK * h)
    };
    let (x, y) = (col * BLOCK + inner % bw, row * BLOCK + inner / bw);
    y * tw + x
}

/// Index of pixel corner (cx, cy) in the (W+1)×(H+1) corner grid.
#[inline]
pub fn corner_index(scene: &Scene, cx: u32, cy: u32) -> u32 {
    cy * (scene.settings.width + 1) + cx
}

/// Pushes the `lens`-th ray through grid corner `ci`. A corner's rays depend only on
/// its index, so a shared corner and a per-pixel copy of it give the same radiance.
#[inline]
fn corner_ray(scene: &Scene, ci: u32, lens: u32, slot: u32, rays: &mut RayQueue) {
    let s = &scene.settings;
    let (cx, cy) = (ci % (s.width + 1), ci / (s.width + 1));
    let w = Vec3::splat(1.0 / s.dof_samples as f32);
    let key = hash(&[s.seed, ci, lens, dim::CORNER]);
    push(scene, Vec2::new(cx as f32, cy as f32), hash(&[s.seed, ci, dim::CORNER]), lens, slot, w, key, rays);
}

/// Adaptive AA, shared corners: rays through the corners of `grid`, a rectangle of the
/// corner grid. Flattened index k: corner k / dof_samples (row-major in the rectangle),
/// lens sample k % dof_samples. Slot: the corner's index in the rectangle.
pub fn generate_corner_grid(scene: &Scene, grid: &Tile, ks: Range<u64>, rays: &mut RayQueue) {
    let dof = scene.settings.dof_samples as u64;
    let gw = grid.x1 - grid.x0;
    for k in ks {
        let slot = (k / dof) as u32;
        let (cx, cy) = (grid.x0 + slot % gw, grid.y0 + slot / gw);
        corner_ray(scene, corner_index(scene, cx, cy), (k % dof) as u32, slot, rays);
    }
}

/// Adaptive AA, unshared corners (the paper's 5 rays per pixel): the four corners of
/// every pixel of `tile`. Flattened index k: pixel k / (4·dof), corner (k / dof) % 4.
/// Slot: 4 × (pixel index in the tile) + corner (0 top-left, 1 top-right, 2 bottom-left,
/// 3 bottom-right).
pub fn generate_pixel_corners(scene: &Scene, tile: &Tile, ks: Range<u64>, rays: &mut RayQueue) {
    let dof = scene.settings.dof_samples as u64;
    let tw = tile.x1 - tile.x0;
    for k in ks {
        let slot = (k / dof) as u32;
        let (p, c) = (slot / 4, slot % 4);
        let (x, y) = (tile.x0 + p % tw + (c & 1), tile.y0 + p / tw + (c >> 1));
        corner_ray(scene, corner_index(scene, x, y), (k % dof) as u32, slot, rays);
    }
}

/// Adaptive AA: rays through the centre of every pixel of `tile`. Flattened index k:
/// pixel k / dof_samples. Slot: the pixel's index in the tile.
pub fn generate_centres(scene: &Scene, tile: &Tile, ks: Range<u64>, rays: &mut RayQueue) {
    let s = &scene.settings;
    let dof = s.dof_samples as u64;
    let w = Vec3::splat(1.0 / dof as f32);
    let tw = tile.x1 - tile.x0;
    for k in ks {
        let (slot, lens) = ((k / dof) as u32, (k % dof) as u32);
        let (x, y) = (tile.x0 + slot % tw, tile.y0 + slot / tw);
        let pixel = y * s.width + x;
        let key = hash(&[s.seed, pixel, lens, dim::CENTRE]);
        let film = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
        push(scene, film, hash(&[s.seed, pixel, dim::CENTRE]), lens, slot, w, key, rays);
    }
}

/// Adaptive AA, refinement level `level`: 2^level stratified rays in each listed pixel
/// (`pixels` are indices in the tile). Flattened index k: listed pixel k / (2^level·dof).
/// Slot: the pixel's index in the tile; weight 1 / (2^level·dof), so a slot sums to the
/// level's estimate.
pub fn generate_refine(scene: &Scene, tile: &Tile, pixels: &[u32], level: u32, ks: Range<u64>, rays: &mut RayQueue) {
    let s = &scene.settings;
    let dof = s.dof_samples;
    let n = 1u32 << level;
    let per = n as u64 * dof as u64;
    let w = Vec3::splat(1.0 / (n as f32 * dof as f32));
    let tw = tile.x1 - tile.x0;
    for k in ks {
        let slot = pixels[(k / per) as usize];
        let j = (k % per) as u32;
        let (sample, lens) = (j / dof, j % dof);
        let (x, y) = (tile.x0 + slot % tw, tile.y0 + slot / tw);
        let pixel = y * s.width + x;
        let film = Vec2::new(x as f32, y as f32) + cmj(sample, n, hash(&[s.seed, pixel, level, dim::REFINE]));
        let key = hash(&[s.seed, pixel, level, j, dim::REFINE]);
        push(scene, film, hash(&[s.seed, pixel, level, sample, dim::LENS]), lens, slot, w, key, rays);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_order_visits_every_pixel_once_in_squares() {
        for tw in 1..=16 {
            for th in 1..=16 {
                let tile = Tile { x0: 32, y0: 16, x1: 32 + tw, y1: 16 + th };
                let mut seen = vec![false; (tw * th) as usize];
                for q in 0..tw * th {
                    let s = block_slot(&tile, q) as usize;
                    assert!(!seen[s], "{tw}x{th}: slot {s} twice");
                    seen[s] = true;
                }
            }
        }
        // A full tile: each run of 16 is one 4×4 square.
        let tile = Tile { x0: 0, y0: 0, x1: 16, y1: 16 };
        for run in 0..16 {
            let xy: Vec<(u32, u32)> =
                (run * 16..run * 16 + 16).map(|q| block_slot(&tile, q)).map(|s| (s % 16, s / 16)).collect();
            let (x0, y0) = xy[0];
            assert!(xy.iter().all(|&(x, y)| x - x0 < 4 && y - y0 < 4), "{xy:?}");
        }
    }
}
