//! Texture tests: lookups on tiny images written into a temporary directory, and the
//! parameterisations, against values read from Mitsuba 3.9.1 (`scalar_rgb`) in Python.

// Mitsuba's numbers are pasted as Python printed them (f64 digits of f32 values), so
// that they can be checked against the Python output.
#![allow(clippy::excessive_precision)]

use super::*;
use glam::{Affine2, Vec2, Vec3};
use image::{ImageBuffer, Luma, LumaA, Rgb, Rgba};
use std::path::{Path, PathBuf};

/// Writes an 8-bit RGB PNG of `w`×`h` texels from rows of (r, g, b).
fn png(dir: &Path, name: &str, w: u32, h: u32, px: &[[u8; 3]]) -> PathBuf {
    let path = dir.join(name);
    let data: Vec<u8> = px.iter().flatten().copied().collect();
    ImageBuffer::<Rgb<u8>, _>::from_raw(w, h, data).unwrap().save(&path).unwrap();
    path
}

/// The 4×3 test image: texel (i, j) (column, row from the top) is
/// (10 + 60i, 20 + 100j, 7).
fn grid(dir: &Path) -> PathBuf {
    let px: Vec<[u8; 3]> =
        (0..3).flat_map(|j| (0..4).map(move |i| [10 + 60 * i as u8, 20 + 100 * j as u8, 7])).collect();
    png(dir, "grid.png", 4, 3, &px)
}

fn load(path: &Path, raw: bool, wrap: Wrap, filter: Filter) -> Bitmap {
    Bitmap::load(path, raw, wrap, filter).unwrap()
}

/// An 8-bit value as read raw.
fn raw8(c: [f32; 3]) -> Vec3 {
    Vec3::from_array(c) / 255.0
}

#[track_caller]
fn close(a: Vec3, b: Vec3, tol: f32) {
    assert!((a - b).abs().max_element() <= tol * b.abs().max_element().max(1e-3), "{a} vs {b}");
}

#[test]
fn v0_is_the_top_row_and_nearest_picks_the_containing_texel() {
    let dir = tempfile::tempdir().unwrap();
    let b = load(&grid(dir.path()), true, Wrap::Repeat, Filter::Nearest);
    assert_eq!((b.width, b.height), (4, 3));
    // Mitsuba: nearest, raw, (0.1, 0.1) -> (10, 20, 7)/255 (the first row's first texel),
    // (0.1, 0.9) -> (10, 220, 7), (0.9, 0.1) -> (190, 20, 7).
    close(b.lookup(Vec2::new(0.1, 0.1)), raw8([10., 20., 7.]), 1e-6);
    close(b.lookup(Vec2::new(0.1, 0.9)), raw8([10., 220., 7.]), 1e-6);
    close(b.lookup(Vec2::new(0.9, 0.1)), raw8([190., 20., 7.]), 1e-6);
    // The texel edge at u = 0.25 belongs to the texel on its right.
    close(b.lookup(Vec2::new(0.25, 0.1)), raw8([70., 20., 7.]), 1e-6);
}

#[test]
fn bilinear_weights_between_texel_centres() {
    let dir = tempfile::tempdir().unwrap();
    let b = load(&grid(dir.path()), true, Wrap::Repeat, Filter::Bilinear);
    // By hand: u = 0.25 is halfway between the centres of columns 0 and 1 (10, 70 -> 40);
    // v = 0.5 is row 1's centre (120). Mitsuba gives the same.
    close(b.lookup(Vec2::new(0.25, 0.5)), raw8([40., 120., 7.]), 1e-6);
    // u = 0.3: x = 0.7 -> 10 + 0.7·60 = 52; v = 0.4: y = 0.7 -> 20 + 0.7·100 = 90.
    close(b.lookup(Vec2::new(0.3, 0.4)), raw8([52., 90., 7.]), 1e-6);
    // A texel centre is the texel itself.
    close(b.lookup(Vec2::new(0.625, 5.0 / 6.0)), raw8([130., 220., 7.]), 1e-6);
}

#[test]
fn srgb_is_decoded_per_texel_before_interpolation_unless_raw() {
    let dir = tempfile::tempdir().unwrap();
    let path = grid(dir.path());
    let b = load(&path, false, Wrap::Repeat, Filter::Bilinear);
    // Mitsuba 3.9.1, raw = false, (0.25, 0.5): the mean of the decoded texels, not the
    // decoded mean (which would be 0.0212 for red).
    let mitsuba = Vec3::new(0.032140668481588364, 0.18782076239585876, 0.0021246890537440777);
    close(b.lookup(Vec2::new(0.25, 0.5)), mitsuba, 1e-5);
    let raw = load(&path, true, Wrap::Repeat, Filter::Bilinear);
    assert!(raw.lookup(Vec2::new(0.25, 0.5)).x > 0.15);
}

#[test]
fn wrap_modes_with_nearest() {
    let dir = tempfile::tempdir().unwrap();
    let path = grid(dir.path());
    let us = [-1.1, -0.9, -0.3, -0.1, 1.1, 1.3, 1.9, 2.1];
    // Mitsuba's red at (u, 0.5), nearest, raw; by hand for repeat: u = -0.1 -> x = -0.4
    // -> texel -1 -> 3 (190); mirror: -1 -> 0 (10); clamp: 0 (10).
    let expect = [
        (Wrap::Repeat, [190., 10., 130., 190., 10., 70., 190., 10.]),
        (Wrap::Mirror, [190., 190., 70., 10., 190., 130., 10., 10.]),
        (Wrap::Clamp, [10., 10., 10., 10., 190., 190., 190., 190.]),
    ];
    for (wrap, reds) in expect {
        let b = load(&path, true, wrap, Filter::Nearest);
        for (u, red) in us.iter().zip(reds) {
            let got = b.lookup(Vec2::new(*u, 0.5)).x * 255.0;
            assert!((got - red).abs() < 1e-3, "{wrap:?} u = {u}: {got} instead of {red}");
        }
    }
}

#[test]
fn wrap_modes_with_bilinear() {
    let dir = tempfile::tempdir().unwrap();
    let path = grid(dir.path());
    let uvs = [Vec2::new(-0.05, 0.1), Vec2::new(1.05, 0.95), Vec2::new(2.3, -0.7)];
    // Mitsuba 3.9.1, raw, ×255.
    let expect = [
        (Wrap::Repeat, [[136., 60., 7.], [64., 150., 7.], [52., 60., 7.]]),
        (Wrap::Mirror, [[10., 20., 7.], [190., 220., 7.], [52., 180., 7.]]),
        (Wrap::Clamp, [[10., 20., 7.], [190., 220., 7.], [190., 20., 7.]]),
    ];
    for (wrap, values) in expect {
        let b = load(&path, true, wrap, Filter::Bilinear);
        for (uv, v) in uvs.iter().zip(values) {
            close(b.lookup(*uv), raw8(v), 1e-5);
        }
    }
}

#[test]
fn one_texel_and_one_wide_images() {
    let dir = tempfile::tempdir().unwrap();
    let one = png(dir.path(), "one.png", 1, 1, &[[100, 50, 25]]);
    let col = png(dir.path(), "col.png", 1, 3, &[[10, 0, 0], [70, 0, 0], [130, 0, 0]]);
    let row = png(dir.path(), "row.png", 3, 1, &[[10, 0, 0], [70, 0, 0], [130, 0, 0]]);
    let uvs = [(0.1, 0.1), (0.5, 0.5), (0.9, 0.3), (0.3, 0.9), (-0.2, 1.2)].map(|(u, v)| Vec2::new(u, v));
    // Mitsuba 3.9.1 (bilinear, raw; it pads images below 2×2 by repeating the last row
    // or column, which changes no lookup): red ×255 at `uvs`.
    let expect = [
        (&col, Wrap::Repeat, [34., 70., 34., 106., 16.]),
        (&col, Wrap::Mirror, [10., 70., 34., 130., 124.]),
        (&col, Wrap::Clamp, [10., 70., 34., 130., 130.]),
        (&row, Wrap::Repeat, [34., 70., 106., 34., 124.]),
        (&row, Wrap::Mirror, [10., 70., 130., 34., 16.]),
        (&row, Wrap::Clamp, [10., 70., 130., 34., 10.]),
    ];
    for (path, wrap, reds) in expect {
        let b = load(path, true, wrap, Filter::Bilinear);
        for (uv, red) in uvs.iter().zip(reds) {
            let got = b.lookup(*uv).x * 255.0;
            assert!((got - red).abs() < 1e-3, "{path:?} {wrap:?} {uv}: {got} instead of {red}");
        }
    }
    for wrap in [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp] {
        for filter in [Filter::Bilinear, Filter::Nearest] {
            let b = load(&one, true, wrap, filter);
            for uv in uvs {
                close(b.lookup(uv), raw8([100., 50., 25.]), 1e-6);
            }
        }
    }
}

#[test]
fn lookups_far_outside_or_nan_stay_among_the_texels() {
    let dir = tempfile::tempdir().unwrap();
    let path = grid(dir.path());
    for wrap in [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp] {
        for filter in [Filter::Bilinear, Filter::Nearest] {
            let b = load(&path, true, wrap, filter);
            let (lo, hi) = b.texels.iter().fold((Vec3::MAX, Vec3::MIN), |(l, h), t| (l.min(*t), h.max(*t)));
            for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -1e30, f32::MAX, 3e9] {
                for v in [b.lookup(Vec2::new(x, 0.5)), b.lookup(Vec2::new(0.5, x)), b.lookup(Vec2::new(x, -x))] {
                    // A blend of texels: inside their range (up to rounding).
                    let inside = v.cmpge(lo - 1e-6).all() && v.cmple(hi + 1e-6).all();
                    assert!(inside, "{wrap:?} {filter:?} at {x}: {v} outside [{lo}, {hi}]");
                }
            }
        }
    }
}

#[test]
fn grey_alpha_and_16_bit_images() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let grey = d.join("grey.png");
    ImageBuffer::<Luma<u8>, _>::from_raw(2, 1, vec![60, 200]).unwrap().save(&grey).unwrap();
    let grey_alpha = d.join("greya.png");
    ImageBuffer::<LumaA<u8>, _>::from_raw(2, 1, vec![60, 9, 200, 255]).unwrap().save(&grey_alpha).unwrap();
    let rgba = d.join("rgba.png");
    ImageBuffer::<Rgba<u8>, _>::from_raw(2, 1, vec![60, 9, 3, 0, 200, 255, 4, 10]).unwrap().save(&rgba).unwrap();
    // Mitsuba 3.9.1, nearest at (0.1, 0.5) and (0.9, 0.5), ×255: alpha neither kept nor
    // multiplied in.
    let expect = [
        (&grey, true, [[60.; 3], [200.; 3]]),
        (&grey, false, [[11.5225; 3], [147.2831; 3]]),
        (&grey_alpha, true, [[60.; 3], [200.; 3]]),
        (&grey_alpha, false, [[11.5225; 3], [147.2831; 3]]),
        (&rgba, true, [[60., 9., 3.], [200., 255., 4.]]),
        (&rgba, false, [[11.5225, 0.6966, 0.2322], [147.2831, 255., 0.3096]]),
    ];
    for (path, raw, [left, right]) in expect {
        let b = load(path, raw, Wrap::Repeat, Filter::Nearest);
        close(b.lookup(Vec2::new(0.1, 0.5)), raw8(left), 1e-4);
        close(b.lookup(Vec2::new(0.9, 0.5)), raw8(right), 1e-4);
    }
    let deep = d.join("rgb16.png");
    ImageBuffer::<Rgb<u16>, _>::from_raw(2, 1, vec![1000, 30000, 65535, 0, 200, 40000]).unwrap().save(&deep).unwrap();
    // Mitsuba stores 16-bit texels as half floats; these keep f32 precision, so they
    // agree with its values to half precision.
    let raw = load(&deep, true, Wrap::Repeat, Filter::Nearest).lookup(Vec2::new(0.1, 0.5));
    close(raw, Vec3::new(1000.0, 30000.0, 65535.0) / 65535.0, 1e-6);
    close(raw, Vec3::new(0.0152587890625, 0.457763671875, 1.0), 1e-3);
    let srgb = load(&deep, false, Wrap::Repeat, Filter::Nearest).lookup(Vec2::new(0.1, 0.5));
    close(srgb, Vec3::new(0.0011806488037109375, 0.177001953125, 1.0), 1e-3);
}

#[cfg(feature = "exr")]
#[test]
fn exr_is_read_linear() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.exr");
    exr::prelude::write_rgb_file(&path, 2, 1, |x, _| if x == 0 { (0.25f32, 2.5f32, 0.0f32) } else { (1.0, 0.5, 8.0) })
        .unwrap();
    // `raw` changes nothing for EXR.
    for raw in [false, true] {
        let b = load(&path, raw, Wrap::Clamp, Filter::Bilinear);
        assert_eq!((b.width, b.height), (2, 1));
        assert_eq!(b.texels, vec![Vec3::new(0.25, 2.5, 0.0), Vec3::new(1.0, 0.5, 8.0)]);
        close(b.lookup(Vec2::new(0.5, 0.5)), Vec3::new(0.625, 1.5, 4.0), 1e-6);
    }
}

/// The CRC-32 a PNG chunk ends with (over its type and data).
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

#[test]
fn bad_files_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = std::fs::read(grid(d)).unwrap();
    let err = |path: &Path| Bitmap::load(path, false, Wrap::Repeat, Filter::Bilinear).unwrap_err();
    assert!(err(&d.join("missing.png")).contains("cannot open"));
    assert!(err(d).contains("not a regular file"));
    let write = |name: &str, bytes: &[u8]| {
        let p = d.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    assert!(err(&write("text.png", b"not an image at all\n")).contains("not a PNG or EXR"));
    assert!(err(&write("empty.png", b"")).contains("not a PNG or EXR"));
    for cut in [8, 20, 33, good.len() / 2, good.len() - 13] {
        let e = err(&write("cut.png", &good[..cut]));
        assert!(e.contains("PNG"), "cut at {cut}: {e}");
    }
    let mut flipped = good.clone();
    let n = flipped.len();
    flipped[n - 20] ^= 0xff;
    err(&write("corrupt.png", &flipped));
    // A valid header claiming 65536×8192 texels (2^29): refused before decoding.
    let mut huge = good.clone();
    huge[16..20].copy_from_slice(&65536u32.to_be_bytes());
    huge[20..24].copy_from_slice(&8192u32.to_be_bytes());
    let crc = crc32(&huge[12..29]);
    huge[29..33].copy_from_slice(&crc.to_be_bytes());
    let e = err(&write("huge.png", &huge));
    assert!(e.contains("65536×8192") && e.contains("more than"), "{e}");
    #[cfg(feature = "exr")]
    assert!(err(&write("cut.exr", &[0x76, 0x2f, 0x31, 0x01, 2, 0, 0])).contains("EXR"));
}

#[test]
fn checkerboard_with_a_to_uv_scale() {
    let (c0, c1) = (Vec3::new(0.9, 0.1, 0.2), Vec3::new(0.05, 0.6, 0.3));
    let t = Texture::Checkerboard { color0: c0, color1: c1, to_uv: Affine2::from_scale(Vec2::new(3.0, 2.0)) };
    // Mitsuba 3.9.1 with to_uv = scale(3, 2, 1).
    let expect = [
        ((0.1, 0.1), c0),
        ((0.2, 0.1), c1),
        ((0.1, 0.3), c1),
        ((0.2, 0.3), c0),
        ((0.4, 0.9), c1),
        ((-0.1, 0.1), c1),
        ((-0.1, -0.1), c0),
        ((0.7, 0.6), c0),
    ];
    for ((u, v), c) in expect {
        assert_eq!(t.eval(Vec2::new(u, v)), c, "({u}, {v})");
    }
    // The fraction 0.5 itself is in the lower half (`> 0.5` in checkerboard.cpp).
    let plain = Texture::Checkerboard { color0: c0, color1: c1, to_uv: Affine2::IDENTITY };
    assert_eq!(plain.eval(Vec2::new(0.5, 0.1)), c0);
    assert_eq!(plain.eval(Vec2::new(0.5001, 0.1)), c1);
}

#[test]
fn bitmap_texture_applies_to_uv_first() {
    let dir = tempfile::tempdir().unwrap();
    let bitmap = load(&grid(dir.path()), true, Wrap::Repeat, Filter::Nearest);
    // (0.3, 0.1) scaled by 3 is (0.9, 0.3): column 3, row 0.
    let t = Texture::Bitmap { bitmap, to_uv: Affine2::from_scale(Vec2::splat(3.0)) };
    close(t.eval(Vec2::new(0.3, 0.1)), raw8([190., 20., 7.]), 1e-6);
}

#[track_caller]
fn close2(a: Vec2, b: Vec2, tol: f32) {
    assert!((a - b).abs().max_element() <= tol, "{a} vs {b}");
}

#[test]
fn sphere_uv_matches_mitsuba() {
    // Mitsuba 3.9.1: `sphere` with center [1, 2, 3], radius 2; `si = s.ray_intersect(ray)`
    // for a few rays, si.p and si.uv printed.
    let c = Vec3::new(1.0, 2.0, 3.0);
    let hits = [
        ([1.0, 0.0, 3.0], [0.75, 0.5000000596046448]),
        ([3.0, 2.0, 3.0], [0.0, 0.5000000596046448]),
        ([1.0, 2.0, 5.0], [0.0, 0.0]),
        ([1.5185186862945557, 0.3703702688217163, 1.9629628658294678], [0.7990281581878662, 0.6735162734985352]),
        ([-0.6346838474273682, 3.1077466011047363, 3.3173420429229736], [0.4052121937274933, 0.4492790400981903]),
        ([1.7242858409881592, 1.0946426391601562, 1.3703564405441284], [0.8573883175849915, 0.8031652569770813]),
        ([1.2000000476837158, 2.299999952316284, 1.0327684879302979], [0.15641643106937408, 0.9423003792762756]),
    ];
    for (p, uv) in hits {
        close2(uv::sphere(c, Vec3::from_array(p)), Vec2::from_array(uv), 2e-6);
    }
}

#[test]
fn quad_uv_matches_mitsuba_rectangle() {
    // Mitsuba 3.9.1: `rectangle` with to_world = translate(1, 2, 3) · rotate(x, 30°) ·
    // scale(2, 3, 1); to_world applied to (-1, -1, 0), (1, -1, 0), (-1, 1, 0) gives the
    // corner and the edges; points from `eval_parameterization(uv)` and a ray hit.
    let corner = Vec3::new(-1.0, -0.5980761051177979, 1.5);
    let u = Vec3::new(3.0, -0.5980761051177979, 1.5) - corner;
    let v = Vec3::new(-1.0, 4.598075866699219, 4.5) - corner;
    let points = [
        ([-1.0, -0.5980761051177979, 1.5], [0.0, 0.0]),
        ([3.0, -0.5980761051177979, 1.5], [1.0, 0.0]),
        ([-1.0, 4.598075866699219, 4.5], [0.0, 1.0]),
        ([0.0, 3.2990379333496094, 3.75], [0.25, 0.75]),
        ([1.2999999523162842, 2.4999992847442627, 3.288674831390381], [0.574999988079071, 0.5962249636650085]),
    ];
    for (p, uv) in points {
        close2(uv::quad(corner, u, v, Vec3::from_array(p)), Vec2::from_array(uv), 2e-6);
    }
    // Skewed edges: still the affine coordinates.
    let (e1, e2) = (Vec3::new(2.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0));
    close2(uv::quad(Vec3::ZERO, e1, e2, 0.3 * e1 + 0.6 * e2), Vec2::new(0.3, 0.6), 1e-6);
    assert_eq!(uv::quad(Vec3::ZERO, e1, 2.0 * e1, Vec3::ONE), Vec2::ZERO);
}

#[test]
fn triangle_uv_matches_mitsuba_mesh() {
    // Mitsuba 3.9.1: an OBJ triangle (v 0.5 -1 2, 3 0.5 1.5, -0.5 2.5 0; vt 0.1 0.2,
    // 0.9 0.35, 0.3 0.95) in a scene, hit by rays along -z; `vertex_texcoords` (v flipped
    // by the OBJ loader) and si.p, si.uv printed.
    let v = [Vec3::new(0.5, -1.0, 2.0), Vec3::new(3.0, 0.5, 1.5), Vec3::new(-0.5, 2.5, 0.0)];
    let uv = [Vec2::new(0.1, 0.8), Vec2::new(0.9, 0.65), Vec2::new(0.3, 0.05)];
    let hits = [
        ([1.0, 0.4999999701976776, 1.2560975551605225], [0.4121951162815094, 0.5329268574714661]),
        ([0.6000000238418579, -0.30000004172325134, 1.6365853548049927], [0.21317073702812195, 0.6675609946250916]),
        ([1.499999761581421, 1.1999999284744263, 0.9414634704589844], [0.6229267716407776, 0.4239024519920349]),
    ];
    for (p, want) in hits {
        close2(uv::triangle(v, uv, Vec3::from_array(p)), Vec2::from_array(want), 2e-6);
    }
    for k in 0..3 {
        close2(uv::triangle(v, uv, v[k]), uv[k], 1e-6);
    }
    assert_eq!(uv::triangle([Vec3::ZERO; 3], uv, Vec3::ONE), uv[0]);
}

#[test]
fn cube_faces_cover_the_unit_square_and_face_outwards() {
    let tris = uv::cube();
    assert_eq!(tris.len(), 12);
    // Mitsuba 3.9.1, `mi.traverse(cube)`: faces start [0, 1, 2, 3, 0, 2] and
    // vertex_texcoords start (0, 1), (1, 1), (1, 0), (0, 0).
    assert_eq!(tris[0].1, [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0)]);
    assert_eq!(tris[1].1, [Vec2::new(0.0, 0.0), Vec2::new(0.0, 1.0), Vec2::new(1.0, 0.0)]);
    for (p, _) in &tris {
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let centre = (p[0] + p[1] + p[2]) / 3.0;
        assert!(n.dot(centre) > 0.0, "{p:?} faces inwards");
        assert!(p.iter().all(|v| v.abs() == Vec3::ONE));
    }
    // Two triangles per face; each face's two triangles together use all four corners of
    // [0, 1]².
    for pair in tris.chunks(2) {
        let mut corners: Vec<_> = pair.iter().flat_map(|t| t.1).map(|c| (c.x as u8, c.y as u8)).collect();
        corners.sort();
        corners.dedup();
        assert_eq!(corners, vec![(0, 0), (0, 1), (1, 0), (1, 1)]);
    }
}

/// Dr.Jit's formula as written: each of the four texels' indices wrapped on its own.
fn lookup_by_the_formula(b: &Bitmap, uv: Vec2) -> Vec3 {
    let n = |i: i64, n: u32| -> usize {
        let n = n as i64;
        (match b.wrap {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Mirror if i.rem_euclid(2 * n) < n => i.rem_euclid(2 * n),
            Wrap::Mirror => 2 * n - 1 - i.rem_euclid(2 * n),
            Wrap::Clamp => i.clamp(0, n - 1),
        }) as usize
    };
    let at = |x: i64, y: i64| b.texels[n(y, b.height) * b.width as usize + n(x, b.width)];
    let floor = |x: f32| x.floor().clamp(-2_147_483_648.0, 2_147_483_648.0) as i64;
    let p = uv * Vec2::new(b.width as f32, b.height as f32);
    if b.filter == Filter::Nearest {
        return at(floor(p.x), floor(p.y));
    }
    let p = p - 0.5;
    let p = Vec2::select(p.is_finite_mask(), p, Vec2::ZERO);
    let (x, y) = (floor(p.x), floor(p.y));
    let w1 = p - p.floor();
    let w0 = 1.0 - w1;
    at(x, y) * (w0.x * w0.y)
        + at(x + 1, y) * (w1.x * w0.y)
        + at(x, y + 1) * (w0.x * w1.y)
        + at(x + 1, y + 1) * (w1.x * w1.y)
}

#[test]
fn lookups_wrap_each_axis_once_with_the_formulas_bits() {
    let dir = tempfile::tempdir().unwrap();
    let paths = [grid(dir.path()), png(dir.path(), "one.png", 1, 1, &[[100, 50, 25]])];
    // Inside the image, past each edge by a little and by whole periods, and far out
    // (beyond 2^31 texels, and not finite).
    let mut coords: Vec<f32> = (-40..=40).map(|k| k as f32 * 0.077).collect();
    coords.extend([0.0, 1.0, -1.0, 0.999_999_9, 1e-30, -1e-30, 3e9, -3e9, 1e30, f32::INFINITY, f32::NAN]);
    for path in &paths {
        for wrap in [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp] {
            for filter in [Filter::Nearest, Filter::Bilinear] {
                let b = load(path, false, wrap, filter);
                for &u in &coords {
                    for &v in coords.iter().step_by(3) {
                        let (got, want) = (b.lookup(Vec2::new(u, v)), lookup_by_the_formula(&b, Vec2::new(u, v)));
                        assert_eq!(
                            got.to_array().map(f32::to_bits),
                            want.to_array().map(f32::to_bits),
                            "{wrap:?} {filter:?} ({u}, {v})"
                        );
                    }
                }
            }
        }
    }
}
