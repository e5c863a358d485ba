//! The environment: radiance arriving from infinitely far along each direction that
//! escapes the scene. A constant (Mitsuba's `constant` emitter; wavetrace's background
//! colour) or a latitude-longitude map (Mitsuba's `envmap`, looked up exactly as Mitsuba
//! 3.9.1 does), turned by a rotation.
//!
//! Under the path transport it is a light: next-event estimation samples it, a constant
//! uniformly over the sphere, a map by a piecewise-constant density over its (u, v)
//! square proportional to luminance × sin θ (pbrt's `ImageInfiniteLight`), and rays that
//! escape are weighted against that density.

use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

use wide::f32x16;

use crate::color::luminance;
use crate::simd::{LANES, V3};

/// The environment: constant radiance, or a map scaled by `radiance`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Environment {
    /// The constant radiance, or the factor on the map's texels.
    pub radiance: Vec3,
    /// The map, if any.
    pub map: Option<LatLong>,
    /// World directions into the map's frame (the inverse of its rotation).
    pub to_local: Mat3,
    /// The map's frame into the world.
    pub to_world: Mat3,
}

/// A latitude-longitude map with its sampling distribution. Mitsuba's convention: a
/// direction d (in the map's frame) reads u = atan2(d.x, −d.z) / 2π, periodic, between
/// texel centres (i + ½) / width, and v = acos(d.y) / π with row j at v = j / (height − 1)
/// (the first row is the +y pole, the last the −y pole), bilinearly.
#[derive(Clone, PartialEq)]
pub struct LatLong {
    width: usize,
    height: usize,
    texels: Vec<Vec3>,
    /// Cumulative sums of the rows' weights, normalised; the last 1.
    rows: Vec<f32>,
    /// Per row, the cumulative sums of its cells' weights, normalised (width per row).
    cols: Vec<f32>,
    /// Each cell's density over the (u, v) square.
    density: Vec<f32>,
    /// Where [`find`] starts in `rows` for each of `height` equal slices of [0, 1]
    /// ([`guide`]).
    row_guide: Vec<u32>,
    /// The same for each row's slice of `cols`, `width` per row.
    col_guide: Vec<u32>,
}

impl std::fmt::Debug for LatLong {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // The texels' sum stands for them: a scene's digest changes with its map.
        let sum = self.texels.iter().fold(glam::DVec3::ZERO, |s, t| s + t.as_dvec3());
        write!(f, "LatLong({}x{}, sum {sum:?})", self.width, self.height)
    }
}

/// One direction drawn towards the environment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvSample {
    /// Unit direction, world.
    pub wi: Vec3,
    /// The radiance arriving along it.
    pub radiance: Vec3,
    /// Its density over solid angle.
    pub pdf: f32,
}

/// Directions drawn towards the environment for 16 lanes ([`Environment::sample_lanes`]).
#[derive(Clone, Copy, Debug)]
pub struct EnvLanes {
    /// Unit directions, world.
    pub wi: V3<f32x16>,
    /// The radiance arriving along them.
    pub radiance: V3<f32x16>,
    /// Their densities over solid angle.
    pub pdf: f32x16,
    /// Bit k: lane k has a sample.
    pub valid: u32,
}

impl Environment {
    /// A constant environment.
    pub fn constant(radiance: Vec3) -> Environment {
        Environment { radiance, map: None, to_local: Mat3::IDENTITY, to_world: Mat3::IDENTITY }
    }

    /// True when it emits nothing.
    pub fn is_black(&self) -> bool {
        self.radiance == Vec3::ZERO || self.map.as_ref().is_some_and(|m| m.rows.is_empty())
    }

    /// The radiance arriving along world direction `d` (unit): seen by a ray going along d.
    pub fn eval(&self, d: Vec3) -> Vec3 {
        match &self.map {
            None => self.radiance,
            Some(map) => self.radiance * map.eval(direction_to_uv(self.to_local * d)),
        }
    }

    /// A direction from the square sample `u`, with its radiance and density; `None` for a
    /// black environment or a zero-density draw. Lane 0 of [`Environment::sample_lanes`].
    pub fn sample(&self, u: Vec2) -> Option<EnvSample> {
        let s = self.sample_lanes([f32x16::splat(u.x), f32x16::splat(u.y)], 1);
        let at = |v: V3<f32x16>| Vec3::new(v.x.to_array()[0], v.y.to_array()[0], v.z.to_array()[0]);
        (s.valid & 1 != 0).then(|| EnvSample { wi: at(s.wi), radiance: at(s.radiance), pdf: s.pdf.to_array()[0] })
    }

    /// Directions from the first `count` of 16 square samples `u`, with their radiance and
    /// density: a cell of the map by its weight and a point uniformly inside it, found
    /// lane by lane, then turned into a direction on lanes (`wide`'s sine and cosine,
    /// within a few units in the last place of libm's); a constant uniformly over the
    /// sphere. Bit k of `valid` is set where lane k has a sample.
    pub fn sample_lanes(&self, u: [f32x16; 2], count: usize) -> EnvLanes {
        let zero = V3 { x: f32x16::ZERO, y: f32x16::ZERO, z: f32x16::ZERO };
        let none = EnvLanes { wi: zero, radiance: zero, pdf: f32x16::ZERO, valid: 0 };
        if self.is_black() || count == 0 {
            return none;
        }
        let all = if count >= LANES { !0 } else { (1u32 << count) - 1 };
        let Some(map) = &self.map else {
            let z = f32x16::ONE - f32x16::splat(2.0) * u[1];
            let r = (f32x16::ONE - z * z).max(f32x16::ZERO).sqrt();
            let (s, c) = (f32x16::splat(2.0 * PI) * u[0]).sin_cos();
            let wi = V3 { x: r * c, y: r * s, z };
            let pdf = f32x16::splat(0.25 * FRAC_1_PI);
            return EnvLanes { wi, radiance: V3::splat(self.radiance), pdf, valid: all };
        };
        let (ux, uy) = (u[0].to_array(), u[1].to_array());
        let (mut uv, mut density, mut texel) = ([[0.0f32; LANES]; 2], [0.0f32; LANES], [[0.0f32; LANES]; 3]);
        for k in 0..count.min(LANES) {
            let (p, d) = map.sample(Vec2::new(ux[k], uy[k]));
            // The map at the drawn point itself: what a ray along wi finds up to the
            // rounding of the round trip through the direction, without its arc tangents.
            let t = self.radiance * map.eval(p);
            (uv[0][k], uv[1][k], density[k]) = (p.x, p.y, d);
            (texel[0][k], texel[1][k], texel[2][k]) = (t.x, t.y, t.z);
        }
        let (sin_theta, cos_theta) = (f32x16::from(uv[1]) * f32x16::splat(PI)).sin_cos();
        let (sin_phi, cos_phi) = (f32x16::from(uv[0]) * f32x16::splat(2.0) * f32x16::splat(PI)).sin_cos();
        let local = V3 { x: sin_phi * sin_theta, y: cos_theta, z: -cos_phi * sin_theta };
        let (c0, c1, c2) = (self.to_world.x_axis, self.to_world.y_axis, self.to_world.z_axis);
        let column = |c: Vec3, s: f32x16| V3::splat(c).scale(s);
        let wi = (column(c0, local.x) + column(c1, local.y) + column(c2, local.z)).normalize();
        let density = f32x16::from(density);
        let valid = (density.simd_gt(f32x16::ZERO) & sin_theta.simd_gt(f32x16::ZERO)).to_bitmask() & all;
        let pdf = density / (f32x16::splat(2.0 * PI * PI) * sin_theta);
        let radiance = V3 { x: f32x16::from(texel[0]), y: f32x16::from(texel[1]), z: f32x16::from(texel[2]) };
        EnvLanes { wi, radiance, pdf, valid }
    }

    /// The density with which [`Environment::sample`] draws world direction `d` (unit).
    pub fn pdf(&self, d: Vec3) -> f32 {
        self.eval_pdf(d).1
    }

    /// [`Environment::eval`] and [`Environment::pdf`] of `d` together, the map's (u, v)
    /// found once (what a ray that escapes needs under multiple importance sampling).
    pub fn eval_pdf(&self, d: Vec3) -> (Vec3, f32) {
        let Some(map) = &self.map else {
            return (self.radiance, if self.is_black() { 0.0 } else { 0.25 * FRAC_1_PI });
        };
        let local = self.to_local * d;
        let uv = direction_to_uv(local);
        let radiance = self.radiance * map.eval(uv);
        let sin_theta = (local.x * local.x + local.z * local.z).sqrt();
        if self.is_black() || sin_theta <= 0.0 {
            return (radiance, 0.0);
        }
        (radiance, map.density_at(uv) / (2.0 * PI * PI * sin_theta))
    }

    /// [`Environment::eval_pdf`] of 16 world directions `d` (the first `count` looked up),
    /// the arc tangents on lanes (`wide`'s, within a few units in the last place of
    /// libm's), each map lookup lane by lane.
    pub fn eval_pdf_lanes(&self, d: V3<f32x16>, count: usize) -> (V3<f32x16>, f32x16) {
        let Some(map) = &self.map else {
            let pdf = if self.is_black() { 0.0 } else { 0.25 * FRAC_1_PI };
            return (V3::splat(self.radiance), f32x16::splat(pdf));
        };
        let (c0, c1, c2) = (self.to_local.x_axis, self.to_local.y_axis, self.to_local.z_axis);
        let local = V3::splat(c0).scale(d.x) + V3::splat(c1).scale(d.y) + V3::splat(c2).scale(d.z);
        let sin_theta = (local.x * local.x + local.z * local.z).sqrt();
        let u = f32x16::atan2(local.x, -local.z) * f32x16::splat(0.5 * FRAC_1_PI);
        let v = f32x16::atan2(sin_theta, local.y) * f32x16::splat(FRAC_1_PI);
        let (u, v) = (u.to_array(), v.to_array());
        let (mut texel, mut density) = ([[0.0f32; LANES]; 3], [0.0f32; LANES]);
        for k in 0..count.min(LANES) {
            let uv = Vec2::new(u[k], v[k]);
            let t = self.radiance * map.eval(uv);
            (texel[0][k], texel[1][k], texel[2][k], density[k]) = (t.x, t.y, t.z, map.density_at(uv));
        }
        let radiance = V3 { x: f32x16::from(texel[0]), y: f32x16::from(texel[1]), z: f32x16::from(texel[2]) };
        let pdf = f32x16::from(density) / (f32x16::splat(2.0 * PI * PI) * sin_theta);
        if self.is_black() {
            return (radiance, f32x16::ZERO);
        }
        (radiance, sin_theta.simd_gt(f32x16::ZERO).select(pdf, f32x16::ZERO))
    }
}

impl LatLong {
    /// The map of `width` × `height` linear RGB texels (row by row from the +y pole) and
    /// its sampling distribution; `None` when a side is 0 or the texel count is wrong.
    pub fn new(width: usize, height: usize, texels: Vec<Vec3>) -> Option<LatLong> {
        if width == 0 || height == 0 || texels.len() != width * height {
            return None;
        }
        let mut map = LatLong {
            width,
            height,
            texels,
            rows: vec![],
            cols: vec![0.0; width * height],
            density: vec![],
            row_guide: vec![],
            col_guide: vec![],
        };
        // A cell's weight: the largest luminance the bilinear lookup takes at its corners
        // and centre (so no cell that shows light has density 0), times sin θ at its
        // centre, the Jacobian of the (u, v) square onto the sphere.
        let mut weight = vec![0.0f64; width * height];
        for j in 0..height {
            let sin_theta = (PI * (j as f32 + 0.5) / height as f32).sin();
            for i in 0..width {
                let probe = |a: f32, b: f32| {
                    let uv = Vec2::new((i as f32 + a) / width as f32, (j as f32 + b) / height as f32);
                    luminance(map.eval(uv)).max(0.0)
                };
                let peak = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)]
                    .iter()
                    .map(|&(a, b)| probe(a, b))
                    .fold(0.0f32, f32::max);
                weight[j * width + i] = f64::from(peak * sin_theta);
            }
        }
        let total: f64 = weight.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            // Black (or unusable): nothing to sample.
            return Some(map);
        }
        let mut row_sum = 0.0;
        map.rows = (0..height)
            .map(|j| {
                let row = &weight[j * width..(j + 1) * width];
                let sum: f64 = row.iter().sum();
                let mut acc = 0.0;
                for (i, w) in row.iter().enumerate() {
                    acc += w;
                    map.cols[j * width + i] =
                        if sum > 0.0 { (acc / sum) as f32 } else { (i + 1) as f32 / width as f32 };
                }
                map.cols[j * width + width - 1] = 1.0;
                row_sum += sum;
                (row_sum / total) as f32
            })
            .collect();
        map.rows[height - 1] = 1.0;
        let cells = (width * height) as f64;
        map.density = weight.iter().map(|w| (w / total * cells) as f32).collect();
        map.row_guide = guide(&map.rows);
        map.col_guide = map.cols.chunks(width).flat_map(guide).collect();
        Some(map)
    }

    /// The texel value at `uv`, as Mitsuba's envmap: periodic in u between texel centres,
    /// rows at v = j / (height − 1), clamped at the poles, bilinear.
    fn eval(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width, self.height);
        let u = uv.x - uv.x.floor();
        let v = if uv.y.is_nan() { 0.0 } else { uv.y.clamp(0.0, 1.0) };
        let x = u * w as f32 - 0.5;
        let y = v * (h - 1) as f32;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        // x0 is at least −1 and x0 + 1 at most w (u < 1): one wrap each way at most.
        let col = |c: f32| {
            let c = c as isize;
            (if c < 0 {
                c + w as isize
            } else if c >= w as isize {
                c - w as isize
            } else {
                c
            }) as usize
        };
        let row = |r: f32| (r.max(0.0) as usize).min(h - 1);
        let at = |c: f32, r: f32| self.texels[row(r) * w + col(c)];
        let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1.0, y0) * fx;
        let bottom = at(x0, y0 + 1.0) * (1.0 - fx) + at(x0 + 1.0, y0 + 1.0) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// A point of the (u, v) square drawn from `s`: a row by its weight, a cell in it by
    /// its weight, uniformly inside the cell; and its density over the square.
    fn sample(&self, s: Vec2) -> (Vec2, f32) {
        let (w, h) = (self.width, self.height);
        let j = find(&self.rows, &self.row_guide, s.y).min(h - 1);
        let lo = if j == 0 { 0.0 } else { self.rows[j - 1] };
        let fy = ((s.y - lo) / (self.rows[j] - lo)).clamp(0.0, 1.0);
        let cols = &self.cols[j * w..(j + 1) * w];
        let i = find(cols, &self.col_guide[j * w..(j + 1) * w], s.x).min(w - 1);
        let lo = if i == 0 { 0.0 } else { cols[i - 1] };
        let fx = ((s.x - lo) / (cols[i] - lo)).clamp(0.0, 1.0);
        let fx = if fx.is_nan() { 0.5 } else { fx };
        let fy = if fy.is_nan() { 0.5 } else { fy };
        // Keep the point inside its cell: (i + fx) / w may round up to the next one.
        let uv = Vec2::new(((i as f32 + fx) / w as f32).min(next_below(i + 1, w)), {
            ((j as f32 + fy) / h as f32).min(next_below(j + 1, h))
        });
        (uv, self.density[j * w + i])
    }

    /// The density over the (u, v) square at `uv`.
    fn density_at(&self, uv: Vec2) -> f32 {
        if self.density.is_empty() {
            return 0.0;
        }
        let u = uv.x - uv.x.floor();
        let i = ((u * self.width as f32) as usize).min(self.width - 1);
        let j = ((uv.y.clamp(0.0, 1.0) * self.height as f32) as usize).min(self.height - 1);
        self.density[j * self.width + i]
    }
}

/// For each k of 0..n (n = `cdf.len()`), the first index of the non-decreasing `cdf`
/// whose value exceeds k / n: where [`find`] starts for a value in [k / n, (k + 1) / n).
fn guide(cdf: &[f32]) -> Vec<u32> {
    let n = cdf.len();
    let mut i = 0;
    (0..n)
        .map(|k| {
            let t = k as f32 / n as f32;
            while i < n && cdf[i] <= t {
                i += 1;
            }
            i as u32
        })
        .collect()
}

/// The first index of the non-decreasing `cdf` whose value exceeds `x`
/// (`partition_point(|c| c <= x)`, the same index for every x), found from its [`guide`]
/// entry in a step or two rather than by bisection. Either scan corrects a slice index
/// that rounding put one off.
fn find(cdf: &[f32], guide: &[u32], x: f32) -> usize {
    let n = cdf.len();
    if x.is_nan() {
        return 0;
    }
    let mut i = guide[((x * n as f32) as usize).min(n - 1)] as usize;
    while i > 0 && cdf[i - 1] > x {
        i -= 1;
    }
    while i < n && cdf[i] <= x {
        i += 1;
    }
    i
}

/// The largest f32 below k / n.
fn next_below(k: usize, n: usize) -> f32 {
    let x = k as f32 / n as f32;
    f32::from_bits(x.to_bits() - 1)
}

/// Mitsuba's `direction_to_uv` (d unit, in the map's frame), with θ from atan2 rather
/// than Mitsuba's acos(d.y), which loses digits near the poles (the same uv elsewhere).
fn direction_to_uv(d: Vec3) -> Vec2 {
    let sin_theta = (d.x * d.x + d.z * d.z).sqrt();
    Vec2::new(d.x.atan2(-d.z) * (0.5 * FRAC_1_PI), sin_theta.atan2(d.y) * FRAC_1_PI)
}

#[cfg(test)]
mod tests;
