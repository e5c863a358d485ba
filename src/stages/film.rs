//! Film accumulation: adds the film queue's radiance to the pass's accumulation slots.

use glam::Vec3;

use crate::queue::FilmQueue;

/// Adds every contribution of `film` to `sums[slot]`. A non-finite contribution (NaN or
/// infinity, which would poison the pixel) is dropped instead; returns how many were. A
/// sum of finite contributions saturates at f32::MAX rather than overflowing to infinity
/// (radiance near f32::MAX, found by fuzzing); below that the `min` changes no bit.
// Out of line: inlined into the wave, whose other stages hold many values, the loop's
// column pointers were kept on the stack (the film stage took 12-15% longer).
#[inline(never)]
pub fn accumulate(film: &FilmQueue, sums: &mut [Vec3]) -> usize {
    let mut dropped = 0;
    let mut i = 0;
    // A run of contributions to one slot (a pixel's samples come together) is summed in a
    // register, in queue order, and stored once: the same additions, so the same bits,
    // without a store and reload of the slot per contribution.
    while i < film.len() {
        let slot = film.slot[i];
        let mut sum = sums[slot as usize];
        while i < film.len() && film.slot[i] == slot {
            let l = Vec3::new(film.r[i], film.g[i], film.b[i]);
            if l.is_finite() {
                sum = (sum + l).min(Vec3::splat(f32::MAX));
            } else {
                dropped += 1;
            }
            i += 1;
        }
        sums[slot as usize] = sum;
    }
    dropped
}
