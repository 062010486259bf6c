//! Kernels of radiance and product guiding on a realistically refined
//! quadtree: one sample (descent + point placement) and one pdf evaluation,
//! and for the product the per-vertex LTC set-up they include; also one
//! product sample on a lobe that earlier descents have already walked
//! (`product_sample_reused_lobe`), the cost per path once a pixel's paths
//! share their first vertex's lobe, as in a long render.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use ltcguide::bsdf::{GgxLobe, Lobes};
use ltcguide::directional::{SQUARE_TO_SOLID_ANGLE_PDF, dir_to_square};
use ltcguide::guiding::build::QuadTreeBuilder;
use ltcguide::guiding::descent::{RadianceWeights, pdf, root_total, sample, sample_direction};
use ltcguide::guiding::product::{ProductLobe, ProductWeights, guiding_ltc_options};
use ltcguide::guiding::quadtree::QuadTree;
use ltcguide::ltc::{LtcTable, ProductKernel, ShadingLtc};
use ltcguide::math::Frame;
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

/// A shading point of a rough-plastic-like surface: a diffuse base under a
/// GGX coat, at a random normal and outgoing direction, α spread over the
/// glossy range the product treats as glossy (≤ 0.5).
struct ShadingPoint {
    lobes: Lobes,
    frame: Frame,
    wo: Vec3,
}

fn shading_points(n: usize) -> Vec<ShadingPoint> {
    let mut rng = Rng::new(5, 3);
    (0..n)
        .map(|i| {
            let normal = square_to_uniform_sphere(rng.next_2d());
            let mut wo = square_to_uniform_sphere(rng.next_2d());
            wo.z = wo.z.abs().max(0.05);
            ShadingPoint {
                lobes: Lobes {
                    diffuse: 0.5,
                    ggx: [GgxLobe {
                        weight: 0.5,
                        alpha: [0.02, 0.1, 0.3][i % 3],
                    }],
                    ggx_count: 1,
                    delta: 0.0,
                    side: 1.0,
                },
                frame: Frame::from_normal(normal),
                wo: wo.normalize(),
            }
        })
        .collect()
}

/// Per guided vertex, as the integrator pays it: the shading point's LTC
/// mixture (`ShadingLtc::new`), the root normaliser, then one sample
/// (`product_sample`) or one pdf of a direction sampled beforehand
/// (`product_pdf`), each with fresh weights.
fn bench_product(c: &mut Criterion) {
    let tree = refined_tree();
    let table = LtcTable::load_default().expect("data/ltc table");
    let opts = guiding_ltc_options();
    let points = shading_points(256);
    let lobe = |p: &ShadingPoint| {
        ProductLobe::new(
            ShadingLtc::new(&p.lobes, &p.frame, p.wo, &table, &opts),
            ProductKernel::Simd,
        )
    };
    let mut rng = Rng::new(8, 1);
    let us: Vec<Vec2> = (0..points.len()).map(|_| rng.next_2d()).collect();
    let sampled: Vec<Vec2> = points
        .iter()
        .zip(&us)
        .map(|(p, &u)| {
            let mut lobe = lobe(p);
            sample(&tree, &mut ProductWeights::Product(&mut lobe), u).map_or(u, |s| s.0)
        })
        .collect();
    let mut i = 0usize;
    c.bench_function("guiding/product_sample", |b| {
        b.iter(|| {
            i = (i + 1) & 255;
            let mut lobe = lobe(black_box(&points[i]));
            let mut w = ProductWeights::Product(&mut lobe);
            let _ = black_box(root_total(&tree, &mut w));
            black_box(sample(black_box(&tree), &mut w, black_box(us[i])))
        })
    });
    let mut j = 0usize;
    c.bench_function("guiding/product_pdf", |b| {
        b.iter(|| {
            j = (j + 1) & 255;
            let mut lobe = lobe(black_box(&points[j]));
            let mut w = ProductWeights::Product(&mut lobe);
            let _ = black_box(root_total(&tree, &mut w));
            black_box(pdf(black_box(&tree), &mut w, black_box(sampled[j])))
        })
    });
    // A lobe kept for 64 descents, as a pixel's paths keep their first
    // vertex's lobe (`guiding::pixel_reuse`): its memo holds the top levels,
    // so each sample pays mostly the levels below where descents part.
    // (On this tree a descent takes 7.6 levels on average, of which about
    // 2 visit a node no earlier descent of its lobe had; session 60.)
    let mut lobes: Vec<ProductLobe> = points.iter().map(lobe).collect();
    let mut rng = Rng::new(11, 4);
    let fresh_us: Vec<Vec2> = (0..4096).map(|_| rng.next_2d()).collect();
    let mut r = 0usize;
    c.bench_function("guiding/product_sample_reused_lobe", |b| {
        b.iter(|| {
            r = r.wrapping_add(1);
            let lobe = &mut lobes[(r >> 6) & 255];
            let mut w = ProductWeights::Product(lobe);
            black_box(sample(
                black_box(&tree),
                &mut w,
                black_box(fresh_us[r & 4095]),
            ))
        })
    });
    let mut k = 0usize;
    c.bench_function("guiding/product_vertex_setup", |b| {
        b.iter(|| {
            k = (k + 1) & 255;
            let p = black_box(&points[k]);
            black_box(ShadingLtc::new(&p.lobes, &p.frame, p.wo, &table, &opts))
        })
    });
}

criterion_group!(benches, bench, bench_product);
criterion_main!(benches);
