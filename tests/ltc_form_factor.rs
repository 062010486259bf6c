//! Exact cylindrical-cell form factors against Monte Carlo over the cells,
//! the precomputed levels against the closed form, and the midpoint rule's
//! error at the depth where it takes over.

use glam::DVec3;
use ltcguide::directional::Cell;
use ltcguide::ltc::form_factor::{
    MIDPOINT_DEPTH, MIDPOINT_POLE_MARGIN, PRECOMPUTED_DEPTH, cell_form_factor,
    cell_form_factor_midpoint, form_factor, uses_midpoint,
};
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
fn midpoint_rule_is_accurate_where_it_takes_over() {
    let mut worst = 0.0f64;
    let n = 1u32 << MIDPOINT_DEPTH;
    let m = MIDPOINT_POLE_MARGIN;
    for &(ix, iy) in &[
        (0, 0),
        (m, 7),
        (n - 1 - m, 7),
        (n / 2, n / 3),
        (n / 7, n - 1),
        (1, 1),
        (n - 1, 5),
    ] {
        let cell = Cell {
            depth: MIDPOINT_DEPTH,
            ix,
            iy,
        };
        let exact = cell_form_factor(cell);
        // What the runtime uses: midpoint away from the poles, closed form near them.
        let used = form_factor(cell).as_dvec3();
        worst = worst.max((exact - used).length() / exact.length());
        if uses_midpoint(cell) {
            let mid = cell_form_factor_midpoint(cell);
            assert!((exact - mid).length() / exact.length() < 1e-6, "{cell:?}");
        }
    }
    println!("midpoint form factor at depth {MIDPOINT_DEPTH}: max relative error {worst:.2e}");
    assert!(worst < 1e-6, "{worst}"); // f32 storage of the result dominates
}
