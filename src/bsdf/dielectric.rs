//! Mitsuba's `dielectric` (smooth glass, two-way) and `thindielectric`
//! (infinitely thin sheet). Both are purely specular: eval and pdf are zero,
//! sampling picks reflection or transmission with probability equal to its
//! weight, so every returned weight is 1 except for the radiance scaling
//! of a real refraction.

use super::BsdfSample;
use super::fresnel::fresnel_dielectric;
use crate::math::{Spectrum, reflect_local};
use glam::Vec3;

/// Smooth dielectric. The normal points to the outside medium; wo.z < 0
/// means the viewer is inside.
#[inline]
pub fn sample_dielectric(eta: f32, wo: Vec3, u_lobe: f32) -> Option<BsdfSample> {
    let f = fresnel_dielectric(wo.z, eta);
    if u_lobe < f.r {
        return Some(BsdfSample {
            wi: reflect_local(wo),
            weight: Spectrum::ONE,
            pdf: f.r,
            is_delta: true,
            eta: 1.0,
        });
    }
    let wi = Vec3::new(-f.eta_ti * wo.x, -f.eta_ti * wo.y, f.cos_t);
    let t = 1.0 - f.r;
    if t <= 0.0 || wi.z == 0.0 {
        return None;
    }
    // Radiance is not invariant across the interface: L/η² is. With η_i on
    // the viewer's side and η_t on the light's side the carried radiance is
    // scaled by (η_i/η_t)² = eta_ti².
    Some(BsdfSample {
        wi,
        weight: Spectrum::splat(f.eta_ti * f.eta_ti),
        pdf: t,
        is_delta: true,
        eta: f.eta_it,
    })
}

/// Reflectance of a thin sheet with all internal bounces summed:
/// R + T²R/(1 − R²) = 2R/(1 + R).
#[inline]
pub fn thin_reflectance(cos: f32, eta: f32) -> f32 {
    let r = fresnel_dielectric(cos.abs(), eta).r;
    if r >= 1.0 { 1.0 } else { 2.0 * r / (1.0 + r) }
}

#[inline]
pub fn sample_thin(eta: f32, wo: Vec3, u_lobe: f32) -> Option<BsdfSample> {
    let r = thin_reflectance(wo.z, eta);
    if u_lobe < r {
        return Some(BsdfSample {
            wi: reflect_local(wo),
            weight: Spectrum::ONE,
            pdf: r,
            is_delta: true,
            eta: 1.0,
        });
    }
    let t = 1.0 - r;
    if t <= 0.0 {
        return None;
    }
    // Straight through: both faces refract by inverse amounts.
    Some(BsdfSample {
        wi: -wo,
        weight: Spectrum::ONE,
        pdf: t,
        is_delta: true,
        eta: 1.0,
    })
}
