//! Where product guiding takes radiance weights instead of the product:
//! the grazing fallback's adjoint, cosine-only vertices and scenes (with
//! and without the plan), and product weights at the first vertices only.

mod product_common;

use glam::{Vec2, Vec3};
use ltcguide::guiding::descent::{self, ChildWeights};
use ltcguide::guiding::guide::{WeightModel, reflected_radiance_estimate};
use ltcguide::guiding::product::{CosineLobes, ProductCache, ProductModel, ProductWeights};
use ltcguide::integrator::guide::VertexContext;
use ltcguide::ltc::ProductKernel;
use ltcguide::ltc::children::ShadingLtc;
use ltcguide::math::Frame;
use ltcguide::render::default_ltc_table;
use ltcguide::sampling::Rng;
use product_common::*;

/// Where the product falls back to radiance weights, ADRRS's adjoint is
/// the albedo times the root's cosine-weighted radiance. At a grazing
/// glossy vertex (beyond the 85° switch) the albedo is the LTC's, built
/// with the lobe; at a diffuse vertex, where no lobe is built, it is the
/// BSDF's own estimate. The two differ here (GGX at α = 0.1 and 88°
/// shadows part of its light), so the test tells them apart.
#[test]
fn the_radiance_fallbacks_adjoint_takes_the_albedo_that_was_built() {
    let table = default_ltc_table().unwrap();
    let model = ProductModel {
        cosine_lobes: CosineLobes::Radiance,
        ..render_options_model(table)
    };
    let normal = Vec3::new(0.3, 0.2, 0.9).normalize();
    let frame = Frame::from_normal(normal);
    let root_radiance = [0.7, 1.3, 0.2, 2.1];
    let root_total = 123.0; // Ignored by the radiance fallback.
    for (alpha, diffuse, theta_o_deg) in [(0.1, false, 88.0), (1.0, true, 30.0)] {
        let bsdf = material(alpha, diffuse).at(Vec2::ZERO);
        let wo = wo_at(theta_o_deg, 0.4);
        let ctx = VertexContext {
            needs_adjoint: true,
            ..first_vertex(&frame, wo, &bsdf)
        };
        let mut cache = ProductCache::default();
        let w = model.weights(&ctx, &mut cache).expect("a reflective BSDF");
        let ProductWeights::RadianceOnly { albedo } = &w else {
            panic!("α {alpha}, θ_o {theta_o_deg}°: radiance weights expected");
        };
        let bsdf_albedo = bsdf.albedo_estimate(wo);
        let expected_albedo = if diffuse {
            assert!(albedo.is_none(), "no lobe is built at a diffuse vertex");
            bsdf_albedo
        } else {
            let ltc = ShadingLtc::new(&bsdf.lobes(wo), &frame, wo, table, &model.options);
            assert_eq!(albedo.copied(), Some(ltc.total()));
            assert!(
                (ltc.total() - bsdf_albedo).abs() > 0.01 * bsdf_albedo,
                "LTC {} and BSDF {bsdf_albedo} albedos must differ for the test to tell",
                ltc.total()
            );
            ltc.total()
        };
        let adjoint = model.adjoint(&w, &ctx, root_total, root_radiance);
        let expected = reflected_radiance_estimate(&frame, wo, expected_albedo, root_radiance);
        assert_eq!(adjoint.to_bits(), expected.to_bits(), "α {alpha}");
        assert!(adjoint > 0.0 && adjoint.is_finite());
    }
}

/// With the default `CosineLobes::Radiance`, a vertex whose lobes are all
/// cosines (a GGX lobe rougher than 0.5, alone or over a diffuse base)
/// takes radiance weights: its samples and pdfs are radiance guiding's, bit
/// for bit. A glossy lobe keeps the product, and `CosineLobes::Product`
/// keeps the paper's cosine product everywhere.
#[test]
fn cosine_vertices_take_radiance_weights_unless_asked_otherwise() {
    let table = default_ltc_table().unwrap();
    let model = |cosine_lobes| ProductModel {
        cosine_lobes,
        ..paper_model(table, ProductKernel::Simd)
    };
    let mut rng = Rng::new(11, 4);
    let tree = random_tree(&mut rng, 200);
    let case = |alpha, diffuse| Case {
        alpha,
        diffuse,
        theta_o_deg: 30.0,
        normal: Vec3::new(0.1, 0.2, 0.97).normalize(),
    };
    let (cosine_as_radiance, cosine_product) =
        (model(CosineLobes::Radiance), model(CosineLobes::Product));
    let mut cache = ProductCache::default();
    for (alpha, diffuse) in [(1.0, false), (1.0, true), (0.6, true)] {
        let mut w = weights_for(
            &case(alpha, diffuse),
            &cosine_as_radiance,
            &mut rng,
            &mut cache,
        )
        .expect("a reflective BSDF");
        assert!(
            matches!(w, ProductWeights::RadianceOnly { .. }),
            "α {alpha}, diffuse {diffuse}"
        );
        // What lets the guide descend with `RadianceWeights` itself.
        assert!(w.is_radiance());
        for _ in 0..500 {
            let u = rng.next_2d();
            let s = descent::sample(&tree, &mut w, u);
            assert_eq!(s, descent::sample(&tree, &mut descent::RadianceWeights, u));
            let p = s.unwrap().0;
            assert_eq!(
                descent::pdf(&tree, &mut w, p).to_bits(),
                descent::pdf(&tree, &mut descent::RadianceWeights, p).to_bits()
            );
        }
        let paper = weights_for(&case(alpha, diffuse), &cosine_product, &mut rng, &mut cache);
        assert!(
            matches!(&paper, Some(ProductWeights::Product(_))),
            "α {alpha}, diffuse {diffuse}: the paper's cosine product"
        );
        assert!(!paper.unwrap().is_radiance());
    }
    for diffuse in [false, true] {
        let glossy = weights_for(
            &case(0.05, diffuse),
            &cosine_as_radiance,
            &mut rng,
            &mut cache,
        );
        assert!(
            matches!(glossy, Some(ProductWeights::Product(_))),
            "a glossy lobe (diffuse base: {diffuse}) keeps the product"
        );
    }
}

/// On a scene whose lobes are all cosines, the per-scene plan makes a
/// product run radiance guiding: the same image as the radiance method, bit
/// for bit, without the LTC table, form factors or a weights check, and the
/// plan line says why. The paper's cosine product is still there on request.
#[test]
fn a_cosine_only_scene_renders_product_as_radiance_guiding() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/analytic/sphere_over_plane.xml");
    let scene = ltcguide::scene::load_scene(&path).unwrap();
    let opts = |method, cosine_lobes| ltcguide::render::RenderOptions {
        method,
        budget: ltcguide::render::Budget::Spp(8),
        seed: 3,
        threads: 1,
        cosine_lobes,
        ..Default::default()
    };
    use ltcguide::render::{Method, render};
    let radiance = render(&scene, &opts(Method::Radiance, CosineLobes::Radiance)).unwrap();
    let product = render(&scene, &opts(Method::Product, CosineLobes::Radiance)).unwrap();
    assert!(radiance.image.pixels.iter().any(|p| p.x > 0.0));
    assert_eq!(radiance.image.pixels, product.image.pixels);

    let plan = product.stats.plan.clone().unwrap();
    assert!(
        plan.contains("every vertex takes radiance weights")
            && plan.contains("ltc table off")
            && plan.contains("diffuse form factors off"),
        "{plan}"
    );
    assert_eq!(product.stats.guiding.as_ref().unwrap().weights_check, "");
    let paper = render(&scene, &opts(Method::Product, CosineLobes::Product)).unwrap();
    assert_ne!(paper.image.pixels, radiance.image.pixels);
    let plan = paper.stats.plan.unwrap();
    assert!(plan.contains("diffuse form factors on"), "{plan}");
    assert!(
        plan.contains("product weights at the first vertex of each path"),
        "{plan}"
    );
}

/// Without the plan, product guiding on a scene of diffuse surfaces is still
/// radiance guiding vertex by vertex (cosine lobes take radiance weights),
/// so with the same seed it renders the same image, bit for bit. The
/// scene's emitter reflects nothing: paths end there in both methods. Before
/// they did, the product gave its black vertices BSDF sampling (a product
/// zero over the sphere) and radiance guiding a guided direction, so the two
/// trees, and images, differed (MAE 1.3e-8 at 16 spp here; noise-sized on
/// cornell-box, whose light is black too).
#[test]
fn without_the_plan_a_diffuse_scene_renders_product_as_radiance_guiding() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/analytic/sphere_over_plane.xml");
    let scene = ltcguide::scene::load_scene(&path).unwrap();
    use ltcguide::render::{Method, render};
    let opts = |method| ltcguide::render::RenderOptions {
        method,
        budget: ltcguide::render::Budget::Spp(16),
        seed: 3,
        threads: 1,
        use_plan: false,
        path: ltcguide::integrator::path::PathSettings {
            max_depth: Some(5),
            ..ltcguide::render::RenderOptions::default().path
        },
        ..Default::default()
    };
    let radiance = render(&scene, &opts(Method::Radiance)).unwrap();
    let product = render(&scene, &opts(Method::Product)).unwrap();
    assert!(radiance.image.pixels.iter().any(|p| p.x > 0.0));
    assert!(radiance.stats.counters.guided_samples > 0);
    assert_eq!(radiance.image.pixels, product.image.pixels);
    let (r, p) = (&radiance.stats.counters, &product.stats.counters);
    assert_eq!(p.product_lobes_built, 0, "{p:?}");
    assert!(r.ended_at_black_surfaces > 0, "{r:?}");
    assert_eq!(r.ended_at_black_surfaces, p.ended_at_black_surfaces);
    assert_eq!(r.rays, p.rays);
}

/// `product_vertices = N` keeps product weights at the first N vertices of
/// a path and gives deeper ones radiance weights; 0 keeps the product at
/// every vertex.
#[test]
fn only_the_first_vertices_take_product_weights() {
    let table = default_ltc_table().unwrap();
    let bsdf = material(0.05, true).at(Vec2::ZERO);
    let frame = Frame::from_normal(Vec3::Z);
    let wo = Vec3::new(0.3, 0.1, 0.95).normalize();
    for (product_vertices, index, product) in [
        (1, 0, true),
        (1, 1, false),
        (1, 7, false),
        (3, 2, true),
        (3, 3, false),
        (0, 0, true),
        (0, 9, true),
    ] {
        let model = ProductModel {
            cosine_lobes: CosineLobes::Radiance,
            product_vertices,
            ..paper_model(table, ProductKernel::Simd)
        };
        let ctx = VertexContext {
            vertex_index: index,
            ..first_vertex(&frame, wo, &bsdf)
        };
        let mut cache = ProductCache::default();
        let w = model.weights(&ctx, &mut cache);
        assert_eq!(
            matches!(w, Some(ProductWeights::Product(_))),
            product,
            "product at the first {product_vertices} vertices, vertex {index}"
        );
        assert!(w.is_some());
    }
}
