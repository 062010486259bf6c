//! BSDF sampling against its pdf: a χ² test of every rough model and of
//! the bare microfacet reflection density, and a check that the test
//! rejects wrong pdfs.

mod bsdf_common;

use bsdf_common::*;
use glam::{Vec2, Vec3};
use ltcguide::bsdf::microfacet::Ggx;
use ltcguide::bsdf::{Bsdf, ConductorFresnel};
use ltcguide::math::reflect_local;
use ltcguide::sampling::Rng;
use ltcguide::stats::chi2::{Chi2Config, Chi2Outcome, SphereMap, chi2_square};

/// `chi2_sphere` with a cancellation-free square coordinate: the shared
/// `SphereMap::to_square` forms s = (1 − cos θ)/2 from an f32 cosine, which
/// quantises s in steps of 3e-8 and misbins samples of lobes narrower than
/// about 1e-3 rad once the map is sharpened. Here s = r²/(2(1 + z)) for the
/// upper half, exact for small angles; the density side is unchanged.
fn chi2_sphere(
    cfg: &Chi2Config,
    map: &SphereMap,
    mut sample: impl FnMut() -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f64,
) -> Chi2Outcome {
    let to_square = |d: Vec3| {
        let l = map.frame.to_local(d).as_dvec3();
        let r2 = l.x * l.x + l.y * l.y;
        let s = if l.z > 0.0 {
            r2 / (2.0 * (1.0 + l.z))
        } else {
            0.5 * (1.0 - l.z)
        };
        let u = s.clamp(0.0, 1.0).powf(1.0 / map.sharpness);
        let mut phi = l.y.atan2(l.x);
        if phi < 0.0 {
            phi += 2.0 * std::f64::consts::PI;
        }
        Vec2::new(u as f32, (phi / (2.0 * std::f64::consts::PI)) as f32)
    };
    chi2_square(
        cfg,
        || sample().map(to_square),
        |p| {
            let (d, jac) = map.from_square(p);
            pdf(d) * jac
        },
    )
}

/// The χ² map for a lobe of roughness `alpha` seen from `wo` (front side):
/// narrow lobes get a polar warp around the mirror direction so they cover
/// many bins; broad ones use the plain map around the normal, whose bin
/// edges then contain the horizon (a bin straddling the horizon near a
/// grazing mirror direction would otherwise hold a sliver of mass that the
/// quadrature can miss).
fn chi2_map(alpha: f32, wo: Vec3) -> (Vec3, f64) {
    match alpha {
        a if a <= 0.02 => (reflect_local(wo), 6.0),
        a if a <= 0.2 => (reflect_local(wo), 3.0),
        _ => (Vec3::Z, 1.0),
    }
}

/// Number of χ² tests in this file, for the Bonferroni correction:
/// (twosided) diffuse, four rough models × 4 α × 5 θ, the bare microfacet
/// reflection density (4 α × 3 θ).
const N_CHI2_TESTS: usize = 2 * 5 + 4 * 20 + 12;

fn chi2_config() -> Chi2Config {
    Chi2Config {
        res_x: 24,
        res_y: 32,
        samples: 150_000,
        significance: 0.01 / N_CHI2_TESTS as f64,
        min_expected: 5.0,
    }
}

/// Runs the χ² test of `bsdf.sample` against `bsdf.pdf` at `wo`, and checks
/// that the pdf integrates to the fraction of samples that were accepted
/// (1 unless directions are lost below the horizon).
fn check_sampling(name: &str, bsdf: &Bsdf, wo: Vec3, axis: Vec3, sharp: f64, seed: u64) {
    let cfg = chi2_config();
    let map = SphereMap::new(axis, sharp);
    let mut rng = Rng::new(seed, 17);
    let mut accepted = 0usize;
    let out = chi2_sphere(
        &cfg,
        &map,
        || {
            let s = bsdf.sample(wo, rng.next_f32(), rng.next_2d())?;
            assert!(!s.is_delta);
            accepted += 1;
            Some(s.wi)
        },
        |wi| bsdf.pdf(wo, wi) as f64,
    );
    let frac = accepted as f64 / cfg.samples as f64;
    eprintln!("{name}: {}", out.message);
    assert!(out.passed, "{name}: {}", out.message);
    // 5σ of the acceptance estimate plus quadrature slack.
    let tol = 5.0 * (frac * (1.0 - frac) / cfg.samples as f64).sqrt() + 2e-3;
    assert!(
        (out.pdf_integral - frac).abs() < tol,
        "{name}: ∫pdf = {} but {frac} of the samples were accepted",
        out.pdf_integral
    );
}

#[test]
fn chi2_diffuse_and_twosided_diffuse() {
    for (i, &th) in THETAS_DEG.iter().enumerate() {
        let wo = wo_at(th);
        check_sampling(
            &format!("diffuse θ={th}"),
            &diffuse(0.7, false),
            wo,
            Vec3::Z,
            1.0,
            i as u64,
        );
        // Two-sided, seen from the back: the lobe is mirrored below.
        check_sampling(
            &format!("twosided diffuse θ={th}"),
            &diffuse(0.7, true),
            flip(wo),
            -Vec3::Z,
            1.0,
            100 + i as u64,
        );
    }
}

#[test]
fn chi2_rough_conductor() {
    for (a, &alpha) in ALPHAS.iter().enumerate() {
        for (t, &th) in THETAS_DEG.iter().enumerate() {
            let wo = wo_at(th);
            check_sampling(
                &format!("roughconductor α={alpha} θ={th}"),
                &rough_conductor(alpha, gold(), false),
                wo,
                chi2_map(alpha, wo).0,
                chi2_map(alpha, wo).1,
                (a * 10 + t) as u64,
            );
        }
    }
}

#[test]
fn chi2_twosided_rough_conductor() {
    for (a, &alpha) in ALPHAS.iter().enumerate() {
        for (t, &th) in THETAS_DEG.iter().enumerate() {
            let wo = flip(wo_at(th));
            check_sampling(
                &format!("twosided roughconductor α={alpha} θ={th}"),
                &rough_conductor(alpha, ConductorFresnel::None, true),
                wo,
                flip(chi2_map(alpha, flip(wo)).0),
                chi2_map(alpha, flip(wo)).1,
                (500 + a * 10 + t) as u64,
            );
        }
    }
}

#[test]
fn chi2_rough_plastic() {
    for (a, &alpha) in ALPHAS.iter().enumerate() {
        for (t, &th) in THETAS_DEG.iter().enumerate() {
            let wo = wo_at(th);
            check_sampling(
                &format!("roughplastic α={alpha} θ={th}"),
                &rough_plastic(alpha, 0.5, false),
                wo,
                chi2_map(alpha, wo).0,
                chi2_map(alpha, wo).1,
                (1000 + a * 10 + t) as u64,
            );
        }
    }
}

#[test]
fn chi2_twosided_rough_plastic() {
    for (a, &alpha) in ALPHAS.iter().enumerate() {
        for (t, &th) in THETAS_DEG.iter().enumerate() {
            let wo = flip(wo_at(th));
            check_sampling(
                &format!("twosided roughplastic α={alpha} θ={th}"),
                &rough_plastic(alpha, 0.3, true),
                wo,
                flip(chi2_map(alpha, flip(wo)).0),
                chi2_map(alpha, flip(wo)).1,
                (2000 + a * 10 + t) as u64,
            );
        }
    }
}

#[test]
fn chi2_rejects_wrong_pdfs() {
    let cfg = Chi2Config {
        significance: 0.01 / N_CHI2_TESTS as f64,
        ..chi2_config()
    };
    let wo = wo_at(30.0);
    let bsdf = rough_conductor(0.5, ConductorFresnel::None, false);
    let map = SphereMap::new(reflect_local(wo), 1.5);
    // A slightly wrong roughness.
    let wrong_alpha = rough_conductor(0.55, ConductorFresnel::None, false);
    let mut rng = Rng::new(9, 9);
    let out = chi2_sphere(
        &cfg,
        &map,
        || bsdf.sample(wo, rng.next_f32(), rng.next_2d()).map(|s| s.wi),
        |wi| wrong_alpha.pdf(wo, wi) as f64,
    );
    assert!(
        !out.passed,
        "α 0.55 pdf accepted for α 0.5: {}",
        out.message
    );
    // The classic mistake: the pdf of sampling D(m) cos θ_m instead of the
    // visible normals.
    let g = Ggx::new(0.5);
    let out = chi2_sphere(
        &cfg,
        &map,
        || bsdf.sample(wo, rng.next_f32(), rng.next_2d()).map(|s| s.wi),
        |wi| {
            if wi.z <= 0.0 {
                return 0.0;
            }
            let h = (wo + wi).normalize();
            (g.d(h) * h.z / (4.0 * wi.dot(h))) as f64
        },
    );
    assert!(
        !out.passed,
        "D·cos pdf accepted for VNDF sampling: {}",
        out.message
    );
}

#[test]
fn microfacet_reflection_density_integrates_to_one() {
    // Without the horizon cut nothing is lost: the reflected VNDF density
    // is normalised over the whole sphere.
    let cfg = chi2_config();
    for &alpha in &ALPHAS {
        for &th in &[0.0f32, 60.0, 89.0] {
            let g = Ggx::new(alpha);
            let wo = wo_at(th);
            let mut rng = Rng::new(77, 3);
            let out = chi2_sphere(
                &cfg,
                &SphereMap::new(chi2_map(alpha, wo).0, chi2_map(alpha, wo).1),
                || Some(g.sample_reflection(wo, rng.next_2d())),
                |wi| g.reflection_pdf(wo, wi) as f64,
            );
            assert!(out.passed, "α={alpha} θ={th}: {}", out.message);
            assert!(
                (out.pdf_integral - 1.0).abs() < 3e-3,
                "α={alpha} θ={th}: {}",
                out.message
            );
        }
    }
}
