//! Ray-query throughput on a real pack scene (staircase, 262k triangles),
//! or the default scene when the pack is absent. The rays are a realistic
//! mix: camera rays and one diffuse bounce from their hit points.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use ltcguide::sampling::{Rng, square_to_cosine_hemisphere};
use ltcguide::scene::{Scene, load_scene};
use std::hint::black_box;
use std::path::Path;

fn scene() -> Scene {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let pack = root.join("../shared/scenes/staircase/scene.xml");
    let path = if pack.exists() {
        pack
    } else {
        eprintln!("scene pack absent: benchmarking the default scene instead of staircase");
        root.join("scenes/cornell-glossy/scene.xml")
    };
    load_scene(&path).expect("scene loads")
}

fn rays(scene: &Scene, n: usize) -> Vec<(Vec3, Vec3, f32)> {
    let mut rng = Rng::new(1, 0);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let film = Vec2::new(
            rng.next_f32() * scene.camera.width as f32,
            rng.next_f32() * scene.camera.height as f32,
        );
        let (o, d) = scene.camera.ray(film);
        out.push((o, d, f32::INFINITY));
        if let Some(it) = scene.intersect(o, d, f32::INFINITY) {
            let local = square_to_cosine_hemisphere(rng.next_2d());
            let n = if it.ng.dot(d) < 0.0 { it.ng } else { -it.ng };
            let dir = ltcguide::math::Frame::from_normal(n).to_world(local);
            let origin = it.p + n * scene.ray_epsilon(it.p);
            // Occlusion queries of bounded length, like shadow rays.
            out.push((origin, dir, 2.0));
        }
    }
    out
}

fn bench(c: &mut Criterion) {
    let scene = scene();
    let rays = rays(&scene, 8192);
    let mut group = c.benchmark_group("accel");
    group.throughput(Throughput::Elements(rays.len() as u64));
    group.bench_function("closest_hit", |b| {
        b.iter(|| {
            let mut hits = 0u32;
            for &(o, d, _) in &rays {
                hits += scene.accel.closest_hit(o, d, 0.0, f32::INFINITY).is_some() as u32;
            }
            black_box(hits)
        })
    });
    group.bench_function("occlusion", |b| {
        b.iter(|| {
            let mut blocked = 0u32;
            for &(o, d, t) in &rays {
                blocked += scene.accel.occluded(o, d, 0.0, t) as u32;
            }
            black_box(blocked)
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
