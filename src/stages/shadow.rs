//! Shadow occlusion: any-hit tests of shadow rays. Reads the shadow queue; writes the
//! contributions of unblocked rays to the film queue.

use crate::queue::{FilmQueue, ShadowQueue};
use crate::scene::Scene;

/// Traces every shadow ray; those that reach their light add their contribution.
/// Returns the number of unblocked rays.
pub fn occlusion(scene: &Scene, shadow: &ShadowQueue, film: &mut FilmQueue) -> usize {
    let mut lit = 0;
    for i in 0..shadow.len() {
        if !scene.accel.occluded(shadow.origin(i), shadow.dir(i), 0.0, shadow.tmax[i]) {
            film.push(shadow.slot[i], shadow.radiance(i));
            lit += 1;
        }
    }
    lit
}
