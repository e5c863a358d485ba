//! Shadow occlusion: any-hit tests of shadow rays. Reads the shadow queue; writes the
//! contributions of unblocked rays to the film queue.

use crate::geometry::Traversal;
use crate::queue::{FilmQueue, ShadowQueue};
use crate::scene::Scene;

/// Traces every shadow ray; those that reach their light add their contribution.
/// Returns the number of unblocked rays. Work is counted in `work` when `count`.
pub fn occlusion(
    scene: &Scene,
    shadow: &ShadowQueue,
    film: &mut FilmQueue,
    work: &mut Traversal,
    count: bool,
) -> usize {
    if count {
        run::<true>(scene, shadow, film, work)
    } else {
        run::<false>(scene, shadow, film, work)
    }
}

fn run<const COUNT: bool>(scene: &Scene, shadow: &ShadowQueue, film: &mut FilmQueue, work: &mut Traversal) -> usize {
    let mut lit = 0;
    for i in 0..shadow.len() {
        if !scene.accel.occluded::<COUNT>(shadow.origin(i), shadow.dir(i), 0.0, shadow.tmax[i], work) {
            film.push(shadow.slot[i], shadow.radiance(i));
            lit += 1;
        }
    }
    lit
}
