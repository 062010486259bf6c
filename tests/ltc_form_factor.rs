//! Exact cylindrical-cell form factors against Monte Carlo over the cells,
//! the precomputed levels against the closed form, and the f32 hot-path
//! form factors against the closed form at every depth.

use glam::DVec3;
use ltcguide::directional::Cell;
use ltcguide::ltc::form_factor::{PRECOMPUTED_DEPTH, cell_form_factor, form_factor};
use ltcguide::sampling::Rng;
use std::f64::consts::PI;

fn mc_form_factor(cell: Cell, n: usize, rng: &mut Rng) -> DVec3 {
    let (u0, v0, size) = cell.square_bounds();
    let mut sum = DVec3::ZERO;
    for _ in 0..n {
        let z = 2.0 * (u0 + size * rng.next_f64()) - 1.0;
        let phi = 2.0 * PI * (v0 + size * rng.next_f64());
        let r = (1.0 - z * z).max(0.0).sqrt();
        sum += DVec3::new(r * phi.cos(), r * phi.sin(), z);
    }
    sum / n as f64 * cell.solid_angle() / PI
}

#[test]
fn closed_form_matches_monte_carlo() {
    let mut rng = Rng::new(11, 2);
    for cell in [
        Cell {
            depth: 1,
            ix: 1,
            iy: 0,
        },
        Cell {
            depth: 1,
            ix: 0,
            iy: 1,
        },
        Cell {
            depth: 2,
            ix: 3,
            iy: 2,
        },
        Cell {
            depth: 3,
            ix: 0,
            iy: 5,
        },
        Cell {
            depth: 4,
            ix: 9,
            iy: 13,
        },
    ] {
        let exact = cell_form_factor(cell);
        let mc = mc_form_factor(cell, 400_000, &mut rng);
        let tol = 5e-3 * cell.solid_angle() / PI;
        assert!((exact - mc).length() < tol, "{cell:?}: {exact:?} vs {mc:?}");
    }
    // The upper hemisphere's F is +z with length 1 (DESIGN §2 normalisation).
    let up = cell_form_factor(Cell {
        depth: 1,
        ix: 1,
        iy: 0,
    }) + cell_form_factor(Cell {
        depth: 1,
        ix: 1,
        iy: 1,
    });
    assert!((up - DVec3::Z).length() < 1e-12, "{up:?}");
}

#[test]
fn precomputed_levels_equal_the_closed_form_and_children_sum() {
    for depth in 0..=PRECOMPUTED_DEPTH {
        let n = 1 << depth;
        for iy in (0..n).step_by(3) {
            for ix in 0..n {
                let cell = Cell { depth, ix, iy };
                let exact = cell_form_factor(cell);
                let tab = form_factor(cell).as_dvec3();
                assert!((exact - tab).length() < 1e-7, "{cell:?}");
                let kids: DVec3 = (0..4).map(|k| cell_form_factor(cell.child(k))).sum();
                assert!((kids - exact).length() < 1e-12, "{cell:?}");
            }
        }
    }
}

#[test]
fn f32_children_form_factors_match_the_closed_form_at_every_depth() {
    use ltcguide::ltc::form_factor::children_form_factors_f32;
    let mut rng = Rng::new(4, 4);
    let mut worst = 0.0f64;
    for depth in 5..20u32 {
        let n = 1u32 << depth;
        for _ in 0..50 {
            let cell = Cell {
                depth,
                ix: rng.next_u32() % n,
                iy: rng.next_u32() % n,
            };
            let got = children_form_factors_f32(cell);
            for k in 0..4 {
                let exact = cell_form_factor(cell.child(k));
                let err = (got[k].as_dvec3() - exact).length() / exact.length();
                worst = worst.max(err);
            }
        }
        // Both poles.
        for ix in [0, n - 1] {
            let cell = Cell {
                depth,
                ix,
                iy: 3 % n,
            };
            let got = children_form_factors_f32(cell);
            for k in 0..4 {
                let exact = cell_form_factor(cell.child(k));
                assert!(
                    (got[k].as_dvec3() - exact).length() <= 1e-5 * exact.length(),
                    "{cell:?}"
                );
            }
        }
    }
    println!("f32 Gauss form factors, depths 6..20: max relative error {worst:.2e}");
    assert!(worst < 2e-5, "{worst}");
}
