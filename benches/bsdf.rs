//! Kernel benchmarks of the GGX rough conductor: eval (+pdf) and sample.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use ltcguide::bsdf::{Bsdf, ConductorFresnel, Material, MaterialKind};
use ltcguide::math::Spectrum;
use ltcguide::sampling::{Rng, square_to_uniform_sphere};
use ltcguide::texture::Texture;
use std::hint::black_box;

fn conductor() -> Bsdf {
    Material::new(
        MaterialKind::RoughConductor {
            alpha: 0.2,
            fresnel: ConductorFresnel::Complex {
                eta: Spectrum::new(0.200, 0.924, 1.102),
                k: Spectrum::new(3.912, 2.452, 2.142),
            },
            specular_reflectance: Texture::Constant(Spectrum::ONE),
        },
        false,
    )
    .unwrap()
    .at(Vec2::ZERO)
}

fn bench(c: &mut Criterion) {
    let b = conductor();
    // A fixed pool of upper-hemisphere pairs so the timed loop measures the
    // BSDF, not the RNG.
    let mut rng = Rng::new(1, 1);
    let pairs: Vec<(Vec3, Vec3)> = (0..1024)
        .map(|_| {
            let mut a = square_to_uniform_sphere(rng.next_2d());
            let mut w = square_to_uniform_sphere(rng.next_2d());
            a.z = a.z.abs();
            w.z = w.z.abs();
            (a, w)
        })
        .collect();
    let us: Vec<(f32, Vec2)> = (0..1024).map(|_| (rng.next_f32(), rng.next_2d())).collect();
    let mut g = c.benchmark_group("bsdf");
    g.bench_function("ggx_eval", |bch| {
        let mut i = 0usize;
        bch.iter(|| {
            let (wo, wi) = pairs[i & 1023];
            i = i.wrapping_add(1);
            black_box(b.eval_pdf(black_box(wo), black_box(wi)))
        })
    });
    g.bench_function("ggx_sample", |bch| {
        let mut i = 0usize;
        bch.iter(|| {
            let (wo, _) = pairs[i & 1023];
            let (ul, u) = us[i & 1023];
            i = i.wrapping_add(1);
            black_box(b.sample(black_box(wo), ul, u))
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
