//! The sphere-clipping approximation: Snyder's closed form against Monte
//! Carlo on true clipped caps, and the tabulated K against the closed form.

use glam::DVec3;
use ltcguide::ltc::sphere_clip::{clipped_cap_form_factor, clipped_integral, k_exact};
use ltcguide::sampling::Rng;
use std::f64::consts::PI;

/// MC estimate of (1/π)∫_cap max(0, ω_z) dω for a cap of half-angle σ whose
/// axis makes angle ω with +z.
fn mc_clipped_cap(omega: f64, sigma: f64, n: usize, rng: &mut Rng) -> f64 {
    let axis = DVec3::new(omega.sin(), 0.0, omega.cos());
    let t1 = DVec3::new(omega.cos(), 0.0, -omega.sin());
    let t2 = DVec3::Y;
    let cos_s = sigma.cos();
    let solid = 2.0 * PI * (1.0 - cos_s);
    let mut sum = 0.0;
    for _ in 0..n {
        let c = 1.0 - rng.next_f64() * (1.0 - cos_s);
        let s = (1.0 - c * c).max(0.0).sqrt();
        let phi = 2.0 * PI * rng.next_f64();
        let w = axis * c + t1 * (s * phi.cos()) + t2 * (s * phi.sin());
        sum += w.z.max(0.0);
    }
    sum / n as f64 * solid / PI
}

#[test]
fn snyder_closed_form_matches_monte_carlo_on_clipped_caps() {
    let mut rng = Rng::new(7, 1);
    for &(omega_deg, sigma_deg) in &[
        (80.0, 20.0),
        (90.0, 10.0),
        (100.0, 30.0),
        (60.0, 45.0),
        (120.0, 40.0),
        (95.0, 3.0),
        (30.0, 80.0),
    ] {
        let (omega, sigma) = (f64::to_radians(omega_deg), f64::to_radians(sigma_deg));
        let mc = mc_clipped_cap(omega, sigma, 400_000, &mut rng);
        let closed = clipped_cap_form_factor(omega.cos(), sigma.sin().powi(2));
        let tol = 4e-3 * sigma.sin().powi(2) + 1e-5;
        assert!(
            (mc - closed).abs() < tol,
            "ω {omega_deg}° σ {sigma_deg}°: MC {mc} closed form {closed}"
        );
    }
    // The hemisphere cap: F = (1 + z)/2.
    assert!((clipped_cap_form_factor(0.3, 1.0) - 0.65).abs() < 1e-12);
}

#[test]
fn tabulated_k_error_is_small() {
    // Measured error of len·K relative to len (i.e. the error of K), on a
    // dense grid over the band where the table is used.
    let mut max_err = 0.0f64;
    let mut sum_sq = 0.0;
    let mut count = 0usize;
    let mut rng = Rng::new(3, 9);
    for _ in 0..200_000 {
        let s = rng.next_f64();
        let len = s * s;
        let z = (2.0 * rng.next_f64() - 1.0) * s;
        let exact = k_exact(z, len) * len;
        let fz = (z * len) as f32;
        let q = (len * len) as f32;
        let approx = clipped_integral(fz, q) as f64;
        let err = (approx - exact).abs() / len.max(1e-30);
        max_err = max_err.max(err);
        sum_sq += err * err;
        count += 1;
    }
    let rms = (sum_sq / count as f64).sqrt();
    println!("sphere-clip table: max |ΔK| = {max_err:.2e}, rms |ΔK| = {rms:.2e}");
    assert!(max_err < 2e-3, "max K error {max_err}");
    // Outside the band the fast path is exact.
    assert_eq!(clipped_integral(0.5, 0.01), 0.5);
    assert_eq!(clipped_integral(-0.5, 0.01), 0.0);
    assert_eq!(clipped_integral(0.0, 0.0), 0.0);
    assert!(clipped_integral(1e-20, 1e-40).is_finite());
}
