//! The crate's one lane abstraction. [`Word`] is a `u32` or 16 of them (`wide::u32x16`),
//! [`Real`] an `f32` or 4, 8 or 16 of them (`wide`'s `f32x4`, `f32x8`, `f32x16`). A sample
//! pattern or a ray formula written once, generic over them, runs ray by ray and 16 rays
//! at a time with the same operations in the same order, so both give the same bits (Rust
//! never fuses a multiply and an add on its own). [`Vector`] adds to a `Real` what only
//! vectors have: lane masks, loads and stores, the unchecked minimum and maximum; the
//! traversal kernels (packets, wide nodes, leaf blocks) are written over it.

use std::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Shl, Shr, Sub};
use wide::{f32x16, f32x4, f32x8, i32x16, u32x16, u32x4, u32x8};

/// Lanes of the renderer's vectors: the stages' lane groups and the traversal's packets
/// (chosen by measurement: docs/performance.md); also the widest [`Vector`], so arrays of
/// `LANES` hold any vector's lanes.
pub const LANES: usize = 16;

/// 32-bit words: wrapping integer arithmetic and lane masks (all bits set or none).
pub trait Word:
    Copy
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
    + BitXor<Output = Self>
    + Not<Output = Self>
    + Shr<u32, Output = Self>
    + Shl<u32, Output = Self>
{
    /// The matching float lanes.
    type Real: Real;
    /// Every lane `x`.
    fn splat(x: u32) -> Self;
    /// Wrapping sum.
    fn wadd(self, o: Self) -> Self;
    /// Wrapping product.
    fn wmul(self, o: Self) -> Self;
    /// The bits in reverse order.
    fn reverse(self) -> Self;
    /// Mask of `self < o` (unsigned).
    fn lt(self, o: Self) -> Self;
    /// Lane-wise `mask ? t : f`.
    fn select(mask: Self, t: Self, f: Self) -> Self;
    /// True when every lane of `mask` is set.
    fn all(mask: Self) -> bool;
    /// Quotient and remainder by `d` ≥ 1, for values below 2²⁴.
    fn div_rem(self, d: u32) -> (Self, Self);
    /// `(self + p) mod len` with the sum wrapping at 2³², for `self < len`, given
    /// `p_mod` = `p mod len` (each lane's `p` may differ).
    fn add_rem(self, p: Self, p_mod: Self, len: u32) -> Self;
    /// The value as a float (exact below 2²⁴).
    fn real(self) -> Self::Real;
    /// `x` truncated toward zero, for `x` in [0, 2³¹) (`as u32`'s value there).
    fn trunc(x: Self::Real) -> Self;
}

/// 32-bit floats.
pub trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// Lane-wise minimum (neither operand is NaN where it is used).
    fn min(self, o: Self) -> Self;
    /// Lane-wise square root (correctly rounded, like `f32::sqrt`).
    fn sqrt(self) -> Self;
    /// Lane-wise absolute value.
    fn abs(self) -> Self;
    /// Lane-wise `test < 0 ? a : b`.
    fn if_negative(test: Self, a: Self, b: Self) -> Self;
    /// One float step toward the sign of `s`: `next_up` where `s > 0`, `next_down` where
    /// `s < 0`, unchanged where `s` is zero (or NaN).
    fn step(self, s: Self) -> Self;
}

impl Word for u32 {
    type Real = f32;
    #[inline(always)]
    fn splat(x: u32) -> Self {
        x
    }
    #[inline(always)]
    fn wadd(self, o: Self) -> Self {
        self.wrapping_add(o)
    }
    #[inline(always)]
    fn wmul(self, o: Self) -> Self {
        self.wrapping_mul(o)
    }
    #[inline(always)]
    fn reverse(self) -> Self {
        self.reverse_bits()
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Self {
        if self < o {
            !0
        } else {
            0
        }
    }
    #[inline(always)]
    fn select(mask: Self, t: Self, f: Self) -> Self {
        if mask != 0 {
            t
        } else {
            f
        }
    }
    #[inline(always)]
    fn all(mask: Self) -> bool {
        mask != 0
    }
    #[inline(always)]
    fn div_rem(self, d: u32) -> (Self, Self) {
        (self / d, self % d)
    }
    #[inline(always)]
    fn add_rem(self, p: u32, _: u32, len: u32) -> Self {
        self.wrapping_add(p) % len
    }
    #[inline(always)]
    fn real(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn trunc(x: f32) -> Self {
        x as u32
    }
}

impl Real for f32 {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        x
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        f32::min(self, o)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn if_negative(test: Self, a: Self, b: Self) -> Self {
        if test < 0.0 {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn step(self, s: Self) -> Self {
        if s > 0.0 {
            self.next_up()
        } else if s < 0.0 {
            self.next_down()
        } else {
            self
        }
    }
}

impl Word for u32x16 {
    type Real = f32x16;
    #[inline(always)]
    fn splat(x: u32) -> Self {
        u32x16::splat(x)
    }
    #[inline(always)]
    fn wadd(self, o: Self) -> Self {
        self + o
    }
    #[inline(always)]
    fn wmul(self, o: Self) -> Self {
        self * o
    }
    #[inline(always)]
    fn reverse(self) -> Self {
        let mut x = self;
        x = ((x >> 1) & u32x16::splat(0x5555_5555)) | ((x & u32x16::splat(0x5555_5555)) << 1);
        x = ((x >> 2) & u32x16::splat(0x3333_3333)) | ((x & u32x16::splat(0x3333_3333)) << 2);
        x = ((x >> 4) & u32x16::splat(0x0f0f_0f0f)) | ((x & u32x16::splat(0x0f0f_0f0f)) << 4);
        x = ((x >> 8) & u32x16::splat(0x00ff_00ff)) | ((x & u32x16::splat(0x00ff_00ff)) << 8);
        (x >> 16) | (x << 16)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Self {
        self.simd_lt(o)
    }
    #[inline(always)]
    fn select(mask: Self, t: Self, f: Self) -> Self {
        mask.select(t, f)
    }
    #[inline(always)]
    fn all(mask: Self) -> bool {
        mask.all()
    }
    #[inline(always)]
    fn div_rem(self, d: u32) -> (Self, Self) {
        // Both below 2²⁴, so exact as floats; the correctly rounded quotient is within
        // one of the true one, and the remainder's sign and size say which way.
        let x: i32x16 = wide::bytemuck::cast(self);
        let df = f32x16::splat(d as f32);
        let q = (f32x16::from_i32x16(x) / df).trunc_int();
        let di = i32x16::splat(d as i32);
        let r = x - q * di;
        let neg = r.simd_lt(i32x16::ZERO);
        let (q, r) = (neg.select(q - i32x16::ONE, q), neg.select(r + di, r));
        let over = r.simd_ge(di);
        let (q, r) = (over.select(q + i32x16::ONE, q), over.select(r - di, r));
        (wide::bytemuck::cast(q), wide::bytemuck::cast(r))
    }
    #[inline(always)]
    fn add_rem(self, p: u32x16, p_mod: u32x16, len: u32) -> Self {
        // With P = p mod len and C = 2³² mod len: without wrap the answer is
        // (self + P) mod len, with wrap (self + P − C) mod len; self + P < 2·len.
        let sum = self + p;
        let wrapped = sum.simd_lt(self);
        let c = ((1u64 << 32) % len as u64) as u32;
        let len_v = u32x16::splat(len);
        let t = self + p_mod;
        // t − C may go below zero (a huge unsigned value): add len back there.
        let below = t.simd_lt(u32x16::splat(c));
        let t_wrapped = below.select(t + len_v - u32x16::splat(c), t - u32x16::splat(c));
        let t = wrapped.select(t_wrapped, t);
        let over = t.simd_lt(len_v);
        over.select(t, t - len_v)
    }
    #[inline(always)]
    fn real(self) -> f32x16 {
        f32x16::from_i32x16(wide::bytemuck::cast(self))
    }
    #[inline(always)]
    fn trunc(x: f32x16) -> Self {
        // Below 2³¹ the signed conversion is the value itself.
        wide::bytemuck::cast(x.fast_trunc_int())
    }
}

/// [`Real`] for `wide`'s float vectors (`$u`: the unsigned words of the same width).
macro_rules! real_vector {
    ($t:ty, $u:ty) => {
        impl Real for $t {
            #[inline(always)]
            fn splat(x: f32) -> Self {
                <$t>::splat(x)
            }
            #[inline(always)]
            fn min(self, o: Self) -> Self {
                <$t>::min(self, o)
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn if_negative(test: Self, a: Self, b: Self) -> Self {
                test.simd_lt(<$t>::ZERO).select(a, b)
            }
            #[inline(always)]
            fn step(self, s: Self) -> Self {
                // f32::next_up / next_down on the bits: NaN and the infinity in the step's
                // direction stay, ±0 goes to the smallest subnormal of that sign, else the
                // magnitude grows or shrinks by one unit in the last place.
                let bits = self.to_bits();
                let one = <$u>::splat(1);
                let sign = <$u>::splat(0x8000_0000);
                let abs = bits & !sign;
                let zero = abs.simd_eq(<$u>::ZERO);
                let positive = bits.simd_eq(abs);
                let up = zero.select(one, positive.select(bits + one, bits - one));
                let down = zero.select(sign | one, positive.select(bits - one, bits + one));
                let nan = self.is_nan().to_bits();
                let up = (nan | bits.simd_eq(<$u>::splat(f32::INFINITY.to_bits()))).select(bits, up);
                let down = (nan | bits.simd_eq(<$u>::splat(f32::NEG_INFINITY.to_bits()))).select(bits, down);
                let (gt, lt) = (s.simd_gt(<$t>::ZERO).to_bits(), s.simd_lt(<$t>::ZERO).to_bits());
                <$t>::from_bits(gt.select(up, lt.select(down, bits)))
            }
        }
    };
}
real_vector!(f32x4, u32x4);
real_vector!(f32x8, u32x8);
real_vector!(f32x16, u32x16);

/// What float vectors add to [`Real`]: lane masks (a lane all ones or all zeros, as
/// `Self`), loads and stores, and the traversal kernels' unchecked minimum and maximum.
pub trait Vector: Real + BitAnd<Output = Self> + BitOr<Output = Self> {
    /// Number of lanes of this vector type (at most [`LANES`], the renderer's).
    const WIDTH: usize;
    /// The first `Self::WIDTH` values of `a`.
    fn load(a: &[f32; LANES]) -> Self;
    /// The first `Self::WIDTH` values of `a` (at least that long).
    fn load_lanes(a: &[f32]) -> Self;
    /// Writes the lanes to the front of `a`.
    fn store(self, a: &mut [f32; LANES]);
    /// Lane `i` (below `Self::WIDTH`).
    fn lane(self, i: usize) -> f32;
    /// Lane-wise minimum without NaN handling (the kernels never produce NaN there).
    fn fast_min(self, o: Self) -> Self;
    /// Lane-wise maximum without NaN handling.
    fn fast_max(self, o: Self) -> Self;
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
    /// One bit per lane of a mask (lane 0 = bit 0).
    fn bits(self) -> u32;
    /// Lane-wise `mask ? t : f`.
    fn select(mask: Self, t: Self, f: Self) -> Self;
}

/// [`Vector`] for `wide`'s float vectors of `$n` lanes.
macro_rules! vector {
    ($t:ty, $n:expr) => {
        impl Vector for $t {
            const WIDTH: usize = $n;
            #[inline(always)]
            fn load(a: &[f32; LANES]) -> Self {
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
            fn store(self, a: &mut [f32; LANES]) {
                a[..$n].copy_from_slice(&self.to_array());
            }
            #[inline(always)]
            fn lane(self, i: usize) -> f32 {
                self.as_array()[i]
            }
            #[inline(always)]
            fn fast_min(self, o: Self) -> Self {
                <$t>::fast_min(self, o)
            }
            #[inline(always)]
            fn fast_max(self, o: Self) -> Self {
                <$t>::fast_max(self, o)
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
vector!(f32x4, 4);
vector!(f32x8, 8);
vector!(f32x16, 16);

/// A vector of three coordinates, each a [`Real`]: glam's `Vec3` operations on lanes, in
/// glam's order of operations.
#[derive(Clone, Copy, Debug)]
pub struct V3<R> {
    /// x coordinates.
    pub x: R,
    /// y coordinates.
    pub y: R,
    /// z coordinates.
    pub z: R,
}

impl<R: Real> V3<R> {
    /// Every lane `v`.
    #[inline(always)]
    pub fn splat(v: glam::Vec3) -> Self {
        V3 { x: R::splat(v.x), y: R::splat(v.y), z: R::splat(v.z) }
    }
    /// Product with a scalar per lane.
    #[inline(always)]
    pub fn scale(self, s: R) -> Self {
        V3 { x: self.x * s, y: self.y * s, z: self.z * s }
    }
    /// Quotient by a scalar per lane, as `Vec3 / f32` (three divisions).
    #[inline(always)]
    pub fn over(self, s: R) -> Self {
        V3 { x: self.x / s, y: self.y / s, z: self.z / s }
    }
    /// Cross product, as `Vec3::cross`.
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        V3 { x: self.y * o.z - o.y * self.z, y: self.z * o.x - o.z * self.x, z: self.x * o.y - o.x * self.y }
    }
    /// Component-wise absolute value.
    #[inline(always)]
    pub fn abs(self) -> Self {
        V3 { x: self.x.abs(), y: self.y.abs(), z: self.z.abs() }
    }
    /// Lane-wise `test < 0 ? a : b`.
    #[inline(always)]
    pub fn if_negative(test: R, a: Self, b: Self) -> Self {
        V3 { x: R::if_negative(test, a.x, b.x), y: R::if_negative(test, a.y, b.y), z: R::if_negative(test, a.z, b.z) }
    }
    /// Dot product, as `Vec3::dot`.
    #[inline(always)]
    pub fn dot(self, o: Self) -> R {
        (self.x * o.x) + (self.y * o.y) + (self.z * o.z)
    }
    /// Unit vector, as `Vec3::normalize` (times the reciprocal of the length).
    #[inline(always)]
    pub fn normalize(self) -> Self {
        self.scale(R::splat(1.0) / self.dot(self).sqrt())
    }
}

impl V3<f32x16> {
    /// The x, y and z lanes as arrays: what a queue's `push_lanes` takes for a vector.
    #[inline(always)]
    pub fn lanes(self) -> [[f32; LANES]; 3] {
        [self.x.to_array(), self.y.to_array(), self.z.to_array()]
    }
    /// Lane k is `f(k)`.
    #[inline(always)]
    pub fn from_fn(f: impl Fn(usize) -> glam::Vec3) -> Self {
        let v: [glam::Vec3; LANES] = std::array::from_fn(f);
        V3 { x: f32x16::from(v.map(|v| v.x)), y: f32x16::from(v.map(|v| v.y)), z: f32x16::from(v.map(|v| v.z)) }
    }
    /// Lane-wise `mask ? a : b` (`mask` all ones or all zeros per lane).
    #[inline(always)]
    pub fn select(mask: f32x16, a: Self, b: Self) -> Self {
        V3 { x: mask.select(a.x, b.x), y: mask.select(a.y, b.y), z: mask.select(a.z, b.z) }
    }
    /// Component-wise product, as `Vec3 * Vec3`.
    #[inline(always)]
    pub fn times(self, o: Self) -> Self {
        V3 { x: self.x * o.x, y: self.y * o.y, z: self.z * o.z }
    }
}

impl V3<f32> {
    /// From a glam vector.
    #[inline(always)]
    pub fn from_vec(v: glam::Vec3) -> Self {
        V3 { x: v.x, y: v.y, z: v.z }
    }
    /// As a glam vector.
    #[inline(always)]
    pub fn vec(self) -> glam::Vec3 {
        glam::Vec3::new(self.x, self.y, self.z)
    }
}

impl<R: Real> Add for V3<R> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        V3 { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

impl<R: Real> Neg for V3<R> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        V3 { x: -self.x, y: -self.y, z: -self.z }
    }
}

impl<R: Real> Sub for V3<R> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        V3 { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

/// Lane `k` of every vector: `u32x16`s as arrays.
#[inline(always)]
pub fn words(v: u32x16) -> [u32; LANES] {
    v.to_array()
}

/// Where 16 lanes read their values in a queue's columns: 16 entries (from 1 to 16
/// ids, the last repeated), and whether they follow a pattern that loads a few values
/// from the column instead of 16 one by one.
pub struct LaneIds {
    /// The entries, one per lane.
    pub idx: [usize; LANES],
    /// The pattern of the entries, if any.
    shape: Shape,
}

/// The patterns of [`LaneIds`] with a faster load than entry by entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    /// Entries `first..first + 16`.
    Run(usize),
    /// Entries `first, …, first + 16 / 2^shift - 1`, each `2^shift` times in a row (1 to
    /// 4: a point's shadow samples side by side).
    Repeat(usize, u32),
    /// Anything else.
    Any,
}

impl LaneIds {
    /// The lanes of `ids` (1 to 16 entries).
    #[inline(always)]
    pub fn new(ids: &[u32]) -> LaneIds {
        let mut idx = [ids[ids.len() - 1] as usize; LANES];
        for (x, &i) in idx.iter_mut().zip(ids) {
            *x = i as usize;
        }
        let first = idx[0];
        let shape = if idx.windows(2).all(|w| w[1] == w[0] + 1) {
            Shape::Run(first)
        } else {
            // The first entry's repeats give the only shift that could fit.
            let same = idx.iter().take_while(|&&i| i == first).count();
            let shift = same.trailing_zeros();
            let fits = same.is_power_of_two() && idx.iter().enumerate().all(|(k, &i)| i == first + (k >> shift));
            if fits {
                Shape::Repeat(first, shift)
            } else {
                Shape::Any
            }
        };
        LaneIds { idx, shape }
    }

    /// The lanes' values of the column `v`, entry by entry (a loop the compiler keeps
    /// inline, unlike `array::from_fn`).
    #[inline(always)]
    fn spread<T: Copy + Default>(&self, v: &[T]) -> [T; LANES] {
        let mut a = [T::default(); LANES];
        for (x, &i) in a.iter_mut().zip(&self.idx) {
            *x = v[i];
        }
        a
    }

    /// The lanes' values of the column `v` where the entries repeat: a load of a few
    /// values, then a shuffle (the fixed shift lets the compiler drop every bounds check
    /// but the slice's).
    #[inline(always)]
    fn repeat<const SHIFT: u32, T: Copy + Default>(v: &[T], first: usize) -> [T; LANES] {
        let src = &v[first..first + (LANES >> SHIFT)];
        let mut a = [T::default(); LANES];
        for (k, x) in a.iter_mut().enumerate() {
            *x = src[k >> SHIFT];
        }
        a
    }

    /// The lanes' values of the column `v` as an array, by the entries' pattern.
    #[inline(always)]
    fn values<T: Copy + Default>(&self, v: &[T]) -> [T; LANES] {
        match self.shape {
            Shape::Repeat(a, 1) => Self::repeat::<1, T>(v, a),
            Shape::Repeat(a, 2) => Self::repeat::<2, T>(v, a),
            Shape::Repeat(a, 3) => Self::repeat::<3, T>(v, a),
            Shape::Repeat(a, _) => [v[a]; LANES],
            Shape::Run(_) | Shape::Any => self.spread(v),
        }
    }

    /// The lanes' values of the column `v`. (A run loads the slice straight into the
    /// vector: through an array it measured 1.5 ns a hit slower in shade.)
    #[inline(always)]
    pub fn gather(&self, v: &[f32]) -> f32x16 {
        match self.shape {
            Shape::Run(a) => f32x16::from(&v[a..a + LANES]),
            Shape::Repeat(..) | Shape::Any => f32x16::from(self.values(v)),
        }
    }

    /// [`LaneIds::gather`] of three columns: a vector's components.
    #[inline(always)]
    pub fn gather3(&self, x: &[f32], y: &[f32], z: &[f32]) -> V3<f32x16> {
        V3 { x: self.gather(x), y: self.gather(y), z: self.gather(z) }
    }

    /// [`LaneIds::gather`] of words.
    #[inline(always)]
    pub fn gather_words(&self, v: &[u32]) -> u32x16 {
        match self.shape {
            Shape::Run(a) => u32x16::from(&v[a..a + LANES]),
            Shape::Repeat(..) | Shape::Any => u32x16::from(self.values(v)),
        }
    }
}

/// Appends the first `count` lanes of `v` to the column `col`. A full vector (the usual
/// case) is one fixed-size copy the compiler inlines, not a call to `memmove`.
#[inline(always)]
pub fn push_lanes<T: Copy>(col: &mut Vec<T>, v: [T; LANES], count: usize) {
    if count == LANES {
        col.extend_from_slice(&v);
    } else {
        col.extend_from_slice(&v[..count]);
    }
}

/// The lanes `first, first + 1, …, first + 15`.
#[inline(always)]
pub fn iota(first: u32) -> u32x16 {
    u32x16::splat(first) + u32x16::from([0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lane_ids_load_a_run_or_a_repeat_only_where_the_ids_follow_it() {
        let col: Vec<f32> = (0..40).map(|i| i as f32 * 1.5).collect();
        let expect = |ids: &[u32]| {
            let last = ids[ids.len() - 1];
            f32x16::from(std::array::from_fn::<f32, LANES, _>(|k| col[*ids.get(k).unwrap_or(&last) as usize]))
        };
        let run: Vec<u32> = (3..19).collect();
        // 15 ids whose repeated last spans 15 (a partial group is never a run), a
        // repeated id that spans 15, and a full run.
        let gap: Vec<u32> = [0].into_iter().chain(2..16).collect();
        let dup: Vec<u32> = [0, 0].into_iter().chain(2..16).collect();
        // Repeats: each entry 2, 4, 8 or 16 times (a 15-id group too), one that breaks
        // its pattern at the end, and one whose first entry repeats 3 times.
        let rep = |n: u32, len: u32| (0..len).map(|k| 5 + k / n).collect::<Vec<u32>>();
        let broken: Vec<u32> = rep(4, 15).into_iter().chain([9]).collect();
        let three: Vec<u32> = [1, 1, 1].into_iter().chain(2..15).collect();
        let repeats = [rep(2, 16), rep(4, 16), rep(8, 16), rep(16, 16), rep(4, 15), vec![7]];
        let cases: Vec<(&Vec<u32>, bool)> =
            [(&run, false), (&gap, false), (&dup, false), (&broken, false), (&three, false)]
                .into_iter()
                .chain(repeats.iter().map(|r| (r, true)))
                .collect();
        for (ids, repeat) in cases {
            let lanes = LaneIds::new(ids);
            assert_eq!(matches!(lanes.shape, Shape::Run(_)), ids == &run, "{ids:?}");
            assert_eq!(matches!(lanes.shape, Shape::Repeat(..)), repeat, "{ids:?}");
            assert_eq!(lanes.gather(&col).to_array(), expect(ids).to_array(), "{ids:?}");
            let words: Vec<u32> = col.iter().map(|x| x.to_bits()).collect();
            assert_eq!(lanes.gather_words(&words).to_array(), expect(ids).to_array().map(f32::to_bits));
        }
    }

    fn lanes(f: impl Fn(usize) -> u32) -> u32x16 {
        u32x16::from(std::array::from_fn::<u32, 16, _>(f))
    }

    #[test]
    fn step_lanes_equal_next_up_and_next_down() {
        let specials = [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::from_bits(0x8000_0001),
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            3.5e-39,
            -7.25e12,
            1e-45,
        ];
        let mut h = 7u32;
        for round in 0..3000 {
            let x: [f32; 16] = std::array::from_fn(|k| {
                h = crate::sampling::mix(h.wrapping_add(0x9e37_79b9));
                if round % 2 == 0 {
                    specials[k]
                } else {
                    f32::from_bits(h)
                }
            });
            for s in [1.0f32, -1.0, 0.0, -0.0, f32::NAN, 1e-40] {
                let got = f32x16::from(x).step(f32x16::splat(s)).to_array();
                for k in 0..16 {
                    assert_eq!(got[k].to_bits(), x[k].step(s).to_bits(), "{} toward {s}", x[k]);
                }
            }
        }
    }

    #[test]
    fn word_lanes_equal_the_scalar_word() {
        let mut h = 0x1234_5678u32;
        let mut next = || {
            h = crate::sampling::mix(h.wrapping_add(0x9e37_79b9));
            h
        };
        for round in 0..4000 {
            let a: [u32; 16] = std::array::from_fn(|_| next());
            let v = u32x16::from(a);
            let r = words(v.reverse());
            for k in 0..16 {
                assert_eq!(r[k], a[k].reverse_bits());
            }
            // Divisors of every size the patterns use, dividends below 2²⁴.
            let d = 1 + next() % if round % 2 == 0 { 70 } else { 1 << 20 };
            let small = lanes(|k| a[k] >> 8);
            let (q, m) = small.div_rem(d);
            let (q, m) = (words(q), words(m));
            for k in 0..16 {
                assert_eq!((q[k], m[k]), ((a[k] >> 8) / d, (a[k] >> 8) % d), "{} / {d}", a[k] >> 8);
            }
            // add_rem over the whole range of p, including sums that wrap.
            let len = 1 + next() % if round % 3 == 0 { 7 } else { 5000 };
            let ps: [u32; 16] = std::array::from_fn(|_| if round % 5 == 0 { u32::MAX - next() % 8 } else { next() });
            let i = lanes(|k| a[k] % len);
            let got = words(i.add_rem(lanes(|k| ps[k]), lanes(|k| ps[k] % len), len));
            for k in 0..16 {
                let p = ps[k];
                assert_eq!(got[k], (a[k] % len).add_rem(p, p % len, len), "({} + {p}) % {len}", a[k] % len);
            }
            let lt = words(v.lt(lanes(|k| a[(k + 1) % 16])));
            for k in 0..16 {
                assert_eq!(lt[k], a[k].lt(a[(k + 1) % 16]));
            }
            let f = words(wide::bytemuck::cast(small.real().to_bits()));
            for k in 0..16 {
                assert_eq!(f[k], ((a[k] >> 8) as f32).to_bits());
            }
        }
    }
}
