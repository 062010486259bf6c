//! Product guiding's sampling distribution: χ² of the product descent
//! against its own pdf at random shading points, normals, roughness
//! (α = 1e-3 and α = 1 included) and grazing θ_o, over synthetic quadtrees;
//! bit-identical pdf of sampled directions; and ADRRS leaving the image's
//! expectation unchanged.

use glam::{Vec2, Vec3};
use ltcguide::bsdf::{ConductorFresnel, Material, MaterialKind};
use ltcguide::directional::{Cell, dir_to_square, square_to_dir};
use ltcguide::guiding::descent::{self, ChildWeights};
use ltcguide::guiding::guide::{WeightModel, reflected_radiance_estimate};
use ltcguide::guiding::product::{
    CosineLobes, ProductCache, ProductModel, ProductWeights, guiding_ltc_options,
};
use ltcguide::guiding::quadtree::{QuadNode, QuadTree};
use ltcguide::integrator::guide::VertexContext;
use ltcguide::ltc::children::ShadingLtc;
use ltcguide::ltc::table::LtcTable;
use ltcguide::ltc::{LtcOptions, ProductKernel};
use ltcguide::math::Frame;
use ltcguide::render::default_ltc_table;
use ltcguide::sampling::{Rng, square_to_uniform_sphere};
use ltcguide::stats::chi2::{Chi2Config, chi2_square_expected};
use ltcguide::texture::Texture;

/// The paper's product at every vertex (its cosine product included), with
/// the LTC API's accurate options and no lobe reuse: the model these tests
/// check unless they say otherwise.
fn paper_model(table: &LtcTable, kernel: ProductKernel) -> ProductModel<'_> {
    ProductModel {
        table,
        kernel,
        options: LtcOptions::default(),
        radiance_only: false,
        cosine_lobes: CosineLobes::Product,
        product_vertices: 0,
        reuse_in_pixel: false,
    }
}

/// [`paper_model`] with the LTC options every product render runs with
/// (`guiding_ltc_options`: sphere-clipped straddlers from level 2, chord
/// quads from level 4, centre rules), which trade accuracy for speed: the
/// sampler must still match its own pdf.
fn render_options_model(table: &LtcTable) -> ProductModel<'_> {
    ProductModel {
        options: guiding_ltc_options(),
        ..paper_model(table, ProductKernel::Simd)
    }
}

/// A random quadtree of about `n` nodes, depth ≤ 9, with some zero cells.
fn random_tree(rng: &mut Rng, n: usize) -> QuadTree {
    let mut nodes = vec![QuadNode {
        sums: [1.0, 0.5, 2.0, 0.7],
        children: [0; 4],
    }];
    let mut depth = vec![0u32];
    while nodes.len() < n {
        let i = (rng.next_u32() as usize) % nodes.len();
        let k = (rng.next_u32() % 4) as usize;
        if nodes[i].children[k] != 0 || depth[i] >= 9 || nodes[i].sums[k] == 0.0 {
            continue;
        }
        let sums = [0; 4].map(|_| {
            if rng.next_f32() < 0.15 {
                0.0
            } else {
                0.05 + 3.0 * rng.next_f32()
            }
        });
        nodes.push(QuadNode {
            sums,
            children: [0; 4],
        });
        depth.push(depth[i] + 1);
        nodes[i].children[k] = (nodes.len() - 1) as u32;
    }
    QuadTree::from_nodes(nodes).unwrap()
}

/// Probability of every χ² bin: each terminal cell's mass, spread over the
/// bins it overlaps in proportion to the overlap area.
fn exact_bin_probabilities(
    tree: &QuadTree,
    w: &mut ProductWeights,
    rx: usize,
    ry: usize,
) -> Vec<f64> {
    exact_bin_probabilities_in(tree, w, rx, ry, Cell::ROOT)
}

/// [`exact_bin_probabilities`] over the bins of the square of `zoom` alone
/// (in its own coordinates), unnormalised: they sum to P(zoom).
fn exact_bin_probabilities_in(
    tree: &QuadTree,
    w: &mut ProductWeights,
    rx: usize,
    ry: usize,
    zoom: Cell,
) -> Vec<f64> {
    let (zu, zv, zs) = zoom.square_bounds();
    let mut bins = vec![0f64; rx * ry];
    descent::for_each_terminal_cell(tree, w, |cell, mass| {
        let (u0, v0, size) = cell.square_bounds();
        // The cell in the zoom's coordinates, clipped to it.
        let (u0, v0, size) = ((u0 - zu) / zs, (v0 - zv) / zs, size / zs);
        if u0 >= 1.0 || v0 >= 1.0 || u0 + size <= 0.0 || v0 + size <= 0.0 {
            return;
        }
        let bin_range = |lo: f64, n: usize| {
            (
                (lo.max(0.0) * n as f64).floor() as usize,
                (((lo + size).min(1.0)) * n as f64).ceil() as usize,
            )
        };
        let ((bx0, bx1), (by0, by1)) = (bin_range(u0, rx), bin_range(v0, ry));
        for by in by0..by1.min(ry) {
            for bx in bx0..bx1.min(rx) {
                let ox =
                    ((bx + 1) as f64 / rx as f64).min(u0 + size) - (bx as f64 / rx as f64).max(u0);
                let oy =
                    ((by + 1) as f64 / ry as f64).min(v0 + size) - (by as f64 / ry as f64).max(v0);
                if ox > 0.0 && oy > 0.0 {
                    bins[by * rx + bx] += mass * ox * oy / (size * size);
                }
            }
        }
    });
    bins
}

fn material(alpha: f32, diffuse: bool) -> Material {
    let kind = if diffuse {
        MaterialKind::RoughPlastic {
            alpha,
            eta: 1.5,
            diffuse_reflectance: Texture::Constant(Vec3::splat(0.5)),
        }
    } else {
        MaterialKind::RoughConductor {
            alpha,
            fresnel: ConductorFresnel::None,
            specular_reflectance: Texture::Constant(Vec3::ONE),
        }
    };
    Material::new(kind, true).unwrap()
}

/// A shading configuration: normal, θ_o and material.
#[derive(Clone, Copy)]
struct Case {
    alpha: f32,
    diffuse: bool,
    theta_o_deg: f32,
    normal: Vec3,
}

fn weights_for<'c>(
    case: &Case,
    model: &'c ProductModel,
    rng: &mut Rng,
    cache: &'c mut ProductCache,
) -> Option<ProductWeights<'c>> {
    let phi = std::f32::consts::TAU * rng.next_f32();
    let bsdf = material(case.alpha, case.diffuse).at(Vec2::ZERO);
    weights_at(
        model,
        case.normal,
        wo_at(case.theta_o_deg, phi),
        &bsdf,
        cache,
    )
}

/// The local ω_o at polar angle `theta_o_deg` and azimuth `phi`.
fn wo_at(theta_o_deg: f32, phi: f32) -> Vec3 {
    let t = theta_o_deg.to_radians();
    Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())
}

/// The product weights of the first vertex at the origin with `normal`,
/// local ω_o `wo` and `bsdf`.
fn weights_at<'c>(
    model: &'c ProductModel,
    normal: Vec3,
    wo: Vec3,
    bsdf: &ltcguide::bsdf::Bsdf,
    cache: &'c mut ProductCache,
) -> Option<ProductWeights<'c>> {
    let frame = Frame::from_normal(normal);
    model.weights(&first_vertex(&frame, wo, bsdf), cache)
}

/// The context of a path's first vertex at the origin, with the geometric
/// normal the shading one and no adjoint asked for.
fn first_vertex<'a>(
    frame: &'a Frame,
    wo: Vec3,
    bsdf: &'a ltcguide::bsdf::Bsdf,
) -> VertexContext<'a> {
    VertexContext {
        p: Vec3::ZERO,
        ng: frame.n,
        frame,
        wo_local: wo,
        bsdf,
        needs_adjoint: false,
        vertex_index: 0,
    }
}

fn cases(rng: &mut Rng) -> Vec<Case> {
    let mut v = Vec::new();
    for &(alpha, diffuse) in &[
        (1e-3, false),
        (0.05, false),
        (0.2, true),
        (0.4, false),
        (1.0, false),
        (1.0, true),
    ] {
        for &theta in &[0.0f32, 45.0, 80.0] {
            let normal = if rng.next_f32() < 0.2 {
                Vec3::Z
            } else {
                square_to_uniform_sphere(rng.next_2d())
            };
            v.push(Case {
                alpha,
                diffuse,
                theta_o_deg: theta,
                normal,
            });
        }
    }
    // Grazing beyond the paper's 85° switch: the radiance fallback.
    v.push(Case {
        alpha: 0.1,
        diffuse: false,
        theta_o_deg: 88.0,
        normal: Vec3::new(0.3, 0.2, 0.9).normalize(),
    });
    v
}

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
