//! Mitsuba 3's precomputed energy tables for `roughplastic`: the external
//! transmittance T(μ) of the rough interface on 64 cosines, and the internal
//! diffuse reflectance R_int. They depend only on (α, η), so each pair is
//! computed once and interned for the life of the process, which lets
//! [`super::Bsdf`] hold a plain `&'static` reference and stay `Copy`.
//!
//! Both quantities are means over visible normals from the incident
//! direction, integrated as Mitsuba does: a tensor Gauss–Legendre rule on the
//! unit square pushed through the visible-normal sampler (32² nodes when
//! η > 1, 128² when η < 1, where total internal reflection makes the
//! integrand rougher). Using the same sampler and rule reproduces Mitsuba's
//! quadrature error too, not only the integral.

use super::fresnel::{fresnel_dielectric, reflect, refract};
use super::microfacet::Ggx;
use crate::math::gauss_legendre;
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// Number of tabulated cosines (Mitsuba's `MI_ROUGH_TRANSMITTANCE_RES`).
pub const TRANSMITTANCE_RES: usize = 64;

#[derive(Debug)]
pub struct RoughPlasticTable {
    /// The clamped roughness and relative IOR the table was built for.
    pub alpha: f32,
    pub eta: f32,
    /// T(μ_j) at μ_j = max(1e-6, j/63).
    pub transmittance: [f32; TRANSMITTANCE_RES],
    /// R_int = 2 · mean_j(R(μ_j; 1/η) μ_j), Mitsuba's rectangle rule.
    pub internal_reflectance: f32,
    /// Cosine-weighted mean 2∫₀¹ T(μ) μ dμ of the interpolated table: the
    /// fraction of Lambertian light from the base that leaves the coating,
    /// used by the product-guiding lobe weights.
    pub mean_transmittance: f32,
}

impl RoughPlasticTable {
    /// Linear interpolation in the table exactly as Mitsuba's `lerp_gather`.
    #[inline]
    pub fn transmittance(&self, cos: f32) -> f32 {
        let x = cos.clamp(0.0, 1.0) * (TRANSMITTANCE_RES - 1) as f32;
        let i = (x as usize).min(TRANSMITTANCE_RES - 2);
        let w = x - i as f32;
        let t = (1.0 - w) * self.transmittance[i] + w * self.transmittance[i + 1];
        t.clamp(0.0, 1.0)
    }

    /// Builds the table (about 0.1 s; callers should use [`table_for`]).
    pub fn compute(alpha: f32, eta: f32) -> Self {
        let distr = Ggx::new(alpha);
        let mus: Vec<f32> = (0..TRANSMITTANCE_RES)
            .map(|j| (j as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6))
            .collect();
        let rule_t = gauss_legendre(if eta > 1.0 { 32 } else { 128 });
        let rule_r = gauss_legendre(if 1.0 / eta > 1.0 { 32 } else { 128 });
        let mut transmittance = [0f32; TRANSMITTANCE_RES];
        let mut r_sum = 0.0f64;
        for (j, &mu) in mus.iter().enumerate() {
            let wi = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
            transmittance[j] = transmitted_energy(&distr, wi, eta, &rule_t).clamp(0.0, 1.0) as f32;
            r_sum += reflected_energy(&distr, wi, 1.0 / eta, &rule_r) * mu as f64;
        }
        let internal_reflectance =
            (2.0 * r_sum / TRANSMITTANCE_RES as f64).clamp(0.0, 0.999) as f32;
        let mut table = RoughPlasticTable {
            alpha: distr.alpha(),
            eta,
            transmittance,
            internal_reflectance,
            mean_transmittance: 0.0,
        };
        // The interpolant is piecewise linear, so a fine midpoint rule is
        // accurate to far below f32 resolution.
        let n = 4096;
        let mut s = 0.0f64;
        for i in 0..n {
            let mu = (i as f32 + 0.5) / n as f32;
            s += table.transmittance(mu) as f64 * mu as f64;
        }
        table.mean_transmittance = (2.0 * s / n as f64) as f32;
        table
    }
}

/// Mean over visible normals m of (1 − F(wi·m)) G1(t, m), t the refracted
/// direction: the energy that crosses the rough interface from `wi`.
fn transmitted_energy(distr: &Ggx, wi: Vec3, eta: f32, rule: &[(f64, f64)]) -> f64 {
    integrate_visible(distr, wi, rule, |m| {
        let f = fresnel_dielectric(wi.dot(m), eta);
        let t = refract(wi, m, f.cos_t, f.eta_ti);
        if t.z * wi.z >= 0.0 {
            return 0.0;
        }
        (1.0 - f.r) * distr.g1(t, m)
    })
}

/// Mean over visible normals of F(wi·m) G1(r, m), r the reflected direction:
/// the energy reflected by the interface (from inside when `eta` < 1).
fn reflected_energy(distr: &Ggx, wi: Vec3, eta: f32, rule: &[(f64, f64)]) -> f64 {
    integrate_visible(distr, wi, rule, |m| {
        let r = reflect(wi, m);
        if r.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        fresnel_dielectric(wi.dot(m), eta).r * distr.g1(r, m)
    })
}

fn integrate_visible(distr: &Ggx, wi: Vec3, rule: &[(f64, f64)], f: impl Fn(Vec3) -> f32) -> f64 {
    let mut sum = 0.0f64;
    for &(x, wx) in rule {
        for &(y, wy) in rule {
            let u = Vec2::new((0.5 * x + 0.5) as f32, (0.5 * y + 0.5) as f32);
            let m = distr.sample_visible(wi, u);
            let v = f(m);
            if v.is_finite() {
                sum += v as f64 * wx * wy * 0.25;
            }
        }
    }
    sum
}

/// The interned table for (α, η). Keys are the exact bit patterns of the
/// clamped α and η, so two materials share a table only if Mitsuba would
/// have computed bit-identical ones.
pub fn table_for(alpha: f32, eta: f32) -> &'static RoughPlasticTable {
    static CACHE: OnceLock<Mutex<HashMap<(u32, u32), &'static RoughPlasticTable>>> =
        OnceLock::new();
    let alpha = Ggx::new(alpha).alpha();
    let key = (alpha.to_bits(), eta.to_bits());
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    if let Some(t) = cache.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return t;
    }
    // Computed outside the lock so loaders on several threads do not
    // serialise; a rare duplicate computation only leaks one small table.
    let table: &'static RoughPlasticTable =
        Box::leak(Box::new(RoughPlasticTable::compute(alpha, eta)));
    cache
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .entry(key)
        .or_insert(table)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smooth_limit_matches_fresnel() {
        // As α → 0 every visible normal is the macro normal and G1 → 1.
        let t = table_for(1e-4, 1.5);
        for j in [16usize, 32, 63] {
            let mu = j as f32 / 63.0;
            let f = 1.0 - fresnel_dielectric(mu, 1.5).r;
            assert!(
                (t.transmittance[j] - f).abs() < 2e-3,
                "{j}: {} vs {f}",
                t.transmittance[j]
            );
        }
        // R_int tends to the internal diffuse Fresnel reflectance (0.596 by
        // the Egan–Hilgeman fit for 1/1.5), up to Mitsuba's coarse μ rule.
        assert!(
            (t.internal_reflectance - 0.596).abs() < 0.02,
            "{}",
            t.internal_reflectance
        );
        assert!(std::ptr::eq(t, table_for(1e-4, 1.5)));
    }
}
