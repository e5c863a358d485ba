//! Closest-hit intersection. Reads the ray queue; writes one hit (or miss) per ray.
//!
//! The tracer decides how: one ray at a time, or packets cut in an order that keeps
//! their rays coherent (camera rays keep their generation order; bounce rays are grouped
//! by direction octant), a packet of mixed octants going one ray at a time.

use crate::accel::tracer::{Coherence, Tracer};
use crate::queue::{HitQueue, RayQueue};

/// Finds the closest hit of every ray in `rays`, in order, into `hits` (cleared first).
/// `coherence` says where the rays come from (the driver knows; the rays don't say).
pub fn intersect(tracer: &mut Tracer, rays: &RayQueue, coherence: Coherence, hits: &mut HitQueue) {
    tracer.closest(rays, coherence, hits);
}
