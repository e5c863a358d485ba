//! Shadow occlusion: any-hit tests of shadow rays. Reads the shadow queue; appends the
//! contributions of unblocked rays to the film queue.
//!
//! With packets on, the tracer groups shadow rays by direction octant (they come out of
//! the shade stage a shading point's samples together, already coherent). Unblocked rays
//! reach the film in queue order whatever the kernel, so the film sums in the same order
//! and packets change no pixel's bits.

use crate::accel::tracer::Tracer;
use crate::queue::{FilmQueue, ShadowQueue};

/// Traces every shadow ray; those that reach their light add their contribution to
/// `film`. Returns the number of unblocked rays.
pub fn occlusion(tracer: &mut Tracer, shadow: &ShadowQueue, film: &mut FilmQueue) -> usize {
    tracer.unblocked(shadow, film)
}
