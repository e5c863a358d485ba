//! Packet traversal of the wide tree: a packet of rays (4, 8 or 16 lanes of `wide`; the
//! renderer uses [`LANES`](crate::simd::LANES)) walks the tree together as one beam
//! (`wbvh::beam`: each node's children tested once for the whole packet); each leaf the
//! beam reaches is slab-tested for every lane, and its primitives (watertight triangles
//! after Woop, Benthin and Wald; spheres; parallelograms) for the lanes that enter it, all
//! lanes at once. A packet whose beam keeps reaching leaves no lane enters gives up and
//! its lanes finish one at a time (the wide single-ray walk).
//!
//! Exactness: the beam test is conservative (it never skips a box a lane enters), and
//! every lane computes the same floating-point operations in the same order as the scalar
//! kernels (slab test, shear, edge functions, the f64 recomputation of edge functions
//! that round to zero, the distance), with the tie rule of every kernel, so a packet
//! finds exactly the single-ray kernels' hits, primitives included.
//!
//! Files: `rays` (a packet's rays in SIMD form and the leaf kernels), `traverse` (the
//! walk, [`closest`], [`occluded`]), `tests`.

mod rays;
mod traverse;

#[cfg(test)]
mod tests;

pub(crate) use traverse::{closest, occluded};

use super::order::Order;

/// A full packet's rays as consecutive entries of their queue: the queue's origin x, y,
/// z and direction x, y, z columns from the packet's first ray, each at least `LANES`
/// long. The lanes then load straight from the queue instead of being transposed from
/// the rays' values (which, written just before, stall the vector loads).
#[derive(Clone, Copy, Debug)]
pub struct Columns<'a>(pub [&'a [f32]; 6]);

/// How a stage forms and traces packets; [`PacketConfig::RENDER`] is the renderer's
/// choice, the other values exist to be measured (`wavetrace bench`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PacketConfig {
    /// How bounce rays are ordered before they are cut into packets (camera rays always
    /// keep their generation order).
    pub bounce_order: Order,
    /// How shadow rays are ordered before they are cut into packets.
    pub shadow_order: Order,
    /// Trace a packet whose rays do not share a direction octant one ray at a time.
    pub split_mixed: bool,
}

impl PacketConfig {
    /// The renderer's settings (chosen by measurement: docs/performance.md).
    pub const RENDER: PacketConfig =
        PacketConfig { bounce_order: Order::Octant, shadow_order: Order::Octant, split_mixed: true };
}

/// Work counters of packet traversals.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PacketWork {
    /// Leaves the packet's beam reached (each slab-tested for every lane at once).
    pub steps: u64,
    /// Lanes entering those leaves, summed: `lanes / (LANES · steps)` is the utilisation.
    pub lanes: u64,
    /// Lanes finished one ray at a time after their packet gave up.
    pub fallbacks: u64,
    /// Box tests per lane: each beam test of a child box counts once for every lane of the
    /// packet (comparable with the single-ray traversal's node count).
    pub nodes: u64,
    /// Primitive tests per lane.
    pub prims: u64,
}
