//! The BSDF interface: every material of the Mitsuba 3 subset, evaluated in
//! the local shading frame (z = shading normal).
//!
//! Conventions (pbrt's, which match the paper's θ_o):
//! - `wo` points from the surface towards the viewer (the previous path vertex);
//! - `wi` points from the surface towards the light (the next path vertex);
//! - both are unit vectors in the local frame;
//! - `eval` returns f(wo, wi)·|cos θ_i| (Mitsuba's `eval` convention);
//! - `pdf` is the solid-angle density of `sample` for its non-delta part,
//!   including the probability of choosing the non-delta technique.
//!
//! (The scene README names the viewer direction `i` and the light direction
//! `o`, as Mitsuba does; its `cos_i` is our `wo.z`.)
//!
//! A [`Material`] holds textures and is what a scene stores; at a hit the
//! integrator resolves the textures with [`Material::at`] into a small `Copy`
//! [`Bsdf`], which answers eval, sample, pdf and the lobe decomposition that
//! product guiding needs ([`Lobes`]).
//!
//! Files: [`microfacet`] (GGX, Smith, visible-normal sampling), [`fresnel`],
//! [`diffuse`], [`conductor`], [`plastic`] (+ [`plastic_tables`], Mitsuba's
//! T(μ)/R_int tables), [`dielectric`], [`material`] (validation, texture
//! resolution), `lobes.rs` (each model's [`Lobes`]); this file declares the
//! interface, dispatches and applies the `twosided` mirroring.

pub mod conductor;
pub mod dielectric;
pub mod diffuse;
pub mod fresnel;
mod lobes;
pub mod material;
pub mod microfacet;
pub mod plastic;
pub mod plastic_tables;

use crate::guards::{GuardEvent, record};
use crate::math::{Spectrum, is_finite3};
use crate::texture::Texture;
use glam::{Vec2, Vec3};
use plastic_tables::RoughPlasticTable;

/// Complex index of refraction of a conductor, or Fresnel = 1 (`material none`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConductorFresnel {
    None,
    Complex { eta: Spectrum, k: Spectrum },
}

/// A material as described by the scene file, with textured parameters.
/// Build it with [`Material::new`], which validates the parameters and
/// precomputes what the models need (roughplastic tables, sampling weights).
#[derive(Clone, Debug)]
pub struct Material {
    pub kind: MaterialKind,
    /// Mitsuba's `twosided` wrapper: back-facing queries are mirrored to the front.
    pub two_sided: bool,
    derived: Derived,
}

/// Per-material constants computed once by [`Material::new`].
#[derive(Clone, Copy, Debug)]
struct Derived {
    /// Mitsuba's s̄/(d̄ + s̄) for the plastics (unused otherwise).
    specular_sampling_weight: f32,
    table: Option<&'static RoughPlasticTable>,
}

#[derive(Clone, Debug)]
pub enum MaterialKind {
    Diffuse {
        reflectance: Texture,
    },
    RoughConductor {
        alpha: f32,
        fresnel: ConductorFresnel,
        specular_reflectance: Texture,
    },
    Conductor {
        fresnel: ConductorFresnel,
        specular_reflectance: Texture,
    },
    RoughPlastic {
        alpha: f32,
        /// int_ior / ext_ior
        eta: f32,
        diffuse_reflectance: Texture,
    },
    Plastic {
        eta: f32,
        diffuse_reflectance: Texture,
    },
    Dielectric {
        eta: f32,
    },
    ThinDielectric {
        eta: f32,
    },
}

/// The outcome of sampling a BSDF.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled direction towards the light, local frame.
    pub wi: Vec3,
    /// f·|cos θ_i| / pdf for a non-delta sample; the delta lobe's weight
    /// divided by its selection probability for a delta sample.
    pub weight: Spectrum,
    /// Solid-angle pdf of the non-delta part (equal to `Bsdf::pdf(wo, wi)`),
    /// or the discrete selection probability of the delta lobe.
    pub pdf: f32,
    pub is_delta: bool,
    /// Relative IOR across the interface for a refraction (η_i/η_t seen from
    /// the viewer's side, Mitsuba's `bs.eta`), else 1 (for Russian roulette
    /// on radiance rather than importance).
    pub eta: f32,
}

impl BsdfSample {
    /// A non-delta sample from its evaluated value f·cos and pdf, both
    /// computed from (wo, wi) so that the pdf is bit-identical to
    /// `Bsdf::pdf(wo, wi)`; `None` when the pdf vanishes.
    #[inline]
    pub fn non_delta(wi: Vec3, value: Spectrum, pdf: f32) -> Option<BsdfSample> {
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: value / pdf,
            pdf,
            is_delta: false,
            eta: 1.0,
        })
    }
}

/// A GGX lobe of the product decomposition: f·cos ≈ `weight` × (GGX with
/// Fresnel 1 and Smith shadowing)·cos, for the given `alpha`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GgxLobe {
    pub weight: f32,
    pub alpha: f32,
}

/// The lobe decomposition of a BSDF at one `wo`, in its local frame, as used
/// by LTC product guiding. Weights are scalar (luminance) and non-negative.
/// - f·cos ≈ `diffuse` × cos θ_i / π + Σ `ggx[j].weight` × GGX_cos(α_j), with
///   GGX_cos = [`microfacet::ggx_cos`] (Fresnel 1; its albedo is < 1);
/// - `delta` is the total weight of smooth (delta) lobes, never guided;
/// - `side`: +1 when the lobes live in the frame's upper hemisphere, −1 when
///   the two-sided mirroring put them in the lower one (then the lobes apply
///   to `wo` and `wi` with their z negated).
///
/// Approximations (exact where not listed):
/// - roughconductor: weight = luminance(R · F_c(cos θ_o)): the Fresnel factor
///   is taken at the viewing angle instead of at wo·h, the usual way of
///   factoring Fresnel out of an LTC-fitted lobe (Heitz et al. 2016); exact
///   for `none`, and close wherever F_c varies slowly (all but grazing);
/// - roughplastic: ggx weight = F(cos θ_o, η) (same approximation); the
///   diffuse term ρ/(1 − R_int)·T(cos θ_o)·T(cos θ_i)/(π η²)·cos θ_i has its
///   T(cos θ_i) replaced by the cosine-weighted mean T̄ = 2∫T(μ)μ dμ, which
///   makes it Lambertian with weight luminance(ρ)/(1 − R_int)·T(cos θ_o)·T̄/η²
///   and preserves its hemispherical integral exactly;
/// - plastic: diffuse weight uses T̄ = 1 − F_dr(η) (Mitsuba's external
///   diffuse Fresnel fit) in the same way; the specular reflection is `delta`;
/// - conductor: `delta` = luminance(R · F_c(cos θ_o)); dielectric and
///   thindielectric: `delta` = 1 (reflection + transmission);
/// - a one-sided reflective model seen from the back has all weights 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobes {
    pub diffuse: f32,
    pub ggx: [GgxLobe; 1],
    pub ggx_count: usize,
    pub delta: f32,
    pub side: f32,
}

impl Lobes {
    const EMPTY: Lobes = Lobes {
        diffuse: 0.0,
        ggx: [GgxLobe {
            weight: 0.0,
            alpha: 1.0,
        }],
        ggx_count: 0,
        delta: 0.0,
        side: 1.0,
    };
}

/// A material with its textures resolved at a shading point.
#[derive(Clone, Copy, Debug)]
pub struct Bsdf {
    pub model: BsdfModel,
    pub two_sided: bool,
}

#[derive(Clone, Copy, Debug)]
pub enum BsdfModel {
    Diffuse {
        reflectance: Spectrum,
    },
    /// Built once per shading point (α clamped by
    /// [`microfacet::Ggx::new`]) and queried as it is.
    RoughConductor(conductor::RoughConductor),
    Conductor {
        fresnel: ConductorFresnel,
        specular_reflectance: Spectrum,
    },
    /// Built once per shading point, as `RoughConductor`.
    RoughPlastic(plastic::RoughPlastic),
    Plastic {
        eta: f32,
        diffuse_reflectance: Spectrum,
        specular_sampling_weight: f32,
    },
    Dielectric {
        eta: f32,
    },
    ThinDielectric {
        eta: f32,
    },
}

#[inline]
fn flip(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, -v.z)
}

/// Zeroes a non-finite or negative result, given whether it is finite
/// (which the caller has checked to count it): callers never see NaN/Inf.
#[inline]
fn sanitize(v: Spectrum, finite: bool) -> Spectrum {
    if finite {
        v.max(Spectrum::ZERO)
    } else {
        Spectrum::ZERO
    }
}

impl Bsdf {
    /// True when `twosided` mirrors this query to the front.
    #[inline]
    fn mirrored(&self, wo: Vec3) -> bool {
        self.two_sided && wo.z < 0.0
    }

    /// f(wo, wi)·|cos θ_i| of the non-delta part.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        self.eval_pdf(wo, wi).0
    }

    /// Solid-angle density of `sample`'s non-delta part at `wi`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_pdf(wo, wi).1
    }

    /// (eval, pdf) in one call, with one dispatch and one mirroring for
    /// both: rough plastic computes them together, and every caller in the
    /// path loop wants both. Never NaN, Inf or negative.
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        self.eval_pdf_counted(wo, wi, &mut 0)
    }

    /// [`Self::eval_pdf`], adding 1 to `nonfinite` when the value or the
    /// pdf was NaN or Inf (and zeroed).
    #[inline]
    pub fn eval_pdf_counted(&self, wo: Vec3, wi: Vec3, nonfinite: &mut u64) -> (Spectrum, f32) {
        let (f, p) = self.eval_pdf_unguarded(wo, wi);
        let (f_finite, p_finite) = (is_finite3(f), p.is_finite());
        if !(f_finite && p_finite) {
            *nonfinite += 1;
        } else if f.min_element() < 0.0 || p < 0.0 {
            record(GuardEvent::BsdfNegative, 1);
        }
        (
            sanitize(f, f_finite),
            if p_finite { p.max(0.0) } else { 0.0 },
        )
    }

    #[inline]
    fn eval_pdf_unguarded(&self, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        let (wo, wi) = if self.mirrored(wo) {
            (flip(wo), flip(wi))
        } else {
            (wo, wi)
        };
        match self.model {
            BsdfModel::Diffuse { reflectance } => {
                (diffuse::eval(reflectance, wo, wi), diffuse::pdf(wo, wi))
            }
            BsdfModel::RoughConductor(m) => m.eval_pdf(wo, wi),
            BsdfModel::RoughPlastic(m) => m.eval_pdf(wo, wi),
            BsdfModel::Plastic {
                eta,
                diffuse_reflectance,
                specular_sampling_weight,
            } => {
                let m = plastic_model(eta, diffuse_reflectance, specular_sampling_weight);
                (m.eval(wo, wi), m.pdf(wo, wi))
            }
            // Delta lobes only: nothing in the non-delta part.
            BsdfModel::Conductor { .. }
            | BsdfModel::Dielectric { .. }
            | BsdfModel::ThinDielectric { .. } => (Spectrum::ZERO, 0.0),
        }
    }

    /// Samples `wi` given `wo`; `u_lobe` picks the lobe/technique, `u` the
    /// direction. `None` when nothing is reflected (back side of a one-sided
    /// model, a direction below the horizon, zero pdf).
    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        self.sample_counted(wo, u_lobe, u, &mut 0)
    }

    /// [`Self::sample`], adding 1 to `nonfinite` when the sample's pdf,
    /// direction or weight was NaN or Inf (the sample is then rejected, or
    /// its weight zeroed). A sample that is `None` for a reason of the
    /// model's (nothing reflected) is not counted.
    #[inline]
    pub fn sample_counted(
        &self,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        nonfinite: &mut u64,
    ) -> Option<BsdfSample> {
        let mirrored = self.mirrored(wo);
        let wo = if mirrored { flip(wo) } else { wo };
        let s = match self.model {
            BsdfModel::Diffuse { reflectance } => diffuse::sample(reflectance, wo, u),
            BsdfModel::RoughConductor(m) => m.sample(wo, u),
            BsdfModel::Conductor {
                fresnel,
                specular_reflectance,
            } => conductor::sample_smooth(&fresnel, specular_reflectance, wo),
            BsdfModel::RoughPlastic(m) => m.sample(wo, u_lobe, u),
            BsdfModel::Plastic {
                eta,
                diffuse_reflectance,
                specular_sampling_weight,
            } => plastic_model(eta, diffuse_reflectance, specular_sampling_weight)
                .sample(wo, u_lobe, u),
            BsdfModel::Dielectric { eta } => dielectric::sample_dielectric(eta, wo, u_lobe),
            BsdfModel::ThinDielectric { eta } => dielectric::sample_thin(eta, wo, u_lobe),
        }?;
        let (pdf_finite, wi_finite) = (s.pdf.is_finite(), is_finite3(s.wi));
        let weight_finite = is_finite3(s.weight);
        if !(pdf_finite && wi_finite && weight_finite) {
            *nonfinite += 1;
        } else if s.pdf < 0.0 || s.weight.min_element() < 0.0 {
            record(GuardEvent::BsdfNegative, 1);
        }
        // `pdf > 0` is false for NaN too.
        if !(s.pdf > 0.0 && pdf_finite && wi_finite) {
            return None;
        }
        Some(BsdfSample {
            wi: if mirrored { flip(s.wi) } else { s.wi },
            weight: sanitize(s.weight, weight_finite),
            ..s
        })
    }

    /// True when every lobe is a delta (Mitsuba's smooth `conductor`,
    /// `dielectric`, `thindielectric`): eval and pdf are identically zero,
    /// so next-event estimation and guiding do not apply.
    pub fn has_smooth_lobes_only(&self) -> bool {
        matches!(
            self.model,
            BsdfModel::Conductor { .. }
                | BsdfModel::Dielectric { .. }
                | BsdfModel::ThinDielectric { .. }
        )
    }

    /// True for Mitsuba's `diffuse` (a single cosine lobe at every ω_o).
    #[inline]
    pub fn is_diffuse(&self) -> bool {
        matches!(self.model, BsdfModel::Diffuse { .. })
    }

    /// Alias of [`Self::has_smooth_lobes_only`].
    #[inline]
    pub fn is_delta_only(&self) -> bool {
        self.has_smooth_lobes_only()
    }

    /// True when the BSDF scatters only into ω_o's hemisphere of the shading
    /// frame (every model but the dielectrics), so that f vanishes below it.
    #[inline]
    pub fn reflects_only(&self) -> bool {
        !matches!(
            self.model,
            BsdfModel::Dielectric { .. } | BsdfModel::ThinDielectric { .. }
        )
    }

    /// True when the BSDF has a non-delta component (NEE and guiding apply).
    #[inline]
    pub fn has_non_delta(&self) -> bool {
        !self.has_smooth_lobes_only()
    }

    /// A cheap estimate of the directional albedo ∫ f cos dω_i at `wo`
    /// (luminance), from the lobe weights: an upper bound for the rough
    /// models, since the GGX albedo is ≤ 1. For roulette and heuristics,
    /// never for unbiased weights.
    pub fn albedo_estimate(&self, wo: Vec3) -> f32 {
        let l = self.lobes(wo);
        let ggx: f32 = l.ggx[..l.ggx_count].iter().map(|g| g.weight).sum();
        l.diffuse + ggx + l.delta
    }
}

#[inline]
fn plastic_model(eta: f32, rho: Spectrum, w: f32) -> plastic::Plastic {
    plastic::Plastic {
        eta,
        diffuse_reflectance: rho,
        specular_sampling_weight: w,
        fdr_int: fresnel::fresnel_diffuse_reflectance(1.0 / eta),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// NaN/Inf values and samples are zeroed or rejected and counted; a
    /// clean BSDF's zero below the horizon, or a sample of nothing, is not.
    #[test]
    fn non_finite_values_and_samples_are_counted() {
        let diffuse = |r: f32| Bsdf {
            model: BsdfModel::Diffuse {
                reflectance: Spectrum::splat(r),
            },
            two_sided: false,
        };
        let (wo, up, down) = (Vec3::Z, Vec3::new(0.6, 0.0, 0.8), -Vec3::Z);
        let u = Vec2::splat(0.3);
        let mut count = 0;
        let (f, p) = diffuse(f32::NAN).eval_pdf_counted(wo, up, &mut count);
        assert_eq!((f, count), (Spectrum::ZERO, 1));
        assert!(p > 0.0);
        let s = diffuse(f32::INFINITY).sample_counted(wo, 0.5, u, &mut count);
        assert_eq!((s.unwrap().weight, count), (Spectrum::ZERO, 2));
        diffuse(0.5).eval_pdf_counted(wo, Vec3::splat(f32::NAN), &mut count);
        assert_eq!(count, 3);
        let clean = diffuse(0.5);
        assert_eq!(
            clean.eval_pdf_counted(wo, down, &mut count).0,
            Spectrum::ZERO
        );
        assert!(clean.sample_counted(down, 0.5, u, &mut count).is_none());
        assert!(clean.sample_counted(wo, 0.5, u, &mut count).is_some());
        assert_eq!(count, 3);
    }

    /// Negative values and weights are zeroed and counted apart from the
    /// non-finite ones; lobe weights that are NaN or negative too.
    #[test]
    fn negative_values_and_invalid_lobe_weights_are_counted() {
        use crate::guards::{GuardEvent, thread_count};
        let diffuse = |r: f32| Bsdf {
            model: BsdfModel::Diffuse {
                reflectance: Spectrum::splat(r),
            },
            two_sided: false,
        };
        let negative = || thread_count(GuardEvent::BsdfNegative);
        let invalid_lobes = || thread_count(GuardEvent::LobeWeightInvalid);
        let (n0, l0) = (negative(), invalid_lobes());
        let (wo, up) = (Vec3::Z, Vec3::new(0.6, 0.0, 0.8));
        let mut nonfinite = 0;
        let (f, p) = diffuse(-0.5).eval_pdf_counted(wo, up, &mut nonfinite);
        assert_eq!((f, nonfinite, negative()), (Spectrum::ZERO, 0, n0 + 1));
        assert!(p > 0.0);
        let s = diffuse(-0.5).sample_counted(wo, 0.5, Vec2::splat(0.3), &mut nonfinite);
        assert_eq!(s.unwrap().weight, Spectrum::ZERO);
        assert_eq!((nonfinite, negative()), (0, n0 + 2));
        diffuse(0.5).eval_pdf_counted(wo, up, &mut nonfinite);
        assert_eq!(negative(), n0 + 2);

        assert_eq!(diffuse(0.5).lobes(wo).diffuse, 0.5);
        assert_eq!(invalid_lobes(), l0);
        assert_eq!(diffuse(f32::NAN).lobes(wo).diffuse, 0.0);
        assert_eq!(diffuse(-1.0).lobes(wo).diffuse, 0.0);
        assert_eq!(invalid_lobes(), l0 + 2);
    }
}
