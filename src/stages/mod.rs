//! The wavefront stages, one module each. A stage is a function from its input
//! queue(s) to its output queue(s); it keeps no state between calls.
//!
//! camera → intersect → shade → { shadow → film ; scatter → intersect → … }
//!
//! The path transport adds `bounce` (diffuse surfaces' rays) and `roulette` (Russian
//! roulette on the deeper levels).
//!
//! Adaptive AA adds `refine` (and `focus` for DOF-aware AA), variance-driven AA
//! `converge`; adaptive shadows add
//! `shadow_corner` and `penumbra`. A stage that traces rays writes them to a queue and
//! hands the whole queue to the tracer (which picks packets or single rays); none
//! traces a ray on its own.

pub mod bounce;
pub mod camera;
pub mod converge;
pub mod film;
pub mod focus;
pub mod intersect;
pub mod penumbra;
pub mod refine;
pub mod roulette;
pub mod scatter;
pub mod shade;
pub mod shadow;
pub mod shadow_corner;

pub use crate::film::Tile;
