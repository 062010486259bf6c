//! Child-integral kernels per quadtree level (level = depth of the children).
//!
//! `children_f64_reference`, `children_scalar` and `children_x16` time the
//! glossy polygon kernels themselves (the deep-level switch disabled, so
//! every level runs the edge sums); `children_diffuse_precomputed` times a
//! diffuse lobe from the cell form factors (through the API, Simd kernel); `api_simd` is what the guider
//! pays per level through `ShadingLtc::child_integrals` with the default
//! switches; `cosine_root_children` the cosine lobe's shares of the root's
//! children (roulette's adjoint, every guided vertex);
//! `level1_near_lune/*` the root's children of the same lobe turned so that
//! |h_x| = 0.01·|h|, where the mapped triangles are ill conditioned: the
//! closed form level 1 now takes there, and the four clipped polygons it
//! took before session 61;
//! `children_x16_guider_chords` times the coarse levels with the
//! product guider's chords (1/16 turn; plain quads from level 4). Cells
//! follow a descent into the lobe (α = 0.1, θ_o = 45°).

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use glam::Vec3;
use ltcguide::bsdf::{GgxLobe, Lobes};
use ltcguide::directional::{Cell, dir_to_square};
use ltcguide::ltc::children::exact_children_f32;
use ltcguide::ltc::children::{LtcOptions, ProductKernel, ShadingLtc};
use ltcguide::ltc::children_x16::children_x16;
use ltcguide::ltc::form_factor::{self, cosine_root_children};
use ltcguide::ltc::level1::level1_children_x4;
use ltcguide::ltc::table::LtcTable;
use ltcguide::math::Frame;
use std::hint::black_box;
use std::time::Duration;

const LEVELS: [u32; 12] = [1, 2, 3, 4, 5, 6, 7, 8, 10, 12, 16, 20];

fn lobes(diffuse: f32, ggx: f32, alpha: f32) -> Lobes {
    Lobes {
        diffuse,
        ggx: [GgxLobe { weight: ggx, alpha }],
        ggx_count: (ggx > 0.0) as usize,
        delta: 0.0,
        side: 1.0,
    }
}

fn node_at(dir: Vec3, depth: u32) -> Cell {
    let p = dir_to_square(dir);
    let n = (1u64 << depth) as f32;
    Cell {
        depth,
        ix: ((p.x * n) as u32).min((1u32 << depth) - 1),
        iy: ((p.y * n) as u32).min((1u32 << depth) - 1),
    }
}

fn bench(c: &mut Criterion) {
    let table = LtcTable::load_default().unwrap();
    form_factor::precompute();
    let frame = Frame::from_normal(Vec3::new(0.3, -0.5, 0.8).normalize());
    let wo = Vec3::new(0.55, 0.45, 0.707).normalize();
    let opts = LtcOptions::default();
    let glossy = ShadingLtc::new(&lobes(0.0, 1.0, 0.1), &frame, wo, &table, &opts);
    let diffuse = ShadingLtc::new(&lobes(1.0, 0.0, 1.0), &frame, wo, &table, &opts);
    let g = glossy.glossy[0];
    // The same lobe with Stokes quadrature along coarse parallels.
    let stokes_opts = LtcOptions {
        stokes_parallels: true,
        ..opts
    };
    let gs = ShadingLtc::new(&lobes(0.0, 1.0, 0.1), &frame, wo, &table, &stokes_opts).glossy[0];
    // The same lobe with the product guider's chords (1/16 turn, plain
    // quads from level 4).
    let guider_opts = LtcOptions {
        plain_quad_depth: ltcguide::guiding::product::guiding_ltc_options().plain_quad_depth,
        ..opts
    };
    let gg = ShadingLtc::new(&lobes(0.0, 1.0, 0.1), &frame, wo, &table, &guider_opts).glossy[0];
    let peak = {
        let m = g.a64.inverse() * glam::DVec3::Z;
        m.normalize().as_vec3()
    };
    let near_lune = {
        let mut a = g.a64;
        a.x_axis.z = 0.01 * a.row(2).length();
        ltcguide::ltc::children::GlossyLtc::from_map(a, 1.0, &opts)
    };
    let mut group = c.benchmark_group("ltc");
    let root = Cell {
        depth: 0,
        ix: 0,
        iy: 0,
    };
    group.bench_function("level1_near_lune/quarter_sphere", |b| {
        b.iter(|| level1_children_x4(black_box(&near_lune.rows), near_lune.orientation))
    });
    group.bench_function("level1_near_lune/polygons", |b| {
        b.iter(|| exact_children_f32(black_box(&near_lune.rows), near_lune.orientation, root))
    });
    // The cosine lobe's root shares, which both guided methods take at
    // every vertex where adjoint-driven roulette reads its estimate.
    let normals: Vec<Vec3> = (0..64)
        .map(|i| {
            let t = i as f32 * 0.7;
            Vec3::new(t.cos() * 0.8, t.sin() * 0.8, 0.6 * (1.3 * t).cos()).normalize()
        })
        .collect();
    // The index, not the normal, goes through `black_box`, so the normal
    // stays in registers as in the integrator.
    let mut i = 0usize;
    group.bench_function("cosine_root_children", |b| {
        b.iter(|| {
            i = (i + 1) & 63;
            cosine_root_children(normals[black_box(i)])
        })
    });
    for level in LEVELS {
        let node = node_at(peak, level - 1);
        group.bench_with_input(
            BenchmarkId::new("children_f64_reference", level),
            &node,
            |b, &n| b.iter(|| g.children_reference(black_box(n))),
        );
        group.bench_with_input(
            BenchmarkId::new("children_scalar", level),
            &node,
            |b, &n| b.iter(|| g.children_scalar(black_box(n), 99)),
        );
        group.bench_with_input(BenchmarkId::new("children_x16", level), &node, |b, &n| {
            b.iter(|| children_x16(&g, black_box(n), 99))
        });
        if (2..gg.plain_quad_depth).contains(&level) {
            group.bench_with_input(
                BenchmarkId::new("children_x16_guider_chords", level),
                &node,
                |b, &n| b.iter(|| children_x16(&gg, black_box(n), 99)),
            );
        }
        if (2..=5).contains(&level) {
            group.bench_with_input(
                BenchmarkId::new("children_scalar_stokes", level),
                &node,
                |b, &n| b.iter(|| gs.children_scalar(black_box(n), 99)),
            );
            group.bench_with_input(
                BenchmarkId::new("children_x16_stokes", level),
                &node,
                |b, &n| b.iter(|| children_x16(&gs, black_box(n), 99)),
            );
        }
        let dnode = node_at(diffuse.normal, level - 1);
        group.bench_with_input(
            BenchmarkId::new("children_diffuse_precomputed", level),
            &dnode,
            |b, &n| b.iter(|| diffuse.child_integrals(black_box(n), ProductKernel::Simd)),
        );
        group.bench_with_input(BenchmarkId::new("api_simd", level), &node, |b, &n| {
            b.iter(|| glossy.child_integrals(black_box(n), ProductKernel::Simd))
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_millis(600))
        .sample_size(20);
    targets = bench
}
criterion_main!(benches);
