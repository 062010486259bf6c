//! The per-scene plan: before rendering, decide from the scene which
//! machinery a run needs, and run only that.
//!
//! - only delta (smooth) materials → no guiding at all: there is no vertex
//!   a guide could serve, so the guided methods render as `pt`;
//! - no GGX lobe with α ≤ 0.5 → no LTC transform work (every lobe is
//!   integrated as a cosine); no GGX lobe at all → no table lookups;
//! - no diffuse-like lobe → the precomputed diffuse form factors are never
//!   built (they are built lazily on first use);
//! - no environment → no environment sampling (no envmap distribution is
//!   built; the light list has no infinite light).
//!
//! The guided renderer may also drop guiding mid-run when its training
//! iterations show it does not pay (see `guiding::train`); that decision is
//! reported in the stats, next to this plan.

use crate::bsdf::MaterialKind;
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

pub fn plan(scene: &Scene, requested: Method, nee: bool) -> ScenePlan {
    let inv = lobe_inventory(scene);
    let mut reasons = Vec::new();
    let guided = requested != Method::Pt;
    let guiding = guided && inv.non_delta;
    if guided && !inv.non_delta {
        reasons.push("only delta materials: no vertex to guide, rendering with pt".into());
    }
    let method = if guiding { requested } else { Method::Pt };
    let product = method == Method::Product;
    if product && !inv.glossy {
        reasons.push("no glossy lobe: the product uses only cosine lobes and form factors".into());
    }
    if product && !inv.diffuse {
        reasons.push("no diffuse lobe: no form factors".into());
    }
    let env = scene.lights.has_infinite();
    ScenePlan {
        requested,
        method,
        guiding,
        ltc_glossy: product && inv.glossy,
        ltc_table: product && (inv.glossy || inv.rough_ggx),
        diffuse_form_factors: product && inv.diffuse,
        environment_sampling: env,
        nee,
        reasons,
    }
}
