//! Product guiding's sampling distribution: χ² of the product descent
//! against its own pdf at random shading points, normals, roughness
//! (α = 1e-3 and α = 1 included) and grazing θ_o, over synthetic quadtrees;
//! bit-identical pdf of sampled directions; and where the product puts its
//! samples. Where it takes radiance weights instead is in
//! `product_fallbacks.rs`; ADRRS leaving the image's expectation unchanged
//! is in `guided_convergence.rs`.

mod product_common;

use glam::{Vec2, Vec3};
use ltcguide::directional::{Cell, dir_to_square, square_to_dir};
use ltcguide::guiding::defensive;
use ltcguide::guiding::descent::{self, ChildWeights};
use ltcguide::guiding::product::ProductCache;
use ltcguide::guiding::quadtree::QuadTree;
use ltcguide::ltc::ProductKernel;
use ltcguide::math::Frame;
use ltcguide::render::default_ltc_table;
use ltcguide::sampling::Rng;
use ltcguide::stats::chi2::{Chi2Config, chi2_square_expected};
use product_common::*;

#[test]
fn product_sampling_matches_its_pdf_chi2() {
    let table = default_ltc_table().unwrap();
    let mut rng = Rng::new(2024, 7);
    let cases = cases(&mut rng);
    let trials = cases.len() * 4;
    let cfg = Chi2Config {
        res_x: 16,
        res_y: 32,
        samples: 60_000,
        significance: 0.01 / trials as f64,
        min_expected: 5.0,
    };
    let models = [
        paper_model(table, ProductKernel::Simd),
        paper_model(table, ProductKernel::Optimized),
        paper_model(table, ProductKernel::Naive),
        render_options_model(table),
    ];
    for model in &models {
        let kernel = model.kernel;
        // The f64 naive kernel is slow; a third of the cases suffice for it.
        let stride = if kernel == ProductKernel::Naive { 3 } else { 1 };
        for (ci, case) in cases.iter().enumerate().step_by(stride) {
            let tree = random_tree(&mut rng, 200);
            let mut cache = ProductCache::default();
            let Some(mut w) = weights_for(case, model, &mut rng, &mut cache) else {
                panic!("case {ci}: the product vanished for a reflective BSDF");
            };
            let mut srng = Rng::new(ci as u64, 99);
            // The distribution is piecewise constant on cells far smaller
            // than any quadrature could resolve (α = 1e-3 lobes reach depth
            // ~16): integrate it exactly over the bins, cell by cell.
            let expected = exact_bin_probabilities(&tree, &mut w, cfg.res_x, cfg.res_y);
            let total: f64 = expected.iter().sum();
            assert!(
                (total - 1.0).abs() < 1e-4,
                "case {ci}: probabilities sum to {total}"
            );
            let out = chi2_square_expected(
                &cfg,
                || descent::sample(&tree, &mut w, srng.next_2d()).map(|(p, _)| p),
                &expected,
            );
            assert!(
                out.passed,
                "{kernel:?} {:?} case {ci} (α {}, θ_o {}°, n {:?}): {}",
                model.options, case.alpha, case.theta_o_deg, case.normal, out.message
            );
        }
    }
}

/// The product mixed with a radiance share (`guiding::defensive`): its
/// samples follow (1 − β)·product + β·radiance, the exact bin
/// probabilities of both descents mixed, at every case and two shares; and
/// the pdf of a sampled point is the returned pdf bit for bit.
#[test]
fn product_with_a_radiance_share_matches_its_pdf_chi2() {
    let table = default_ltc_table().unwrap();
    let model = render_options_model(table);
    let mut rng = Rng::new(2026, 52);
    let cases = cases(&mut rng);
    let shares = [0.3f32, 0.7];
    let cfg = Chi2Config {
        res_x: 16,
        res_y: 32,
        samples: 60_000,
        significance: 0.01 / (cases.len() * shares.len()) as f64,
        min_expected: 5.0,
    };
    for (ci, case) in cases.iter().enumerate() {
        for &share in &shares {
            let tree = random_tree(&mut rng, 200);
            let mut cache = ProductCache::default();
            let mut w = weights_for(case, &model, &mut rng, &mut cache).unwrap();
            let product = exact_bin_probabilities(&tree, &mut w, cfg.res_x, cfg.res_y);
            let radiance =
                exact_bin_probabilities(&tree, &mut descent::RadianceWeights, cfg.res_x, cfg.res_y);
            // Radiance weights (the grazing case's fallback) ignore the share.
            let s = if w.is_radiance() { 0.0 } else { share as f64 };
            let expected: Vec<f64> = product
                .iter()
                .zip(&radiance)
                .map(|(p, r)| (1.0 - s) * p + s * r)
                .collect();
            let mut srng = Rng::new(ci as u64, 7);
            let out = chi2_square_expected(
                &cfg,
                || defensive::sample(&tree, &mut w, share, srng.next_2d()).map(|(p, _)| p),
                &expected,
            );
            assert!(
                out.passed,
                "share {share}, case {ci} (α {}, θ_o {}°): {}",
                case.alpha, case.theta_o_deg, out.message
            );
            for _ in 0..500 {
                let (p, pdf) = defensive::sample(&tree, &mut w, share, rng.next_2d()).unwrap();
                assert_eq!(defensive::pdf(&tree, &mut w, share, p), pdf);
                assert!(pdf > 0.0);
            }
        }
    }
}

/// The guide's vertex under product weights samples and evaluates the
/// mixture with the model's share, or the leaf's when the tree learns it:
/// the pdf it returns for a sample is its pdf of that direction, and it is
/// the mixture of the two descents' at that share. The vertex reports a
/// learned share for the records, and only then.
#[test]
fn the_guide_vertex_mixes_with_the_models_or_the_leafs_share() {
    use ltcguide::guiding::guide::SdGuide;
    use ltcguide::guiding::sdtree::{SdTree, SdTreeConfig};
    use ltcguide::guiding::share_learning::LearnedShare;
    use ltcguide::integrator::guide::{Guide, GuideVertex};
    use ltcguide::integrator::stats::RenderCounters;
    let table = default_ltc_table().unwrap();
    let mut rng = Rng::new(52, 1);
    let quadtree = random_tree(&mut rng, 300);
    let frame = Frame::from_normal(Vec3::new(0.2, -0.3, 0.93).normalize());
    let bsdf = material(0.05, false).at(Vec2::ZERO);
    let wo = wo_at(40.0, 1.0);
    // (the model's share, the tree's learned share, the share expected)
    let cases = [
        (0.0f32, None, 0.0f32),
        (0.4, None, 0.4),
        (0.4, Some(0.7f32), 0.7),
        // A model without a share learns none, whatever the tree holds.
        (0.0, Some(0.7), 0.0),
    ];
    for (share, learned, expected_share) in cases {
        let config = SdTreeConfig {
            learned_radiance_share: learned.map(|_| 0.4),
            ..SdTreeConfig::default()
        };
        let mut tree = SdTree::new(Vec3::splat(-1.0), Vec3::ONE, config);
        tree.leaves_mut()[0].sampling = quadtree.clone();
        if let Some(l) = learned {
            tree.leaves_mut()[0].share = LearnedShare::starting_at(l);
        }
        let model = ltcguide::guiding::product::ProductModel {
            radiance_share: share,
            ..render_options_model(table)
        };
        let guide = SdGuide {
            tree: &tree,
            model: &model,
            learning: false,
            fixed_alpha: None,
        };
        let ctx = first_vertex(&frame, wo, &bsdf);
        let (mut cache, mut counters) = (ProductCache::default(), RenderCounters::default());
        let at = guide.locate(ctx.p);
        let mut v = guide.vertex(&ctx, at, &mut cache, &mut counters).unwrap();
        let reported = if learned.is_some() {
            expected_share
        } else {
            0.0
        };
        assert!(
            (v.learned_share() - reported).abs() < 1e-6,
            "{share} {learned:?}: {}",
            v.learned_share()
        );
        let mut wcache = ProductCache::default();
        let mut w = weights_at(&model, frame.n, wo, &bsdf, &mut wcache).unwrap();
        assert!(!w.is_radiance());
        let mut mixed = 0;
        for _ in 0..300 {
            let (dir, pdf) = v.sample(rng.next_2d()).unwrap();
            assert_eq!(v.pdf(dir), pdf);
            let product = descent::pdf_direction(&quadtree, &mut w, dir);
            let radiance = descent::pdf_direction(&quadtree, &mut descent::RadianceWeights, dir);
            let expected = (1.0 - expected_share) * product + expected_share * radiance;
            assert!(
                (pdf - expected).abs() <= 1e-5 * expected,
                "{share} {learned:?}: {pdf} against {expected}"
            );
            mixed += (pdf != product) as u32;
        }
        assert_eq!(
            mixed > 0,
            expected_share > 0.0,
            "share {share}, learned {learned:?}: {mixed} of 300 mixed"
        );
    }
}

/// The whole-square χ² cannot resolve a sharp lobe: at α = 1e-3 it falls
/// in a few of its bins. Here the distribution conditioned on the deepest
/// cell that still holds half the mass, in that cell's own coordinates,
/// resolves the product's refinement below the tree's leaves.
#[test]
fn sharp_product_lobes_pass_chi2_when_zoomed_in() {
    let table = default_ltc_table().unwrap();
    let models = [
        paper_model(table, ProductKernel::Simd),
        render_options_model(table),
    ];
    let mut rng = Rng::new(41, 2);
    let tree = random_tree(&mut rng, 200);
    let lobes = [(1e-3, 10.0), (0.01, 45.0), (0.05, 80.0), (1e-3, 70.0)];
    let cfg = Chi2Config {
        res_x: 16,
        res_y: 16,
        samples: 100_000,
        significance: 0.01 / (lobes.len() * models.len()) as f64,
        min_expected: 5.0,
    };
    for (model, (alpha, theta_o_deg)) in models
        .iter()
        .flat_map(|m| lobes.iter().map(move |&l| (m, l)))
    {
        let case = Case {
            alpha,
            diffuse: false,
            theta_o_deg,
            normal: Vec3::new(0.3, -0.4, 0.87).normalize(),
        };
        let mut cache = ProductCache::default();
        let mut w = weights_for(&case, model, &mut rng, &mut cache).unwrap();
        // The densest terminal cell, then its deepest ancestor holding half
        // the mass.
        let mut densest = (Cell::ROOT, 0.0f64);
        descent::for_each_terminal_cell(&tree, &mut w, |cell, mass| {
            let density = mass / cell.square_bounds().2.powi(2);
            if density > densest.1 {
                densest = (cell, density);
            }
        });
        let ancestor = |d: u32| {
            let s = densest.0.depth - d;
            Cell {
                depth: d,
                ix: densest.0.ix >> s,
                iy: densest.0.iy >> s,
            }
        };
        let (zoom, expected) = (0..=densest.0.depth)
            .rev()
            .map(|d| {
                let zoom = ancestor(d);
                (
                    zoom,
                    exact_bin_probabilities_in(&tree, &mut w, 16, 16, zoom),
                )
            })
            .find(|(_, bins)| bins.iter().sum::<f64>() >= 0.5)
            .unwrap();
        let p_zoom: f64 = expected.iter().sum();
        let expected: Vec<f64> = expected.iter().map(|p| p / p_zoom).collect();
        let (zu, zv, zs) = zoom.square_bounds();
        let out = chi2_square_expected(
            &cfg,
            || loop {
                let (p, _) = descent::sample(&tree, &mut w, rng.next_2d()).unwrap();
                let q = Vec2::new(
                    ((p.x as f64 - zu) / zs) as f32,
                    ((p.y as f64 - zv) / zs) as f32,
                );
                if (0.0..1.0).contains(&q.x) && (0.0..1.0).contains(&q.y) {
                    return Some(q);
                }
            },
            &expected,
        );
        let deep = model.options.deep_cell_size;
        println!(
            "deep size {deep} α {alpha} θo {theta_o_deg}: zoom depth {} (P {p_zoom:.2}), dof {}, p {:.3}",
            zoom.depth, out.dof, out.p_value
        );
        assert!(
            out.passed,
            "deep size {deep} α {alpha} θo {theta_o_deg}: {}",
            out.message
        );
        assert!(
            out.dof >= 30,
            "α {alpha}: only {} degrees of freedom",
            out.dof
        );
    }
}

#[test]
fn chi2_rejects_the_radiance_distribution_for_product_samples() {
    // The test must be able to fail: expected counts from radiance-only
    // weights do not describe product samples of a glossy lobe.
    let table = default_ltc_table().unwrap();
    let model = paper_model(table, ProductKernel::Simd);
    let mut rng = Rng::new(77, 1);
    let tree = random_tree(&mut rng, 200);
    let case = Case {
        alpha: 0.1,
        diffuse: false,
        theta_o_deg: 30.0,
        normal: Vec3::new(0.2, -0.3, 0.93).normalize(),
    };
    let mut cache = ProductCache::default();
    let mut w = weights_for(&case, &model, &mut rng, &mut cache).unwrap();
    let cfg = Chi2Config {
        res_x: 16,
        res_y: 32,
        samples: 60_000,
        significance: 0.01,
        min_expected: 5.0,
    };
    let mut radiance = descent::RadianceWeights;
    let mut bins = vec![0f64; 16 * 32];
    descent::for_each_terminal_cell(&tree, &mut radiance, |cell, mass| {
        let (u0, v0, size) = cell.square_bounds();
        // Radiance-only trees stop at their leaves, which are coarser than
        // the 16×32 bins only at depth < 5: spread by overlap.
        for by in 0..32 {
            for bx in 0..16 {
                let ox = ((bx + 1) as f64 / 16.0).min(u0 + size) - (bx as f64 / 16.0).max(u0);
                let oy = ((by + 1) as f64 / 32.0).min(v0 + size) - (by as f64 / 32.0).max(v0);
                if ox > 0.0 && oy > 0.0 {
                    bins[by * 16 + bx] += mass * ox * oy / (size * size);
                }
            }
        }
    });
    let mut srng = Rng::new(3, 3);
    let out = chi2_square_expected(
        &cfg,
        || descent::sample(&tree, &mut w, srng.next_2d()).map(|(p, _)| p),
        &bins,
    );
    assert!(!out.passed, "{}", out.message);
}

#[test]
fn pdf_of_a_sampled_direction_is_the_returned_pdf() {
    let table = default_ltc_table().unwrap();
    let models = [
        paper_model(table, ProductKernel::Simd),
        render_options_model(table),
    ];
    let mut rng = Rng::new(5, 5);
    for (case, model) in cases(&mut rng.clone())
        .into_iter()
        .flat_map(|c| models.iter().map(move |m| (c, m)))
    {
        let tree = random_tree(&mut rng, 300);
        let mut cache = ProductCache::default();
        let mut w = weights_for(&case, model, &mut rng, &mut cache).unwrap();
        for _ in 0..2000 {
            let (p, pdf) = descent::sample(&tree, &mut w, rng.next_2d()).unwrap();
            assert_eq!(descent::pdf(&tree, &mut w, p), pdf);
            // Through world directions the square point is recomputed with
            // rounding; the pdf of the direction is still the leaf's.
            let d = square_to_dir(p);
            let back = descent::pdf(&tree, &mut w, dir_to_square(d));
            assert!(back > 0.0, "a sampled direction has zero pdf");
        }
    }
}

#[test]
fn product_weights_concentrate_where_the_bsdf_is() {
    // Uniform radiance: the product's root normaliser is the BSDF integral,
    // and sampling follows the BSDF lobe (mean cosine to the reflection
    // direction close to 1 for a narrow lobe).
    let table = default_ltc_table().unwrap();
    let model = paper_model(table, ProductKernel::Simd);
    let tree = QuadTree::uniform(1.0);
    let case = Case {
        alpha: 0.02,
        diffuse: false,
        theta_o_deg: 30.0,
        normal: Vec3::Z,
    };
    let mut rng = Rng::new(1, 2);
    let mut cache = ProductCache::default();
    let mut w = weights_for(&case, &model, &mut rng, &mut cache).unwrap();
    let mut cos_to_normal = 0.0;
    for _ in 0..1000 {
        let (p, _) = descent::sample(&tree, &mut w, rng.next_2d()).unwrap();
        cos_to_normal += square_to_dir(p).z as f64;
    }
    // The mirror direction of a 30° view has cos θ = cos 30° ≈ 0.87.
    assert!(
        (cos_to_normal / 1000.0 - 0.866).abs() < 0.05,
        "{}",
        cos_to_normal / 1000.0
    );
    let total = descent::root_total(&tree, &mut w);
    assert!(total > 0.0 && total.is_finite());
    let _ = w.child_weights(ltcguide::directional::Cell::ROOT, [1.0; 4]);
}

/// Under uniform radiance the product samples the BSDF's lobe, so a narrow
/// lobe's samples must gather about the world-space mirror direction: for
/// tilted normals and several azimuths of ω_o, which a frame or azimuth
/// error (a lobe turned about the normal) would miss, while the cosine to
/// the normal alone would not.
#[test]
fn product_samples_gather_about_the_world_mirror_direction() {
    let table = default_ltc_table().unwrap();
    let model = paper_model(table, ProductKernel::Simd);
    let tree = QuadTree::uniform(1.0);
    let bsdf = material(0.02, false).at(Vec2::ZERO);
    let mut rng = Rng::new(5, 6);
    for normal in [
        Vec3::new(0.3, -0.5, 0.8),
        Vec3::new(-0.9, 0.1, -0.2),
        Vec3::new(0.0, 1.0, 0.0),
    ] {
        let normal = normal.normalize();
        let frame = Frame::from_normal(normal);
        for phi in [0.4f32, 2.0, 4.5] {
            let wo = wo_at(35.0, phi);
            let mut cache = ProductCache::default();
            let mut w = weights_at(&model, normal, wo, &bsdf, &mut cache).unwrap();
            let mean: Vec3 = (0..1000)
                .map(|_| square_to_dir(descent::sample(&tree, &mut w, rng.next_2d()).unwrap().0))
                .sum();
            let mirror = frame.to_world(Vec3::new(-wo.x, -wo.y, wo.z));
            let cos = mean.normalize().dot(mirror);
            // α = 0.02 puts the samples within a few degrees of the mirror
            // direction; a lobe turned by 30° about the normal gives 0.96.
            assert!(cos > 0.995, "normal {normal}, φ_o {phi}: cos {cos}");
        }
    }
}
