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

/// The 8-bit display value the PNG stores for a linear value: [`display8_formula`]'s
/// byte, read from a table by the value's top bits and corrected by one comparison
/// with where the next byte starts (the formula's `powf` per channel cost 3 ms of a
/// 4-spp 320×240 render's output). Equal to the formula for every `f32` (checked for
/// all 2³² of them by an ignored test; the suite checks around every step and a sample
/// in between).
#[inline]
pub fn to_display8(linear: f32) -> u8 {
    // NaN, negatives and zero are 0, as the formula's clamp makes them.
    if linear.is_nan() || linear <= 0.0 {
        return 0;
    }
    if linear >= 1.0 {
        return 255;
    }
    let t = display_table();
    let k = t.first[(linear.to_bits() >> DISPLAY_SHIFT) as usize];
    k + (linear >= t.starts[k as usize + 1]) as u8
}

/// The 8-bit display value by the formula: the sRGB value, scaled and rounded.
#[inline]
pub fn display8_formula(linear: f32) -> u8 {
    (srgb_encode(linear) * 255.0 + 0.5) as u8
}

/// Low bits of an `f32` below [`DisplayTable::first`]'s index: a bucket of 2¹⁴
/// consecutive floats spans a relative width of 2⁻⁹, over which the byte rises by at
/// most 0.23, so one comparison finishes the lookup.
const DISPLAY_SHIFT: u32 = 14;

/// [`to_display8`]'s tables.
struct DisplayTable {
    /// Per bucket of floats in (0, 1), the byte of its first float.
    first: Vec<u8>,
    /// Per byte k in 1..=255, the least `f32` whose formula byte is at least k; entry 0
    /// is unused and entry 256 infinite.
    starts: [f32; 257],
}

/// The tables, built on first use (about 0.1 ms): each start from the inverse transfer
/// function, moved a few floats to where the formula's byte changes (the formula does
/// not decrease, and positive floats' bit patterns are in their values' order).
fn display_table() -> &'static DisplayTable {
    static TABLE: std::sync::OnceLock<DisplayTable> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let byte = |b: u32| display8_formula(f32::from_bits(b)) as usize;
        let mut starts = [f32::INFINITY; 257];
        starts[0] = f32::NEG_INFINITY;
        for (k, start) in starts.iter_mut().enumerate().take(256).skip(1) {
            let mut b = srgb_decode((k as f32 - 0.5) / 255.0).clamp(0.0, 1.0).to_bits();
            while b > 0 && byte(b - 1) >= k {
                b -= 1;
            }
            while byte(b) < k {
                b += 1;
            }
            *start = f32::from_bits(b);
        }
        let mut k = 0;
        let first = (0..1.0f32.to_bits() >> DISPLAY_SHIFT)
            .map(|i| {
                let x = f32::from_bits(i << DISPLAY_SHIFT);
                while k < 255 && x >= starts[k + 1] {
                    k += 1;
                }
                k as u8
            })
            .collect();
        DisplayTable { first, starts }
    })
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The table gives the formula's byte around every step (4096 floats each side), at
    /// the extremes and on a sample of every 997th float.
    #[test]
    fn display_bytes_by_table_are_the_formulas() {
        let starts = &display_table().starts[..256];
        let check = |x: f32| assert_eq!(to_display8(x), display8_formula(x), "{x:e} ({:#x})", x.to_bits());
        for &s in &starts[1..] {
            let b = s.to_bits();
            (b.saturating_sub(4096)..b + 4096).for_each(|b| check(f32::from_bits(b)));
        }
        for x in [0.0, -0.0, 1.0, 7.0, -1.0, f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE] {
            check(x);
        }
        (0..u32::MAX).step_by(997).for_each(|b| check(f32::from_bits(b)));
    }

    /// Every `f32`: `cargo test --release --lib color -- --ignored` (about a minute).
    #[test]
    #[ignore]
    fn display_bytes_by_table_are_the_formulas_for_every_f32() {
        let bad =
            (0..=u32::MAX).filter(|&b| to_display8(f32::from_bits(b)) != display8_formula(f32::from_bits(b))).count();
        assert_eq!(bad, 0);
    }
}
