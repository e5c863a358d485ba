//! Camera generation: stratified pixel samples, thin-lens sampling when the aperture
//! is open. Writes camera rays; reads nothing but the scene.

use glam::{Vec2, Vec3};
use std::ops::Range;

use super::Tile;
use crate::queue::RayQueue;
use crate::sampling::{cmj, concentric_disk, dim, hash};
use crate::scene::Scene;

/// Appends the camera rays of every pixel of `tile` for the flattened per-pixel sample
/// indices in `samples` (index j is AA sample j / dof_samples, lens sample j % dof_samples).
/// Each ray carries weight 1 / (aa_samples × dof_samples), so a pixel's sum is its mean.
pub fn generate(scene: &Scene, tile: &Tile, samples: Range<u32>, rays: &mut RayQueue) {
    let s = &scene.settings;
    let cam = &scene.camera;
    let dof = s.dof_samples;
    let w = Vec3::splat(1.0 / (s.aa_samples as f32 * dof as f32));
    for y in tile.y0..tile.y1 {
        for x in tile.x0..tile.x1 {
            let pixel = y * s.width + x;
            let pixel_pattern = hash(&[s.seed, pixel, dim::PIXEL]);
            for j in samples.clone() {
                let (aa, lens) = (j / dof, j % dof);
                let film = Vec2::new(x as f32, y as f32) + cmj(aa, s.aa_samples, pixel_pattern);
                let d = cam.pinhole_dir(film, s.width, s.height);
                let key = hash(&[s.seed, pixel, j, dim::PATH]);
                if cam.aperture > 0.0 {
                    // Thin lens: every ray through the same film point meets on the focus plane.
                    let focus = cam.position + d * (cam.focus_distance / d.dot(cam.forward));
                    let l = cam.aperture * concentric_disk(cmj(lens, dof, hash(&[s.seed, pixel, aa, dim::LENS])));
                    let o = cam.position + l.x * cam.right + l.y * cam.up;
                    rays.push(o, (focus - o).normalize(), pixel, w, 0, key);
                } else {
                    rays.push(cam.position, d, pixel, w, 0, key);
                }
            }
        }
    }
}
