//! wavetrace: a data-oriented wavefront CPU ray tracer.
//!
//! Rays live in structure-of-arrays queues ([`queue`]) and move between stages
//! ([`stages`]): camera generation, closest-hit intersection, shading, shadow
//! occlusion, reflection/refraction scattering and film accumulation. The
//! driver in [`render`] runs the stages over screen tiles in parallel.
//!
//! The tools built on the renderer (output files, heatmaps, image comparison, sweeps,
//! plots, the traversal benchmark) live in [`tools`].
#![warn(missing_docs)]

pub mod accel;
pub mod bsdf;
pub mod color;
pub mod emitter;
pub mod error;
pub mod film;
pub mod light;
pub mod motion;
pub mod queue;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod simd;
pub mod stages;
pub mod stats;
pub mod surface;
pub mod system;
pub mod texture;
pub mod tools;

pub use error::{Error, Result};
pub use render::{render, RenderOptions, RenderOutput};
pub use scene::{Scene, DEFAULT_SCENE};
