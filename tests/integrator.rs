//! Estimators against closed forms and against each other.

mod common;

use glam::Vec3;
use ltcguide::integrator::guide::NoGuide;
use ltcguide::integrator::path::{PathScratch, PathSettings, RouletteMode, trace_path};
use ltcguide::integrator::stats::RenderCounters;
use ltcguide::sampling::Rng;
use ltcguide::scene::load_scene;
use std::path::Path;

fn data(p: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(p)
}

/// Direct lighting from a sphere light onto a diffuse plane:
/// L_o(x) = ρ·L·(r/d)²·cos θ (the sphere is entirely above the horizon).
#[test]
fn sphere_light_direct_lighting_matches_closed_form_with_and_without_nee() {
    let scene = load_scene(&data("analytic/sphere_over_plane.xml")).unwrap();
    let (c, r, l, rho) = (Vec3::new(0.7, 1.5, 0.3), 0.4f32, 10.0f32, 0.5f32);
    let points = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.7, 0.0, 0.3),
        Vec3::new(-1.5, 0.0, 1.0),
        Vec3::new(2.5, 0.0, -2.0),
    ];
    for nee in [true, false] {
        let settings = PathSettings {
            nee,
            max_depth: Some(2),
            roulette: RouletteMode::Off,
            adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
            defer_guide_pdf: true,
        };
        for (k, &x) in points.iter().enumerate() {
            let to = c - x;
            let d = to.length();
            let expected = rho * l * (r / d).powi(2) * (to.y / d);
            // A camera ray straight down onto x, starting below the sphere.
            let o = x + Vec3::new(0.0, 1.0, 0.0);
            let mut rng = Rng::new(11, k as u64);
            let mut counters = RenderCounters::default();
            let mut scratch = PathScratch::default();
            let n = if nee { 20_000 } else { 400_000 };
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let v = trace_path(
                    &scene,
                    &NoGuide,
                    &settings,
                    o,
                    -Vec3::Y,
                    &mut rng,
                    &mut counters,
                    &mut scratch,
                    &mut (),
                    &mut (),
                    0.0,
                )
                .y as f64;
                sum += v;
                sum2 += v * v;
            }
            let mean = sum / n as f64;
            let se = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
            assert!(
                (mean - expected as f64).abs() < 4.0 * se + 1e-4 * expected as f64,
                "nee {nee}, point {x}: {mean} ± {se} vs closed form {expected}"
            );
        }
    }
}

/// The analytic scene with its diffuse floor's reflectance set after
/// loading, past the loader's checks, to a value no scene file may hold.
fn sphere_over_plane_with_floor_reflectance(value: f32) -> ltcguide::scene::Scene {
    use ltcguide::bsdf::MaterialKind;
    use ltcguide::texture::Texture;
    let mut scene = load_scene(&data("analytic/sphere_over_plane.xml")).unwrap();
    let floor = scene
        .materials
        .iter_mut()
        .find(|m| matches!(&m.kind, MaterialKind::Diffuse { reflectance: Texture::Constant(r) } if r.x == 0.5))
        .unwrap();
    floor.kind = MaterialKind::Diffuse {
        reflectance: Texture::Constant(glam::Vec3::splat(value)),
    };
    scene
}

/// A BSDF that evaluates and samples to Inf (a diffuse floor whose
/// reflectance was made infinite after loading) is zeroed by the BSDF layer,
/// and the path loop counts every such value: NEE's evaluation and the
/// BSDF sample each time. Nothing non-finite reaches the estimate.
#[test]
fn non_finite_bsdf_values_are_counted_by_the_path_loop() {
    let scene = sphere_over_plane_with_floor_reflectance(f32::INFINITY);
    let settings = PathSettings {
        nee: true,
        max_depth: Some(3),
        roulette: RouletteMode::Off,
        adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
        defer_guide_pdf: true,
    };
    let mut rng = Rng::new(3, 0);
    let mut counters = RenderCounters::default();
    let mut scratch = PathScratch::default();
    let paths = 100;
    for _ in 0..paths {
        let v = trace_path(
            &scene,
            &NoGuide,
            &settings,
            Vec3::new(0.0, 1.0, 0.0),
            -Vec3::Y,
            &mut rng,
            &mut counters,
            &mut scratch,
            &mut (),
            &mut (),
            0.0,
        );
        assert_eq!(v, Vec3::ZERO);
    }
    assert_eq!(counters.nonfinite_samples, 0);
    // Every path: its BSDF sample, and NEE's evaluation where the light
    // sample was visible (most of them).
    assert!(
        counters.bsdf_nonfinite > paths && counters.bsdf_nonfinite <= 2 * paths,
        "{counters:?}"
    );
}

/// Guards that fire where no per-thread counters reach (here a negative
/// BSDF value and negative lobe weights) reach a render's statistics,
/// counted on the render's own workers, and the image stays non-negative.
#[test]
fn guard_events_of_a_render_reach_its_stats() {
    use ltcguide::render::{Budget, Method, RenderOptions, render};
    let scene = sphere_over_plane_with_floor_reflectance(-0.5);
    for method in [Method::Pt, Method::Product] {
        let opts = RenderOptions {
            method,
            budget: Budget::Spp(4),
            threads: 2,
            use_plan: false,
            // The paper's cosine product looks at the diffuse floor's lobes
            // (radiance weights at cosine vertices skip them).
            cosine_lobes: ltcguide::guiding::product::CosineLobes::Product,
            ..Default::default()
        };
        let r = render(&scene, &opts).unwrap();
        let g = r.stats.guards;
        assert!(g.bsdf_negative > 0, "{method:?}: {g:?}");
        assert_eq!(
            g.lobe_weights_invalid > 0,
            method == Method::Product,
            "{method:?}: {g:?}"
        );
        assert!(g.describe().contains("bsdf_negative"), "{g:?}");
        assert!(r.image.pixels.iter().all(|p| p.min_element() >= 0.0));
    }
}

/// A guide whose adjoint estimate is NaN: at every vertex where ADRRS
/// would play (from the second on), the path loop counts the estimate as
/// invalid and plays classic roulette's rule instead of none at all.
/// (The SD-tree guide had turned non-finite estimates into none,
/// uncounted.)
#[test]
fn non_finite_adjoint_estimates_are_counted_by_the_path_loop() {
    use ltcguide::guiding::descent::RadianceWeights;
    use ltcguide::guiding::guide::{SdGuide, WeightModel};
    use ltcguide::guiding::quadtree::QuadTree;
    use ltcguide::guiding::sdtree::{SdTree, SdTreeConfig};
    use ltcguide::integrator::guide::{Guide, VertexContext};

    struct NanAdjoint;
    impl WeightModel for NanAdjoint {
        type Weights<'a> = RadianceWeights;
        type Cache = ();
        fn weights(&self, _ctx: &VertexContext, _cache: &mut ()) -> Option<RadianceWeights> {
            Some(RadianceWeights)
        }
        fn adjoint(&self, _: &RadianceWeights, _: &VertexContext, _: f32, _: [f32; 4]) -> f32 {
            f32::NAN
        }
        fn name(&self) -> &'static str {
            "nan-adjoint"
        }
    }

    // The sphere light reflects, so that paths go on from it (a black
    // surface ends them).
    let mut scene = load_scene(&data("analytic/sphere_over_plane.xml")).unwrap();
    let sphere = scene
        .materials
        .iter_mut()
        .find(|m| m.reflects_nothing())
        .unwrap();
    sphere.kind = ltcguide::bsdf::MaterialKind::Diffuse {
        reflectance: ltcguide::texture::Texture::Constant(Vec3::splat(0.5)),
    };
    assert!(!sphere.reflects_nothing());
    let mut tree = SdTree::new(scene.bounds.0, scene.bounds.1, SdTreeConfig::default());
    tree.leaves_mut()[0].sampling = QuadTree::uniform(1.0);
    // BSDF sampling only: the guide is there for its adjoint estimate.
    let guide = SdGuide {
        tree: &tree,
        model: &NanAdjoint,
        learning: false,
        fixed_alpha: Some(1.0),
    };
    let settings = PathSettings {
        nee: false,
        max_depth: Some(3),
        roulette: RouletteMode::Adrrs,
        adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
        defer_guide_pdf: true,
    };
    let mut rng = Rng::new(5, 0);
    let mut counters = RenderCounters::default();
    let mut scratch = PathScratch::default();
    let mut recorder = guide.new_recorder();
    let paths = 2000;
    for _ in 0..paths {
        // Straight down under the sphere light: about 7 % of the floor's
        // cosine samples hit the sphere, a second vertex.
        trace_path(
            &scene,
            &guide,
            &settings,
            Vec3::new(0.7, 1.0, 0.3),
            -Vec3::Y,
            &mut rng,
            &mut counters,
            &mut scratch,
            &mut recorder,
            &mut (),
            1.0,
        );
    }
    let invalid = counters.adrrs.invalid_estimate;
    assert!(invalid > 50 && invalid < 400, "{counters:?}");
    assert_eq!(counters.adrrs.played + counters.adrrs.above_window, 0);
}

/// The first vertex a guide could act on, as the α image and the
/// attribution's pixel classes see it: on the analytic scene every pixel
/// centre's ray meets the floor or the black sphere light first, and the
/// vertex is there exactly where it meets the floor (paths end at the
/// sphere, which reflects nothing).
#[test]
fn the_first_vertex_to_guide_is_never_on_a_surface_that_reflects_nothing() {
    use ltcguide::integrator::first_vertex::at_pixel_centre;
    let scene = load_scene(&data("analytic/sphere_over_plane.xml")).unwrap();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let mut on_sphere = 0;
    for i in 0..w * h {
        let film = glam::Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
        let (o, d) = scene.camera.ray(film);
        let it = scene
            .intersect(o, d, f32::INFINITY)
            .expect("every ray meets the scene");
        let black = scene.material_of(&it).reflects_nothing();
        on_sphere += black as usize;
        match at_pixel_centre(&scene, i) {
            None => assert!(black, "pixel {i}: no vertex, yet the floor was hit"),
            Some(v) => {
                assert!(!black, "pixel {i}: a vertex on the black sphere");
                assert!(
                    (v.p - it.p).length() < 1e-4,
                    "pixel {i}: {:?} vs {:?}",
                    v.p,
                    it.p
                );
            }
        }
    }
    // The sphere (radius 0.4, 4.5 below the camera) covers a disc of the
    // 64 × 64 image; the floor the rest.
    assert!(on_sphere > 20 && on_sphere < w * h / 2, "{on_sphere}");
}

/// A caller that keeps its record buffers across calls (the trainer) gets
/// the records a fresh set would hold: stale records are dropped, surplus
/// buffers removed, and the film and counters do not depend on the reuse.
#[test]
fn reused_record_buffers_hold_exactly_the_calls_records() {
    use ltcguide::film::image::Film;
    use ltcguide::guiding::guide::{RadianceModel, SdGuide};
    use ltcguide::guiding::quadtree::QuadTree;
    use ltcguide::guiding::record::RecordBuffer;
    use ltcguide::guiding::sdtree::{SdTree, SdTreeConfig};
    use ltcguide::integrator::render_passes_into;

    let scene = load_scene(&data("analytic/sphere_over_plane.xml")).unwrap();
    let mut tree = SdTree::new(scene.bounds.0, scene.bounds.1, SdTreeConfig::default());
    tree.leaves_mut()[0].sampling = QuadTree::uniform(1.0);
    let guide = SdGuide {
        tree: &tree,
        model: &RadianceModel::default(),
        learning: true,
        fixed_alpha: Some(0.5),
    };
    let settings = PathSettings {
        nee: false,
        max_depth: Some(3),
        roulette: RouletteMode::Classic,
        adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
        defer_guide_pdf: true,
    };
    let (w, h) = (scene.camera.width, scene.camera.height);
    let call = |passes: std::ops::Range<u64>, buffers: &mut Vec<RecordBuffer>| {
        let mut film = Film::new(w, h);
        let counters = render_passes_into(
            &scene, &guide, &settings, 9, passes, None, &mut film, buffers,
        );
        (film.image().pixels, counters.paths, counters.rays)
    };
    let mut fresh = Vec::new();
    let fresh_out = call(2..4, &mut fresh);
    let records: usize = fresh.iter().map(|b| b.records.len()).sum();
    assert!(records > 0, "the call recorded nothing");
    // The same buffers after a larger call, with a stale buffer appended.
    let mut reused = Vec::new();
    call(0..6, &mut reused);
    let blocks = reused.len();
    reused.push(fresh[0].clone());
    let reused_out = call(2..4, &mut reused);
    assert_eq!(reused.len(), blocks);
    assert_eq!(fresh_out, reused_out);
    let as_records =
        |b: &[RecordBuffer]| -> Vec<Vec<_>> { b.iter().map(|b| b.records.clone()).collect() };
    assert_eq!(as_records(&fresh), as_records(&reused));
}

/// The smooth-plastic floor scene, with NEE and classic roulette.
fn smooth_plastic_floor() -> (ltcguide::scene::Scene, PathSettings) {
    let scene = load_scene(&data("analytic/smooth_plastic_floor.xml")).unwrap();
    let path = PathSettings {
        nee: true,
        max_depth: scene.max_depth,
        roulette: RouletteMode::Classic,
        adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
        defer_guide_pdf: true,
    };
    (scene, path)
}

/// Smooth plastic's coat is a delta lobe beside a diffuse base that is
/// guided. BSDF sampling is chosen there with probability α, so a delta
/// sample's weight is f/(α·p_lobe); without the 1/α the coat's reflection
/// came out scaled by α (a learned α of ~0.3 darkened this floor by ~60 %).
/// Each guided estimator, at a learned and at a fixed α, must agree with
/// path tracing; a fixed α of 0, which would never sample the coat, is
/// refused.
#[test]
fn guided_estimators_agree_with_pt_on_smooth_plastic() {
    use ltcguide::film::compare::compare_blocks;
    use ltcguide::render::{Method, RenderOptions, render};
    let (scene, path) = smooth_plastic_floor();
    let run = |method: Method, bsdf_fraction: Option<f32>, spp: u32, seed: u64| {
        let opts = RenderOptions {
            bsdf_fraction,
            // Guiding as such: a strategy trial may hand the run to path tracing.
            use_plan: false,
            ..common::options(method, spp, seed, path)
        };
        render(&scene, &opts)
    };
    let pt = run(Method::Pt, None, 512, 21).unwrap();
    for (method, fraction) in [
        (Method::Radiance, None),
        (Method::Radiance, Some(0.25)),
        (Method::Product, None),
    ] {
        let g = run(method, fraction, 256, 22).unwrap();
        assert_eq!(
            g.stats.guards.total(),
            0,
            "{method:?}: {:?}",
            g.stats.guards
        );
        assert!(
            g.stats.counters.guided_samples > 0,
            "{method:?} {fraction:?}"
        );
        let cmp = compare_blocks(&g.image, &g.variance, &pt.image, &pt.variance, 8).unwrap();
        common::assert_blocks_agree(
            &format!("smooth plastic, {method:?} α {fraction:?} vs pt"),
            &cmp,
        );
    }
    let Err(refused) = run(Method::Radiance, Some(0.0), 1, 1) else {
        panic!("a fixed α of 0 was accepted on smooth plastic");
    };
    assert!(refused.contains("--bsdf-fraction 0"), "{refused}");
    // Path tracing takes no BSDF fraction, so the rule does not apply to it.
    assert!(run(Method::Pt, Some(0.0), 1, 1).is_ok());
}

/// A delta sample at a guided vertex is a sample of its mixture: Adam must
/// see it, or the coat's share looks wasted to the KL gradient (BSDF
/// sampling's density over the continuous directions holds only the base's
/// share), α falls to its floor of 0.05, and the coat is reached rarely and
/// with weight 20. With those samples left out, learned α had ~10× the
/// variance of a fixed 0.5 here; with them it has less than the fixed one.
#[test]
fn the_learned_fraction_keeps_sampling_a_delta_coat() {
    use ltcguide::render::{Method, RenderOptions, render};
    let (scene, path) = smooth_plastic_floor();
    let total_variance = |bsdf_fraction: Option<f32>| {
        let opts = RenderOptions {
            bsdf_fraction,
            use_plan: false,
            ..common::options(Method::Radiance, 256, 23, path)
        };
        let r = render(&scene, &opts).unwrap();
        r.variance.iter().sum::<f64>()
    };
    let (learned, fixed) = (total_variance(None), total_variance(Some(0.5)));
    eprintln!("summed pixel variance: learned α {learned:.4e}, fixed 0.5 {fixed:.4e}");
    assert!(
        learned < fixed,
        "learned {learned:.4e}, fixed 0.5 {fixed:.4e}"
    );
}

/// The tilted diffuse plane under a uniform sky of radiance 1, with its
/// one-bounce path settings, without NEE or roulette.
fn floor_under_uniform_sky() -> (ltcguide::scene::Scene, PathSettings) {
    let scene = load_scene(&data("analytic/floor_under_uniform_sky.xml")).unwrap();
    let path = PathSettings {
        nee: false,
        max_depth: scene.max_depth,
        roulette: RouletteMode::Off,
        adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
        defer_guide_pdf: true,
    };
    (scene, path)
}

/// The tree estimates ∫L dω at a leaf as Σ(L/p)/N over the samples of the
/// vertices' mixtures, so N must count every sample drawn, including the
/// guided directions below the surface, whose radiance is 0. Left out, they
/// inflated the estimate by N_all/N_kept, and ADRRS's adjoint with it.
/// Under a uniform sky of radiance 1, ∫L dω at a point of the plane is 2π
/// (1 above its horizon, 0 below).
#[test]
fn the_tree_counts_every_sample_of_the_mixture() {
    use ltcguide::render::{Method, RenderOptions, render};
    let (scene, path) = floor_under_uniform_sky();
    // At 8 spp the last training iteration guides with a coarse tree, whose
    // box splats leak flux below the tilted horizon: ~20 % of its guided
    // samples go there. Leaving them out of N gave 1.118 by the mean over
    // the 3 seeds' leaves; counting them, 1.002.
    let (mut integrals, mut below, mut guided) = (Vec::new(), 0, 0);
    for seed in 5..8 {
        let opts = RenderOptions {
            use_plan: false,
            ..common::options(Method::Radiance, 8, seed, path)
        };
        let r = render(&scene, &opts).unwrap();
        let tree = r.tree.expect("a guided render returns its tree");
        integrals.extend(
            tree.leaves()
                .iter()
                .filter(|l| l.sampling.total() > 0.0)
                .map(|l| l.sampling.radiance_integral() as f64),
        );
        below += r.stats.counters.guided_below_horizon;
        guided += r.stats.counters.guided_samples;
    }
    let ratio = integrals.iter().sum::<f64>() / integrals.len() as f64 / (2.0 * PI_F64);
    eprintln!(
        "∫L dω / 2π = {ratio:.4} over {} leaves; {below} of {guided} guided samples below the horizon",
        integrals.len()
    );
    assert!(
        below * 10 > guided,
        "too few samples below the horizon to test"
    );
    assert!((ratio - 1.0).abs() < 0.04, "∫L dω / 2π = {ratio:.4}");
}

const PI_F64: f64 = std::f64::consts::PI;

/// `--guide-support hemisphere` on the tilted plane under a uniform sky,
/// where every pixel is ρ·L = 0.5: radiance guiding over the sphere sends a
/// share of its guided samples below the plane (the box splat leaks flux
/// there), the hemisphere weights almost none, and both images stay at 0.5.
/// Sending none below lowers the variance, since every guided sample then
/// carries light (summed pixel variance 0.80× the sphere's here; 15 % of
/// the sphere's guided samples and 0.9 % of the hemisphere's went below).
#[test]
fn hemisphere_support_guides_above_the_surface_without_bias() {
    use ltcguide::guiding::support::GuideSupport;
    use ltcguide::render::{Method, RenderOptions, render};
    let (scene, path) = floor_under_uniform_sky();
    let mut summed_variance = [0.0f64; 2];
    let mut below_share = [0.0f64; 2];
    for (i, support) in [GuideSupport::Sphere, GuideSupport::Hemisphere]
        .into_iter()
        .enumerate()
    {
        let opts = RenderOptions {
            use_plan: false,
            guide_support: support,
            ..common::options(Method::Radiance, 16, 9, path)
        };
        let r = render(&scene, &opts).unwrap();
        assert_eq!(r.stats.guards.total(), 0, "{:?}", r.stats.guards);
        let c = &r.stats.counters;
        let below = c.guided_below_horizon as f64 / c.guided_samples as f64;
        let n = r.variance.len() as f64;
        let mean = r.image.mean_rgb().x as f64;
        let standard_error = r.variance.iter().sum::<f64>().sqrt() / n;
        summed_variance[i] = r.variance.iter().sum::<f64>();
        eprintln!(
            "{support:?}: {below:.4} of {} guided samples below, mean {mean:.5} ± {standard_error:.5}",
            c.guided_samples
        );
        assert!(
            (mean - 0.5).abs() < 4.0 * standard_error,
            "{support:?}: mean {mean} against 0.5 ± {standard_error}"
        );
        below_share[i] = below;
    }
    assert!(below_share[0] > 0.05, "sphere: {} below", below_share[0]);
    assert!(
        below_share[1] < 0.2 * below_share[0],
        "hemisphere: {} below, sphere {}",
        below_share[1],
        below_share[0]
    );
    let ratio = summed_variance[1] / summed_variance[0];
    eprintln!("summed pixel variance, hemisphere / sphere: {ratio:.3}");
    assert!(ratio < 1.0, "hemisphere / sphere variance {ratio}");
}

/// Inside a sphere that emits inward, every pixel is 1 + ρ + ρ² at three
/// segments. Next-event estimation from a point on the sphere itself, which
/// rounding puts just outside it about as often as just inside, took the
/// cone branch there, where a flipped sphere is never sampled, while the
/// pdf used for MIS still gave BSDF-sampled hits the cone's pdf: the image
/// came out 2.52 instead of 2.71. Sampling and pdf now count a point on the
/// sphere as inside alike.
#[test]
fn nee_from_a_point_on_an_emitting_sphere_matches_the_closed_form() {
    use ltcguide::render::{Budget, Method, RenderOptions, render};
    let scene = load_scene(&data("analytic/inside_emitting_sphere.xml")).unwrap();
    let expected = 1.0 + 0.9 + 0.81;
    for nee in [false, true] {
        let opts = RenderOptions {
            method: Method::Pt,
            budget: Budget::Spp(64),
            seed: 3,
            path: PathSettings {
                nee,
                max_depth: scene.max_depth,
                roulette: RouletteMode::Off,
                adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
                defer_guide_pdf: true,
            },
            ..Default::default()
        };
        let r = render(&scene, &opts).unwrap();
        let n = r.image.pixels.len() as f64;
        let mean = r.image.pixels.iter().map(|p| p.x as f64).sum::<f64>() / n;
        eprintln!("inside an emitting sphere, nee {nee}: {mean:.6}, expected {expected}");
        // Light samples close to the shading point make NEE's tail heavy, so
        // its sample variance understates the error of the mean (seeds give
        // 2.7093–2.7102). A relative bound of 0.5 % stands far from the
        // defect's −7 %; without NEE every path is exact.
        assert!(
            (mean / expected - 1.0).abs() < 5e-3,
            "nee {nee}: {mean:.4}, expected {expected}"
        );
    }
}
