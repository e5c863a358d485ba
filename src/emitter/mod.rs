//! Emitters that are not surfaces of the scene, one module each, giving what the stages
//! ask of a light: its radiance along a direction, a sampled direction, and the density
//! of that sample.
//!
//! - [`environment`]: the background, constant or a lat-long map (Mitsuba's `constant`
//!   and `envmap`), a light at infinity under the path transport.
//!
//! Area and point lights, which the paper's shadow stages sample, are in `light.rs`.

pub mod environment;
