//! Quick kernel timing robust to a shared machine: the minimum over batches
//! of the mean time per call (criterion's `cargo bench --bench ltc` is the
//! reference measurement).
use glam::Vec3;
use ltcguide::bsdf::{GgxLobe, Lobes};
use ltcguide::directional::{Cell, dir_to_square};
use ltcguide::ltc::children::{LtcOptions, ProductKernel, ShadingLtc};
use ltcguide::ltc::children_x16::children_x16;
use ltcguide::ltc::table::LtcTable;
use ltcguide::math::Frame;
use std::hint::black_box;
use std::time::Instant;

fn min_ns(f: impl FnMut()) -> f64 {
    batches_ns(f)[0]
}

/// The 40 batch means (ns per call), sorted: the minimum is the least
/// disturbed batch, the median what a mean-based measurement (criterion)
/// sees on a shared machine.
fn batches_ns(mut f: impl FnMut()) -> Vec<f64> {
    let mut v: Vec<f64> = (0..40)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..2000 {
                f();
            }
            t.elapsed().as_secs_f64() * 1e9 / 2000.0
        })
        .collect();
    v.sort_by(f64::total_cmp);
    v
}

fn main() {
    let table = LtcTable::load_default().unwrap();
    let frame = Frame::from_normal(Vec3::new(0.3, -0.5, 0.8).normalize());
    let wo = Vec3::new(0.55, 0.45, 0.707).normalize();
    let lobes = |d: f32, g: f32| Lobes {
        diffuse: d,
        ggx: [GgxLobe {
            weight: g,
            alpha: 0.1,
        }],
        ggx_count: (g > 0.0) as usize,
        delta: 0.0,
        side: 1.0,
    };
    let opts = LtcOptions::default();
    let s = ShadingLtc::new(&lobes(0.0, 1.0), &frame, wo, &table, &opts);
    let d = ShadingLtc::new(&lobes(1.0, 0.0), &frame, wo, &table, &opts);
    let g = s.glossy[0];
    // The same lobe with Stokes quadrature along the coarse parallels
    // instead of chords, to compare in the same run.
    let chord_opts = LtcOptions {
        stokes_parallels: true,
        ..opts
    };
    let gc = ShadingLtc::new(&lobes(0.0, 1.0), &frame, wo, &table, &chord_opts).glossy[0];
    let peak = (g.a64.inverse() * glam::DVec3::Z).normalize().as_vec3();
    let setup = min_ns(|| {
        black_box(ShadingLtc::new(
            black_box(&lobes(0.3, 1.0)),
            &frame,
            wo,
            &table,
            &opts,
        ));
    });
    println!("ShadingLtc::new (diffuse + GGX): {setup:.1} ns");
    println!(
        "level | ref f64 | scalar | x16 | x16/scalar | diffuse | api simd | Stokes: scalar | x16 (ns)"
    );
    for level in [2u32, 3, 4, 5, 6, 8, 10, 12, 16, 20] {
        let p = dir_to_square(peak);
        let n = (1u64 << (level - 1)) as f32;
        let cell = Cell {
            depth: level - 1,
            ix: (p.x * n) as u32,
            iy: (p.y * n) as u32,
        };
        let r = min_ns(|| {
            black_box(g.children_reference(black_box(cell)));
        });
        let sc = min_ns(|| {
            black_box(g.children_scalar(black_box(cell), 99));
        });
        let xb = batches_ns(|| {
            black_box(children_x16(&g, black_box(cell), 99));
        });
        let (x, x_median) = (xb[0], xb[20]);
        let df = min_ns(|| {
            black_box(d.diffuse_form_factors(black_box(cell)));
        });
        let api = min_ns(|| {
            black_box(s.child_integrals(black_box(cell), ProductKernel::Simd));
        });
        let es = min_ns(|| {
            black_box(ltcguide::ltc::quad_x16::quad_children_x16(
                &g,
                black_box(cell),
            ));
        });
        let deep = min_ns(|| {
            black_box(g.children_deep(black_box(cell)));
        });
        let dx = min_ns(|| {
            black_box(d.child_integrals(black_box(cell), ProductKernel::Simd));
        });
        let csc = min_ns(|| {
            black_box(gc.children_scalar(black_box(cell), 99));
        });
        let cx = min_ns(|| {
            black_box(children_x16(&gc, black_box(cell), 99));
        });
        print!(
            "[quad x16 only {es:.1}, deep {deep:.1}, diffuse api simd {dx:.1}, x16 median {x_median:.1}] "
        );
        println!(
            "{level:>5} | {r:>7.1} | {sc:>6.1} | {x:>5.1} | {:>5.2} | {df:>6.1} | {api:>6.1} | {csc:>6.1} | {cx:>5.1}",
            sc / x
        );
    }
}
