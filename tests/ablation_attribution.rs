//! The two studies of where the product's time and variance go: the
//! ablation (the paper's Table 1, each kernel's cost and what the plan
//! saves) and the attribution (product against radiance guiding, factor by
//! factor and by pixel class), run on tiny scenes.

mod common;

use common::study::{settings, tiny};
use ltcguide::guiding::adam::FractionLearning;
use ltcguide::guiding::product::CosineLobes;
use ltcguide::integrator::path::{PathSettings, RouletteMode};
use ltcguide::render::{Method, TimeBase};
use ltcguide::scene::Scene;
use std::path::Path;

/// The ablation times the paper's three kernels with the paper's product
/// (every vertex, cosine lobes included, so that a diffuse scene exercises
/// them) and no plan, then the plan rows: with the plan, without it, and without it at
/// the paper's setting, against which the savings are stated.
#[test]
fn ablation_reports_every_kernel_and_plan_row() {
    let scene = tiny();
    let out = ltcguide::experiment::ablation::run_ablation(
        &scene,
        2,
        0,
        settings(&scene, Method::Product),
        false,
    )
    .unwrap();
    let names: Vec<&str> = out.kernels.iter().map(|r| r.variant.as_str()).collect();
    assert_eq!(names, ["naive", "optimized", "simd"]);
    assert_eq!(out.plan.len(), 3);
    assert!(out.plan[2].variant.contains("every vertex, cosine product"));
    assert!(
        out.kernels
            .iter()
            .chain(&out.plan)
            .all(|r| r.spp == 2 && r.seconds > 0.0),
        "{}",
        out.markdown
    );
    assert!(out.markdown.contains("| naive |") && out.markdown.contains("| 100 % |"));
    // The kernels run without the plan, so no strategy trial can hand part
    // of a kernel's samples to another strategy; the plan rows say what
    // their runs ended with.
    assert!(
        out.kernels
            .iter()
            .all(|r| r.outcome == "the method as such"),
        "{}",
        out.markdown
    );
    assert!(out.markdown.contains("| after the strategy trial |"));
    use ltcguide::experiment::ablation::trial_outcome;
    use ltcguide::guiding::trial::{CHEAPER_WEIGHTS, FALLBACK_IMAGE};
    assert_eq!(
        trial_outcome(Some(&format!(
            "plan: … | guiding does not pay here …, and {FALLBACK_IMAGE}"
        ))),
        "path tracing with NEE: the image holds its passes alone"
    );
    assert_eq!(
        trial_outcome(Some(&format!(
            "plan: … | product {CHEAPER_WEIGHTS} (efficiency …)"
        ))),
        "radiance weights"
    );
    assert_eq!(
        trial_outcome(Some("plan: … | plan disabled")),
        "the method as such"
    );
    assert!(
        out.plan_line
            .contains("every vertex takes radiance weights"),
        "{}",
        out.plan_line
    );
}

/// The attribution's pairs differ only in the method: on a scene whose
/// lobes are all cosines, product guiding takes radiance weights at every
/// vertex, so every variance factor is 1 up to rounding (a pair rendered
/// with different seeds or settings would be off by percents). On a
/// glossy floor the product changes the variances, and every factor is a
/// finite positive ratio.
#[test]
fn attribution_pairs_differ_only_in_the_method() {
    use ltcguide::experiment::attribution::{AttributionOptions, ClassSplit, run_attribution};
    use ltcguide::experiment::pixel_classes::PixelClass;
    let options = |scene: &Scene, exact_integrals| AttributionOptions {
        spp: 8,
        seeds: 2,
        threads: 2,
        path: settings(scene, Method::Product),
        guide_fraction: 0.2,
        other_roulette: RouletteMode::Classic,
        exact_integrals,
        bsdf_fraction_l2: None,
        bsdf_fraction_learning: FractionLearning::Kl,
        radiance_share: ltcguide::guiding::defensive::RadianceShare::fixed(0.3),
        cosine_lobes: CosineLobes::Radiance,
        product_vertices: 1,
        pixel_reuse: true,
        clock: TimeBase::Cpu,
        progress: false,
    };
    let diffuse = tiny();
    let out = run_attribution(&diffuse, &options(&diffuse, true)).unwrap();
    assert_eq!(out.factors.len(), 9, "{}", out.markdown);
    assert!(
        out.markdown
            .contains("seconds of each render's own CPU time per thread"),
        "{}",
        out.markdown
    );
    // No glossy first vertex: nothing to split there.
    assert!(out.at_glossy.is_empty() && !out.markdown.contains("At the glossy first vertices"));
    for f in &out.factors {
        assert_eq!(f.per_seed.len(), 2);
        if f.name.contains("variance") || f.name.starts_with("expected relMSE") {
            for v in &f.per_seed {
                assert!((v - 1.0).abs() < 1e-4, "{}: {v}\n{}", f.name, out.markdown);
            }
        }
    }
    // The split by first vertex: no glossy pixels, ratios 1 where radiance
    // guiding has variance, and pixels and shares that add up.
    assert!(
        out.by_class
            .iter()
            .all(|c| !matches!(c.class, PixelClass::Glossy | PixelClass::GlossyCoat))
    );
    let total = |f: fn(&ClassSplit) -> f64| out.by_class.iter().map(f).sum::<f64>();
    assert!((total(|c| c.pixels) - 1.0).abs() < 1e-9);
    assert!((total(|c| c.radiance_share) - 1.0).abs() < 1e-9);
    for c in out.by_class.iter().filter(|c| c.radiance_share > 0.0) {
        assert!(
            c.per_seed.iter().all(|v| (v - 1.0).abs() < 1e-4),
            "{}",
            out.markdown
        );
    }
    // Different seeds give different renders: the ratios are not trivially 1.
    let seeds_differ =
        out.alpha[0] != out.alpha[1] || out.factors.iter().any(|f| f.per_seed[0] != f.per_seed[1]);
    assert!(seeds_differ, "{}", out.markdown);

    // The paper's product (cosine product at every vertex, no lobe reuse)
    // reaches the renders: on the same cosine-only scene its guide is no
    // longer radiance guiding's, so the variance per sample moves off 1, and
    // the header names the settings.
    let paper = AttributionOptions {
        cosine_lobes: CosineLobes::Product,
        product_vertices: 0,
        pixel_reuse: false,
        seeds: 1,
        ..options(&diffuse, false)
    };
    let out = run_attribution(&diffuse, &paper).unwrap();
    assert!(
        out.markdown.contains("product weights at every vertex;")
            && out.markdown.contains("no lobe reuse across paths")
            && out.markdown.contains("cosine lobes: product,")
            && out
                .markdown
                .contains("cosine-only vertices take the cosine product"),
        "{}",
        out.markdown
    );
    let per_sample = &out.factors[2];
    assert!(per_sample.name.starts_with("variance per sample"));
    assert!(
        (per_sample.per_seed[0] - 1.0).abs() > 1e-3,
        "{}",
        out.markdown
    );

    let glossy_xml = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/analytic/sphere_over_plane.xml"),
    )
    .unwrap()
    .replacen(
        r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>"#,
        r#"<bsdf type="roughconductor"><float name="alpha" value="0.1"/></bsdf>"#,
        1,
    )
    .replace(r#"value="2"/></integrator>"#, r#"value="4"/></integrator>"#);
    let glossy =
        ltcguide::scene::load_scene_from_str(&glossy_xml, Path::new("glossy.xml")).unwrap();
    let out = run_attribution(&glossy, &options(&glossy, false)).unwrap();
    assert_eq!(out.factors.len(), 8, "{}", out.markdown);
    assert!(
        out.factors
            .iter()
            .all(|f| f.mean() > 0.0 && f.mean().is_finite())
    );
    for per_sample in &out.factors[2..4] {
        assert!(
            per_sample.per_seed.iter().all(|v| (v - 1.0).abs() > 1e-3),
            "{}: the product changed nothing on a glossy floor\n{}",
            per_sample.name,
            out.markdown
        );
    }
    assert!(
        out.markdown
            .contains("At zero overhead the product would reach")
    );
    // The floor is glossy: the product's own distribution acts there.
    let floor = out
        .by_class
        .iter()
        .find(|c| c.class == PixelClass::Glossy)
        .expect("the glossy floor's pixels are classed glossy");
    assert!(floor.pixels > 0.1 && floor.radiance_share > 0.0);
    assert!(
        floor.per_seed.iter().all(|v| (v - 1.0).abs() > 1e-3),
        "{}",
        out.markdown
    );
    assert!(
        out.markdown
            .contains("| glossy GGX lobe (α ≤ 0.5), most of the weight |")
    );
    // At the glossy first vertices: the learned pair's ratio is the class
    // split's, fixing α does change the product's variance, and no ratio is
    // off by the orders of magnitude a normaliser from other renders gave
    // (a firefly weighed by a third render's dark pixel).
    let names: Vec<&str> = out.at_glossy.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "product / radiance, learned α",
            "product / radiance, BSDF fraction fixed",
            "product: fixed / learned α",
            "radiance: fixed / learned α"
        ]
    );
    let row = |i: usize| &out.at_glossy[i].per_seed;
    for s in 0..2 {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs();
        assert!(close(row(0)[s], floor.per_seed[s]), "{}", out.markdown);
        for r in 0..4 {
            assert!(row(r)[s] > 0.05 && row(r)[s] < 20.0, "{}", out.markdown);
        }
        assert!((row(2)[s] - 1.0).abs() > 1e-3, "{}", out.markdown);
    }
    assert!(out.markdown.contains("| product: fixed / learned α |"));

    // `--bsdf-fraction-l2` reaches both methods' learned fractions: a huge
    // λ holds α at ½, none lets it move.
    let alpha_at = |lambda: f64| {
        let opts = AttributionOptions {
            seeds: 1,
            spp: 32,
            bsdf_fraction_l2: Some(lambda),
            ..options(&glossy, false)
        };
        let out = run_attribution(&glossy, &opts).unwrap();
        assert!(
            out.markdown
                .contains(&format!("NEE off, BSDF fraction's L2 λ = {lambda},")),
            "{}",
            out.markdown
        );
        out.alpha[0]
    };
    let (held, free) = (alpha_at(1e4), alpha_at(0.0));
    let off_half = |a: (f64, f64)| [(a.0 - 0.5).abs(), (a.1 - 0.5).abs()];
    assert!(off_half(held).iter().all(|&d| d < 1e-3), "{held:?}");
    assert!(off_half(free).iter().all(|&d| d > 3e-3), "{free:?}");

    // `--bsdf-fraction-learning variance-grid` reaches both methods' learned
    // fractions and the header, while the fixed-fraction factor still runs
    // (a fixed α learns nothing, whichever learning the run names).
    let opts = AttributionOptions {
        seeds: 1,
        spp: 32,
        bsdf_fraction_learning: FractionLearning::VarianceGrid,
        ..options(&glossy, false)
    };
    let out = run_attribution(&glossy, &opts).unwrap();
    assert!(
        out.markdown
            .contains("NEE off, BSDF fraction learned by variance-grid,"),
        "{}",
        out.markdown
    );
    assert!(
        out.markdown
            .contains("| variance per sample, BSDF fraction fixed at 0.2 |"),
        "{}",
        out.markdown
    );
}

/// Pixels are classed by the floor's material as the product treats it:
/// a sharp conductor is glossy, a plastic's coat over its base is a coat,
/// and GGX rougher than 0.5 is a cosine lobe. The light's own pixels (a
/// black diffuse sphere, where paths end) have no vertex to guide, and
/// every other pixel sees the floor.
#[test]
fn pixel_classes_follow_the_product_treatment_of_the_material() {
    use ltcguide::experiment::pixel_classes::{PixelClass, class_counts, classify};
    let xml = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/analytic/sphere_over_plane.xml"),
    )
    .unwrap();
    let floor = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>"#;
    let cases = [
        (floor, PixelClass::Cosine),
        (
            r#"<bsdf type="roughconductor"><float name="alpha" value="0.1"/></bsdf>"#,
            PixelClass::Glossy,
        ),
        (
            r#"<bsdf type="roughconductor"><float name="alpha" value="0.8"/></bsdf>"#,
            PixelClass::Cosine,
        ),
        (
            r#"<bsdf type="roughplastic"><float name="alpha" value="0.1"/></bsdf>"#,
            PixelClass::GlossyCoat,
        ),
    ];
    for (bsdf, want) in cases {
        let scene = ltcguide::scene::load_scene_from_str(
            &xml.replacen(floor, bsdf, 1),
            Path::new("classes.xml"),
        )
        .unwrap();
        let classes = classify(&scene);
        assert_eq!(classes.len(), 64 * 64);
        let counts = class_counts(&classes);
        let i = PixelClass::ALL.iter().position(|&c| c == want).unwrap();
        // The floor fills the view but for the sphere's few pixels.
        assert!(counts[i] > 64 * 64 * 9 / 10, "{bsdf}: {counts:?}");
        assert!(counts[3] > 0, "{bsdf}: {counts:?}");
        assert_eq!(counts[i] + counts[3], 64 * 64, "{bsdf}: {counts:?}");
    }
}

#[test]
fn attribution_refuses_options_it_cannot_run() {
    use ltcguide::experiment::attribution::{AttributionOptions, check};
    let scene = tiny();
    let good = AttributionOptions {
        spp: 8,
        seeds: 1,
        threads: 0,
        path: settings(&scene, Method::Product),
        guide_fraction: 0.2,
        other_roulette: RouletteMode::Classic,
        exact_integrals: false,
        bsdf_fraction_l2: None,
        bsdf_fraction_learning: FractionLearning::Kl,
        radiance_share: ltcguide::guiding::defensive::RadianceShare::fixed(0.3),
        cosine_lobes: CosineLobes::Radiance,
        product_vertices: 1,
        pixel_reuse: true,
        clock: TimeBase::Wall,
        progress: false,
    };
    assert!(check(&good).is_ok());
    assert!(
        check(&AttributionOptions {
            bsdf_fraction_l2: Some(0.0),
            ..good.clone()
        })
        .is_ok()
    );
    let bad = [
        AttributionOptions {
            spp: 1,
            ..good.clone()
        },
        AttributionOptions {
            seeds: 0,
            ..good.clone()
        },
        AttributionOptions {
            guide_fraction: 1.0,
            ..good.clone()
        },
        AttributionOptions {
            guide_fraction: f32::NAN,
            ..good.clone()
        },
        AttributionOptions {
            other_roulette: RouletteMode::Adrrs,
            ..good.clone()
        },
        AttributionOptions {
            radiance_share: ltcguide::guiding::defensive::RadianceShare::fixed(1.0),
            ..good.clone()
        },
        AttributionOptions {
            bsdf_fraction_l2: Some(-0.01),
            ..good.clone()
        },
        AttributionOptions {
            bsdf_fraction_l2: Some(f64::NAN),
            ..good.clone()
        },
        AttributionOptions {
            bsdf_fraction_l2: Some(f64::INFINITY),
            ..good.clone()
        },
        AttributionOptions {
            path: PathSettings {
                adrrs_window: 0.5,
                defer_guide_pdf: true,
                ..good.path
            },
            ..good.clone()
        },
        AttributionOptions {
            path: PathSettings {
                max_depth: Some(0),
                ..good.path
            },
            ..good.clone()
        },
    ];
    for opts in bad {
        assert!(check(&opts).is_err(), "{opts:?}");
    }
}
