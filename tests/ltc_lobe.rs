//! The LTC lobe itself: its density integrates to 1 and its sampler passes a
//! χ² goodness-of-fit test, for table entries from sharp to rough.

mod ltc_common;

use glam::Vec3;
use ltc_common::table;
use ltcguide::ltc::lobe::Ltc;
use ltcguide::sampling::Rng;
use ltcguide::stats::chi2::{Chi2Config, SphereMap, chi2_sphere};

fn ltc_for(alpha: f32, theta_deg: f32) -> Ltc {
    let e = table().lookup(alpha, theta_deg.to_radians().cos());
    Ltc::new(e.params().matrix())
}

#[test]
fn density_integrates_to_one_and_sampling_passes_chi2() {
    let cases = [
        (1.0f32, 0.0f32),
        (0.5, 60.0),
        (0.1, 30.0),
        (0.1, 80.0),
        (0.01, 45.0),
        (1e-3, 10.0),
    ];
    for (alpha, theta) in cases {
        let ltc = ltc_for(alpha, theta);
        let peak = (ltc.m * glam::DVec3::Z).normalize().as_vec3();
        // Sharpen the χ² bins around the lobe so that narrow lobes spread.
        let sharpness = (0.05 / alpha as f64).clamp(1.0, 50.0);
        let map = SphereMap::new(peak, sharpness);
        let mut rng = Rng::new(31, alpha.to_bits() as u64);
        let cfg = Chi2Config {
            samples: 100_000,
            significance: 0.01 / cases.len() as f64,
            ..Chi2Config::default()
        };
        let out = chi2_sphere(
            &cfg,
            &map,
            || {
                let w = ltc.sample(rng.next_f64(), rng.next_f64());
                Some(Vec3::new(w.x as f32, w.y as f32, w.z as f32))
            },
            |w| ltc.density(w.as_dvec3()),
        );
        println!(
            "α {alpha} θo {theta}: ∫D = {:.5}, χ² p = {:.3}",
            out.pdf_integral, out.p_value
        );
        assert!(
            (out.pdf_integral - 1.0).abs() < 2e-3,
            "α {alpha} θ {theta}: ∫ = {}",
            out.pdf_integral
        );
        assert!(out.passed, "α {alpha} θ {theta}: {}", out.message);
    }
}
