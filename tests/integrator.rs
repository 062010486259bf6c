//! Estimators against closed forms and against each other.

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

/// A BSDF that evaluates and samples to Inf (a diffuse floor whose
/// reflectance was made infinite after loading) is zeroed by the BSDF layer,
/// and the path loop counts every such value: NEE's evaluation and the
/// BSDF sample each time. Nothing non-finite reaches the estimate.
#[test]
fn non_finite_bsdf_values_are_counted_by_the_path_loop() {
    use ltcguide::bsdf::MaterialKind;
    use ltcguide::texture::Texture;
    let mut scene = load_scene(&data("analytic/sphere_over_plane.xml")).unwrap();
    let floor = scene
        .materials
        .iter_mut()
        .find(|m| matches!(&m.kind, MaterialKind::Diffuse { reflectance: Texture::Constant(r) } if r.x == 0.5))
        .unwrap();
    floor.kind = MaterialKind::Diffuse {
        reflectance: Texture::Constant(glam::Vec3::splat(f32::INFINITY)),
    };
    let settings = PathSettings {
        nee: true,
        max_depth: Some(3),
        roulette: RouletteMode::Off,
        adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
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
