//! The Stokes quadrature of parallels (coarse children, levels 2–5)
//! against the true cells (f64 exact clipping of polygons with chords of
//! 1/4096 turn), next to the chord kernels it replaces.

mod ltc_common;

use glam::Vec3;
use ltc_common::*;
use ltcguide::directional::Cell;
use ltcguide::ltc::children::LtcOptions;
use ltcguide::ltc::children_x16;
use ltcguide::ltc::parallel_quadrature::node_counts;
use ltcguide::ltc::polygon::cell_integral_chords;
use ltcguide::math::Frame;
use ltcguide::sampling::Rng;

const TRUE_CELL_CHORD: f64 = 1.0 / 4096.0;

/// Every lobe glossy, Stokes quadrature on.
fn stokes() -> LtcOptions {
    LtcOptions {
        stokes_parallels: true,
        ..all_glossy()
    }
}

/// Errors relative to the parent's mass (floored at 1e-3 of the lobe),
/// over random lobes, frames (the polar axis among them) and coarse nodes,
/// of the Stokes children and of the chord children on the same nodes.
#[test]
fn stokes_children_match_the_true_cells_better_than_chords() {
    let mut rng = Rng::new(5, 11);
    let chords = all_glossy();
    let (mut worst, mut sum, mut chord_sum, mut chord_worst, mut count) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0usize);
    let mut by_level = [0usize; 4];
    for trial in 0..240 {
        let frame = if trial % 8 == 0 {
            Frame::from_normal(Vec3::Z)
        } else {
            random_frame(&mut rng)
        };
        let alpha = [0.01f32, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0][trial % 7];
        let theta = [0.0, 30.0, 60.0, 80.0, 89.9][trial % 5] + rng.next_f64() * 0.05;
        let s = shading(Some(alpha), theta, &frame, &stokes());
        let c = shading(Some(alpha), theta, &frame, &chords);
        let (g, gc) = (s.glossy[0], c.glossy[0]);
        for depth in 1..5u32 {
            let Some(_) = g.stokes_nodes_at(depth + 1) else {
                continue;
            };
            let m = 1u32 << depth;
            let cell = Cell {
                depth,
                ix: rng.next_u32() % m,
                iy: rng.next_u32() % m,
            };
            let o = g.orientation as f64;
            let want: [f64; 4] = std::array::from_fn(|k| {
                cell_integral_chords(cell.child(k), &g.a64, o, TRUE_CELL_CHORD)
            });
            let parent = want.iter().sum::<f64>().max(1e-3);
            let got = g.children_scalar(cell, 99);
            let old = gc.children_scalar(cell, 99);
            by_level[depth as usize - 1] += 1;
            for k in 0..4 {
                assert!(got[k].is_finite() && got[k] >= 0.0);
                let e = (got[k] as f64 - want[k]).abs() / parent;
                let ec = (old[k] as f64 - want[k]).abs() / parent;
                assert!(
                    e <= 5e-4,
                    "trial {trial} α {alpha} θ {theta:.1} {cell:?} child {k}: {} vs {}",
                    got[k],
                    want[k]
                );
                worst = worst.max(e);
                chord_worst = chord_worst.max(ec);
                sum += e;
                chord_sum += ec;
                count += 1;
            }
        }
    }
    let (mean, chord_mean) = (sum / count as f64, chord_sum / count as f64);
    println!(
        "Stokes vs true cells: {count} children (nodes per level 2–5: {by_level:?}), \
         worst {worst:.1e} mean {mean:.1e}; chords of 1/64 turn: worst {chord_worst:.1e} \
         mean {chord_mean:.1e}"
    );
    assert!(by_level.iter().all(|&n| n > 20), "{by_level:?}");
    assert!(mean * 10.0 < chord_mean, "{mean} vs {chord_mean}");
    assert!(worst < chord_worst, "{worst} vs {chord_worst}");
}

/// Node counts grow with the lobe's sharpness and shrink with depth, and
/// the sharpest lobes keep the chords at the coarsest levels.
#[test]
fn node_counts_follow_the_lobe_and_the_level() {
    let frame = tilted_frame();
    let opts = stokes();
    let mut previous = [0u32; 4];
    for (i, &alpha) in [1.0f32, 0.5, 0.3, 0.1, 0.03, 0.01, 1e-3].iter().enumerate() {
        let g = shading(Some(alpha), 45.0, &frame, &opts).glossy[0];
        let n = node_counts(&g.a64);
        assert_eq!(n, g.stokes_nodes);
        // 0 (chords) counts as infinitely many nodes.
        let eff = n.map(|n| if n == 0 { u32::MAX } else { n as u32 });
        for l in 1..4 {
            assert!(eff[l] <= eff[l - 1], "α {alpha}: {n:?}");
        }
        if i > 0 {
            for l in 0..4 {
                assert!(eff[l] >= previous[l], "α {alpha}: {n:?}");
            }
        }
        previous = eff;
    }
    let sharp = shading(Some(1e-3), 45.0, &frame, &opts).glossy[0];
    assert_eq!(sharp.stokes_nodes_at(2), None);
    let broad = shading(Some(0.5), 45.0, &frame, &opts).glossy[0];
    assert!(broad.stokes_nodes.iter().all(|&n| n > 0));
    let off = LtcOptions {
        stokes_parallels: false,
        ..opts
    };
    let chords = shading(Some(0.5), 45.0, &frame, &off).glossy[0];
    assert!((2..=5).all(|d| chords.stokes_nodes_at(d).is_none()));
}

/// Poles, the polar-axis normal (whose horizon is the equator, a parallel
/// of the grid) and grazing lobes stay finite and non-negative, and the
/// children of the root's children still sum to their parents' exact
/// integrals.
#[test]
fn stokes_children_are_finite_and_sum_to_their_parents() {
    let opts = stokes();
    let mut sums_checked = 0;
    for normal in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(1e-4, 0.0, 1.0)] {
        let frame = Frame::from_normal(normal.normalize());
        for &alpha in &[0.1f32, 0.3, 1.0] {
            for &theta in &[0.0, 45.0, 89.99] {
                let s = shading(Some(alpha), theta, &frame, &opts);
                let g = s.glossy[0];
                for depth in 1..5u32 {
                    let m = 1u32 << depth;
                    for ix in 0..m {
                        for iy in [0, m - 1] {
                            let cell = Cell { depth, ix, iy };
                            for v in [g.children_scalar(cell, 99), g.children_exact_f32(cell)] {
                                assert!(v.iter().all(|x| x.is_finite() && *x >= 0.0));
                            }
                        }
                    }
                }
                // Level 2 sums to level 1 (exact quarter spheres).
                for k in 0..4 {
                    let parent = Cell::ROOT.child(k);
                    let whole = g.children_scalar(Cell::ROOT, 99)[k] as f64;
                    let parts: f64 = g
                        .children_scalar(parent, 99)
                        .iter()
                        .map(|&x| x as f64)
                        .sum();
                    if g.stokes_nodes_at(2).is_some() {
                        sums_checked += 1;
                        assert!(
                            (parts - whole).abs() <= 2e-4,
                            "n {normal} α {alpha} θ {theta}: {parts} vs {whole}"
                        );
                    }
                }
            }
        }
    }
    // Lobes without Stokes nodes at level 2 skip the sum: some must not.
    assert!(
        sums_checked > 0,
        "no lobe's level 2 was checked against level 1"
    );
}

/// The wide kernel against the scalar one on every coarse node of broad
/// and medium lobes (many children across the horizon, so the crossing
/// path and its horizon arcs are compared too): lane for lane within 1e-5.
#[test]
fn stokes_wide_kernel_equals_scalar() {
    let mut rng = Rng::new(8, 3);
    let (mut compared, mut worst, mut stokes_nodes) = (0usize, 0.0f64, 0usize);
    for trial in 0..24 {
        let frame = if trial % 6 == 0 {
            Frame::from_normal(Vec3::Z)
        } else {
            random_frame(&mut rng)
        };
        let alpha = [0.05f32, 0.1, 0.3, 1.0][trial % 4];
        let s = shading(Some(alpha), 89.0 * rng.next_f64(), &frame, &stokes());
        let g = s.glossy[0];
        for depth in 1..5u32 {
            stokes_nodes += g.stokes_nodes_at(depth + 1).is_some() as usize;
            let m = 1u32 << depth;
            for ix in 0..m {
                for iy in 0..m {
                    let cell = Cell { depth, ix, iy };
                    let a = g.children_scalar(cell, 99);
                    let b = children_x16::children_x16(&g, cell, 99);
                    // Near-zero children are compared against their node, so that
                    // deep nodes (whole nodes of ~1e-12) are compared too.
                    let node: f64 = a.iter().map(|&v| v as f64).sum();
                    for k in 0..4 {
                        let rel = (a[k] as f64 - b[k] as f64).abs() / a[k].abs().max(1e-30) as f64;
                        if a[k] > 0.0 {
                            worst = worst.max(rel);
                        }
                        compared += 1;
                        assert!(
                            rel <= 1e-5
                                || ((a[k] - b[k]).abs() as f64) <= 1e-12f64.min(1e-5 * node),
                            "α {alpha} {cell:?} child {k}: scalar {} x16 {}",
                            a[k],
                            b[k]
                        );
                    }
                }
            }
        }
    }
    assert!(stokes_nodes > 60, "{stokes_nodes}");
    println!("Stokes x16 vs scalar: {compared} lanes, worst relative difference {worst:.2e}");
}
