//! Mitsuba's `diffuse`: a one-sided Lambertian reflector, f = ρ/π.

use super::BsdfSample;
use crate::math::{INV_PI, Spectrum};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use glam::{Vec2, Vec3};

#[inline]
pub fn eval(rho: Spectrum, wo: Vec3, wi: Vec3) -> Spectrum {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return Spectrum::ZERO;
    }
    rho * (wi.z * INV_PI)
}

#[inline]
pub fn pdf(wo: Vec3, wi: Vec3) -> f32 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    cosine_hemisphere_pdf(wi.z)
}

#[inline]
pub fn sample(rho: Spectrum, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
    if wo.z <= 0.0 {
        return None;
    }
    let wi = square_to_cosine_hemisphere(u);
    let pdf = cosine_hemisphere_pdf(wi.z);
    if pdf <= 0.0 {
        return None;
    }
    // Cosine sampling cancels f·cos exactly, so the weight is ρ itself.
    Some(BsdfSample {
        wi,
        weight: rho,
        pdf,
        is_delta: false,
        eta: 1.0,
    })
}
