//! Unit tests: packets of every width against single rays, SIMD kernels against scalar kernels bit for bit.

use glam::Vec3;
use wide::{f32x16, f32x4, f32x8};

use super::rays::{Axes, Lanes};
use super::{Columns, PacketWork};
use crate::accel::shapes::{intersect_triangle, NO_LIGHT};
use crate::accel::{Accel, Ray, Traversal};
use crate::accel::{Primitive, Shape};
use crate::simd::{Vector, LANES};

/// A grid of small triangles (some sharing edges) and spheres.
fn scene() -> Accel {
    let mut prims = Vec::new();
    for i in 0..20 {
        for j in 0..20 {
            let c = Vec3::new(i as f32 * 0.3, j as f32 * 0.3, ((i * 7 + j * 3) % 5) as f32 * 0.2);
            let (e1, e2) = (Vec3::new(0.25, 0.0, 0.05), Vec3::new(0.0, 0.25, -0.05));
            if (i + j) % 3 == 0 {
                prims.push(Primitive {
                    shape: Shape::Sphere { center: c, radius: 0.12 },
                    material: 0,
                    light: NO_LIGHT,
                });
            } else {
                // Two triangles sharing the edge v1–v2.
                prims.push(Primitive {
                    shape: Shape::Triangle { v0: c, v1: c + e1, v2: c + e2 },
                    material: 0,
                    light: NO_LIGHT,
                });
                prims.push(Primitive {
                    shape: Shape::Triangle { v0: c + e1, v1: c + e1 + e2, v2: c + e2 },
                    material: 0,
                    light: NO_LIGHT,
                });
            }
        }
    }
    Accel::build_reference(prims)
}

fn check<S: Vector>(accel: &Accel) -> PacketWork {
    let mut h = 12345u32;
    let mut rnd = || {
        h = crate::sampling::mix(h);
        crate::sampling::to_unit(h)
    };
    let mut work = PacketWork::default();
    for round in 0..400 {
        let n = 1 + (rnd() * S::WIDTH as f32) as usize % S::WIDTH;
        let (mut o, mut d) = (Vec::new(), Vec::new());
        for _ in 0..n {
            let orig = Vec3::new(rnd() * 6.0, rnd() * 6.0, 3.0 + rnd());
            // Every fourth packet aims at grid vertices (shared edges and corners).
            let dir = if round % 4 == 0 {
                let v = Vec3::new((rnd() * 20.0).floor() * 0.3, (rnd() * 20.0).floor() * 0.3, 0.4);
                v - orig
            } else if round % 4 == 1 {
                // Incoherent: any direction.
                Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5)
            } else {
                Vec3::new(rnd() - 0.5, rnd() - 0.5, -1.0)
            };
            o.push(orig);
            d.push(dir.normalize());
        }
        let mut out = [(0.0, 0); LANES];
        super::closest::<S>(accel, &o, &d, None, 0.0, &mut out, &mut work);
        let tmax: Vec<f32> = (0..n).map(|_| 1.0 + rnd() * 4.0).collect();
        let mut occ = [false; LANES];
        super::occluded::<S>(accel, &o, &d, None, &tmax, &mut occ, &mut work);
        // The same rays as queue columns (a full packet's lanes load from them): the same
        // answers, bit for bit.
        let col = |f: fn(&Vec3) -> f32, v: &[Vec3]| v.iter().map(f).collect::<Vec<f32>>();
        let c = [
            col(|v| v.x, &o),
            col(|v| v.y, &o),
            col(|v| v.z, &o),
            col(|v| v.x, &d),
            col(|v| v.y, &d),
            col(|v| v.z, &d),
        ];
        let cols = Some(Columns([&c[0][..], &c[1][..], &c[2][..], &c[3][..], &c[4][..], &c[5][..]]));
        let (mut out_c, mut occ_c) = ([(0.0, 0); LANES], [false; LANES]);
        super::closest::<S>(accel, &o, &d, cols, 0.0, &mut out_c, &mut PacketWork::default());
        super::occluded::<S>(accel, &o, &d, cols, &tmax, &mut occ_c, &mut PacketWork::default());
        let bits = |v: &[(f32, u32)]| v.iter().map(|&(t, p)| (t.to_bits(), p)).collect::<Vec<_>>();
        assert_eq!((bits(&out_c[..n]), &occ_c[..n]), (bits(&out[..n]), &occ[..n]));
        for l in 0..n {
            let single = accel.closest::<false>(Ray::new(o[l], d[l], 0.0, f32::INFINITY), &mut Traversal::default());
            match single {
                Some((t, p)) => {
                    assert_eq!(out[l].0, t, "lane {l}");
                    // The same primitive, ties included (the lowest id wins in every kernel).
                    assert_eq!(out[l].1, p, "lane {l}");
                }
                None => assert_eq!(out[l].1, u32::MAX),
            }
            let blocked = accel.occluded::<false>(Ray::new(o[l], d[l], 0.0, tmax[l]), &mut Traversal::default());
            assert_eq!(occ[l], blocked, "lane {l}");
        }
    }
    assert!(work.lanes > 0 && work.lanes <= S::WIDTH as u64 * work.steps);
    work
}

#[test]
fn packets_match_single_rays_at_every_width() {
    let accel = scene();
    let work = [check::<f32x4>(&accel), check::<f32x8>(&accel), check::<f32x16>(&accel)];
    // Both paths ran: the coherent packets walked as beams, and some incoherent ones
    // (every fourth round) gave up and finished lane by lane.
    assert!(work.iter().all(|w| w.steps > 0 && w.fallbacks > 0), "{work:?}");
}

#[test]
fn simd_kernels_equal_scalar_kernels_bit_for_bit() {
    // Mixed dominant axes in one packet, rays through vertices and edges.
    let (v0, v1, v2) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
    let o = [
        Vec3::new(0.2, 0.2, 1.0),
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::new(3.0, 0.5, 0.1),
        Vec3::new(0.5, 0.5, -1.0),
        Vec3::new(-1.0, 0.3, 0.5),
        Vec3::new(0.5, -2.0, 0.3),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(0.25, 0.25, 1e-3),
    ];
    let d = [
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::new(-1.0, 0.0, -0.03).normalize(),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, -0.4).normalize(),
        Vec3::new(0.0, 1.0, -0.1).normalize(),
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::new(0.3, -0.2, -1.0).normalize(),
    ];
    let lanes = Lanes::<f32x8>::new(&o, &d, None, 0.0);
    let mut t = [0.0; LANES];
    lanes.triangle(v0, v1, v2, 0xff).store(&mut t);
    for l in 0..8 {
        assert_eq!(t[l].to_bits(), intersect_triangle(v0, v1, v2, o[l], d[l]).to_bits(), "lane {l}");
    }
    assert!(matches!(lanes.frame().axes, Axes::Mixed(..)));
    // Spheres (from inside, tangent from the centre plane, behind) and parallelograms
    // (edge-on, through a corner, from behind) against the same lanes.
    let shapes = [
        Shape::Sphere { center: Vec3::new(0.2, 0.2, 0.0), radius: 0.5 },
        Shape::Sphere { center: Vec3::new(1.0, 0.0, 0.5), radius: 1.0 },
        Shape::Sphere { center: Vec3::new(0.0, 0.0, -2.0), radius: 0.25 },
        Shape::Quad { corner: Vec3::new(0.0, 0.0, 0.0), u: Vec3::new(1.0, 0.0, 0.0), v: Vec3::new(0.0, 1.0, 0.0) },
        Shape::Quad { corner: Vec3::new(-1.0, -1.0, 0.5), u: Vec3::new(2.0, 0.0, 0.0), v: Vec3::new(0.0, 0.0, 1.0) },
    ];
    for shape in &shapes {
        for (tmin, tmax) in [(0.0, f32::INFINITY), (0.1, 1.5)] {
            lanes.shape(shape, 0xff, f32x8::splat(tmin), f32x8::splat(tmax)).store(&mut t);
            for l in 0..8 {
                let t = if t[l] > tmin && t[l] < tmax { t[l] } else { f32::INFINITY };
                assert_eq!(t.to_bits(), shape.intersect(o[l], d[l], tmin, tmax).to_bits(), "{shape:?} lane {l}");
            }
        }
    }
}
