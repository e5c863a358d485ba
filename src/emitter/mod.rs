//! Emitters that are not surfaces of the scene, one module each, giving what the stages
//! ask of a light: its radiance along a direction, a sampled direction, and the density
//! of that sample.
//!
//! - [`area`]: parallelograms and triangles, sampled by area; their exact irradiance.
//! - [`sphere`]: spheres, sampled in the cone they subtend.
//! - [`environment`]: the background, constant or a lat-long map (Mitsuba's `constant`
//!   and `envmap`), a light at infinity under the path transport.
//!
//! How the stages sample the scene's lights (which light, how many samples, probes, the
//! seeds that keep a pixel's samples stratified) is `light/`, which calls these.

pub mod area;
pub mod environment;
pub mod sphere;
