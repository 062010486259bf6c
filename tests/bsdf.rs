//! BSDF properties: consistency of sample/eval/pdf, normalisation, white
//! furnace, Mitsuba check values, reciprocity, one-sidedness and numerical
//! robustness. Sampling against the pdf (χ²) is in `bsdf_chi2.rs`.

mod bsdf_common;

use bsdf_common::*;
use glam::{Vec2, Vec3};
use ltcguide::bsdf::microfacet::ggx_cos;
use ltcguide::bsdf::plastic::RoughPlastic;
use ltcguide::bsdf::{Bsdf, BsdfModel, ConductorFresnel, Material, MaterialKind};
use ltcguide::math::{PI, Spectrum, luminance, reflect_local, spherical_direction};
use ltcguide::sampling::{Rng, square_to_uniform_sphere};
use ltcguide::texture::Texture;

/// Every non-delta BSDF under test, with a label.
fn non_delta_bsdfs() -> Vec<(String, Bsdf)> {
    let mut v = vec![
        ("diffuse".to_string(), diffuse(0.6, false)),
        ("twosided diffuse".to_string(), diffuse(0.6, true)),
        ("plastic".to_string(), plastic(0.6)),
    ];
    for &a in &ALPHAS {
        v.push((
            format!("roughconductor {a}"),
            rough_conductor(a, gold(), false),
        ));
        v.push((
            format!("twosided roughconductor {a}"),
            rough_conductor(a, ConductorFresnel::None, true),
        ));
        v.push((format!("roughplastic {a}"), rough_plastic(a, 0.6, false)));
        v.push((
            format!("twosided roughplastic {a}"),
            rough_plastic(a, 0.6, true),
        ));
    }
    v
}

fn random_dir(rng: &mut Rng) -> Vec3 {
    square_to_uniform_sphere(rng.next_2d())
}

#[test]
fn sample_pdf_and_weight_match_pdf_and_eval() {
    let mut rng = Rng::new(4, 4);
    for (name, b) in non_delta_bsdfs() {
        let mut non_delta = 0;
        for _ in 0..4000 {
            let wo = random_dir(&mut rng);
            let Some(s) = b.sample(wo, rng.next_f32(), rng.next_2d()) else {
                continue;
            };
            assert!(s.pdf > 0.0 && s.pdf.is_finite(), "{name}");
            if s.is_delta {
                continue;
            }
            non_delta += 1;
            let pdf = b.pdf(wo, s.wi);
            assert!(
                (s.pdf - pdf).abs() <= 1e-5 * pdf,
                "{name}: sample pdf {} vs pdf {pdf}",
                s.pdf
            );
            let expect = b.eval(wo, s.wi) / pdf;
            let err = (s.weight - expect).abs().max_element();
            assert!(
                err <= 1e-4 * expect.max_element().max(1.0),
                "{name}: {:?} vs {expect:?}",
                s.weight
            );
        }
        assert!(
            non_delta > 500,
            "{name}: only {non_delta} non-delta samples"
        );
    }
}

/// Directional albedo ∫ f cos dω at `wo` by BSDF sampling and by uniform
/// sphere sampling: (mean, standard error) for each.
fn albedo_two_ways(b: &Bsdf, wo: Vec3, n: usize, seed: u64) -> ((f64, f64), (f64, f64)) {
    let mut rng = Rng::new(seed, 5);
    let stats = |xs: &mut dyn FnMut() -> f64| {
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            let x = xs();
            s += x;
            s2 += x * x;
        }
        let m = s / n as f64;
        (m, ((s2 / n as f64 - m * m).max(0.0) / n as f64).sqrt())
    };
    let bs = stats(&mut || {
        b.sample(wo, rng.next_f32(), rng.next_2d())
            .map_or(0.0, |s| luminance(s.weight) as f64)
    });
    let un = stats(&mut || {
        let wi = square_to_uniform_sphere(rng.next_2d());
        luminance(b.eval(wo, wi)) as f64 * 4.0 * PI as f64
    });
    (bs, un)
}

#[test]
fn white_furnace_diffuse_and_rough_mirror() {
    let b = diffuse(1.0, false);
    for &th in &[0.0f32, 45.0, 80.0] {
        let ((m1, e1), (m2, e2)) = albedo_two_ways(&b, wo_at(th), 200_000, 1);
        assert!(
            (m1 - 1.0).abs() < 1e-5 && e1 < 1e-5,
            "diffuse BSDF-sampled albedo {m1}"
        );
        assert!(
            (m2 - 1.0).abs() < 5.0 * e2,
            "diffuse uniform albedo {m2} ± {e2}"
        );
    }
    for &alpha in &[0.2f32, 0.5, 1.0] {
        for &th in &[0.0f32, 60.0, 85.0] {
            let b = rough_conductor(alpha, ConductorFresnel::None, false);
            let ((m1, e1), (m2, e2)) = albedo_two_ways(&b, wo_at(th), 400_000, 2);
            let tol = 5.0 * (e1 * e1 + e2 * e2).sqrt();
            assert!(
                (m1 - m2).abs() < tol,
                "α={alpha} θ={th}: {m1}±{e1} vs {m2}±{e2}"
            );
            // Single-scattering GGX loses much energy when rough (≈0.3 at α = 1).
            assert!(
                m1 <= 1.0 + 5.0 * e1 && m1 > 0.2,
                "α={alpha} θ={th}: albedo {m1}"
            );
        }
    }
    // As α → 0 shadowing vanishes and the rough mirror reflects everything.
    let mut last = 0.0;
    for &alpha in &[0.3f32, 0.1, 0.01, 0.001] {
        let b = rough_conductor(alpha, ConductorFresnel::None, false);
        let ((m, _), _) = albedo_two_ways(&b, wo_at(30.0), 100_000, 3);
        assert!(
            m <= 1.0 + 1e-4 && m >= last - 1e-3,
            "α={alpha}: {m} after {last}"
        );
        last = m;
    }
    assert!(last > 0.999, "α=0.001 albedo {last}");
    // The guiding lobe GGX_cos is the same function with R = F = 1.
    let b = rough_conductor(0.3, ConductorFresnel::None, false);
    let mut rng = Rng::new(5, 5);
    for _ in 0..1000 {
        let (wo, wi) = (random_dir(&mut rng), random_dir(&mut rng));
        let a = b.eval(wo, wi).x;
        let g = ggx_cos(0.3, wo, wi);
        assert!((a - g).abs() <= 1e-5 * g.max(1.0), "{a} vs {g}");
    }
}

fn diffuse_albedo_numeric(p: &RoughPlastic, wo: Vec3) -> f64 {
    // ∫ f_d cos dω over the hemisphere; f_d depends on θ_i only.
    let n = 20_000;
    let mut s = 0.0f64;
    for i in 0..n {
        let mu = (i as f32 + 0.5) / n as f32;
        let wi = spherical_direction(mu, 0.0);
        s += p.eval_diffuse(wo, wi).x as f64 / mu as f64 * mu as f64;
    }
    // dω = dμ dφ, and eval already holds one factor of μ.
    s * 2.0 * std::f64::consts::PI / n as f64
}

fn rough_plastic_parts(b: &Bsdf) -> RoughPlastic {
    match b.model {
        BsdfModel::RoughPlastic(p) => p,
        _ => unreachable!(),
    }
}

#[test]
fn mitsuba_roughplastic_diffuse_check_values() {
    // README: ρ = 0.8, η = 1.5, normal viewing: Mitsuba's diffuse part
    // reflects 0.695 at α = 0.1 and 0.605 at α = 0.2 (the 1 − F shortcut
    // would give about 0.75).
    for &(alpha, expect) in &[(0.1f32, 0.695f64), (0.2, 0.605)] {
        let b = rough_plastic(alpha, 0.8, false);
        let p = rough_plastic_parts(&b);
        let got = diffuse_albedo_numeric(&p, Vec3::Z);
        assert!(
            (got - expect).abs() <= 0.005,
            "α={alpha}: {got} vs Mitsuba {expect}"
        );
        // The guiding lobe weight carries exactly that energy.
        let l = b.lobes(Vec3::Z);
        assert!(
            (l.diffuse as f64 - got).abs() < 1e-3,
            "lobe {} vs {got}",
            l.diffuse
        );
        eprintln!("roughplastic α={alpha}: diffuse albedo {got:.4} (Mitsuba {expect})");
    }
}

#[test]
fn roughplastic_diffuse_lobe_weight_is_the_diffuse_albedo() {
    for &alpha in &[0.05f32, 0.3] {
        let b = rough_plastic(alpha, 0.6, false);
        let p = rough_plastic_parts(&b);
        for &th in &[0.0f32, 40.0, 75.0] {
            let wo = wo_at(th);
            let got = diffuse_albedo_numeric(&p, wo);
            let l = b.lobes(wo);
            assert!(
                (l.diffuse as f64 - got).abs() < 1e-3 * got.max(0.1),
                "{} vs {got}",
                l.diffuse
            );
            let f = ltcguide::bsdf::fresnel::fresnel_dielectric_r(wo.z, 1.5);
            assert_eq!(l.ggx_count, 1);
            assert!((l.ggx[0].weight - f).abs() < 1e-6 && l.ggx[0].alpha == alpha);
        }
    }
}

#[test]
fn fresnel_check_values() {
    // Conductor at normal incidence: ((η−1)² + k²)/((η+1)² + k²) per channel.
    let (eta, k) = match gold() {
        ConductorFresnel::Complex { eta, k } => (eta, k),
        _ => unreachable!(),
    };
    let expect = ((eta - 1.0) * (eta - 1.0) + k * k) / ((eta + 1.0) * (eta + 1.0) + k * k);
    let m = Material::new(
        MaterialKind::Conductor {
            fresnel: gold(),
            specular_reflectance: c(1.0),
        },
        false,
    )
    .unwrap()
    .at(Vec2::ZERO);
    let s = m.sample(Vec3::Z, 0.5, Vec2::splat(0.5)).unwrap();
    assert!(s.is_delta && s.wi.z > 0.999);
    assert!(
        (s.weight - expect).abs().max_element() < 1e-5,
        "{:?} vs {expect:?}",
        s.weight
    );
    // Copper-like values as a second case, via the rough model's lobe weight.
    let cu = ConductorFresnel::Complex {
        eta: Spectrum::new(0.200, 0.924, 1.102),
        k: Spectrum::new(3.912, 2.452, 2.142),
    };
    let (e, kk) = (
        Spectrum::new(0.200, 0.924, 1.102),
        Spectrum::new(3.912, 2.452, 2.142),
    );
    let f0 = ((e - 1.0) * (e - 1.0) + kk * kk) / ((e + 1.0) * (e + 1.0) + kk * kk);
    let l = rough_conductor(0.2, cu, false).lobes(Vec3::Z);
    assert!((l.ggx[0].weight - luminance(f0)).abs() < 1e-5);

    // Dielectric at normal incidence: ((η−1)/(η+1))² = 0.04 for η = 1.5.
    let glass = Material::new(MaterialKind::Dielectric { eta: 1.5 }, false)
        .unwrap()
        .at(Vec2::ZERO);
    let r = glass.sample(Vec3::Z, 0.0, Vec2::ZERO).unwrap();
    assert!((r.pdf - 0.04).abs() < 1e-6 && r.wi.z > 0.0, "{r:?}");
    // Thin sheet: R' = 2R/(1 + R).
    let thin = Material::new(MaterialKind::ThinDielectric { eta: 1.5 }, false)
        .unwrap()
        .at(Vec2::ZERO);
    let r = thin.sample(Vec3::Z, 0.0, Vec2::ZERO).unwrap();
    assert!((r.pdf - 0.08 / 1.04).abs() < 1e-6, "{r:?}");
    let t = thin.sample(wo_at(40.0), 0.9999, Vec2::ZERO).unwrap();
    assert!((t.wi + wo_at(40.0)).length() < 1e-6 && t.weight == Spectrum::ONE);
}

#[test]
fn dielectric_reflect_plus_transmit_conserves_energy() {
    for &eta in &[1.5f32, 1.33, 2.4] {
        let glass = Material::new(MaterialKind::Dielectric { eta }, false)
            .unwrap()
            .at(Vec2::ZERO);
        for i in 0..90 {
            for side in [1.0f32, -1.0] {
                let th = (i as f32 + 0.5).to_radians();
                let wo = Vec3::new(th.sin(), 0.0, side * th.cos());
                let r = glass.sample(wo, 0.0, Vec2::ZERO).unwrap();
                let t = glass.sample(wo, 0.999_999, Vec2::ZERO);
                let p_t = t.filter(|t| t.wi.z * wo.z < 0.0).map_or(0.0, |t| t.pdf);
                assert!(
                    (r.pdf + p_t - 1.0).abs() < 1e-5,
                    "η={eta} θ={i} side {side}"
                );
                assert!(r.is_delta && r.weight == Spectrum::ONE && r.wi.z * wo.z > 0.0);
                if let Some(t) = t.filter(|t| t.wi.z * wo.z < 0.0) {
                    // Snell: η_o sinθ_o = η_i sinθ_i, and (η_o/η_i)² radiance scaling.
                    let (n_o, n_i) = if side > 0.0 { (1.0, eta) } else { (eta, 1.0) };
                    let sin_i = (t.wi.x * t.wi.x + t.wi.y * t.wi.y).sqrt();
                    assert!((n_o * th.sin() - n_i * sin_i).abs() < 1e-5);
                    let scale = (n_o / n_i) * (n_o / n_i);
                    assert!((t.weight.x - scale).abs() < 1e-5 && (t.eta - n_i / n_o).abs() < 1e-5);
                    assert!((t.wi.length() - 1.0).abs() < 1e-5);
                } else {
                    // Only total internal reflection may have no transmission.
                    assert!(side < 0.0 && eta * th.sin() >= 1.0 - 1e-4, "η={eta} θ={i}");
                }
            }
        }
    }
}

#[test]
fn reflective_models_are_reciprocal_and_one_sided() {
    let mut rng = Rng::new(8, 8);
    for (name, b) in non_delta_bsdfs() {
        for _ in 0..2000 {
            let (wo, wi) = (random_dir(&mut rng), random_dir(&mut rng));
            let f_ab = b.eval(wo, wi);
            let f_ba = b.eval(wi, wo);
            if wo.z.abs() > 1e-3 && wi.z.abs() > 1e-3 {
                let lhs = f_ab / wi.z.abs();
                let rhs = f_ba / wo.z.abs();
                let err = (lhs - rhs).abs().max_element();
                assert!(
                    err <= 2e-4 * lhs.max_element().max(1e-2),
                    "{name}: {lhs:?} vs {rhs:?}"
                );
            }
            if !b.two_sided {
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    assert_eq!(f_ab, Spectrum::ZERO, "{name}");
                    assert_eq!(b.pdf(wo, wi), 0.0, "{name}");
                }
                if wo.z <= 0.0 {
                    assert!(b.sample(wo, 0.5, rng.next_2d()).is_none(), "{name}");
                }
            } else {
                // Mirrored: the back looks like the front, and never transmits.
                let m = b.eval(flip(wo), flip(wi));
                assert!((m - f_ab).abs().max_element() <= 1e-6 * f_ab.max_element().max(1e-3));
                if wo.z * wi.z < 0.0 {
                    assert_eq!(f_ab, Spectrum::ZERO, "{name}");
                }
                let l = b.lobes(wo);
                assert_eq!(l.side, if wo.z < 0.0 { -1.0 } else { 1.0 });
            }
        }
    }
}

#[test]
fn stiff_parameters_stay_finite_and_non_negative() {
    let mut all: Vec<Bsdf> = Vec::new();
    for &alpha in &[1e-4f32, 0.0, 1.0] {
        all.push(rough_conductor(alpha, gold(), true));
        all.push(rough_conductor(alpha, ConductorFresnel::None, false));
        all.push(rough_plastic(alpha, 0.9, true));
    }
    all.push(diffuse(1.0, true));
    all.push(plastic(0.9));
    for eta in [1.5f32, 0.5] {
        for kind in [
            MaterialKind::Dielectric { eta },
            MaterialKind::ThinDielectric { eta },
        ] {
            all.push(Material::new(kind, false).unwrap().at(Vec2::ZERO));
        }
    }
    let ok = |v: Spectrum| v.is_finite() && v.min_element() >= 0.0;
    let mut rng = Rng::new(6, 6);
    let grazing = 89.99f32.to_radians();
    let wos = [
        Vec3::new(grazing.sin(), 0.0, grazing.cos()),
        Vec3::new(0.0, grazing.sin(), -grazing.cos()),
        Vec3::Z,
        -Vec3::Z,
        Vec3::X,
        Vec3::new(1.0, 0.0, 1e-7).normalize(),
    ];
    for b in &all {
        for &wo in &wos {
            let l = b.lobes(wo);
            assert!(l.diffuse >= 0.0 && l.delta >= 0.0 && l.ggx[0].weight >= 0.0);
            assert!(l.diffuse.is_finite() && l.delta.is_finite() && l.ggx[0].weight.is_finite());
            assert!(b.albedo_estimate(wo).is_finite());
            let mut wis = vec![reflect_local(wo), Vec3::Z, -wo, wos[0], wos[1]];
            for _ in 0..200 {
                wis.push(random_dir(&mut rng));
            }
            for wi in wis {
                let (e, p) = (b.eval(wo, wi), b.pdf(wo, wi));
                assert!(
                    ok(e) && p.is_finite() && p >= 0.0,
                    "{b:?} {wo:?} {wi:?}: {e:?} {p}"
                );
            }
            for _ in 0..2000 {
                if let Some(s) = b.sample(wo, rng.next_f32(), rng.next_2d()) {
                    assert!(
                        ok(s.weight) && s.pdf.is_finite() && s.pdf > 0.0,
                        "{b:?} {wo:?} {s:?}"
                    );
                    assert!((s.wi.length() - 1.0).abs() < 1e-3, "{s:?}");
                }
            }
            // Corner samples of the unit square.
            for u in [
                Vec2::ZERO,
                Vec2::new(0.0, 0.999_999_9),
                Vec2::splat(0.999_999_9),
            ] {
                for ul in [0.0f32, 0.999_999_9] {
                    if let Some(s) = b.sample(wo, ul, u) {
                        assert!(ok(s.weight) && s.pdf.is_finite() && s.pdf > 0.0, "{s:?}");
                    }
                }
            }
        }
    }
}

#[test]
fn constructor_validates_and_lobes_classify() {
    let bad = [
        MaterialKind::RoughConductor {
            alpha: f32::NAN,
            fresnel: ConductorFresnel::None,
            specular_reflectance: c(1.0),
        },
        MaterialKind::RoughPlastic {
            alpha: -0.1,
            eta: 1.5,
            diffuse_reflectance: c(0.5),
        },
        MaterialKind::RoughPlastic {
            alpha: 0.1,
            eta: f32::INFINITY,
            diffuse_reflectance: c(0.5),
        },
        MaterialKind::Plastic {
            eta: 1.0,
            diffuse_reflectance: c(0.5),
        },
        MaterialKind::Dielectric { eta: -1.5 },
        MaterialKind::Diffuse {
            reflectance: c(f32::NAN),
        },
        MaterialKind::Conductor {
            fresnel: ConductorFresnel::Complex {
                eta: Spectrum::splat(f32::NAN),
                k: Spectrum::ONE,
            },
            specular_reflectance: c(1.0),
        },
    ];
    for kind in bad {
        assert!(
            Material::new(kind.clone(), false).is_err(),
            "{kind:?} accepted"
        );
    }
    assert!(Material::new(MaterialKind::Dielectric { eta: 1.5 }, true).is_err());

    // Textures are resolved at uv.
    let checker = Material::new(
        MaterialKind::Diffuse {
            reflectance: Texture::Checkerboard {
                color0: Spectrum::splat(0.8),
                color1: Spectrum::splat(0.2),
                scale: Vec2::splat(2.0),
            },
        },
        false,
    )
    .unwrap();
    let at = |uv: Vec2| match checker.at(uv).model {
        BsdfModel::Diffuse { reflectance } => reflectance.x,
        _ => unreachable!(),
    };
    assert_eq!(at(Vec2::new(0.1, 0.1)), 0.8);
    assert_eq!(at(Vec2::new(0.3, 0.1)), 0.2);

    let glass = Material::new(MaterialKind::Dielectric { eta: 1.5 }, false)
        .unwrap()
        .at(Vec2::ZERO);
    assert!(glass.has_smooth_lobes_only() && glass.is_delta_only());
    assert_eq!(glass.lobes(-Vec3::Z).delta, 1.0);
    assert_eq!(glass.eval(Vec3::Z, -Vec3::Z), Spectrum::ZERO);
    assert!(!diffuse(0.5, false).has_smooth_lobes_only());
    assert!(!plastic(0.5).has_smooth_lobes_only());
    let l = rough_conductor(0.3, ConductorFresnel::None, true).lobes(-Vec3::Z);
    assert_eq!((l.side, l.ggx_count, l.ggx[0].weight), (-1.0, 1, 1.0));
    let l = rough_conductor(0.3, ConductorFresnel::None, false).lobes(-Vec3::Z);
    assert_eq!((l.side, l.ggx[0].weight, l.diffuse), (1.0, 0.0, 0.0));
    let l = diffuse(0.5, false).lobes(wo_at(30.0));
    assert!((l.diffuse - 0.5).abs() < 1e-6 && l.ggx_count == 0 && l.delta == 0.0);
    // Smooth plastic: delta F, Lambertian rest.
    let l = plastic(0.5).lobes(Vec3::Z);
    assert!(
        (l.delta - 0.04).abs() < 1e-5 && l.diffuse > 0.3 && l.diffuse < 0.6,
        "{l:?}"
    );
}

#[test]
fn smooth_plastic_sampling_is_unbiased() {
    // E[weight] over the mixed delta/diffuse sampler must equal the delta
    // reflectance F(cos θ_o) plus the diffuse albedo, estimated here
    // independently by uniform sampling of eval.
    let b = plastic(0.7);
    for &th in &[0.0f32, 60.0, 85.0] {
        let wo = wo_at(th);
        let ((m_bsdf, e_bsdf), (m_unif, e_unif)) = albedo_two_ways(&b, wo, 300_000, 11);
        let f = ltcguide::bsdf::fresnel::fresnel_dielectric_r(wo.z, 1.5) as f64;
        let expect = f + m_unif;
        let tol = 5.0 * (e_bsdf * e_bsdf + e_unif * e_unif).sqrt();
        assert!(
            (m_bsdf - expect).abs() < tol,
            "θ={th}: {m_bsdf} vs {expect} ± {tol}"
        );
        // The lobe decomposition carries the same energy up to the
        // T(cos θ_i) → T̄ approximation (exact in the integral).
        let l = b.lobes(wo);
        assert!((l.delta as f64 - f).abs() < 1e-6);
        assert!(
            (l.diffuse as f64 - m_unif).abs() < 0.02 + 5.0 * e_unif,
            "{} vs {m_unif}",
            l.diffuse
        );
    }
}

/// `Material::reflects_nothing` (which ends a path at the surface) holds
/// only where the BSDF is zero for every uv and pair of directions: each
/// material it accepts evaluates and samples to zero at random queries on
/// both sides, and each one it refuses reflects something at some query. A
/// checkerboard with one black colour is refused although half its texels
/// are black.
#[test]
fn reflects_nothing_only_where_every_query_is_zero() {
    let kinds = |black: f32| {
        vec![
            MaterialKind::Diffuse {
                reflectance: c(black),
            },
            MaterialKind::RoughConductor {
                alpha: 0.2,
                fresnel: gold(),
                specular_reflectance: c(black),
            },
            MaterialKind::Conductor {
                fresnel: ConductorFresnel::None,
                specular_reflectance: c(black),
            },
            MaterialKind::RoughPlastic {
                alpha: 0.2,
                eta: 1.5,
                diffuse_reflectance: c(black),
            },
            MaterialKind::Plastic {
                eta: 1.5,
                diffuse_reflectance: c(black),
            },
            MaterialKind::Dielectric { eta: 1.5 },
            MaterialKind::Diffuse {
                reflectance: Texture::Checkerboard {
                    color0: Spectrum::ZERO,
                    color1: Spectrum::splat(black.max(0.5)),
                    scale: Vec2::ONE,
                },
            },
        ]
    };
    let mut rng = Rng::new(17, 4);
    // The largest value or weight over many random queries.
    let mut largest = |m: &Material| {
        let mut most = 0.0f32;
        for _ in 0..2000 {
            let bsdf = m.at(rng.next_2d());
            let wo = square_to_uniform_sphere(rng.next_2d());
            let wi = square_to_uniform_sphere(rng.next_2d());
            most = most.max(bsdf.eval(wo, wi).max_element());
            if let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) {
                most = most.max(s.weight.max_element());
            }
        }
        most
    };
    let mut accepted = 0;
    for black in [0.0, 0.7] {
        for two_sided in [false, true] {
            for kind in kinds(black) {
                let name = format!("{kind:?}, two-sided {two_sided}");
                let Ok(m) = Material::new(kind, two_sided) else {
                    continue; // a two-sided dielectric is refused
                };
                let most = largest(&m);
                if m.reflects_nothing() {
                    accepted += 1;
                    assert_eq!(most, 0.0, "{name}");
                } else {
                    assert!(most > 0.0, "{name}: refused, yet nothing reflected");
                }
            }
        }
    }
    // Zero diffuse, rough conductor and conductor, one- and two-sided.
    assert_eq!(accepted, 6);
}
