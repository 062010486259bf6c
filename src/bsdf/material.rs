//! Building a [`Material`] from scene parameters (validation, Mitsuba's
//! derived constants) and resolving its textures into a [`Bsdf`].

use super::conductor::RoughConductor;
use super::microfacet::Ggx;
use super::plastic::RoughPlastic;
use super::{
    Bsdf, BsdfModel, ConductorFresnel, Derived, Material, MaterialKind, plastic, plastic_tables,
};
use crate::math::{Spectrum, is_finite3, luminance};
use crate::texture::Texture;
use glam::Vec2;

fn check_texture(name: &str, t: &Texture) -> Result<(), String> {
    let ok = |c: Spectrum| is_finite3(c) && c.min_element() >= 0.0;
    match t {
        Texture::Constant(c) => {
            if !ok(*c) {
                return Err(format!(
                    "{name}: invalid value {c:?} (must be finite and ≥ 0)"
                ));
            }
        }
        Texture::Checkerboard { color0, color1, .. } => {
            if !ok(*color0) || !ok(*color1) {
                return Err(format!(
                    "{name}: checkerboard colours must be finite and ≥ 0"
                ));
            }
        }
        // Finite and non-negative by construction.
        Texture::Bitmap8(_) => {}
        Texture::Bitmap(img) => {
            if img.non_finite_pixels() > 0 {
                return Err(format!("{name}: bitmap contains non-finite pixels"));
            }
        }
    }
    Ok(())
}

/// Mitsuba's `Texture::mean()` in RGB mode: channel mean for a constant,
/// mean luminance over the pixels for a bitmap, average of both colours for
/// a checkerboard.
fn texture_mean(t: &Texture) -> f32 {
    let m = match t {
        Texture::Constant(c) => (c.x + c.y + c.z) / 3.0,
        Texture::Checkerboard { color0, color1, .. } => {
            0.5 * ((color0.x + color0.y + color0.z) / 3.0 + (color1.x + color1.y + color1.z) / 3.0)
        }
        Texture::Bitmap(img) => {
            let n = img.pixels.len().max(1);
            (img.pixels.iter().map(|&p| luminance(p) as f64).sum::<f64>() / n as f64) as f32
        }
        Texture::Bitmap8(img) => {
            let n = (img.width * img.height).max(1);
            (img.pixels().map(|p| luminance(p) as f64).sum::<f64>() / n as f64) as f32
        }
    };
    if m.is_finite() { m.max(0.0) } else { 0.0 }
}

fn check_alpha(alpha: f32) -> Result<(), String> {
    if alpha.is_finite() && alpha >= 0.0 {
        Ok(())
    } else {
        Err(format!("alpha = {alpha} must be finite and ≥ 0"))
    }
}

/// IORs must be positive and differ across the interface (Mitsuba throws
/// otherwise for every dielectric-based model).
fn check_eta(eta: f32) -> Result<(), String> {
    if eta.is_finite() && eta > 0.0 && eta != 1.0 {
        Ok(())
    } else {
        Err(format!(
            "relative IOR int_ior/ext_ior = {eta} must be finite, positive and ≠ 1"
        ))
    }
}

fn check_conductor(fr: &ConductorFresnel) -> Result<(), String> {
    match fr {
        ConductorFresnel::Complex { eta, k }
            if !is_finite3(*eta)
                || !is_finite3(*k)
                || eta.min_element() < 0.0
                || k.min_element() < 0.0 =>
        {
            Err(format!(
                "conductor eta {eta:?} / k {k:?} must be finite and ≥ 0"
            ))
        }
        _ => Ok(()),
    }
}

impl Material {
    /// Validates the parameters (finite, non-negative α and colours; finite,
    /// positive relative IOR ≠ 1; `twosided` only around reflective models)
    /// and precomputes the roughplastic tables (interned per (α, η), about
    /// 0.1 s the first time a pair is seen).
    pub fn new(kind: MaterialKind, two_sided: bool) -> Result<Material, String> {
        let mut derived = Derived {
            specular_sampling_weight: 0.5,
            table: None,
        };
        match &kind {
            MaterialKind::Diffuse { reflectance } => check_texture("reflectance", reflectance)?,
            MaterialKind::RoughConductor {
                alpha,
                fresnel,
                specular_reflectance,
            } => {
                check_alpha(*alpha)?;
                check_conductor(fresnel)?;
                check_texture("specular_reflectance", specular_reflectance)?;
            }
            MaterialKind::Conductor {
                fresnel,
                specular_reflectance,
            } => {
                check_conductor(fresnel)?;
                check_texture("specular_reflectance", specular_reflectance)?;
            }
            MaterialKind::RoughPlastic {
                alpha,
                eta,
                diffuse_reflectance,
            } => {
                check_alpha(*alpha)?;
                check_eta(*eta)?;
                check_texture("diffuse_reflectance", diffuse_reflectance)?;
                derived.specular_sampling_weight =
                    plastic::specular_sampling_weight(texture_mean(diffuse_reflectance));
                derived.table = Some(plastic_tables::table_for(*alpha, *eta));
            }
            MaterialKind::Plastic {
                eta,
                diffuse_reflectance,
            } => {
                check_eta(*eta)?;
                check_texture("diffuse_reflectance", diffuse_reflectance)?;
                derived.specular_sampling_weight =
                    plastic::specular_sampling_weight(texture_mean(diffuse_reflectance));
            }
            MaterialKind::Dielectric { eta } | MaterialKind::ThinDielectric { eta } => {
                check_eta(*eta)?;
                if two_sided {
                    return Err("twosided can only wrap a reflective BSDF, not a dielectric".into());
                }
            }
        }
        Ok(Material {
            kind,
            two_sided,
            derived,
        })
    }

    /// Resolves the textures at `uv` (already v-flipped as the README says).
    pub fn at(&self, uv: Vec2) -> Bsdf {
        // The loader rejects non-finite and negative texels, so lookups are
        // finite and non-negative; a negative value set after loading reaches
        // the BSDF layer, which zeroes and counts it (`bsdf_negative`).
        let tex = |t: &Texture| t.eval(uv);
        let model = match &self.kind {
            MaterialKind::Diffuse { reflectance } => BsdfModel::Diffuse {
                reflectance: tex(reflectance),
            },
            MaterialKind::RoughConductor {
                alpha,
                fresnel,
                specular_reflectance,
            } => BsdfModel::RoughConductor(RoughConductor {
                distr: Ggx::new(*alpha),
                fresnel: *fresnel,
                specular_reflectance: tex(specular_reflectance),
            }),
            MaterialKind::Conductor {
                fresnel,
                specular_reflectance,
            } => BsdfModel::Conductor {
                fresnel: *fresnel,
                specular_reflectance: tex(specular_reflectance),
            },
            MaterialKind::RoughPlastic {
                alpha,
                eta,
                diffuse_reflectance,
            } => {
                // `kind` is public and could have been edited after `new`;
                // a stale table is replaced rather than silently used.
                let table = match self.derived.table {
                    Some(t) if t.eta == *eta && t.alpha == Ggx::new(*alpha).alpha() => t,
                    _ => plastic_tables::table_for(*alpha, *eta),
                };
                BsdfModel::RoughPlastic(RoughPlastic {
                    distr: Ggx::new(*alpha),
                    eta: *eta,
                    diffuse_reflectance: tex(diffuse_reflectance),
                    specular_sampling_weight: self.derived.specular_sampling_weight,
                    table,
                })
            }
            MaterialKind::Plastic {
                eta,
                diffuse_reflectance,
            } => BsdfModel::Plastic {
                eta: *eta,
                diffuse_reflectance: tex(diffuse_reflectance),
                specular_sampling_weight: self.derived.specular_sampling_weight,
            },
            MaterialKind::Dielectric { eta } => BsdfModel::Dielectric { eta: *eta },
            MaterialKind::ThinDielectric { eta } => BsdfModel::ThinDielectric { eta: *eta },
        };
        Bsdf {
            model,
            two_sided: self.two_sided,
        }
    }

    /// The texture [`at`](Self::at) will read, if any.
    fn texture(&self) -> Option<&Texture> {
        match &self.kind {
            MaterialKind::Diffuse { reflectance: t }
            | MaterialKind::RoughConductor {
                specular_reflectance: t,
                ..
            }
            | MaterialKind::Conductor {
                specular_reflectance: t,
                ..
            }
            | MaterialKind::RoughPlastic {
                diffuse_reflectance: t,
                ..
            }
            | MaterialKind::Plastic {
                diffuse_reflectance: t,
                ..
            } => Some(t),
            MaterialKind::Dielectric { .. } | MaterialKind::ThinDielectric { .. } => None,
        }
    }

    /// Starts loading the texels [`at`](Self::at) will read at `uv`.
    /// Texel fetches from large textures miss the cache; the path loop
    /// issues this as soon as a hit is known and does independent work
    /// (light sampling, the shadow ray) before the lookup.
    #[inline]
    pub fn prefetch(&self, uv: Vec2) {
        if let Some(t) = self.texture() {
            t.prefetch(uv);
        }
    }

    /// True when every `at(uv)` is zero for every pair of directions: a
    /// constant zero reflectance, as the pack's emitters have. A path that
    /// meets such a surface ends there once its emission is added, since
    /// nothing it scatters could contribute; sampling a direction, tracing
    /// it and recording it in the guide would be work without effect.
    #[inline]
    pub fn reflects_nothing(&self) -> bool {
        reflects_nothing(&self.kind)
    }

    /// True for smooth `plastic`: a delta coat beside a rough lobe, so the
    /// vertex is guided while one of its lobes only BSDF sampling reaches.
    #[inline]
    pub fn has_delta_and_non_delta_lobes(&self) -> bool {
        matches!(self.kind, MaterialKind::Plastic { .. })
    }

    /// [`Bsdf::has_smooth_lobes_only`] of every `at(uv)`, known without a
    /// texture lookup.
    #[inline]
    pub fn has_smooth_lobes_only(&self) -> bool {
        matches!(
            self.kind,
            MaterialKind::Conductor { .. }
                | MaterialKind::Dielectric { .. }
                | MaterialKind::ThinDielectric { .. }
        )
    }
}

/// Whether `kind` reflects nothing anywhere (see
/// [`Material::reflects_nothing`]). A plastic's coat always reflects, and a
/// dielectric always transmits, so only a zero diffuse or conductor
/// reflectance qualifies, and only as a constant: a texture may hold black
/// texels beside others.
#[inline]
fn reflects_nothing(kind: &MaterialKind) -> bool {
    let zero = |t: &Texture| matches!(t, Texture::Constant(c) if *c == Spectrum::ZERO);
    match kind {
        MaterialKind::Diffuse { reflectance } => zero(reflectance),
        MaterialKind::RoughConductor {
            specular_reflectance,
            ..
        }
        | MaterialKind::Conductor {
            specular_reflectance,
            ..
        } => zero(specular_reflectance),
        MaterialKind::RoughPlastic { .. }
        | MaterialKind::Plastic { .. }
        | MaterialKind::Dielectric { .. }
        | MaterialKind::ThinDielectric { .. } => false,
    }
}
