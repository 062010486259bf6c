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
            for (k, got) in got.iter().enumerate() {
                let exact = cell_form_factor(cell.child(k));
                let err = (got.as_dvec3() - exact).length() / exact.length();
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
            for (k, got) in got.iter().enumerate() {
                let exact = cell_form_factor(cell.child(k));
                assert!(
                    (got.as_dvec3() - exact).length() <= 1e-5 * exact.length(),
                    "{cell:?}"
                );
            }
        }
    }
    println!("f32 Gauss form factors, depths 6..20: max relative error {worst:.2e}");
    assert!(worst < 2e-5, "{worst}");
}

/// The lune form of the cosine lobe's quarter-sphere integrals against the
/// f64 reference (exact clipping): exact at n_x = 0, second order in n_x
/// (the first-order term cancels by the cells' x ↦ −x symmetry), so it is
/// accurate where the triangle form of `level1` is not.
#[test]
fn cosine_quarter_spheres_near_lune_is_second_order_in_n_x() {
    use glam::DMat3;
    use ltcguide::ltc::form_factor::cosine_quarter_spheres_near_lune;
    use ltcguide::ltc::polygon::cell_integral_reference;
    use ltcguide::math::Frame;
    let mut rng = Rng::new(5, 1);
    let mut worst = [0.0f64; 5];
    let eps: [f64; 5] = [0.0, 1e-4, 1e-3, 4e-3, 1e-2];
    for i in 0..200 {
        // Include the axes themselves (n = ±y, ±z) among the normals.
        let beta = if i < 4 {
            i as f64 * PI / 2.0
        } else {
            2.0 * PI * rng.next_f64()
        };
        for (j, &e) in eps.iter().enumerate() {
            let s = (1.0 - e * e).sqrt();
            let n = DVec3::new(
                if i % 2 == 0 { e } else { -e },
                s * beta.cos(),
                s * beta.sin(),
            );
            let frame = Frame::from_normal(n.as_vec3());
            let to_local =
                DMat3::from_cols(frame.s.as_dvec3(), frame.t.as_dvec3(), frame.n.as_dvec3())
                    .transpose();
            let o = to_local.determinant().signum();
            let lune = cosine_quarter_spheres_near_lune(n.as_vec3());
            let mut sum = 0.0;
            for (k, &l) in lune.iter().enumerate() {
                assert!(l.is_finite() && l >= 0.0, "{lune:?}");
                let r = cell_integral_reference(Cell::ROOT.child(k), &to_local, o);
                worst[j] = worst[j].max((l as f64 - r).abs());
                sum += l as f64;
            }
            assert!((sum - 1.0).abs() < 1e-5, "children sum {sum}");
        }
    }
    eprintln!("worst |lune − exact| by n_x {eps:?}: {worst:?}");
    assert!(worst[0] < 2e-6, "{worst:?}");
    // Second order: 10× smaller n_x, ≥ 50× smaller error (above f32 noise).
    assert!(worst[2] < 5e-6 + worst[4] / 50.0, "{worst:?}");
    assert!(worst[3] < 3e-5, "{worst:?}");
}

/// The irradiance shares of the root cells (radiance guiding's adjoint
/// weights), in closed form: equal to the f64 exactly clipped cosine
/// integrals within 5e-7 at random normals, at the axes (signed zeros
/// included) and as n_x → 0 (down to 1e-30, where the cells tend to lunes
/// and the mapped-triangle form had to clip polygons), non-negative, and
/// summing to 1 within 1e-6. (Measured worst: printed; 8.7e-8 at first.)
#[test]
fn cosine_root_children_are_the_exact_quarter_sphere_shares() {
    use glam::DMat3;
    use ltcguide::ltc::form_factor::cosine_root_children;
    use ltcguide::ltc::polygon::cell_integral_reference;
    use ltcguide::math::Frame;
    let mut rng = Rng::new(8, 4);
    let mut normals: Vec<DVec3> = vec![
        DVec3::X,
        -DVec3::X,
        DVec3::Y,
        -DVec3::Z,
        DVec3::new(4e-3, 0.6, 0.8),
        DVec3::new(-3.9e-3, -0.8, 0.6),
        DVec3::new(4.1e-3, 0.0, 1.0),
        DVec3::new(0.0, -0.0, 1.0),
        DVec3::new(-0.0, 1.0, 0.0),
        DVec3::new(0.0, 0.0, -1.0),
        DVec3::new(1e-30, 0.0, 1.0),
        DVec3::new(-1e-30, -1.0, 0.0),
    ];
    for e in [1e-7f64, 1e-5, 1e-3, 0.02, 0.049, 0.051] {
        for beta in [0.3f64, 2.0, 3.9, 5.5] {
            let s = (1.0 - e * e).sqrt();
            normals.push(DVec3::new(e, s * beta.cos(), s * beta.sin()));
            normals.push(DVec3::new(-e, s * beta.sin(), s * beta.cos()));
        }
    }
    for _ in 0..300 {
        let z = 2.0 * rng.next_f64() - 1.0;
        let phi = 2.0 * PI * rng.next_f64();
        let r = (1.0 - z * z).sqrt();
        normals.push(DVec3::new(r * phi.cos(), r * phi.sin(), z));
    }
    let mut worst = 0.0f64;
    for n in normals {
        let n = n.normalize();
        let frame = Frame::from_normal(n.as_vec3());
        let to_local = DMat3::from_cols(frame.s.as_dvec3(), frame.t.as_dvec3(), frame.n.as_dvec3())
            .transpose();
        let o = to_local.determinant().signum();
        let shares = cosine_root_children(n.as_vec3());
        let mut sum = 0.0;
        for (k, &s) in shares.iter().enumerate() {
            assert!(s.is_finite() && s >= 0.0, "{n:?}: {shares:?}");
            let exact = cell_integral_reference(Cell::ROOT.child(k), &to_local, o);
            worst = worst.max((s as f64 - exact).abs());
            sum += s as f64;
        }
        assert!((sum - 1.0).abs() < 1e-6, "{n:?}: shares sum to {sum}");
    }
    eprintln!("worst |share − exact| {worst:.2e}");
    assert!(worst < 5e-7, "{worst}");
}
