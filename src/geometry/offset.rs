//! Robust ray origins: Wächter and Binder, "A Fast and Robust Method for Avoiding
//! Self-Intersection" (Ray Tracing Gems, 2019).
//!
//! The hit point is pushed off the surface along the geometric normal by a few
//! units in the last place of its own coordinates (an integer offset of the float
//! bits), so the offset scales with the magnitude of the position instead of being
//! a fixed epsilon that fails far from the origin or at tiny scales.

use glam::Vec3;

const ORIGIN: f32 = 1.0 / 32.0;
const FLOAT_SCALE: f32 = 1.0 / 65536.0;
const INT_SCALE: f32 = 256.0;

/// Moves `p` off the surface to the side `n` points to. `n` need not be unit length
/// but must be finite and non-zero.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    let n = n.normalize();
    let of_i = [(INT_SCALE * n.x) as i32, (INT_SCALE * n.y) as i32, (INT_SCALE * n.z) as i32];
    let pa = p.to_array();
    let na = n.to_array();
    let mut out = [0.0f32; 3];
    for k in 0..3 {
        let bits = pa[k].to_bits() as i32;
        let shifted = bits.wrapping_add(if pa[k] < 0.0 { -of_i[k] } else { of_i[k] });
        let p_i = f32::from_bits(shifted as u32);
        out[k] = if pa[k].abs() < ORIGIN { pa[k] + FLOAT_SCALE * na[k] } else { p_i };
    }
    Vec3::from_array(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_moves_to_the_normal_side_at_every_scale() {
        for &s in &[1e-4f32, 1.0, 1e4, 1e6] {
            for &n in &[Vec3::Y, Vec3::NEG_Y, Vec3::new(1.0, 1.0, 0.0)] {
                let p = Vec3::new(0.3 * s, 0.7 * s, -0.2 * s);
                let q = offset_ray_origin(p, n);
                assert!((q - p).dot(n) > 0.0, "scale {s}, n {n}: {p} -> {q}");
                assert!((q - p).length() < 1e-3 * s.max(1.0), "offset too large at scale {s}");
            }
        }
    }
}
