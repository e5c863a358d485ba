//! The sRGB transfer functions, in one place: what the PNG stores, what adaptive AA
//! compares, and what `compare` and FLIP decode.

/// The sRGB transfer function of a linear value clamped to [0, 1].
#[inline]
pub fn srgb_encode(linear: f32) -> f32 {
    let c = if linear.is_nan() { 0.0 } else { linear.clamp(0.0, 1.0) };
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// The 8-bit display value the PNG stores for a linear value.
#[inline]
pub fn to_display8(linear: f32) -> u8 {
    (srgb_encode(linear) * 255.0 + 0.5) as u8
}

/// The inverse of the sRGB transfer function.
#[inline]
pub fn srgb_decode(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// The luminance (Y) of a linear Rec. 709 colour, with Mitsuba's coefficients.
#[inline]
pub fn luminance(c: glam::Vec3) -> f32 {
    c.x * 0.212_671 + c.y * 0.715_16 + c.z * 0.072_169
}
