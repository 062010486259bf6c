//! The tiny comparison every study test starts from.

use ltcguide::experiment::compare::CompareOptions;
use ltcguide::film::image::Image;
use ltcguide::guiding::product::CosineLobes;
use ltcguide::integrator::path::{PathSettings, RouletteMode};
use ltcguide::render::{Method, TimeBase};
use ltcguide::scene::{Scene, load_scene};
use std::path::Path;

pub fn settings(scene: &Scene, method: Method) -> PathSettings {
    PathSettings {
        nee: method == Method::Pt,
        max_depth: scene.max_depth,
        roulette: if method == Method::Pt {
            RouletteMode::Classic
        } else {
            RouletteMode::Adrrs
        },
        adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
        defer_guide_pdf: true,
    }
}

pub fn tiny() -> Scene {
    load_scene(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/analytic/sphere_over_plane.xml"),
    )
    .unwrap()
}

/// The options every test starts from: `methods` for one run of 0.2 s
/// into `out_dir`, the paper's NEE choice, no roulette override, product
/// guiding's defaults, methods one after the other, no progress.
pub fn compare_options(methods: Vec<Method>, out_dir: &Path) -> CompareOptions {
    CompareOptions {
        methods,
        seconds: 0.2,
        time_base: TimeBase::Wall,
        runs: 1,
        first_run: 0,
        threads: 0,
        out_dir: out_dir.to_path_buf(),
        path_for: settings,
        nee: ltcguide::experiment::compare::NeeChoice::Paper,
        guided_roulette: None,
        defer_guide_pdf: true,
        training_stop: ltcguide::guiding::schedule::TrainingStop::Budget,
        cosine_lobes: CosineLobes::Radiance,
        product_vertices: 1,
        pixel_reuse: true,
        radiance_share: ltcguide::guiding::defensive::RadianceShare::default(),
        guide_support: ltcguide::guiding::support::GuideSupport::Sphere,
        bsdf_fraction_l2: None,
        bsdf_fraction_learning: ltcguide::guiding::adam::FractionLearning::Kl,
        side_by_side: false,
        use_plan: true,
        progress: false,
        reference_file: None,
        overwrite: false,
    }
}

/// A uniform 64×64 reference, the tiny scene's size.
pub fn flat_reference() -> Image {
    Image {
        width: 64,
        height: 64,
        pixels: vec![glam::Vec3::splat(0.5); 64 * 64],
    }
}
