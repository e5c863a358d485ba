//! The wavefront stages, one module each. A stage is a function from its input
//! queue(s) to its output queue(s); it keeps no state between calls.
//!
//! camera → intersect → shade → { shadow → film ; scatter → intersect → … }
//!
//! Adaptive AA adds `refine` (and `focus` for DOF-aware AA); adaptive shadows add
//! `shadow_corner` and `penumbra`.

pub mod camera;
pub mod film;
pub mod focus;
pub mod intersect;
pub mod penumbra;
pub mod refine;
pub mod scatter;
pub mod shade;
pub mod shadow;
pub mod shadow_corner;

/// A rectangle of pixels `[x0, x1) × [y0, y1)` rendered by one worker.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    /// Left column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// One past the right column.
    pub x1: u32,
    /// One past the bottom row.
    pub y1: u32,
}

impl Tile {
    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        ((self.x1 - self.x0) * (self.y1 - self.y0)) as usize
    }
}
