//! Full renders of the default and bunny scenes at reduced size, with the single-ray (wide) and the
//! packet kernel, on one and two threads, reported as rays per second (criterion
//! `Throughput::Elements` = rays traced per render).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::path::Path;
use wavetrace::scene::{load, SceneSource};
use wavetrace::{render, RenderOptions};

fn bench_scene(c: &mut Criterion, name: &str, src: SceneSource) {
    let mut g = c.benchmark_group("render");
    g.sample_size(10);
    for packets in [false, true] {
        let sets = vec!["render.width=160".into(), "render.height=120".into(), format!("render.packets={packets}")];
        let scene = load(&src, &sets).expect("scene loads");
        for threads in [1, 2] {
            let opts = RenderOptions { threads: Some(threads), ..Default::default() };
            let rays = render(&scene, &opts).expect("render").stats.total_rays();
            g.throughput(Throughput::Elements(rays));
            let kernel = if packets { "packet" } else { "single" };
            g.bench_function(format!("{name}/160x120/{kernel}/{threads}-thread"), |b| {
                b.iter(|| render(&scene, &opts).expect("render"))
            });
        }
    }
    g.finish();
}

fn renders(c: &mut Criterion) {
    bench_scene(c, "default", SceneSource::default_scene());
    let bunny = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bunny.toml");
    bench_scene(c, "bunny", SceneSource::from_file(&bunny).expect("bunny scene"));
}

criterion_group!(benches, renders);
criterion_main!(benches);
