//! The `Simd` trait: the lane-wise operations the packet kernels need, for `wide`'s f32x4, f32x8 and f32x16.

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Sub};
use wide::{f32x16, f32x4, f32x8};

use super::MAX;

/// The lane-wise operations the packet kernels need, over `wide`'s f32 vectors.
pub trait Simd:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
{
    /// Number of lanes.
    const LANES: usize;
    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// The first `LANES` values of `a`.
    fn load(a: &[f32; MAX]) -> Self;
    /// The first `LANES` values of `a` (at least that long).
    fn load_lanes(a: &[f32]) -> Self;
    /// Writes the lanes to the front of `a`.
    fn store(self, a: &mut [f32; MAX]);
    /// Lane-wise minimum (no NaN handling: the kernels never produce NaN here).
    fn min(self, o: Self) -> Self;
    /// Lane-wise maximum (no NaN handling).
    fn max(self, o: Self) -> Self;
    /// Mask of `self >= o`.
    fn ge(self, o: Self) -> Self;
    /// Mask of `self > o`.
    fn gt(self, o: Self) -> Self;
    /// Mask of `self < o`.
    fn lt(self, o: Self) -> Self;
    /// Mask of `self <= o`.
    fn le(self, o: Self) -> Self;
    /// Mask of `self == o`.
    fn eq(self, o: Self) -> Self;
    /// Mask of finite lanes.
    fn finite(self) -> Self;
    /// Mask of lanes with the sign bit set.
    fn negative(self) -> Self;
    /// Mask of NaN lanes.
    fn nan(self) -> Self;
    /// Lane-wise square root.
    fn sqrt(self) -> Self;
    /// One bit per lane of a mask (lane 0 = bit 0).
    fn bits(self) -> u32;
    /// Lane-wise `mask ? t : f`.
    fn select(mask: Self, t: Self, f: Self) -> Self;
}

macro_rules! simd {
    ($t:ty, $n:expr) => {
        impl Simd for $t {
            const LANES: usize = $n;
            #[inline(always)]
            fn splat(x: f32) -> Self {
                <$t>::splat(x)
            }
            #[inline(always)]
            fn load(a: &[f32; MAX]) -> Self {
                let mut v = [0.0f32; $n];
                v.copy_from_slice(&a[..$n]);
                <$t>::from(v)
            }
            #[inline(always)]
            fn load_lanes(a: &[f32]) -> Self {
                let v: [f32; $n] = a[..$n].try_into().expect("a slice of LANES values");
                <$t>::from(v)
            }
            #[inline(always)]
            fn store(self, a: &mut [f32; MAX]) {
                a[..$n].copy_from_slice(&self.to_array());
            }
            #[inline(always)]
            fn min(self, o: Self) -> Self {
                self.fast_min(o)
            }
            #[inline(always)]
            fn max(self, o: Self) -> Self {
                self.fast_max(o)
            }
            #[inline(always)]
            fn ge(self, o: Self) -> Self {
                self.simd_ge(o)
            }
            #[inline(always)]
            fn gt(self, o: Self) -> Self {
                self.simd_gt(o)
            }
            #[inline(always)]
            fn lt(self, o: Self) -> Self {
                self.simd_lt(o)
            }
            #[inline(always)]
            fn le(self, o: Self) -> Self {
                self.simd_le(o)
            }
            #[inline(always)]
            fn eq(self, o: Self) -> Self {
                self.simd_eq(o)
            }
            #[inline(always)]
            fn finite(self) -> Self {
                self.is_finite()
            }
            #[inline(always)]
            fn negative(self) -> Self {
                self.is_sign_negative()
            }
            #[inline(always)]
            fn nan(self) -> Self {
                self.is_nan()
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn bits(self) -> u32 {
                self.to_bitmask() as u32
            }
            #[inline(always)]
            fn select(mask: Self, t: Self, f: Self) -> Self {
                mask.select(t, f)
            }
        }
    };
}
simd!(f32x4, 4);
simd!(f32x8, 8);
simd!(f32x16, 16);
