//! Mitsuba's `roughplastic` and `plastic`: a dielectric coating (rough GGX or
//! smooth) over a Lambertian base, with `nonlinear = false`.
//!
//! Sampling follows Mitsuba: the specular lobe is chosen with probability
//! p_s = (1 − T(cos θ_o)) w / ((1 − T(cos θ_o)) w + T(cos θ_o)(1 − w)), where
//! w = s̄/(d̄ + s̄) is the specular sampling weight from the mean specular
//! (1) and diffuse reflectances; for the smooth model 1 − T is the Fresnel
//! reflectance F(cos θ_o). The pdf is the exact mixture of both techniques.

use super::BsdfSample;
use super::fresnel::fresnel_dielectric_r;
use super::microfacet::Ggx;
use super::plastic_tables::RoughPlasticTable;
use crate::math::{INV_PI, Spectrum, is_finite3, reflect_local};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use glam::{Vec2, Vec3};

/// Mitsuba's specular sampling weight s̄/(d̄ + s̄) with s̄ = 1 (no
/// `specular_reflectance` in the subset); `d_mean` is the texture's mean.
pub fn specular_sampling_weight(d_mean: f32) -> f32 {
    let d = if d_mean.is_finite() {
        d_mean.max(0.0)
    } else {
        0.0
    };
    1.0 / (d + 1.0)
}

/// Probability of choosing the specular technique, guarded so a black base
/// with full transmission (0/0) still samples something.
#[inline]
fn specular_probability(one_minus_t: f32, w: f32) -> f32 {
    let ps = one_minus_t * w;
    let pd = (1.0 - one_minus_t) * (1.0 - w);
    let sum = ps + pd;
    if sum > 0.0 && sum.is_finite() {
        (ps / sum).clamp(0.0, 1.0)
    } else {
        w.clamp(0.0, 1.0)
    }
}

#[derive(Clone, Copy, Debug)]
pub struct RoughPlastic {
    pub distr: Ggx,
    pub eta: f32,
    pub diffuse_reflectance: Spectrum,
    pub specular_sampling_weight: f32,
    pub table: &'static RoughPlasticTable,
}

impl RoughPlastic {
    /// The diffuse term's per-channel scale ρ / ((1 − R_int) π η²): the
    /// diffuse f is this times T(cos θ_o) T(cos θ_i).
    #[inline]
    fn diffuse_scale(&self) -> Spectrum {
        self.diffuse_reflectance
            * (INV_PI / ((1.0 - self.table.internal_reflectance) * self.eta * self.eta))
    }

    #[inline]
    pub fn prob_specular(&self, cos_o: f32) -> f32 {
        specular_probability(
            1.0 - self.table.transmittance(cos_o),
            self.specular_sampling_weight,
        )
    }

    /// (f·cos θ_i, pdf) for a pair of upper-hemisphere directions.
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let t_o = self.table.transmittance(wo.z);
        let t_i = self.table.transmittance(wi.z);
        let p_spec = specular_probability(1.0 - t_o, self.specular_sampling_weight);
        let mut value = self.diffuse_scale() * (t_o * t_i * wi.z);
        let mut pdf = (1.0 - p_spec) * cosine_hemisphere_pdf(wi.z);
        if let Some(r) = self.distr.reflection(wo, wi) {
            let f = fresnel_dielectric_r(r.cos_oh, self.eta);
            value += Spectrum::splat(f * (r.pdf * r.g1_i));
            pdf += p_spec * r.pdf;
        }
        if !pdf.is_finite() || !is_finite3(value) {
            return (Spectrum::ZERO, 0.0);
        }
        (value.max(Spectrum::ZERO), pdf.max(0.0))
    }

    /// Only the diffuse (base) term of f·cos θ_i, for the check values and
    /// the lobe-weight tests.
    pub fn eval_diffuse(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Spectrum::ZERO;
        }
        self.diffuse_scale()
            * (self.table.transmittance(wo.z) * self.table.transmittance(wi.z) * wi.z)
    }

    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.prob_specular(wo.z) {
            self.distr.sample_reflection(wo, u)
        } else {
            square_to_cosine_hemisphere(u)
        };
        if wi.z <= 0.0 {
            return None;
        }
        let (value, pdf) = self.eval_pdf(wo, wi);
        BsdfSample::non_delta(wi, value, pdf)
    }
}

/// Smooth `plastic`: a delta reflection with weight F(cos θ_o) plus
/// f_d = ρ / (1 − F_dr) (1 − F(cos θ_o)) (1 − F(cos θ_i)) / (π η²).
#[derive(Clone, Copy, Debug)]
pub struct Plastic {
    pub eta: f32,
    pub diffuse_reflectance: Spectrum,
    pub specular_sampling_weight: f32,
    /// Internal diffuse Fresnel reflectance (Egan–Hilgeman fit at 1/η).
    pub fdr_int: f32,
}

impl Plastic {
    #[inline]
    pub fn prob_specular(&self, cos_o: f32) -> f32 {
        specular_probability(
            fresnel_dielectric_r(cos_o, self.eta),
            self.specular_sampling_weight,
        )
    }

    /// The non-delta part only.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let t_o = 1.0 - fresnel_dielectric_r(wo.z, self.eta);
        let t_i = 1.0 - fresnel_dielectric_r(wi.z, self.eta);
        let v = self.diffuse_reflectance
            * (t_o * t_i * wi.z * INV_PI / ((1.0 - self.fdr_int) * self.eta * self.eta));
        if is_finite3(v) {
            v.max(Spectrum::ZERO)
        } else {
            Spectrum::ZERO
        }
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        (1.0 - self.prob_specular(wo.z)) * cosine_hemisphere_pdf(wi.z)
    }

    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let p_spec = self.prob_specular(wo.z);
        if u_lobe < p_spec {
            let f = fresnel_dielectric_r(wo.z, self.eta);
            return Some(BsdfSample {
                wi: reflect_local(wo),
                weight: Spectrum::splat(f / p_spec),
                pdf: p_spec,
                is_delta: true,
                eta: 1.0,
            });
        }
        let wi = square_to_cosine_hemisphere(u);
        let pdf = self.pdf(wo, wi);
        if pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.eval(wo, wi) / pdf,
            pdf,
            is_delta: false,
            eta: 1.0,
        })
    }
}
