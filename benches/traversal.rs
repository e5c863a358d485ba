//! Traversal kernels on the bunny: single-ray (scalar) against 8-wide packets, for
//! coherent primary rays, incoherent bounce rays and shadow any-hit rays. Throughput is
//! rays per second (criterion `Throughput::Elements`).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use std::path::Path;
use wavetrace::geometry::packet::{PacketWork, LANES};
use wavetrace::geometry::Traversal;
use wavetrace::scene::{load, SceneSource};

const N: usize = 1 << 16;

fn rays(kind: &str) -> (Vec<Vec3>, Vec<Vec3>, Vec<f32>) {
    let mut h = 7u32;
    let mut rnd = || {
        h = wavetrace::sampling::mix(h);
        wavetrace::sampling::to_unit(h)
    };
    let (mut o, mut d, mut t) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..N {
        match kind {
            // A 256×256 pinhole grid, in 8-ray runs along a row: neighbours are coherent.
            "coherent" => {
                let (x, y) = ((i % 256) as f32 / 256.0 - 0.5, (i / 256) as f32 / 256.0 - 0.5);
                o.push(Vec3::new(0.1, 0.45, 2.0));
                d.push(Vec3::new(x * 0.8, -y * 0.8, -1.0).normalize());
                t.push(f32::INFINITY);
            }
            // Random origins in the bunny's box, random directions.
            _ => {
                o.push(Vec3::new(rnd() * 1.2 - 0.5, rnd() * 1.0, rnd() * 0.8 - 0.4));
                d.push(Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize());
                t.push(if kind == "shadow" { 0.5 } else { f32::INFINITY });
            }
        }
    }
    (o, d, t)
}

fn kernels(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bunny.toml");
    let scene = load(&SceneSource::from_file(&path).expect("bunny"), &[]).expect("bunny scene");
    let accel = &scene.accel;
    let mut g = c.benchmark_group("traversal/bunny");
    g.sample_size(10);
    g.throughput(Throughput::Elements(N as u64));
    for kind in ["coherent", "incoherent", "shadow"] {
        let (o, d, t) = rays(kind);
        g.bench_function(format!("{kind}/scalar"), |b| {
            b.iter(|| {
                let mut w = Traversal::default();
                let mut hits = 0u32;
                for i in 0..N {
                    hits += if kind == "shadow" {
                        accel.occluded::<false>(o[i], d[i], 0.0, t[i], &mut w) as u32
                    } else {
                        accel.closest::<false>(o[i], d[i], 0.0, t[i], &mut w).is_some() as u32
                    };
                }
                hits
            })
        });
        g.bench_function(format!("{kind}/packet8"), |b| {
            b.iter(|| {
                let mut w = PacketWork::default();
                let mut hits = 0u32;
                let mut out = [(0.0f32, 0u32); LANES];
                let mut occ = [false; LANES];
                for s in (0..N).step_by(LANES) {
                    let r = s..s + LANES;
                    if kind == "shadow" {
                        accel.occluded8(&o[r.clone()], &d[r.clone()], &t[r], &mut occ, &mut w);
                        hits += occ.iter().filter(|&&x| x).count() as u32;
                    } else {
                        accel.closest8(&o[r.clone()], &d[r], 0.0, &mut out, &mut w);
                        hits += out.iter().filter(|h| h.1 != u32::MAX).count() as u32;
                    }
                }
                hits
            })
        });
    }
    g.finish();
}

criterion_group!(benches, kernels);
criterion_main!(benches);
