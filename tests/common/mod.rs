//! Helpers shared by the integration tests: locating the scene pack (tests
//! that need it skip with a message when `../shared` is absent) and
//! rendering with statistics.
#![allow(dead_code)]

pub mod study;

use ltcguide::film::compare::{BlockComparison, compare_blocks};
use ltcguide::film::exr_io::read_image;
use ltcguide::film::image::Image;
use ltcguide::integrator::path::{PathSettings, RouletteMode};
use ltcguide::render::{Budget, Method, RenderOptions, RenderResult, render};
use ltcguide::scene::{Scene, load_scene};
use std::path::{Path, PathBuf};

pub const PACK_SCENES: [&str; 5] = [
    "cornell-box",
    "veach-mis",
    "veach-ajar",
    "staircase",
    "living-room",
];

/// A fresh scratch directory for a test named `name`: per process, so
/// test binaries running at once do not share it.
pub fn work_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ltcguide-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The small stiff scene that ships with ltcguide.
pub fn default_scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/stiff/scene.xml")
}

/// `../shared/scenes` next to the repository, if present.
pub fn pack_dir() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes");
    dir.join("README.md").exists().then_some(dir)
}

/// Skips a test (returns None after printing why) when the pack is absent.
pub fn pack_scene(name: &str) -> Option<(Scene, PathBuf)> {
    let Some(dir) = pack_dir() else {
        eprintln!("SKIPPED: the scene pack ../shared/scenes is absent (a fresh clone has no pack)");
        return None;
    };
    let path = dir.join(name).join("scene.xml");
    let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    Some((scene, dir.join(name)))
}

pub fn reference(scene_dir: &Path) -> (Image, u32) {
    let img = read_image(&scene_dir.join("reference.exr")).expect("reference.exr");
    let meta: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(scene_dir.join("meta.json")).expect("meta.json"),
    )
    .expect("json");
    let spp = meta["reference"]["spp"].as_u64().expect("reference.spp") as u32;
    (img, spp)
}

pub fn render_spp(scene: &Scene, method: Method, spp: u32, seed: u64, nee: bool) -> RenderResult {
    let path = PathSettings {
        nee,
        max_depth: scene.max_depth.or(Some(10)),
        roulette: RouletteMode::Classic,
        adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
        defer_guide_pdf: true,
    };
    render(scene, &options(method, spp, seed, path)).expect("render")
}

/// Block comparison of a render against a noisy reference of `ref_spp`
/// samples; the reference's per-pixel variance is estimated from our own
/// (same estimator) scaled by the sample counts.
pub fn compare_with_reference(
    result: &RenderResult,
    reference: &Image,
    ref_spp: u32,
    block: usize,
) -> BlockComparison {
    let var = &result.variance;
    let scale = result.stats.spp as f64 / ref_spp as f64;
    let var_ref: Vec<f64> = var.iter().map(|v| v * scale).collect();
    compare_blocks(&result.image, var, reference, &var_ref, block).expect("same size")
}

/// Asserts that two estimates of one image agree block by block (see
/// `pack_reference.rs` for the derivation of the three criteria), after
/// printing the statistics.
pub fn assert_blocks_agree(label: &str, cmp: &BlockComparison) {
    eprintln!(
        "{label}: means {:.5} / {:.5}, z_global {:.2}, mean z² {:.2}, max |z| {:.2}, beyond 4σ {:.1} %, {} blocks",
        cmp.mean_a,
        cmp.mean_b,
        cmp.z_global,
        cmp.mean_z2(),
        cmp.max_abs_z(),
        100.0 * cmp.fraction_above(4.0),
        cmp.z.len()
    );
    assert!(
        cmp.mean_z2() < 2.0,
        "{label}: mean z² = {:.2}",
        cmp.mean_z2()
    );
    assert!(
        cmp.fraction_above(4.0) <= 0.03,
        "{label}: {:.1} % of blocks beyond 4σ",
        100.0 * cmp.fraction_above(4.0)
    );
    assert!(
        cmp.z_global.abs() < 4.0,
        "{label}: global z = {:.2}",
        cmp.z_global
    );
}

/// Render options for tests: everything at its default but what varies.
pub fn options(method: Method, spp: u32, seed: u64, path: PathSettings) -> RenderOptions {
    RenderOptions {
        method,
        budget: Budget::Spp(spp),
        seed,
        path,
        ..Default::default()
    }
}
