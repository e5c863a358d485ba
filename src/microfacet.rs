//! Microfacet reflection and transmission: the GGX and Beckmann normal distributions with
//! visible-normal sampling, Smith shadowing, Fresnel for conductors (complex index of
//! refraction), and the rough conductor and rough dielectric BSDFs built on them, as
//! Mitsuba 3 defines them (`microfacet.h`, `roughconductor.cpp`, `roughdielectric.cpp`).
//!
//! Directions are in the local shading frame: +z is the shading normal.

/// A microfacet normal distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    /// Trowbridge–Reitz (GGX): long tails, Mitsuba's usual choice.
    Ggx,
    /// Beckmann: a Gaussian of slopes, Mitsuba's default for rough plugins.
    Beckmann,
}

/// A microfacet distribution with its roughness along the frame's two tangents.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    /// Which distribution.
    pub distribution: Distribution,
    /// Roughness along the frame's first tangent (x).
    pub alpha_u: f32,
    /// Roughness along the second tangent (y); equal to `alpha_u` when isotropic.
    pub alpha_v: f32,
}
