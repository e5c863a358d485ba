//! Counter-based random numbers and stratified sample patterns.
//!
//! Every random number is a pure function of (seed, pixel, sample, dimension), so
//! queues carry no generator state and an image is bit-identical for any thread
//! count or tile order.

use glam::Vec2;

use crate::simd::{Real, Word, LANES};
use wide::u32x16;

mod progressive;
pub use progressive::{morton_levels, progressive_cell, progressive_order, Progressive};

/// Sample dimensions: each use of randomness gets its own, so streams never correlate.
pub mod dim {
    /// Position of a camera sample inside its pixel.
    pub const PIXEL: u32 = 1;
    /// Position of a camera sample on the lens.
    pub const LENS: u32 = 2;
    /// Position of a shadow sample on a quad light.
    pub const LIGHT: u32 = 3;
    /// The key that names a camera path (and, hashed again, its branches).
    pub const PATH: u32 = 4;
    /// Adaptive AA: paths through pixel corners.
    pub const CORNER: u32 = 5;
    /// Adaptive AA: paths through pixel centres.
    pub const CENTRE: u32 = 6;
    /// Adaptive AA: refinement sample positions.
    pub const REFINE: u32 = 7;
    /// Adaptive shadows: jittered probe positions on a quad light.
    pub const PROBE: u32 = 8;
    /// Penumbra early stopping: the scramble of the progressive order of a point's
    /// light samples.
    pub const STOP_ORDER: u32 = 9;
    /// Glossy surfaces: the microfacet normal sampled at a path's hit.
    pub const GLOSS: u32 = 10;
    /// Rough glass: the choice between the sampled normal's reflection and refraction.
    pub const GLOSS_BRANCH: u32 = 11;
    /// Rough surfaces under multiple importance sampling: the point sampled on a light.
    pub const GLOSS_LIGHT: u32 = 12;
    /// Rough surfaces under multiple importance sampling: the light chosen, when several.
    pub const GLOSS_LIGHT_PICK: u32 = 13;
    /// Motion blur: a camera path's time in the shutter.
    pub const TIME: u32 = 14;
    /// Path transport: the direction a diffuse surface scatters a path's ray in.
    pub const BOUNCE: u32 = 15;
    /// Path transport: Russian roulette's decision for a path's ray.
    pub const ROULETTE: u32 = 16;
    /// Path transport: a light sample's direction towards the environment.
    pub const ENVIRONMENT: u32 = 17;
    /// Variance-driven AA: a round's film positions.
    pub const VARIANCE: u32 = 18;
    /// Blue-noise dithering: the order of a 2×2 pixel block's pixels in its sequences.
    pub const DITHER: u32 = 19;
    /// `wavetrace bench`: bounce directions of the secondary ray set (far from the
    /// renderer's dimensions, which grow from 1).
    pub const BENCH: u32 = 100;
}

/// The power heuristic (β = 2) of multiple importance sampling: the weight of a sample
/// drawn with density `a` where another strategy has density `b` for it. 0 when `a` is 0
/// (the strategy cannot draw it); the two weights of a direction always sum to 1, and to
/// ½ each where both densities overflow.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    if a <= 0.0 || a.is_nan() {
        return 0.0;
    }
    let r = b / a;
    let w = 1.0 / (1.0 + r * r);
    if w.is_nan() {
        0.5
    } else {
        w
    }
}

/// A 32-bit integer hash with good avalanche (Wellons' "lowbias32"), on one word or on
/// lanes of them.
#[inline(always)]
pub fn mix<W: Word>(mut x: W) -> W {
    x = x ^ (x >> 16);
    x = x.wmul(W::splat(0x7feb_352d));
    x = x ^ (x >> 15);
    x = x.wmul(W::splat(0x846c_a68b));
    x = x ^ (x >> 16);
    x
}

/// The start of every [`hash`].
const HASH_START: u32 = 0x9e37_79b9;

/// One key folded into a hash state.
#[inline(always)]
fn hash_step<W: Word>(h: W, k: W) -> W {
    mix(h ^ k.wadd(W::splat(0x632b_e5ab)))
}

/// Hashes a list of counters into one well-mixed key.
#[inline]
pub fn hash(keys: &[u32]) -> u32 {
    keys.iter().fold(HASH_START, |h, &k| hash_step(h, k))
}

/// [`hash`] on lanes of keys.
#[inline(always)]
pub fn hash_lanes<W: Word, const N: usize>(keys: [W; N]) -> W {
    keys.into_iter().fold(W::splat(HASH_START), hash_step)
}

/// A float in [0, 1) from a hash value (24 bits of mantissa).
#[inline]
pub fn to_unit(h: u32) -> f32 {
    unit(h)
}

/// [`to_unit`] on lanes.
#[inline(always)]
fn unit<W: Word>(h: W) -> W::Real {
    (h >> 8).real() * W::Real::splat(1.0 / 16_777_216.0)
}

/// Kensler's hashed permutation of `i` within `0..len` ("Correlated Multi-Jittered
/// Sampling", Pixar 2013): a bijection chosen by `pattern`, computed without tables. On
/// lanes, each lane repeats the rounds until its value falls below `len`, as one word does.
#[inline(always)]
fn permute<W: Word>(i: W, len: u32, p: W, p_mod: W) -> W {
    let mut w = len.wrapping_sub(1);
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    let w = W::splat(w);
    let (len_w, mut i, mut done) = (W::splat(len), i, W::splat(0));
    loop {
        let mut j = i ^ p;
        j = j.wmul(W::splat(0xe170_893d));
        j = j ^ (p >> 16);
        j = j ^ ((j & w) >> 4);
        j = j ^ (p >> 8);
        j = j.wmul(W::splat(0x0929_eb3f));
        j = j ^ (p >> 23);
        j = j ^ ((j & w) >> 1);
        j = j.wmul(W::splat(1) | (p >> 27));
        j = j.wmul(W::splat(0x6935_fa69));
        j = j ^ ((j & w) >> 11);
        j = j.wmul(W::splat(0x74dc_b303));
        j = j ^ ((j & w) >> 2);
        j = j.wmul(W::splat(0x9e50_1cc3));
        j = j ^ ((j & w) >> 2);
        j = j.wmul(W::splat(0xc860_a3df));
        j = j & w;
        j = j ^ (j >> 5);
        i = W::select(done, i, j);
        done = done | i.lt(len_w);
        if W::all(done) {
            break;
        }
    }
    i.add_rem(p, p_mod, len)
}

/// Sample `s` of `n` of a correlated multi-jittered 2D pattern in [0,1)^2 (Kensler 2013).
///
/// The `n` samples of one pattern fall in distinct cells of an m×k grid (m = round(√n),
/// k = ⌈n/m⌉); when n = m·k they are also stratified in both 1D projections. Any n ≥ 1
/// is allowed, and every cell is equally likely to be used, so estimates stay unbiased.
pub fn cmj(s: u32, n: u32, pattern: u32) -> Vec2 {
    cmj_cell(s, n, pattern).0
}

/// The m×k grid of an `n`-sample CMJ pattern: m = round(√n) columns, k = ⌈n/m⌉ rows.
pub fn cmj_grid(n: u32) -> (u32, u32) {
    let m = ((n as f32).sqrt().round() as u32).max(1);
    (m, n.div_ceil(m))
}

/// [`cmj`]'s sample, and the grid cell it lies in (row-major index in the [`cmj_grid`]).
pub fn cmj_cell(s: u32, n: u32, pattern: u32) -> (Vec2, u32) {
    let (x, y, cell) = cmj_lanes(s, n, pattern);
    (Vec2::new(x, y), cell)
}

/// Largest sample count [`cmj_lanes`] takes on vector lanes (their division is exact
/// below 2²⁴).
pub const CMJ_LANES_MAX: u32 = 1 << 23;

/// [`cmj_cell`] for lanes of sample indices `s` (each below `n`): the x and y lanes and
/// the cells. On vector lanes `n` must be at most [`CMJ_LANES_MAX`].
#[inline(always)]
pub fn cmj_lanes<W: Word>(s: W, n: u32, pattern: u32) -> (W::Real, W::Real, W) {
    cmj_keyed(s, n, CmjKey::new(pattern, n).0.map(W::splat))
}

/// The words a CMJ pattern of `n` samples draws from its `pattern` seed, worked out once
/// per pattern, so that lanes can each hold a pattern of their own ([`cmj_keyed`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CmjKey(pub [u32; 8]);

impl CmjKey {
    /// The keys of 16 patterns for `n` samples ([`CmjKey::new`]), hashed on lanes.
    pub fn sixteen(pattern: u32x16, n: u32) -> [CmjKey; LANES] {
        let p = pattern.to_array();
        if n != 1 {
            return std::array::from_fn(|k| CmjKey::new(p[k], n));
        }
        let [a, b] = [1, 2].map(|w| hash_lanes([pattern, u32x16::splat(w)]).to_array());
        std::array::from_fn(|k| CmjKey([a[k], b[k], 0, 0, 0, 0, 0, 0]))
    }

    /// The key of `pattern` for `n` samples.
    pub fn new(pattern: u32, n: u32) -> CmjKey {
        if n == 1 {
            return CmjKey([hash(&[pattern, 1]), hash(&[pattern, 2]), 0, 0, 0, 0, 0, 0]);
        }
        let (m, k) = cmj_grid(n);
        let [a, b, c] = [0x5163_3e2d, 0x68bc_21eb, 0x02e5_be93u32].map(|f| pattern.wrapping_mul(f));
        let [jx, jy] = [0x967a_889b, 0x368c_c8b7u32].map(|f| pattern.wrapping_mul(f));
        CmjKey([a, a % (m * k).max(1), b, b % m, c, c % k.max(1), jx, jy])
    }
}

/// [`cmj_lanes`] with each lane's pattern given by its [`CmjKey`] words (`key[w]` holds
/// word w of every lane's key).
#[inline(always)]
pub fn cmj_keyed<W: Word>(s: W, n: u32, key: [W; 8]) -> (W::Real, W::Real, W) {
    if n == 1 {
        return (unit(key[0]), unit(key[1]), W::splat(0));
    }
    let (m, k) = cmj_grid(n);
    // Permute over all m·k cells, not just the first n: when n < m·k the n samples then
    // fill a random subset of the grid instead of always leaving the last row short,
    // which would bias every estimate.
    let s = permute(s, m * k, key[0], key[1]);
    let (row, col) = s.div_rem(m);
    let sx = permute(col, m, key[2], key[3]);
    let sy = permute(row, k, key[4], key[5]);
    let jx = unit(hash_lanes([s, key[6]]));
    let jy = unit(hash_lanes([s, key[7]]));
    let (mf, kf) = (W::Real::splat(m as f32), W::Real::splat(k as f32));
    let x = (col.real() + (sy.real() + jx) / kf) / mf;
    let y = (row.real() + (sx.real() + jy) / mf) / kf;
    // Rounding in the divisions can give exactly 1.0; keep the half-open interval.
    let one = W::Real::splat(ONE_MINUS_EPS);
    (x.min(one), y.min(one), s)
}

/// Laine and Karras's hash-based Owen scrambling of the bits of `x` from the low end:
/// bit b is flipped depending only on `seed` and the bits below b (Burley 2020).
#[inline]
fn laine_karras<W: Word>(mut x: W, seed: W) -> W {
    x = x.wadd(seed);
    x = x ^ x.wmul(W::splat(0x6c50_b47c));
    x = x ^ x.wmul(W::splat(0xb82f_1e52));
    x = x ^ x.wmul(W::splat(0xc7af_e638));
    x = x ^ x.wmul(W::splat(0x8d22_f6e6));
    x
}

/// Owen (nested uniform) scrambling of a binary fraction: each digit, from the most
/// significant, flipped depending on the digits before it. It maps every aligned block
/// of 2^k values onto an aligned block of 2^k values.
#[inline(always)]
fn owen_scramble<W: Word>(x: W, seed: W) -> W {
    laine_karras(x.reverse(), seed).reverse()
}

/// Point `i` of the first two dimensions of the Sobol sequence, as 32-bit binary
/// fractions: dimension 0 is the van der Corput sequence, dimension 1 has the direction
/// numbers v₁ = 2⁻¹, vₖ₊₁ = vₖ ⊕ (vₖ ≫ 1). Together a (0, 2)-sequence in base 2: every
/// aligned block of 2^k points has one point in each elementary interval of area 2^-k.
///
/// Direction number vₖ has fraction bit p set exactly when C(k, p) is odd, that is when
/// p's bits are a subset of k's (Lucas), so bit p of dimension 1 is the XOR of the index
/// bits k ⊇ p: a superset-XOR transform of the index, five shift-and-mask steps instead
/// of a loop over the index's 32 bits.
#[inline(always)]
fn sobol2<W: Word>(i: W) -> (W, W) {
    let mut w = i;
    w = w ^ ((w >> 1) & W::splat(0x5555_5555));
    w = w ^ ((w >> 2) & W::splat(0x3333_3333));
    w = w ^ ((w >> 4) & W::splat(0x0f0f_0f0f));
    w = w ^ ((w >> 8) & W::splat(0x00ff_00ff));
    w = w ^ ((w >> 16) & W::splat(0x0000_ffff));
    (i.reverse(), w.reverse())
}

/// Sample `index` of an Owen-scrambled 2D Sobol sequence keyed by `seed` (Burley 2020,
/// "Practical Hash-based Owen Scrambling"), in [0,1)². A pure function, like every
/// sample here. The index is Owen-scrambled too, which shuffles the order but keeps
/// aligned blocks aligned, so:
/// - the first N = 2^k indices (a pixel's whole budget) are a (0, k, 2)-net: one point in
///   every elementary interval of area 1/N, both 1D projections stratified;
/// - so is each aligned block of 2^j consecutive indices (one camera sample's 2^j shadow
///   rays, when shadow ray j of camera sample i is index i·2^j + j);
/// - each point alone is uniform over the square (the scrambling is random), so every
///   estimate stays unbiased, whatever the index.
pub fn sobol_owen(index: u32, seed: u32) -> Vec2 {
    let (x, y) = sobol_owen_lanes(index, seed);
    Vec2::new(x, y)
}

/// Blue-noise dithering (Ahmed and Wonka 2020, "Screen-space blue-noise diffusion of
/// Monte Carlo sampling error via hierarchical ordering of pixels", its first level):
/// the four pixels of the 2×2 block holding pixel (`x`, `y`) of an image `width` wide
/// share one set of sequences, keyed by the block, and the pixel takes the `rank`-th
/// run of `n` consecutive indices of each. Returns (the block's number, which replaces
/// the pixel's in its keys, and the pixel's first index `rank · n`); `rank` is the
/// pixel's place in the block (x bit, y bit) Owen-scrambled by the block. Four aligned
/// runs of a (0, 2)-sequence's points make one stratified set, so the block's pixels
/// estimate from complementary points: their errors are negatively correlated, which
/// moves noise to the highest frequencies without changing any pixel's own
/// distribution (each run alone is as stratified as a pixel's own sequence).
pub fn dither(seed: u32, width: u32, x: u32, y: u32, n: u32) -> (u32, u32) {
    dither_lanes(seed, width, x, y, n)
}

/// [`dither`] on lanes of pixels.
#[inline(always)]
pub fn dither_lanes<W: Word>(seed: u32, width: u32, x: W, y: W, n: u32) -> (W, W) {
    let block = (y >> 1).wmul(W::splat(width.div_ceil(2))).wadd(x >> 1);
    let one = W::splat(1);
    let place = (x & one) | (y & one) << 1;
    let rank = owen_scramble(place << 30, hash_lanes([W::splat(seed), block, W::splat(dim::DITHER)])) >> 30;
    (block, rank.wmul(W::splat(n)))
}

/// [`sobol_owen`] for lanes of indices and seeds: the x and y lanes.
#[inline(always)]
pub fn sobol_owen_lanes<W: Word>(index: W, seed: W) -> (W::Real, W::Real) {
    let (x, y) = sobol2(owen_scramble(index, mix(seed ^ W::splat(0x5bd1_e995))));
    let x = owen_scramble(x, mix(seed ^ W::splat(0x1b87_3593)));
    let y = owen_scramble(y, mix(seed ^ W::splat(0xcc9e_2d51)));
    let one = W::Real::splat(ONE_MINUS_EPS);
    (unit(x).min(one), unit(y).min(one))
}

/// The largest f32 below 1.
pub const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

/// Maps [0,1)^2 to the unit disk with Shirley's concentric mapping (area preserving,
/// so stratification survives).
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// A direction of the hemisphere about +z drawn with density cos θ / π from `u` in
/// [0,1)² (Malley's method: the concentric disk lifted onto the hemisphere).
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> glam::Vec3 {
    let d = concentric_disk(u);
    glam::Vec3::new(d.x, d.y, (1.0 - d.length_squared()).max(0.0).sqrt())
}

/// [`concentric_disk`] of 16 points `(x, y)` on lanes: the branches become lane selects,
/// and the sine and cosine are `wide`'s (within 2 units in the last place of the unit
/// disk of libm's, tested), so the points may differ from the scalar ones in their last
/// bits.
#[inline]
pub fn concentric_disk_lanes(x: wide::f32x16, y: wide::f32x16) -> (wide::f32x16, wide::f32x16) {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};
    use wide::f32x16;
    let (two, one) = (f32x16::splat(2.0), f32x16::splat(1.0));
    let (ox, oy) = (two * x - one, two * y - one);
    let wide_x = ox.abs().simd_gt(oy.abs());
    let r = wide_x.select(ox, oy);
    let quarter = f32x16::splat(FRAC_PI_4);
    let theta = wide_x.select(quarter * (oy / ox), f32x16::splat(FRAC_PI_2) - quarter * (ox / oy));
    let (sin, cos) = theta.sin_cos();
    let zero = ox.simd_eq(f32x16::ZERO) & oy.simd_eq(f32x16::ZERO);
    let disk = |v: f32x16| zero.select(f32x16::ZERO, r * v);
    (disk(cos), disk(sin))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in
            [(1.0f32, 1.0f32), (2.0, 0.5), (1e-30, 1e30), (3.0, 0.0), (f32::MAX, f32::MAX), (f32::INFINITY, 2.0)]
        {
            let (wa, wb) = (power_heuristic(a, b), power_heuristic(b, a));
            assert!((wa + wb - 1.0).abs() < 1e-6 && (0.0..=1.0).contains(&wa), "{a} {b}: {wa} + {wb}");
        }
        assert_eq!(power_heuristic(2.0, 1.0), 0.8);
        // A strategy that cannot draw the sample gets no weight.
        assert_eq!(power_heuristic(0.0, 1.0), 0.0);
        assert_eq!(power_heuristic(f32::NAN, 1.0), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, f32::INFINITY), 0.5);
    }

    #[test]
    fn concentric_disk_on_lanes_is_the_scalar_one_within_2_ulp() {
        use wide::f32x16;
        // The centre (mapped to 0 without a division), the diagonals (the branch's tie),
        // the edges, and a sweep of hashed points.
        let mut pts = vec![(0.5, 0.5), (0.0, 0.0), (1.0, 1.0), (0.25, 0.75), (0.75, 0.25), (0.5, 0.0), (0.0, 0.5)];
        pts.extend((0..4000u32).map(|i| (to_unit(hash(&[i, 1])), to_unit(hash(&[i, 2])))));
        for chunk in pts.chunks(16) {
            let n = chunk.len();
            let lane = |f: fn(&(f32, f32)) -> f32| f32x16::from(std::array::from_fn(|k| f(&chunk[k.min(n - 1)])));
            let (x, y) = concentric_disk_lanes(lane(|p| p.0), lane(|p| p.1));
            let (x, y) = (x.to_array(), y.to_array());
            for (k, &(u, v)) in chunk.iter().enumerate() {
                let want = concentric_disk(Vec2::new(u, v));
                // Units in the last place of 1, the disk's radius.
                let ulps = ((x[k] - want.x).abs().max((y[k] - want.y).abs())) / f32::EPSILON;
                assert!(ulps <= 2.0, "({u}, {v}): {ulps} ulp");
                if want == Vec2::ZERO {
                    assert_eq!((x[k], y[k]), (0.0, 0.0));
                }
            }
        }
    }

    #[test]
    fn lanes_give_the_scalar_bits() {
        use wide::u32x16;
        for n in [1u32, 2, 3, 5, 7, 16, 17, 64, 100, 1000, 4099] {
            for pattern in [0u32, 1, 0xdead_beef, u32::MAX, 0x8000_0000] {
                for first in (0..n).step_by(16) {
                    let s = u32x16::from(std::array::from_fn::<u32, 16, _>(|k| (first + k as u32).min(n - 1)));
                    let (x, y, cell) = cmj_lanes(s, n, pattern);
                    let (sobol_x, sobol_y) = sobol_owen_lanes(s, u32x16::splat(pattern));
                    for k in 0..16 {
                        let i = (first + k as u32).min(n - 1);
                        let (p, c) = cmj_cell(i, n, pattern);
                        assert_eq!(
                            (x.to_array()[k].to_bits(), y.to_array()[k].to_bits()),
                            (p.x.to_bits(), p.y.to_bits())
                        );
                        assert_eq!(cell.to_array()[k], c, "n {n} pattern {pattern} sample {i}");
                        let q = sobol_owen(i, pattern);
                        assert_eq!(
                            (sobol_x.to_array()[k].to_bits(), sobol_y.to_array()[k].to_bits()),
                            (q.x.to_bits(), q.y.to_bits())
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn permute_is_a_bijection() {
        for len in [1u32, 2, 3, 7, 16, 100] {
            let mut seen = vec![false; len as usize];
            for i in 0..len {
                let p = permute(i, len, 12345, 12345 % len) as usize;
                assert!(!seen[p], "len {len}: {p} twice");
                seen[p] = true;
            }
        }
    }

    #[test]
    fn cmj_is_stratified_in_each_axis() {
        for n in [4u32, 9, 16, 10, 64] {
            let mut xs = vec![0u32; n as usize];
            let mut ys = vec![0u32; n as usize];
            for s in 0..n {
                let p = cmj(s, n, 777);
                assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
                xs[(p.x * n as f32) as usize] += 1;
                ys[(p.y * n as f32) as usize] += 1;
            }
            // Perfect 1D stratification holds when n = m*k exactly.
            let m = ((n as f32).sqrt().round()) as u32;
            if n % m == 0 {
                assert!(xs.iter().all(|&c| c == 1), "n {n}: x strata {xs:?}");
                assert!(ys.iter().all(|&c| c == 1), "n {n}: y strata {ys:?}");
            }
        }
    }

    #[test]
    fn cmj_is_unbiased_when_n_is_not_a_grid() {
        // n = 8 uses 8 of 9 cells: averaged over patterns, every region gets its share.
        for n in [2u32, 8, 32, 128] {
            let mut lower = 0u32;
            let patterns = 2000;
            for p in 0..patterns {
                lower += (0..n).filter(|&s| cmj(s, n, mix(p)).y < 0.5).count() as u32;
            }
            let frac = lower as f64 / (n * patterns) as f64;
            assert!((frac - 0.5).abs() < 0.01, "n {n}: {frac} of samples in the lower half");
            let last_row = (0..patterns).map(|p| (0..n).filter(|&s| cmj(s, n, mix(p)).y > 0.9).count()).sum::<usize>();
            let expect = 0.1 * (n * patterns) as f64;
            assert!(
                (last_row as f64 - expect).abs() < 0.05 * expect,
                "n {n}: top tenth holds {last_row}, expected {expect}"
            );
        }
    }

    #[test]
    fn sobol_dimension_one_matches_its_direction_numbers() {
        // The textbook loop: XOR of direction numbers v₁ = 2⁻¹, vₖ₊₁ = vₖ ⊕ (vₖ ≫ 1).
        let reference = |i: u32| {
            let (mut y, mut v, mut bits) = (0u32, 1u32 << 31, i);
            while bits != 0 {
                if bits & 1 != 0 {
                    y ^= v;
                }
                bits >>= 1;
                v ^= v >> 1;
            }
            y
        };
        let mut x = 1u32;
        for i in (0..70_000).chain([u32::MAX, u32::MAX - 1, 1 << 31, 0xdead_beef]) {
            assert_eq!(sobol2(i).1, reference(i), "index {i}");
            x = mix(x);
            assert_eq!(sobol2(x).1, reference(x), "index {x}");
        }
    }

    /// Counts, for a 2^k-point set, the points in every elementary interval of area 2^-k
    /// (every split 2^a × 2^(k-a)); each must hold exactly one.
    fn assert_net(points: &[Vec2], k: u32, what: &str) {
        for a in 0..=k {
            let (cols, rows) = (1u32 << a, 1u32 << (k - a));
            let mut count = vec![0u32; 1 << k];
            for p in points {
                let (c, r) = ((p.x * cols as f32) as u32, (p.y * rows as f32) as u32);
                count[(r * cols + c) as usize] += 1;
            }
            assert!(count.iter().all(|&n| n == 1), "{what}: {cols}x{rows} intervals not stratified: {count:?}");
        }
    }

    #[test]
    fn sobol_owen_prefixes_and_aligned_blocks_are_nets() {
        for seed in [0u32, 1, 0xdead_beef, 12345] {
            for k in 0..=8 {
                let n = 1u32 << k;
                let prefix: Vec<Vec2> = (0..n).map(|i| sobol_owen(i, seed)).collect();
                assert_net(&prefix, k, &format!("seed {seed}, first {n}"));
                // Blocks of 2^j (one camera sample's shadow rays) inside a 2^k budget.
                for j in 0..=k.min(4) {
                    for b in 0..(n >> j) {
                        let block: Vec<Vec2> = (b << j..(b + 1) << j).map(|i| sobol_owen(i, seed)).collect();
                        assert_net(&block, j, &format!("seed {seed}, block {b} of {}", 1 << j));
                    }
                }
            }
        }
    }

    /// The four pixels of each 2×2 block share the block's number and take the four
    /// runs of its sequences, in an order that differs between blocks; an odd width's
    /// last column is a block of two.
    #[test]
    fn dithered_pixels_take_the_four_runs_of_their_block() {
        let (width, n) = (7u32, 12u32);
        let mut orders = std::collections::HashSet::new();
        for by in 0..4u32 {
            for bx in 0..4u32 {
                let pixels: Vec<(u32, u32)> =
                    [(0, 0), (1, 0), (0, 1), (1, 1)].iter().map(|&(dx, dy)| (2 * bx + dx, 2 * by + dy)).collect();
                let got: Vec<(u32, u32)> =
                    pixels.iter().filter(|p| p.0 < width).map(|&(x, y)| dither(5, width, x, y, n)).collect();
                assert!(got.iter().all(|g| g.0 == by * 4 + bx), "block numbers {got:?}");
                let mut firsts: Vec<u32> = got.iter().map(|g| g.1).collect();
                orders.insert(firsts.clone());
                firsts.sort_unstable();
                firsts.dedup();
                assert_eq!(firsts.len(), got.len(), "distinct runs {got:?}");
                assert!(firsts.iter().all(|f| f % n == 0 && *f < 4 * n), "runs of n {got:?}");
            }
        }
        assert!(orders.len() > 4, "blocks order their pixels differently: {orders:?}");
    }

    #[test]
    fn sobol_owen_is_a_pure_function_in_the_unit_square_and_seeds_differ() {
        for i in 0..4096 {
            let p = sobol_owen(i, 7);
            assert_eq!(p, sobol_owen(i, 7));
            assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y), "{p}");
        }
        let differ = (0..64).filter(|&i| sobol_owen(i, 1) != sobol_owen(i, 2)).count();
        assert!(differ > 60, "seeds must scramble differently ({differ} of 64 differ)");
        // The scrambled points are uniform: the mean of many is the square's centre.
        let mean = (0..1u32 << 14).map(|i| sobol_owen(i, 99)).sum::<Vec2>() / (1u32 << 14) as f32;
        assert!((mean - Vec2::splat(0.5)).abs().max_element() < 1e-3, "{mean}");
        // Across seeds, one index is uniform too (unbiased estimates for any index).
        let mean = (0..1u32 << 14).map(|s| sobol_owen(5, s)).sum::<Vec2>() / (1u32 << 14) as f32;
        assert!((mean - Vec2::splat(0.5)).abs().max_element() < 0.01, "{mean}");
    }

    #[test]
    fn cmj_cell_holds_the_sample() {
        for n in [1u32, 4, 10, 64, 128] {
            let (m, k) = cmj_grid(n);
            for s in 0..n {
                let (p, c) = cmj_cell(s, n, 99);
                assert_eq!(p, cmj(s, n, 99));
                assert_eq!(((p.x * m as f32) as u32, (p.y * k as f32) as u32), (c % m, c / m), "n {n} s {s}");
            }
        }
    }

    #[test]
    fn concentric_disk_stays_inside() {
        for s in 0..256 {
            let d = concentric_disk(cmj(s, 256, 3));
            assert!(d.length() <= 1.0 + 1e-6);
        }
    }
}
