//! The guide's pdf of a BSDF sample computed only if the path brings
//! radiance (`integrator::deferred_pdf`): the same estimate as computing it
//! at once, path by path and record by record, and the same expectation
//! under adjoint-driven roulette, which reads a stand-in meanwhile.

mod common;

use glam::{Vec2, Vec3};
use ltcguide::film::compare::compare_blocks;
use ltcguide::guiding::guide::SdGuide;
use ltcguide::guiding::product::{DEFAULT_PRODUCT_VERTICES, ProductCache, ProductModel};
use ltcguide::guiding::record::Record;
use ltcguide::guiding::sdtree::SdTree;
use ltcguide::integrator::guide::Guide;
use ltcguide::integrator::path::{PathScratch, PathSettings, RouletteMode, trace_path};
use ltcguide::integrator::stats::RenderCounters;
use ltcguide::render::{Method, RenderOptions, default_ltc_table, render};
use ltcguide::sampling::Rng;
use ltcguide::scene::{Scene, load_scene};
use std::path::Path;

/// The project's glossy scene lit through a gap: without NEE most of its
/// paths bring nothing, and its GGX surfaces take product weights.
fn glossy_gap() -> Scene {
    load_scene(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/glossy-gap/scene.xml")).unwrap()
}

fn settings(scene: &Scene, roulette: RouletteMode, defer: bool) -> PathSettings {
    PathSettings {
        nee: false,
        max_depth: scene.max_depth,
        roulette,
        adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
        defer_guide_pdf: defer,
    }
}

/// A tree trained by a short product render, to guide the paths below.
fn trained_tree(scene: &Scene) -> SdTree {
    let opts = RenderOptions {
        use_plan: false,
        threads: 2,
        ..common::options(
            Method::Product,
            8,
            3,
            settings(scene, RouletteMode::Off, true),
        )
    };
    render(scene, &opts)
        .unwrap()
        .tree
        .expect("a guided render returns its tree")
}

fn close(a: f32, b: f32, what: &str, path: usize) {
    let tolerance = 2e-5 * a.abs().max(b.abs()) + 1e-30;
    assert!(
        (a - b).abs() <= tolerance,
        "path {path}: {what} {a:e} deferred against {b:e} at once"
    );
}

/// Every path traced with the deferred pdf has the value the eager path
/// has (roulette off, so that both see the same random numbers), and the
/// learning records agree field by field, but for the pdfs of vertices
/// whose path brought nothing, which keep the stand-in; their radiance and
/// product are zero either way. Forgetting to rescale the contributions,
/// the recorded throughputs or the vertex's pdfs fails it.
#[test]
fn a_deferred_pdf_changes_no_path_and_no_record_that_carries_radiance() {
    let scene = glossy_gap();
    let tree = trained_tree(&scene);
    let table = default_ltc_table().unwrap();
    let model = ProductModel {
        table,
        kernel: ltcguide::ltc::ProductKernel::Simd,
        options: ltcguide::guiding::product::guiding_ltc_options(),
        radiance_only: false,
        cosine_lobes: Default::default(),
        product_vertices: DEFAULT_PRODUCT_VERTICES,
        reuse_in_pixel: true,
        radiance_share: 0.3,
    };
    let guide = SdGuide {
        tree: &tree,
        model: &model,
        learning: true,
        fixed_alpha: None,
    };
    let trace = |defer: bool| {
        let settings = settings(&scene, RouletteMode::Off, defer);
        let mut counters = RenderCounters::default();
        let mut scratch = PathScratch::default();
        let mut recorder = guide.new_recorder();
        let mut cache = ProductCache::default();
        let mut values = Vec::new();
        let mut records: Vec<Vec<Record>> = Vec::new();
        let (w, h) = (scene.camera.width, scene.camera.height);
        for i in 0..20_000usize {
            let mut rng = Rng::new(11, i as u64);
            // A pixel's paths one after the other, as the render loop
            // traces them (lobes are reused within a pixel).
            let pixel = (i / 4) * 7919 % (w * h);
            let film = Vec2::new((pixel % w) as f32, (pixel / w) as f32) + rng.next_2d();
            let (o, d) = scene.camera.ray(film);
            guide.clear_recorder(&mut recorder);
            let v = trace_path(
                &scene,
                &guide,
                &settings,
                o,
                d,
                &mut rng,
                &mut counters,
                &mut scratch,
                &mut recorder,
                &mut cache,
                1.0,
            );
            values.push(v);
            records.push(recorder.records.clone());
        }
        (values, records, counters)
    };
    let (deferred, deferred_records, dc) = trace(true);
    let (eager, eager_records, ec) = trace(false);
    eprintln!(
        "{} pdfs deferred, {} resolved; {} paths",
        dc.guide_pdfs_deferred,
        dc.guide_pdfs_resolved,
        eager.len()
    );
    assert_eq!(ec.guide_pdfs_deferred, 0);
    assert!(
        dc.guide_pdfs_deferred > 2000 && dc.guide_pdfs_resolved > 100,
        "the test must defer pdfs and resolve some: {dc:?}"
    );
    assert!(
        dc.guide_pdfs_resolved < dc.guide_pdfs_deferred / 2,
        "most deferred pdfs should never be computed here: {dc:?}"
    );
    assert_eq!(dc.rays, ec.rays, "the same paths were traced");
    assert_eq!(dc.invalid_scattering, ec.invalid_scattering);
    let mut nonzero = 0;
    for (i, (a, b)) in deferred.iter().zip(&eager).enumerate() {
        close(a.x, b.x, "red", i);
        close(a.y, b.y, "green", i);
        close(a.z, b.z, "blue", i);
        nonzero += (*b != Vec3::ZERO) as usize;
    }
    assert!(nonzero > 200, "{nonzero} paths brought radiance");
    let mut stand_ins = 0;
    for (i, (ra, rb)) in deferred_records.iter().zip(&eager_records).enumerate() {
        assert_eq!(ra.len(), rb.len(), "path {i}: record counts");
        for (a, b) in ra.iter().zip(rb) {
            assert_eq!((a.position, a.direction), (b.position, b.direction));
            close(a.radiance, b.radiance, "recorded radiance", i);
            close(a.product, b.product, "recorded product", i);
            close(a.bsdf_pdf, b.bsdf_pdf, "BSDF pdf", i);
            close(a.alpha, b.alpha, "α", i);
            if (a.radiance, a.product) != (0.0, 0.0) {
                close(a.guide_pdf, b.guide_pdf, "guide pdf", i);
                close(a.throughput_pdf, b.throughput_pdf, "throughput·p", i);
            } else if a.guide_pdf != b.guide_pdf {
                // The deferred vertex of a path that brought nothing keeps
                // the stand-in; its throughput·p is at most the exact one.
                stand_ins += 1;
                assert_eq!(a.guide_pdf, 0.0, "path {i}: stand-in guide pdf");
                assert!(a.throughput_pdf <= b.throughput_pdf * (1.0 + 1e-6));
            }
        }
    }
    assert!(stand_ins > 1000, "{stand_ins} records kept a stand-in");
}

/// Under adjoint-driven roulette, which reads the stand-in throughput after
/// a deferred vertex, the image's expectation is the eager one's: both
/// guided methods, globally and block by block (the median of z², as in
/// `guided_convergence.rs`, since roulette's survivors are heavy-tailed).
#[test]
fn roulette_on_a_stand_in_changes_no_expectation() {
    let scene = glossy_gap();
    for method in [Method::Radiance, Method::Product] {
        let run = |defer: bool, seed: u64| {
            let opts = RenderOptions {
                use_plan: false,
                ..common::options(
                    method,
                    32,
                    seed,
                    settings(&scene, RouletteMode::Adrrs, defer),
                )
            };
            render(&scene, &opts).unwrap()
        };
        let deferred = run(true, 1);
        let eager = run(false, 2);
        let c = &deferred.stats.counters;
        assert!(c.guide_pdfs_deferred > 0 && c.adrrs.played > 0, "{c:?}");
        assert_eq!(eager.stats.counters.guide_pdfs_deferred, 0);
        let cmp = compare_blocks(
            &deferred.image,
            &deferred.variance,
            &eager.image,
            &eager.variance,
            16,
        )
        .unwrap();
        eprintln!(
            "{method:?}: means {:.5} / {:.5}, z_global {:.2}, median z² {:.2}; {} of {} deferred pdfs resolved",
            cmp.mean_a,
            cmp.mean_b,
            cmp.z_global,
            cmp.median_z2(),
            c.guide_pdfs_resolved,
            c.guide_pdfs_deferred
        );
        assert!(
            cmp.z_global.abs() < 4.0,
            "{method:?}: z {:.2}",
            cmp.z_global
        );
        assert!(
            cmp.median_z2() < 1.0,
            "{method:?}: median z² {:.2}",
            cmp.median_z2()
        );
    }
}
