//! Film accumulation: adds the film queue's radiance to the pass's accumulation slots.

use glam::Vec3;

use crate::queue::FilmQueue;

/// Adds every contribution of `film` to `sums[slot]`.
pub fn accumulate(film: &FilmQueue, sums: &mut [Vec3]) {
    for i in 0..film.len() {
        sums[film.slot[i] as usize] += Vec3::new(film.r[i], film.g[i], film.b[i]);
    }
}
