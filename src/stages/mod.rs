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

pub use crate::film::Tile;
