//! Traversal kernels on the bunny (69k triangles) and the ogre (124k, the largest test
//! mesh): obvhs's own single-ray traversal and ours against packets of 4, 8 and 16 lanes,
//! the wide BVH's single-ray kernel and the hybrid, on the ray sets of
//! `wavetrace bench` (coherent primary rays, shadow any-hit rays, incoherent diffuse
//! bounces), traced through the renderer's own stages on one thread. Throughput is rays
//! per second (criterion `Throughput::Elements`).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::path::Path;
use wavetrace::accel::packet::PacketConfig;
use wavetrace::accel::tracer::{Kernel, Width};
use wavetrace::scene::{load, SceneSource};
use wavetrace::tools::bench::{ray_sets, trace};

fn kernels(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("pool");
    for name in ["bunny", "ogre"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.toml"));
        let source = SceneSource::from_file(&path).expect("scene file");
        let scene = load(&source, &["render.aa.samples=1".into()]).expect("scene");
        let sets = ray_sets(&scene, 1 << 18);
        let mut g = c.benchmark_group(format!("traversal/{name}"));
        g.sample_size(10);
        for (set_name, set) in &sets {
            g.throughput(Throughput::Elements(set.len() as u64));
            let kernels = [
                ("packet4", Kernel::Packet(Width::X4, PacketConfig::RENDER)),
                ("packet8", Kernel::Packet(Width::X8, PacketConfig::RENDER)),
                ("packet16", Kernel::Packet(Width::X16, PacketConfig::RENDER)),
                ("wide", Kernel::Wide),
                ("stream", Kernel::Stream),
                ("hybrid", Kernel::HYBRID),
            ];
            for (label, kernel) in kernels {
                g.bench_function(format!("{set_name}/{label}"), |b| {
                    b.iter(|| trace(&scene.accel, set, &pool, kernel).1)
                });
            }
        }
        g.finish();
    }
}

criterion_group!(benches, kernels);
criterion_main!(benches);
