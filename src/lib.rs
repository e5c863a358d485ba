//! wavetrace: a data-oriented wavefront CPU ray tracer.
//!
//! Rays live in structure-of-arrays queues ([`queue`]) and move between stages
//! ([`stages`]): camera generation, closest-hit intersection, shading, shadow
//! occlusion, reflection/refraction scattering and film accumulation. The
//! driver in [`render`] runs the stages over screen tiles in parallel.
#![warn(missing_docs)]

pub mod bench;
pub mod color;
pub mod compare;
pub mod error;
pub mod film;
pub mod flip;
pub mod geometry;
pub mod heatmap;
pub mod light;
pub mod output;
pub mod plot;
pub mod queue;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod stages;
pub mod stats;
pub mod surface;
pub mod sweep;

pub use error::{Error, Result};
pub use render::{render, RenderOptions, RenderOutput};
pub use scene::{Scene, DEFAULT_SCENE};
