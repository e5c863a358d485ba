//! Planar area lights, parallelograms and triangles (a `rectangle` or an emitting mesh's
//! triangles): one light sample on lanes, and the exact irradiance of a polygon light,
//! which the adaptive shadow test sends to the film for a lit point and the tests check
//! the samplers against.

use glam::Vec3;

use crate::sampling::sobol_owen_lanes;
use crate::simd::{Real, Word, V3};

/// A planar light's origin, edges and normal on lanes (a parallelogram's corner and edges,
/// or a triangle's first vertex and edges): one light on every lane, or a light per lane.
#[derive(Clone, Copy, Debug)]
pub struct QuadLanes<R> {
    /// Corner.
    pub corner: V3<R>,
    /// First edge.
    pub u: V3<R>,
    /// Second edge.
    pub v: V3<R>,
    /// Unit normal of the emitting side.
    pub normal: V3<R>,
}

impl<R: Real> QuadLanes<R> {
    /// The same light on every lane.
    #[inline(always)]
    pub fn splat(corner: Vec3, u: Vec3, v: Vec3, normal: Vec3) -> Self {
        QuadLanes { corner: V3::splat(corner), u: V3::splat(u), v: V3::splat(v), normal: V3::splat(normal) }
    }
}

/// One light sample of a quad, on lanes: what [`quad_sample`] computes.
#[derive(Clone, Copy, Debug)]
pub struct QuadSample<R> {
    /// The sample's position in [0,1)² over the quad.
    pub uv: (R, R),
    /// Unit direction from the shading point to the sample.
    pub wi: V3<R>,
    /// Distance to the sample.
    pub dist: R,
    /// Its square.
    pub dist2: R,
    /// Cosine at the shading point (n · wi).
    pub cos_x: R,
    /// Cosine at the light (−normal · wi).
    pub cos_y: R,
}

/// Sample `index` of the Owen-scrambled Sobol sequence `seed` on `quad`, seen from origin
/// `o` with normal `n`: the one formula behind every area-light sample, for one ray
/// ([`area_light_samples`]) and for 16 (the shade stage's lanes), with the same bits. A
/// `triangle` (the half of the parallelogram below its diagonal) folds the unit square
/// onto itself along the diagonal first; [`QuadSample::uv`] stays unfolded.
#[inline(always)]
pub fn quad_sample<W: Word>(
    quad: &QuadLanes<W::Real>,
    o: V3<W::Real>,
    n: V3<W::Real>,
    index: W,
    seed: W,
    triangle: bool,
) -> QuadSample<W::Real> {
    let uv = sobol_owen_lanes(index, seed);
    let (mut x, mut y) = uv;
    if triangle {
        // x + y > 1 exactly when 1 − (x + y) < 0 (the sign of a rounded difference is exact).
        let one = W::Real::splat(1.0);
        let over = one - (x + y);
        (x, y) = (W::Real::if_negative(over, one - x, x), W::Real::if_negative(over, one - y, y));
    }
    let to = quad.corner + quad.u.scale(x) + quad.v.scale(y) - o;
    let dist2 = to.dot(to);
    let dist = dist2.sqrt();
    let wi = to.over(dist);
    QuadSample { uv, wi, dist, dist2, cos_x: n.dot(wi), cos_y: -quad.normal.dot(wi) }
}

/// Irradiance at `o` (unit normal `n`) from a parallelogram of unit radiance with
/// corners `c, c+u, c+u+v, c+v`: [`polygon_irradiance`] of its four corners.
pub fn quad_irradiance(o: Vec3, n: Vec3, c: Vec3, u: Vec3, v: Vec3) -> f32 {
    polygon_irradiance(o, n, &[c, c + u, c + u + v, c + v])
}

/// Irradiance at `o` (unit normal `n`) from a planar convex polygon of unit radiance with
/// 3 or 4 vertices `verts` (in order around it), by Lambert's polygon formula
/// E = ½ Σ θ_k (n · γ_k), with the polygon first clipped to the hemisphere above `o`.
/// Angles come from an arctangent ([`edge_angle`]), which keeps its precision for small,
/// distant lights.
pub fn polygon_irradiance(o: Vec3, n: Vec3, verts: &[Vec3]) -> f32 {
    debug_assert!((3..=4).contains(&verts.len()));
    let mut rel = [Vec3::ZERO; 4];
    for (r, &p) in rel.iter_mut().zip(verts) {
        *r = p - o;
    }
    let m = verts.len();
    // Sutherland–Hodgman against the tangent plane: at most m + 1 vertices remain.
    let mut poly = [V3::splat(Vec3::ZERO); 5];
    let mut len = 0;
    for k in 0..m {
        let (a, b) = (rel[k], rel[(k + 1) % m]);
        let (da, db) = (n.dot(a), n.dot(b));
        if da > 0.0 {
            poly[len] = V3::from_vec(a);
            len += 1;
        }
        if (da > 0.0) != (db > 0.0) {
            poly[len] = V3::from_vec(a + (b - a) * (da / (da - db)));
            len += 1;
        }
    }
    unclipped_irradiance(V3::from_vec(n), &poly[..len])
}

/// [`polygon_irradiance`] of a polygon whose vertices, relative to the point (`rel`, in
/// order around it), all lie above the point's tangent plane (normal `n`): Lambert's
/// sum without the clipping, the same operations on lanes as in scalar code.
#[inline(always)]
pub fn unclipped_irradiance<R: Real>(n: V3<R>, rel: &[V3<R>]) -> R {
    let (m, zero) = (rel.len(), R::splat(0.0));
    let mut sum = zero;
    for k in 0..m {
        let (a, b) = (rel[k].normalize(), rel[(k + 1) % m].normalize());
        let cross = a.cross(b);
        let sin = cross.dot(cross).sqrt();
        // An edge seen end on (sin 0) adds nothing.
        sum = sum + R::if_negative(-sin, edge_angle(sin, a.dot(b)) * n.dot(cross.over(sin)), zero);
    }
    R::splat(0.5) * sum.abs()
}

/// atan2(`sin`, `cos`) for `sin` > 0: the angle in (0, π) whose sine and cosine are
/// proportional to them. Agner Fog's single-precision arctangent (the vector class
/// library's `atan2`, as `wide` has it, without fused multiply-adds): the octant's ratio
/// t ≤ 1, reduced to |z| ≤ √2 − 1 by atan t = π/4 + atan((t − 1)/(t + 1)), and a
/// cubic in z² beside z. The same operations on lanes and in scalar code; within 3
/// units in the last place of f64's `atan2` (2.76 at worst in `tests/stages.rs`),
/// relative to the angle however small.
#[inline(always)]
pub fn edge_angle<R: Real>(sin: R, cos: R) -> R {
    let (zero, one) = (R::splat(0.0), R::splat(1.0));
    let x = cos.abs();
    // Negative where the angle is past π/4 from the nearer axis: swap to keep t ≤ 1.
    let swap = x - sin;
    let t = R::if_negative(swap, x, sin) / R::if_negative(swap, sin, x);
    let near = t - R::splat(std::f32::consts::SQRT_2 - 1.0);
    let z = R::if_negative(near, t, t - one) / R::if_negative(near, one, t + one);
    let zz = z * z;
    let p = ((R::splat(0.080_537_446) * zz + R::splat(-0.138_776_85)) * zz + R::splat(0.199_777_11)) * zz
        + R::splat(-0.333_329_5);
    let a = p * (zz * z) + z + R::if_negative(near, zero, R::splat(std::f32::consts::FRAC_PI_4));
    let a = R::if_negative(swap, R::splat(std::f32::consts::FRAC_PI_2) - a, a);
    R::if_negative(cos, R::splat(std::f32::consts::PI) - a, a)
}
