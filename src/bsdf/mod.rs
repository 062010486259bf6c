//! The BSDF interface: every material of the Mitsuba 3 subset, evaluated in
//! the local shading frame (z = shading normal).
//!
//! Conventions (pbrt's, which match the paper's θ_o):
//! - `wo` points from the surface towards the viewer (the previous path vertex);
//! - `wi` points from the surface towards the light (the next path vertex);
//! - both are unit vectors in the local frame;
//! - `eval` returns f(wo, wi)·|cos θ_i| (Mitsuba's `eval` convention);
//! - `pdf` is the solid-angle density of `sample` for its non-delta part.
//!
//! A [`Material`] holds textures and is what a scene stores; at a hit the
//! integrator resolves the textures with [`Material::at`] into a small `Copy`
//! [`Bsdf`], which answers eval, sample, pdf and the lobe decomposition that
//! product guiding needs ([`Lobes`]).

use crate::math::Spectrum;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Complex index of refraction of a conductor, or Fresnel = 1 (`material none`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConductorFresnel {
    None,
    Complex { eta: Spectrum, k: Spectrum },
}

/// A material as described by the scene file, with textured parameters.
#[derive(Clone, Debug)]
pub struct Material {
    pub kind: MaterialKind,
    /// Mitsuba's `twosided` wrapper: back-facing queries are mirrored to the front.
    pub two_sided: bool,
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
    /// (including its selection probability) for a delta sample.
    pub weight: Spectrum,
    /// Solid-angle pdf of the non-delta part (equal to `Bsdf::pdf(wo, wi)`),
    /// or the discrete selection probability of the delta lobe.
    pub pdf: f32,
    pub is_delta: bool,
    /// Relative IOR across the interface for a refraction, else 1 (for
    /// Russian roulette on radiance rather than importance).
    pub eta: f32,
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
/// - f·cos ≈ `diffuse` × cos θ_i / π + Σ `ggx[j].weight` × GGX_cos(α_j)
/// - `delta` is the total weight of smooth (delta) lobes, never guided.
/// - `wo_local` is `wo` after the two-sided mirroring (z ≥ 0 for reflective
///   materials), so the caller knows the lobes' frame orientation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobes {
    pub diffuse: f32,
    pub ggx: [GgxLobe; 1],
    pub ggx_count: usize,
    pub delta: f32,
    /// +1 when the lobes live in the frame's upper hemisphere, −1 when the
    /// two-sided mirroring put them in the lower one.
    pub side: f32,
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
    RoughConductor {
        alpha: f32,
        fresnel: ConductorFresnel,
        specular_reflectance: Spectrum,
    },
    Conductor {
        fresnel: ConductorFresnel,
        specular_reflectance: Spectrum,
    },
    RoughPlastic {
        alpha: f32,
        eta: f32,
        diffuse_reflectance: Spectrum,
    },
    Plastic {
        eta: f32,
        diffuse_reflectance: Spectrum,
    },
    Dielectric {
        eta: f32,
    },
    ThinDielectric {
        eta: f32,
    },
}

impl Material {
    pub fn new(kind: MaterialKind, two_sided: bool) -> Result<Material, String> {
        Ok(Material { kind, two_sided })
    }

    pub fn at(&self, uv: Vec2) -> Bsdf {
        let reflectance = match &self.kind {
            MaterialKind::Diffuse { reflectance } => reflectance.eval(uv),
            MaterialKind::RoughPlastic {
                diffuse_reflectance,
                ..
            }
            | MaterialKind::Plastic {
                diffuse_reflectance,
                ..
            } => diffuse_reflectance.eval(uv),
            MaterialKind::RoughConductor {
                specular_reflectance,
                ..
            }
            | MaterialKind::Conductor {
                specular_reflectance,
                ..
            } => specular_reflectance.eval(uv),
            _ => Spectrum::ZERO,
        };
        Bsdf {
            model: BsdfModel::Diffuse { reflectance },
            two_sided: self.two_sided,
        }
    }
}

impl Bsdf {
    fn rho(&self) -> Spectrum {
        match self.model {
            BsdfModel::Diffuse { reflectance } => reflectance,
            _ => Spectrum::ZERO,
        }
    }
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        let (wo, wi) = if self.two_sided && wo.z < 0.0 {
            (-wo, -wi)
        } else {
            (wo, wi)
        };
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Spectrum::ZERO;
        }
        self.rho() * wi.z * crate::math::INV_PI
    }
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = if self.two_sided && wo.z < 0.0 {
            (-wo, -wi)
        } else {
            (wo, wi)
        };
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        wi.z * crate::math::INV_PI
    }
    pub fn sample(&self, wo: Vec3, _u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let flip = self.two_sided && wo.z < 0.0;
        let wo_f = if flip { -wo } else { wo };
        if wo_f.z <= 0.0 {
            return None;
        }
        let mut wi = crate::sampling::square_to_cosine_hemisphere(u);
        let pdf = wi.z * crate::math::INV_PI;
        if pdf <= 0.0 {
            return None;
        }
        if flip {
            wi = -wi;
        }
        Some(BsdfSample {
            wi,
            weight: self.rho(),
            pdf,
            is_delta: false,
            eta: 1.0,
        })
    }
    pub fn lobes(&self, _wo: Vec3) -> Lobes {
        Lobes {
            diffuse: crate::math::luminance(self.rho()),
            ggx: [GgxLobe {
                weight: 0.0,
                alpha: 1.0,
            }],
            ggx_count: 0,
            delta: 0.0,
            side: 1.0,
        }
    }
    pub fn has_smooth_lobes_only(&self) -> bool {
        false
    }
}
