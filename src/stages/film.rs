//! Film accumulation: adds the film queue's radiance to the tile's pixel sums.

use glam::Vec3;

use super::Tile;
use crate::queue::FilmQueue;

/// Adds every contribution of `film` to `sums`, the tile's pixels in row-major order.
/// `width` is the image width that global pixel indices use.
pub fn accumulate(film: &FilmQueue, tile: &Tile, width: u32, sums: &mut [Vec3]) {
    let tw = tile.x1 - tile.x0;
    for i in 0..film.len() {
        let p = film.pixel[i];
        let (x, y) = (p % width - tile.x0, p / width - tile.y0);
        sums[(y * tw + x) as usize] += Vec3::new(film.r[i], film.g[i], film.b[i]);
    }
}
