//! The materials' scattering functions, one module per material family, each giving what
//! the scatter stage asks of a BSDF: its value times the cosine, its density, and a
//! sample, in the local shading frame (+z the shading normal), written after Mitsuba 3's
//! plugins so that a scene renders the same material in both.
//!
//! - [`microfacet`]: the GGX and Beckmann distributions, and the rough conductor and
//!   rough dielectric built on them (`roughconductor`, `roughdielectric`).
//! - [`plastic`]: a diffuse base under a smooth or rough dielectric coating (`plastic`,
//!   `roughplastic`).
//!
//! Lambert and Phong, the paper's diffuse material, live with the shade stage's surface
//! queue (`surface.rs`), which evaluates them 16 points at a time.

pub mod microfacet;
pub mod plastic;
