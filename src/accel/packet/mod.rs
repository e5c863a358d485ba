//! Packet traversal of the obvhs `Bvh2`: a packet of rays (4, 8 or 16 lanes of `wide`; the
//! renderer uses [`LANES`](crate::simd::LANES)) walks the tree together; each node pair's boxes are
//! slab-tested for all lanes at once under an active-lane mask, and a leaf's primitives
//! (watertight triangles after Woop, Benthin and Wald; spheres; parallelograms) are tested
//! for all its lanes at once. When fewer than `min_active` lanes still enter a node pair,
//! those lanes may finish its subtree one ray at a time (the scalar traversal; off in the
//! renderer, measured).
//!
//! Exactness: every lane computes the same floating-point operations in the same order as
//! the scalar kernels (slab test, shear, edge functions, the f64 recomputation of edge
//! functions that round to zero, the distance), so a packet finds exactly the scalar
//! traversal's closest distance and blockers; only on exact ties in t may it report
//! another primitive.
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
    /// Below this many lanes entering a node pair, each of them finishes the pair's
    /// subtree alone (the scalar traversal).
    pub min_active: u32,
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
        PacketConfig { min_active: 0, bounce_order: Order::Octant, shadow_order: Order::Octant, split_mixed: true };
}

/// Work counters of packet traversals.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PacketWork {
    /// Node pairs whose boxes were tested for a whole packet (one SIMD test per box).
    pub steps: u64,
    /// Active lanes summed over those tests: `lanes / (LANES · steps)` is the utilisation.
    pub lanes: u64,
    /// Lane subtrees finished one ray at a time after the packet thinned out.
    pub fallbacks: u64,
    /// Box tests per lane: each SIMD box test counts once for every lane that entered the
    /// parent node (comparable with the scalar traversal's node count).
    pub nodes: u64,
    /// Primitive tests per lane.
    pub prims: u64,
}

/// Iterates over the set bits of a lane mask, lowest first.
#[inline(always)]
fn lanes_of(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let l = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            l
        })
    })
}
