//! Kernels of radiance guiding on a realistically refined quadtree: one
//! sample (descent + point placement) and one pdf evaluation.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use ltcguide::directional::{SQUARE_TO_SOLID_ANGLE_PDF, dir_to_square};
use ltcguide::guiding::build::QuadTreeBuilder;
use ltcguide::guiding::descent::{RadianceWeights, pdf, sample, sample_direction};
use ltcguide::guiding::quadtree::QuadTree;
use ltcguide::math::PI;
use ltcguide::sampling::{Rng, square_to_uniform_sphere};
use std::hint::black_box;

/// Learns a guide for a field of 40 lobes of different widths on a dim
/// floor, the way the renderer would: 11 iterations of doubling length,
/// half the samples from the guide.
fn refined_tree() -> QuadTree {
    // 12 small bright sources of equal power (amplitude ∝ κ, κ from 10³ to
    // 10⁵, i.e. 0.03 to 0.003 rad wide) on a floor holding a quarter of the
    // power. Each source holds ~6 %, enough to stay above ρ after the box
    // filter blurs it over ~4 leaf cells, so it grows a chain of cells until
    // resolved: a few hundred nodes, like PPG trees near small emitters.
    let mut lrng = Rng::new(99, 1);
    let lobes: Vec<(Vec3, f32, f32)> = (0..12)
        .map(|i| {
            let k = 1000.0 * 100f32.powf(i as f32 / 11.0);
            (square_to_uniform_sphere(lrng.next_2d()), k, k / 12_000.0)
        })
        .collect();
    let radiance = |d: Vec3| {
        1.7e-4
            + lobes
                .iter()
                .map(|&(m, k, a)| a * (k * (m.dot(d) - 1.0)).exp())
                .sum::<f32>()
    };
    let mut rng = Rng::new(7, 0);
    let mut tree = QuadTree::new();
    for k in 0..11 {
        let mut rec = tree.structure_copy();
        let guided = tree.total() > 0.0;
        let alpha = if guided { 0.5 } else { 1.0 };
        for _ in 0..(1000usize << k) {
            let u = rng.next_2d();
            let d = if rng.next_f32() < alpha {
                square_to_uniform_sphere(u)
            } else {
                sample_direction(&tree, &mut RadianceWeights, u).unwrap().0
            };
            let pg = if guided {
                pdf(&tree, &mut RadianceWeights, dir_to_square(d)) * SQUARE_TO_SOLID_ANGLE_PDF
            } else {
                0.0
            };
            let p_mix = alpha / (4.0 * PI) + (1.0 - alpha) * pg;
            let _ = rec.record_box(dir_to_square(d), radiance(d) / p_mix);
        }
        tree = QuadTreeBuilder::default().build(&rec).unwrap();
    }
    tree
}

fn bench(c: &mut Criterion) {
    let tree = refined_tree();
    eprintln!(
        "guiding bench tree: {} nodes, depth {}, {} bytes",
        tree.node_count(),
        tree.depth(),
        tree.bytes()
    );
    let mut rng = Rng::new(1, 2);
    let points: Vec<Vec2> = (0..4096).map(|_| rng.next_2d()).collect();
    // Evaluate the pdf where the guide actually samples, as MIS does.
    let sampled: Vec<Vec2> = points
        .iter()
        .map(|&u| sample(&tree, &mut RadianceWeights, u).unwrap().0)
        .collect();
    let mut i = 0usize;
    c.bench_function("guiding/radiance_sample", |b| {
        b.iter(|| {
            i = (i + 1) & 4095;
            black_box(sample(
                black_box(&tree),
                &mut RadianceWeights,
                black_box(points[i]),
            ))
        })
    });
    let mut j = 0usize;
    c.bench_function("guiding/radiance_pdf", |b| {
        b.iter(|| {
            j = (j + 1) & 4095;
            black_box(pdf(
                black_box(&tree),
                &mut RadianceWeights,
                black_box(sampled[j]),
            ))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
