//! Surface parameterisations as Mitsuba 3.9.1 defines them: the UV a texture is looked up
//! at, for spheres (`sphere.cpp`), rectangles (`rectangle.cpp`), triangles of a mesh
//! (barycentric interpolation of `vertex_texcoords`) and the `cube` (`cube.cpp`).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A sphere's UV at point p, as Mitsuba's sphere for an unrotated to_world (centre +
/// uniform scale): (φ/2π, θ/π) with Mitsuba's axes, the pole on +z. θ is the angle from +z
/// (v = 0 at the +z pole, 1 at the −z pole); φ = atan2(y, x) in [0, 2π), so u = 0 on +x
/// and u = 0.25 on +y. `p` need not lie exactly on the sphere: its direction from the
/// centre is used (Mitsuba too projects the hit point onto the sphere first).
pub fn sphere(center: Vec3, p: Vec3) -> Vec2 {
    let d = (p - center).normalize_or_zero();
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    Vec2::new(phi * (0.5 / PI), unit_angle_z(d) * (1.0 / PI))
}

/// The angle between unit `d` and +z, accurate near both poles (Dr.Jit's `unit_angle_z`).
fn unit_angle_z(d: Vec3) -> f32 {
    let t = 2.0 * (0.5 * Vec3::new(d.x, d.y, d.z - 1f32.copysign(d.z)).length()).min(1.0).asin();
    if d.z >= 0.0 {
        t
    } else {
        PI - t
    }
}

/// A parallelogram corner + a·u + b·v: (a, b). For Mitsuba's `rectangle` with `to_world`
/// M (its local square is [−1, 1]² at z = 0, and its uv is ((x + 1)/2, (y + 1)/2) of the
/// local point), this equals Mitsuba's uv when `corner` = M·(−1, −1, 0), `u` =
/// M·(1, −1, 0) − corner and `v` = M·(−1, 1, 0) − corner: u runs along the local +x edge,
/// v along the local +y edge. The edges need not be orthogonal; a point off the plane is
/// projected onto it (least squares). A degenerate parallelogram gives (0, 0).
pub fn quad(corner: Vec3, u: Vec3, v: Vec3, p: Vec3) -> Vec2 {
    coordinates(u, v, p - corner).unwrap_or(Vec2::ZERO)
}

/// The corner UVs of a primitive without its own: a triangle's barycentric coordinates
/// (b1, b2), a quad's (a, b), as Mitsuba gives a mesh without UVs.
pub const DEFAULT_UVS: [Vec2; 3] = [Vec2::ZERO, Vec2::X, Vec2::Y];

/// A triangle's UV at p by barycentric interpolation of its corners' UVs (as Mitsuba's
/// mesh: uv0·(1 − b1 − b2) + uv1·b1 + uv2·b2). A point off the triangle's plane is
/// projected onto it; a degenerate triangle gives its first corner's UV.
pub fn triangle(v: [Vec3; 3], uv: [Vec2; 3], p: Vec3) -> Vec2 {
    match coordinates(v[1] - v[0], v[2] - v[0], p - v[0]) {
        Some(b) => uv[0] * (1.0 - b.x - b.y) + uv[1] * b.x + uv[2] * b.y,
        None => uv[0],
    }
}

/// (a, b) minimising |a·e1 + b·e2 − d|, from the 2×2 normal equations (Cramer's rule);
/// `None` when e1 and e2 are parallel or zero.
fn coordinates(e1: Vec3, e2: Vec3, d: Vec3) -> Option<Vec2> {
    let (a11, a12, a22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (r1, r2) = (d.dot(e1), d.dot(e2));
    let det = a11 * a22 - a12 * a12;
    // Relative test: the Gram determinant is |e1 × e2|², of order a11·a22.
    if det.is_nan() || det <= 1e-12 * a11 * a22 {
        return None;
    }
    Some(Vec2::new((r1 * a22 - r2 * a12) / det, (r2 * a11 - r1 * a12) / det))
}

/// Mitsuba's `cube` as 12 triangles with its per-corner UVs (positions in [-1, 1]³, the
/// cube's local space; the importer transforms them), read from `cube.cpp`: 24 vertices,
/// four per face, each face's quad mapped onto [0, 1]², triangles wound counter-clockwise
/// seen from outside.
pub fn cube() -> Vec<([Vec3; 3], [Vec2; 3])> {
    const VERTICES: [[f32; 3]; 24] = [
        [1., -1., -1.],
        [1., -1., 1.],
        [-1., -1., 1.],
        [-1., -1., -1.],
        [1., 1., -1.],
        [-1., 1., -1.],
        [-1., 1., 1.],
        [1., 1., 1.],
        [1., -1., -1.],
        [1., 1., -1.],
        [1., 1., 1.],
        [1., -1., 1.],
        [1., -1., 1.],
        [1., 1., 1.],
        [-1., 1., 1.],
        [-1., -1., 1.],
        [-1., -1., 1.],
        [-1., 1., 1.],
        [-1., 1., -1.],
        [-1., -1., -1.],
        [1., 1., -1.],
        [1., -1., -1.],
        [-1., -1., -1.],
        [-1., 1., -1.],
    ];
    // The same four texture coordinates on every face, in vertex order.
    const FACE_UV: [[f32; 2]; 4] = [[0., 1.], [1., 1.], [1., 0.], [0., 0.]];
    const TRIANGLES: [[usize; 3]; 12] = [
        [0, 1, 2],
        [3, 0, 2],
        [4, 5, 6],
        [7, 4, 6],
        [8, 9, 10],
        [11, 8, 10],
        [12, 13, 14],
        [15, 12, 14],
        [16, 17, 18],
        [19, 16, 18],
        [20, 21, 22],
        [23, 20, 22],
    ];
    TRIANGLES
        .iter()
        .map(|t| (t.map(|i| Vec3::from_array(VERTICES[i])), t.map(|i| Vec2::from_array(FACE_UV[i % 4]))))
        .collect()
}
