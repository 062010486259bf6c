//! Where f32 edge sums lose to cancellation: the measurement behind
//! `DEFAULT_DEEP_CELL_SIZE`. For cells along descents into several lobes we
//! compare, against the f64 exact reference, (a) the f32 edge sum and (b)
//! density(centre) × solid angle, as a function of the child's size in the
//! lobe's cosine space, δ' = (2π/2^depth)·‖A‖_F. Edge sums lose ~ε/δ'
//! relative accuracy, the midpoint rule ~δ'², so they cross near ε^(1/3).

mod ltc_common;

use ltc_common::*;
use ltcguide::ltc::children::DEFAULT_DEEP_CELL_SIZE;

#[test]
fn deep_switch_threshold() {
    let frame = tilted_frame();
    // Buckets of log2 δ' from −16 to 0.
    let mut poly = [0.0f64; 17];
    let mut mid = [0.0f64; 17];
    let mut cells = [0usize; 17];
    let mut used = 0.0f64;
    for &alpha in &[1e-3f32, 0.01, 0.1, 0.5] {
        for &theta in &[0.0, 45.0, 80.0] {
            let s = shading(Some(alpha), theta, &frame, &all_glossy());
            let g = s.glossy[0];
            let kappa = (g.a64.x_axis.length_squared()
                + g.a64.y_axis.length_squared()
                + g.a64.z_axis.length_squared())
            .sqrt();
            let p = peak(&s);
            for offset in [0.0, 2e-4, 1e-3] {
                let target = (p + glam::DVec3::new(offset, -offset, 0.5 * offset)).normalize();
                for depth in 5..21u32 {
                    let cell = cell_containing(target, depth - 1);
                    let r = g.children_reference(cell);
                    let parent: f64 = r.iter().map(|&v| v as f64).sum();
                    if parent < 1e-6 {
                        continue;
                    }
                    let err = |x: [f32; 4]| {
                        (0..4)
                            .map(|k| (x[k] as f64 - r[k] as f64).abs())
                            .fold(0.0, f64::max)
                            / parent
                    };
                    let dp = 2.0 * std::f64::consts::PI / (1u64 << depth) as f64 * kappa;
                    let b = (dp.log2().floor() + 16.0).clamp(0.0, 16.0) as usize;
                    cells[b] += 1;
                    poly[b] = poly[b].max(err(g.children_scalar(cell, 99)));
                    mid[b] = mid[b].max(err(g.children_deep(cell)));
                    used = used.max(err(g.children_scalar(cell, g.deep_depth)));
                }
            }
        }
    }
    println!("log2 δ' | max error f32 edge sum | max error density×Ω (relative to parent)");
    for b in 0..17 {
        println!(
            "{:>6} | {:>10.2e} | {:>10.2e}",
            b as i32 - 16,
            poly[b],
            mid[b]
        );
    }
    println!("with the switch at δ' = {DEFAULT_DEEP_CELL_SIZE}: max error {used:.2e}");
    // At the switch the midpoint rule must already beat the edge sum, and
    // one bucket coarser the edge sum must still be the better choice.
    let b = (f64::from(DEFAULT_DEEP_CELL_SIZE).log2().floor() + 16.0) as usize;
    // Empty buckets would compare 0 with 0 and pass whatever the kernels do.
    assert!(
        cells[b - 1] > 0 && cells[b + 2] > 0,
        "no cells measured about the switch: {cells:?}"
    );
    assert!(
        mid[b - 1] <= poly[b - 1] * 1.5 + 1e-6,
        "midpoint {} vs edges {}",
        mid[b - 1],
        poly[b - 1]
    );
    assert!(
        poly[b + 2] <= mid[b + 2],
        "edges {} vs midpoint {}",
        poly[b + 2],
        mid[b + 2]
    );
    assert!(used < 1e-3, "{used}");
}
