//! The per-scene plan: before rendering, decide from the scene which
//! machinery a run needs, and run only that.
//!
//! - only delta (smooth) materials → no guiding at all: there is no vertex
//!   a guide could serve, so the guided methods render as `pt`;
//! - no GGX lobe with α ≤ 0.5 → no LTC transform work; with the default
//!   `CosineLobes::Radiance` every vertex then takes radiance weights, so
//!   the product run is radiance guiding (no table, no form factors, no
//!   weights check); with the paper's cosine product every lobe is
//!   integrated as a cosine, and no GGX lobe at all → no table lookups;
//! - no cosine lobe that the product integrates (with radiance weights at
//!   cosine vertices: none beside a glossy lobe) → the precomputed diffuse
//!   form factors are never built (they are built lazily on first use);
//! - no environment → no environment sampling (no envmap distribution is
//!   built; the light list has no infinite light).
//!
//! The guided renderer may also drop guiding mid-run when a trial of its
//! strategies measures path tracing with NEE more efficient (see
//! `guiding::trial`); that decision is reported in the stats, next to this
//! plan.

use crate::bsdf::MaterialKind;
use crate::guiding::product::CosineLobes;
use crate::render::Method;
use crate::scene::Scene;
use serde::Serialize;

/// Rough lobes above this α are integrated as cosines (the paper's rule,
/// mirrored from `LtcOptions::default`).
const ROUGH_AS_DIFFUSE_ABOVE: f32 = 0.5;

#[derive(Clone, Debug, Serialize, PartialEq, Eq)]
pub struct ScenePlan {
    pub requested: Method,
    /// The method actually run.
    pub method: Method,
    pub guiding: bool,
    /// GGX lobes integrated with LTC transforms (α ≤ 0.5).
    pub ltc_glossy: bool,
    /// Any GGX lobe (table lookups for LTC matrices and albedos).
    pub ltc_table: bool,
    /// Cosine lobes (diffuse, plastic bases, rough GGX) use the form factors.
    pub diffuse_form_factors: bool,
    /// Some vertex takes product weights (false: a product run is radiance
    /// guiding, every vertex being a cosine one with radiance weights).
    pub product_weights: bool,
    pub environment_sampling: bool,
    pub nee: bool,
    pub reasons: Vec<String>,
}

impl ScenePlan {
    pub fn line(&self) -> String {
        let on = |b: bool| if b { "on" } else { "off" };
        let mut s = format!(
            "plan: method {} | guiding {} | ltc glossy {} | ltc table {} | diffuse form factors {} | env sampling {} | nee {}",
            format!("{:?}", self.method).to_lowercase(),
            on(self.guiding),
            on(self.ltc_glossy),
            on(self.ltc_table),
            on(self.diffuse_form_factors),
            on(self.environment_sampling),
            on(self.nee)
        );
        if !self.reasons.is_empty() {
            s.push_str(" | ");
            s.push_str(&self.reasons.join("; "));
        }
        s
    }
}

/// What the materials that shapes actually use contain.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LobeInventory {
    pub diffuse: bool,
    pub glossy: bool,
    pub rough_ggx: bool,
    pub non_delta: bool,
    /// A material with a cosine lobe beside a glossy one (rough plastic
    /// with α ≤ 0.5 and a diffuse base).
    pub mixed: bool,
}

pub fn lobe_inventory(scene: &Scene) -> LobeInventory {
    let mut inv = LobeInventory::default();
    let mut used = vec![false; scene.materials.len()];
    for s in &scene.shapes {
        used[s.material as usize] = true;
    }
    for (m, _) in scene.materials.iter().zip(&used).filter(|(_, u)| **u) {
        let ggx = |alpha: f32, inv: &mut LobeInventory| {
            inv.non_delta = true;
            if alpha <= ROUGH_AS_DIFFUSE_ABOVE {
                inv.glossy = true;
            } else {
                inv.rough_ggx = true;
                inv.diffuse = true;
            }
        };
        match &m.kind {
            MaterialKind::Diffuse { reflectance } => {
                if !reflectance.is_black() {
                    inv.diffuse = true;
                    inv.non_delta = true;
                }
            }
            MaterialKind::RoughConductor {
                alpha,
                specular_reflectance,
                ..
            } => {
                if !specular_reflectance.is_black() {
                    ggx(*alpha, &mut inv);
                }
            }
            MaterialKind::RoughPlastic {
                alpha,
                diffuse_reflectance,
                ..
            } => {
                ggx(*alpha, &mut inv);
                if !diffuse_reflectance.is_black() {
                    inv.diffuse = true;
                    inv.mixed |= *alpha <= ROUGH_AS_DIFFUSE_ABOVE;
                }
            }
            MaterialKind::Plastic {
                diffuse_reflectance,
                ..
            } => {
                if !diffuse_reflectance.is_black() {
                    inv.diffuse = true;
                    inv.non_delta = true;
                }
            }
            MaterialKind::Conductor { .. }
            | MaterialKind::Dielectric { .. }
            | MaterialKind::ThinDielectric { .. } => {}
        }
    }
    inv
}

/// The plan of a run; `cosine_lobes`, `product_vertices`, `pixel_reuse`
/// and `radiance_share` are product guiding's settings (see
/// `guiding::product` and `guiding::defensive`).
pub fn plan(
    scene: &Scene,
    requested: Method,
    nee: bool,
    cosine_lobes: CosineLobes,
    product_vertices: u32,
    pixel_reuse: bool,
    radiance_share: crate::guiding::defensive::RadianceShare,
) -> ScenePlan {
    let inv = lobe_inventory(scene);
    let mut reasons = Vec::new();
    let guided = requested != Method::Pt;
    let guiding = guided && inv.non_delta;
    if guided && !inv.non_delta {
        reasons.push("only delta materials: no vertex to guide, rendering with pt".into());
    }
    let method = if guiding { requested } else { Method::Pt };
    let product = method == Method::Product;
    let cosine_product = cosine_lobes == CosineLobes::Product;
    let product_weights = product && (inv.glossy || cosine_product);
    if product && !inv.glossy {
        reasons.push(if cosine_product {
            "no glossy lobe: the product uses only cosine lobes and form factors".into()
        } else {
            "no glossy lobe: every vertex takes radiance weights (cosine lobes; --cosine-lobes product for the paper's cosine product), so this run is radiance guiding".into()
        });
    }
    if product_weights {
        reasons.push(format!(
            "product weights at {}",
            crate::guiding::product::product_weights_scope(
                product_vertices,
                pixel_reuse,
                radiance_share,
            )
        ));
    }
    let form_factors = product
        && if cosine_product {
            inv.diffuse
        } else {
            inv.mixed
        };
    if product && inv.glossy && !form_factors {
        reasons.push(if inv.diffuse {
            "no cosine lobe beside a glossy one: cosine vertices take radiance weights, no form factors".into()
        } else {
            "no diffuse lobe: no form factors".into()
        });
    }
    let env = scene.lights.has_infinite();
    ScenePlan {
        requested,
        method,
        guiding,
        ltc_glossy: product && inv.glossy,
        ltc_table: product && (inv.glossy || (cosine_product && inv.rough_ggx)),
        diffuse_form_factors: form_factors,
        product_weights,
        environment_sampling: env,
        nee,
        reasons,
    }
}
