//! The lobe decomposition of each model for LTC product guiding: the
//! weights and roughness that [`Lobes`] documents, with its approximations.

use super::{Bsdf, BsdfModel, GgxLobe, Lobes, conductor, flip, fresnel, plastic};
use crate::guards::{GuardEvent, record};
use crate::math::luminance;
use glam::Vec3;

impl Bsdf {
    /// The lobe decomposition for product guiding (see [`Lobes`]).
    pub fn lobes(&self, wo: Vec3) -> Lobes {
        let mirrored = self.mirrored(wo);
        let side = if mirrored { -1.0 } else { 1.0 };
        let wo = if mirrored { flip(wo) } else { wo };
        let mut l = Lobes {
            side,
            ..Lobes::EMPTY
        };
        let front = wo.z > 0.0;
        let cos_o = wo.z.clamp(0.0, 1.0);
        let nonneg = |x: f32| {
            if x >= 0.0 && x.is_finite() {
                x
            } else {
                record(GuardEvent::LobeWeightInvalid, 1);
                0.0
            }
        };
        match self.model {
            BsdfModel::Diffuse { reflectance } if front => {
                l.diffuse = nonneg(luminance(reflectance));
            }
            BsdfModel::RoughConductor(m) if front => {
                l.ggx[0] = GgxLobe {
                    weight: nonneg(luminance(
                        m.specular_reflectance * conductor::fresnel(&m.fresnel, cos_o),
                    )),
                    alpha: m.distr.alpha(),
                };
                l.ggx_count = 1;
            }
            BsdfModel::Conductor {
                fresnel,
                specular_reflectance,
            } if front => {
                l.delta = nonneg(luminance(
                    specular_reflectance * conductor::fresnel(&fresnel, cos_o),
                ));
            }
            BsdfModel::RoughPlastic(plastic::RoughPlastic {
                distr,
                eta,
                diffuse_reflectance,
                table,
                ..
            }) if front => {
                l.ggx[0] = GgxLobe {
                    weight: nonneg(fresnel::fresnel_dielectric_r(cos_o, eta)),
                    alpha: distr.alpha(),
                };
                l.ggx_count = 1;
                l.diffuse = nonneg(
                    luminance(diffuse_reflectance) / (1.0 - table.internal_reflectance)
                        * table.transmittance(cos_o)
                        * table.mean_transmittance
                        / (eta * eta),
                );
            }
            BsdfModel::Plastic {
                eta,
                diffuse_reflectance,
                ..
            } if front => {
                let f = fresnel::fresnel_dielectric_r(cos_o, eta);
                let fdr_int = fresnel::fresnel_diffuse_reflectance(1.0 / eta);
                let t_mean = 1.0 - fresnel::fresnel_diffuse_reflectance(eta);
                l.delta = nonneg(f);
                l.diffuse = nonneg(
                    luminance(diffuse_reflectance) / (1.0 - fdr_int) * (1.0 - f) * t_mean
                        / (eta * eta),
                );
            }
            BsdfModel::Dielectric { .. } | BsdfModel::ThinDielectric { .. } => {
                // Reflection + transmission carry all the energy (up to the
                // radiance scaling of refraction).
                l.delta = 1.0;
            }
            _ => {}
        }
        l
    }
}
