//! `wavetrace bench --mesh` / `--sphere`: the issue-13 ray sets around a bare triangle
//! mesh (no scene file: the mesh alone, as Embree sees it), a generated displaced
//! icosphere to show how cost grows with triangle count, and the `.npy` export that
//! `benches/embree.py` traces with Embree on the same rays.
//!
//! The sets, all deterministic (a hash of the ray index, never a random state):
//! - `camera`: a pinhole camera looking at the mesh from outside its bounds, `side²`
//!   rays in 16×16 screen tiles (the renderer's coherent order), closest-hit;
//! - `shadow`: from every camera hit to a point on a quad light above the mesh, any-hit;
//! - `bounce`: one cosine-distributed diffuse bounce from every camera hit, closest-hit;
//! - `random`: a chord of the bounding sphere between two uniform points on it, closest-hit;
//! - `bounce-shadow`: from every bounce hit to the light, any-hit (incoherent shadows).

use glam::Vec3;
use std::io::Write;
use std::path::Path;

use super::bench::{any_hit_set, closest_set, cosine_direction, RaySet};
use crate::accel::offset::offset_ray_origin;
use crate::accel::tracer::Coherence;
use crate::accel::BvhQuality;
use crate::accel::{Accel, Primitive, Ray, Shape, Traversal, NO_LIGHT};
use crate::error::{Error, Result};
use crate::film::Tile;
use crate::sampling::{hash, to_unit};
use crate::stages::camera::block_slot;

/// The acceleration structure over a bare triangle list (one material, no lights), with
/// leaves of at most `max_leaf` primitives, built at `quality`.
pub fn mesh_accel(tris: Vec<[Vec3; 3]>, max_leaf: u32, quality: BvhQuality) -> Accel {
    Accel::build_with(
        tris.into_iter()
            .map(|[v0, v1, v2]| Primitive { shape: Shape::Triangle { v0, v1, v2 }, material: 0, light: NO_LIGHT })
            .collect(),
        max_leaf,
        quality,
    )
}

/// A closed unit icosphere subdivided `levels` times (20·4^levels triangles): the
/// vertices, shared exactly between neighbouring triangles, and the triangles as vertex
/// indices. [`displaced_sphere`] and the packet tests' closed mesh build on it.
pub fn icosphere(levels: u32) -> (Vec<Vec3>, Vec<[usize; 3]>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&p| Vec3::from(p).normalize())
    .collect();
    let mut faces: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::with_capacity(faces.len() * 4);
        for [a, b, c] in faces {
            let mut m = |i: usize, j: usize| {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    v.push(((v[i] + v[j]) * 0.5).normalize());
                    v.len() - 1
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    (v, faces)
}

/// A closed icosphere subdivided `levels` times (20·4^levels triangles; 8 gives
/// 1,310,720), its radius displaced by a few sines so the surface is not a sphere (boxes
/// then overlap as on a scanned mesh). Neighbouring triangles share vertices exactly.
pub fn displaced_sphere(levels: u32) -> Vec<[Vec3; 3]> {
    let (v, faces) = icosphere(levels);
    let bump = |p: Vec3| p * (1.0 + 0.08 * (7.0 * p.x).sin() * (5.0 * p.y).cos() + 0.03 * (23.0 * p.z).sin());
    let v: Vec<Vec3> = v.into_iter().map(bump).collect();
    faces.into_iter().map(|[a, b, c]| [v[a], v[b], v[c]]).collect()
}

/// A uniform value in [0, 1) for ray `i`, dimension `dim`.
fn u(i: usize, dim: u32) -> f32 {
    to_unit(hash(&[i as u32, dim, 0x6d65_7368]))
}

/// A uniform unit vector from two uniform values.
fn sphere_dir(u1: f32, u2: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Where a ray hit, lifted off the surface on the side it arrived from: (origin, normal).
fn hit_point(accel: &Accel, o: Vec3, d: Vec3, t: f32, prim: u32) -> (Vec3, Vec3) {
    let shape = accel.prim(prim).shape;
    let (x, err) = shape.surface_point(o, d, t);
    let ng = shape.normal(x).normalize();
    let n = if ng.dot(d) < 0.0 { ng } else { -ng };
    (offset_ray_origin(x, err, n), n)
}

/// The issue-13 ray sets around the mesh in `accel` with a `side × side` camera (see the
/// module docs).
pub fn mesh_ray_sets(accel: &Accel, side: usize) -> Vec<(&'static str, RaySet)> {
    let (lo, hi) = accel.bounds();
    let (c, diag) = ((lo + hi) * 0.5, (hi - lo).length().max(1e-3));
    let eye = c + Vec3::new(0.3, 0.4, 1.0).normalize() * diag * 1.2;
    let fwd = (c - eye).normalize();
    let right = fwd.cross(Vec3::Y).normalize();
    let up = right.cross(fwd);
    // The light: a square of side diag/2 above the mesh, facing down.
    let light = |i: usize, dim: u32| {
        Vec3::new(c.x + (u(i, dim) - 0.5) * diag * 0.5, hi.y + diag * 0.5, c.z + (u(i, dim + 1) - 0.5) * diag * 0.5)
    };
    let to_light = |i: usize, p: Vec3, dim: u32| {
        let q = light(i, dim);
        ((p, (q - p).normalize()), (q - p).length())
    };
    let mut camera = Vec::with_capacity(side * side);
    // The renderer's order: 16×16 tiles, each walked in 4×4 blocks (`camera::block_slot`).
    for ty in (0..side).step_by(16) {
        for tx in (0..side).step_by(16) {
            let tile =
                Tile { x0: tx as u32, y0: ty as u32, x1: (tx + 16).min(side) as u32, y1: (ty + 16).min(side) as u32 };
            let tw = tile.x1 - tile.x0;
            for q in 0..tw * (tile.y1 - tile.y0) {
                let slot = block_slot(&tile, q);
                let (x, y) = (tile.x0 + slot % tw, tile.y0 + slot / tw);
                let (sx, sy) = ((x as f32 + 0.5) / side as f32 - 0.5, 0.5 - (y as f32 + 0.5) / side as f32);
                camera.push((eye, (fwd + 0.8 * (sx * right + sy * up)).normalize()));
            }
        }
    }
    let mut c0 = Traversal::default();
    let (mut shadow, mut bounce, mut bounce_shadow) = (Vec::new(), Vec::new(), Vec::new());
    for (i, &(o, d)) in camera.iter().enumerate() {
        if let Some((t, prim)) = accel.closest::<false>(Ray::new(o, d, 0.0, f32::INFINITY), &mut c0) {
            let (p, n) = hit_point(accel, o, d, t, prim);
            shadow.push(to_light(i, p, 2));
            bounce.push((p, cosine_direction(n, u(i, 4), u(i, 5))));
        }
    }
    for (i, &(o, d)) in bounce.iter().enumerate() {
        if let Some((t, prim)) = accel.closest::<false>(Ray::new(o, d, 0.0, f32::INFINITY), &mut c0) {
            bounce_shadow.push(to_light(i, hit_point(accel, o, d, t, prim).0, 6));
        }
    }
    let r = diag * 0.5 * 1.01;
    let random: Vec<(Vec3, Vec3)> = (0..side * side)
        .map(|i| {
            let (a, b) = (c + r * sphere_dir(u(i, 8), u(i, 9)), c + r * sphere_dir(u(i, 10), u(i, 11)));
            (a, (b - a).normalize_or(Vec3::X))
        })
        .collect();
    let segments = |s: Vec<((Vec3, Vec3), f32)>| s.into_iter().map(|((o, d), t)| (o, d, t)).collect::<Vec<_>>();
    vec![
        ("camera", closest_set(&camera, Coherence::Camera)),
        ("shadow", any_hit_set(&segments(shadow))),
        ("bounce", closest_set(&bounce, Coherence::Bounce)),
        ("random", closest_set(&random, Coherence::Bounce)),
        ("bounce-shadow", any_hit_set(&segments(bounce_shadow))),
    ]
}

/// Writes a NumPy `.npy` file (format 1.0, little-endian) of `shape` from raw values.
/// (Three dtypes and one writer: not worth a dependency.)
fn write_npy(path: &Path, descr: &str, shape: &[usize], data: &[u8]) -> Result<()> {
    let dims: Vec<String> = shape.iter().map(|n| n.to_string()).collect();
    let dims = if dims.len() == 1 { format!("{},", dims[0]) } else { dims.join(", ") };
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': ({dims}), }}");
    // Magic (6) + version (2) + length (2) + header + '\n', padded to 64 bytes.
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let fail = |e: std::io::Error| Error::input(format!("{}: {e}", path.display()));
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).map_err(fail)?);
    f.write_all(b"\x93NUMPY\x01\x00").map_err(fail)?;
    f.write_all(&(header.len() as u16).to_le_bytes()).map_err(fail)?;
    f.write_all(header.as_bytes()).map_err(fail)?;
    f.write_all(data).map_err(fail)?;
    f.flush().map_err(fail)
}

/// f32 values as little-endian bytes.
fn f32_bytes(v: impl Iterator<Item = f32>) -> Vec<u8> {
    v.flat_map(f32::to_le_bytes).collect()
}

/// Exports the triangles (`triangles.npy`, n×3×3 f32, in the BVH's primitive order, so
/// primitive ids agree) and every set: `SET.origins.npy`, `SET.dirs.npy` (n×3 f32),
/// `SET.tmax.npy` (n f32; infinity for closest-hit sets), and the wide kernel's answers
/// (`SET.t.npy`: closest distance, infinity for a miss; `SET.prim.npy` i32, −1 for a miss;
/// or `SET.blocked.npy` u8). `sets.txt` lists `SET closest|anyhit` per line.
pub fn export(dir: &Path, accel: &Accel, sets: &[(&'static str, RaySet)]) -> Result<()> {
    let mut tris = Vec::with_capacity(accel.len() * 9);
    for p in accel.prims() {
        let Shape::Triangle { v0, v1, v2 } = p.shape else {
            return Err(Error::input("--export-rays: the scene has spheres or parallelograms; Embree gets triangles only (use --mesh or --sphere)"));
        };
        tris.extend([v0, v1, v2].iter().flat_map(|v| v.to_array()));
    }
    // Only now, so a refused scene leaves nothing behind.
    std::fs::create_dir_all(dir).map_err(|e| Error::input(format!("{}: {e}", dir.display())))?;
    write_npy(&dir.join("triangles.npy"), "<f4", &[accel.len(), 3, 3], &f32_bytes(tris.into_iter()))?;
    let mut list = String::new();
    let mut c = Traversal::default();
    for (name, set) in sets {
        let rays = set.rays();
        let n = rays.len();
        let file = |suffix: &str| dir.join(format!("{name}.{suffix}.npy"));
        write_npy(&file("origins"), "<f4", &[n, 3], &f32_bytes(rays.iter().flat_map(|r| r.0.to_array())))?;
        write_npy(&file("dirs"), "<f4", &[n, 3], &f32_bytes(rays.iter().flat_map(|r| r.1.to_array())))?;
        write_npy(&file("tmax"), "<f4", &[n], &f32_bytes(rays.iter().map(|r| r.2)))?;
        if let RaySet::AnyHit(_) = set {
            let blocked: Vec<u8> =
                rays.iter().map(|&(o, d, t)| accel.occluded::<false>(Ray::new(o, d, 0.0, t), &mut c) as u8).collect();
            write_npy(&file("blocked"), "|u1", &[n], &blocked)?;
            list += &format!("{name} anyhit\n");
        } else {
            let hits: Vec<(f32, i32)> = rays
                .iter()
                .map(|&(o, d, _)| {
                    accel
                        .closest::<false>(Ray::new(o, d, 0.0, f32::INFINITY), &mut c)
                        .map_or((f32::INFINITY, -1), |(t, p)| (t, p as i32))
                })
                .collect();
            write_npy(&file("t"), "<f4", &[n], &f32_bytes(hits.iter().map(|h| h.0)))?;
            let prims: Vec<u8> = hits.iter().flat_map(|h| h.1.to_le_bytes()).collect();
            write_npy(&file("prim"), "<i4", &[n], &prims)?;
            list += &format!("{name} closest\n");
        }
    }
    std::fs::write(dir.join("sets.txt"), list).map_err(|e| Error::input(format!("{}: {e}", dir.display())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_padded_and_parsable() {
        let dir = std::env::temp_dir().join(format!("wavetrace-npy-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.npy");
        write_npy(&path, "<f4", &[2, 3], &f32_bytes((0..6).map(|i| i as f32))).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((10 + len) % 64, 0);
        let header = std::str::from_utf8(&bytes[10..10 + len]).unwrap();
        assert!(header.contains("'shape': (2, 3)") && header.ends_with('\n'), "{header}");
        assert_eq!(bytes.len(), 10 + len + 24);
        assert_eq!(f32::from_le_bytes(bytes[bytes.len() - 4..].try_into().unwrap()), 5.0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn generated_sphere_is_closed_and_sized() {
        let tris = displaced_sphere(2);
        assert_eq!(tris.len(), 20 * 16);
        let accel = mesh_accel(tris, crate::accel::MAX_LEAF, BvhQuality::High);
        let mut c = Traversal::default();
        for i in 0..2000 {
            let d = sphere_dir(u(i, 0), u(i, 1));
            assert!(
                accel.closest::<false>(Ray::new(Vec3::ZERO, d, 0.0, f32::INFINITY), &mut c).is_some(),
                "ray {i} escaped"
            );
        }
    }
}
