//! The function the LTC table approximates: the GGX microfacet BRDF times the
//! cosine, with Fresnel = 1 and the height-correlated Smith masking-shadowing
//! G2 = 1/(1 + Λ(ω_o) + Λ(ω_i)) (Heitz 2014), in the local frame (z = normal).
//!
//! Everything here is f64: it is the fit target and the reference of tests,
//! never on a hot path.

use glam::DVec3;
use std::f64::consts::PI;

/// Smith Λ for GGX: (−1 + √(1 + α² tan²θ)) / 2.
#[inline]
pub fn lambda(alpha: f64, cos_theta: f64) -> f64 {
    let c2 = (cos_theta * cos_theta).max(1e-300);
    let tan2 = ((1.0 - c2) / c2).max(0.0);
    0.5 * (-1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// GGX normal distribution D(h).
#[inline]
pub fn ndf(alpha: f64, cos_h: f64) -> f64 {
    if cos_h <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = cos_h * cos_h * (a2 - 1.0) + 1.0;
    a2 / (PI * t * t)
}

/// f(ω_o, ω_i)·cos θ_i; zero outside the upper hemisphere.
pub fn eval_cos(alpha: f64, wo: DVec3, wi: DVec3) -> f64 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let h = (wo + wi).normalize();
    let g2 = 1.0 / (1.0 + lambda(alpha, wo.z) + lambda(alpha, wi.z));
    ndf(alpha, h.z) * g2 / (4.0 * wo.z)
}

/// Solid-angle density of [`sample_vndf`]: G1(ω_o)·D(h) / (4 cos θ_o).
/// Non-zero also where ω_i falls below the horizon (the sample is then wasted).
pub fn pdf_vndf(alpha: f64, wo: DVec3, wi: DVec3) -> f64 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    let h = wo + wi;
    if h.length_squared() < 1e-300 {
        return 0.0;
    }
    let h = h.normalize();
    if h.dot(wo) <= 0.0 {
        return 0.0;
    }
    let g1 = 1.0 / (1.0 + lambda(alpha, wo.z));
    g1 * ndf(alpha, h.z) / (4.0 * wo.z)
}

/// Samples ω_i by reflecting ω_o about a visible normal (Heitz 2018).
pub fn sample_vndf(alpha: f64, wo: DVec3, u1: f64, u2: f64) -> DVec3 {
    let vh = DVec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        DVec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
    } else {
        DVec3::X
    };
    let t2 = vh.cross(t1);
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let p1 = r * phi.cos();
    let mut p2 = r * phi.sin();
    let s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
    let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    let ne = DVec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(1e-12)).normalize();
    2.0 * wo.dot(ne) * ne - wo
}

/// Directional albedo ρ = ∫ f·cos dω and its Schlick-weighted part
/// ρ5 = ∫ f·cos·(1 − ω_o·h)^5 dω, by VNDF sampling on an n×n stratified grid
/// (the VNDF weight is G2/G1, so this estimator has very low variance).
pub fn albedo(alpha: f64, wo: DVec3, n: usize) -> (f64, f64) {
    let mut rho = 0.0;
    let mut rho5 = 0.0;
    let g1_inv = 1.0 + lambda(alpha, wo.z);
    for j in 0..n {
        for i in 0..n {
            let wi = sample_vndf(
                alpha,
                wo,
                (i as f64 + 0.5) / n as f64,
                (j as f64 + 0.5) / n as f64,
            );
            if wi.z <= 0.0 {
                continue;
            }
            let w = g1_inv / (1.0 + lambda(alpha, wo.z) + lambda(alpha, wi.z));
            let h = (wo + wi).normalize();
            rho += w;
            rho5 += w * (1.0 - wo.dot(h)).clamp(0.0, 1.0).powi(5);
        }
    }
    let nn = (n * n) as f64;
    (rho / nn, rho5 / nn)
}
