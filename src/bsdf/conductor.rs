//! Mitsuba's `conductor` (smooth mirror) and `roughconductor` (GGX with
//! visible-normal sampling), both one-sided, with the exact conductor
//! Fresnel factor or `material none` (Fresnel = 1).

use super::fresnel::fresnel_conductor;
use super::microfacet::Ggx;
use super::{BsdfSample, ConductorFresnel};
use crate::math::{Spectrum, is_finite3, reflect_local};
use glam::{Vec2, Vec3};

/// F_c(cos) per channel, or 1 for `material none`.
#[inline]
pub fn fresnel(fr: &ConductorFresnel, cos: f32) -> Spectrum {
    match fr {
        ConductorFresnel::None => Spectrum::ONE,
        ConductorFresnel::Complex { eta, k } => fresnel_conductor(cos, *eta, *k),
    }
}

/// Parameters of a rough conductor at one shading point.
#[derive(Clone, Copy, Debug)]
pub struct RoughConductor {
    pub distr: Ggx,
    pub fresnel: ConductorFresnel,
    pub specular_reflectance: Spectrum,
}

impl RoughConductor {
    /// f·cos θ_i = R F_c(wo·h) D(h) G(wo, wi, h) / (4 cos θ_o), and the
    /// sampling density D(h) G1(wo, h) / (4 cos θ_o), sharing D and G1.
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let Some(r) = self.distr.reflection(wo, wi) else {
            return (Spectrum::ZERO, 0.0);
        };
        let pdf = r.pdf;
        let value = self.specular_reflectance * fresnel(&self.fresnel, r.cos_oh) * (pdf * r.g1_i);
        if !pdf.is_finite() || !is_finite3(value) {
            return (Spectrum::ZERO, 0.0);
        }
        (value.max(Spectrum::ZERO), pdf.max(0.0))
    }

    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = self.distr.sample_reflection(wo, u);
        if wi.z <= 0.0 {
            return None;
        }
        // Evaluated from the half vector of (wo, wi), not from the sampled
        // normal, so the returned pdf is bit-identical to `pdf(wo, wi)` (MIS
        // needs that; at α = 1e-4 the two would differ by rounding).
        let (value, pdf) = self.eval_pdf(wo, wi);
        BsdfSample::non_delta(wi, value, pdf)
    }
}

/// The smooth conductor: a delta reflection with weight R F_c(cos θ_o).
#[inline]
pub fn sample_smooth(
    fr: &ConductorFresnel,
    specular_reflectance: Spectrum,
    wo: Vec3,
) -> Option<BsdfSample> {
    if wo.z <= 0.0 {
        return None;
    }
    Some(BsdfSample {
        wi: reflect_local(wo),
        weight: specular_reflectance * fresnel(fr, wo.z),
        pdf: 1.0,
        is_delta: true,
        eta: 1.0,
    })
}
