//! Product guiding (Diolatzis et al. 2020): the child weight of the shared
//! descent is L_k·D_k, where L_k is the stored radiance of child k and D_k
//! the integral of the cosine-weighted BSDF over the child's spherical cell,
//! computed with linearly transformed cosines.
//!
//! The paper's fallbacks:
//! - outgoing elevation θ_o ≥ 85° → radiance-only weights (the LTC fit is
//!   poor there and the lobe is mostly clipped);
//! - GGX lobes with α > 0.5 → treated as diffuse (inside `ShadingLtc`);
//! - a product that vanishes over the whole sphere → BSDF sampling;
//! - all children's products vanishing under a non-zero parent (chord or
//!   clipping error) → radiance weights at that level (inside the descent).

use super::descent::ChildWeights;
use super::guide::WeightModel;
use crate::directional::Cell;
use crate::integrator::guide::VertexContext;
use crate::ltc::{LtcOptions, LtcTable, ProductKernel, ShadingLtc};

pub struct ProductModel<'t> {
    pub table: &'t LtcTable,
    pub kernel: ProductKernel,
    pub options: LtcOptions,
}

/// Per-vertex weights: the product, or the radiance fallback.
pub enum ProductWeights {
    Product {
        ltc: ShadingLtc,
        kernel: ProductKernel,
    },
    RadianceOnly {
        albedo: f32,
    },
}

impl ChildWeights for ProductWeights {
    #[inline]
    fn child_weights(&mut self, cell: Cell, radiance: [f32; 4]) -> [f32; 4] {
        match self {
            ProductWeights::Product { ltc, kernel } => {
                let d = ltc.child_integrals(cell, *kernel);
                [
                    radiance[0] * d[0],
                    radiance[1] * d[1],
                    radiance[2] * d[2],
                    radiance[3] * d[3],
                ]
            }
            ProductWeights::RadianceOnly { .. } => radiance,
        }
    }

    /// Only glossy lobes vary faster than the radiance tree resolves; a
    /// cosine lobe is smooth at every leaf size the tree produces.
    fn refine_below_leaves_to(&self) -> u32 {
        match self {
            ProductWeights::Product { ltc, .. } if ltc.glossy_count > 0 => {
                crate::guiding::quadtree::MAX_DEPTH
            }
            _ => 0,
        }
    }
}

impl WeightModel for ProductModel<'_> {
    type Weights<'a>
        = ProductWeights
    where
        Self: 'a;

    fn weights<'a>(&'a self, ctx: &VertexContext) -> Option<ProductWeights> {
        let lobes = ctx.bsdf.lobes(ctx.wo_local);
        // Two-sided mirroring flips z only (the lobes' frame).
        let w = ctx.wo_local;
        let wo = if lobes.side < 0.0 {
            glam::Vec3::new(w.x, w.y, -w.z)
        } else {
            w
        };
        let ltc = ShadingLtc::new(&lobes, ctx.frame, wo, self.table, &self.options);
        if !(ltc.total() > 0.0) {
            // The product vanishes everywhere: sample the BSDF.
            return None;
        }
        if ltc.prefers_radiance_only() {
            return Some(ProductWeights::RadianceOnly {
                albedo: ltc.total(),
            });
        }
        Some(ProductWeights::Product {
            ltc,
            kernel: self.kernel,
        })
    }

    /// With product weights the root normaliser Σ_k L_k·D_k already
    /// estimates the reflected radiance; in the radiance fallback it is
    /// albedo × mean incident radiance, as for radiance guiding.
    fn adjoint(&self, weights: &ProductWeights, _ctx: &VertexContext, root_total: f32) -> f32 {
        match weights {
            ProductWeights::Product { .. } => root_total,
            ProductWeights::RadianceOnly { albedo } => albedo * 0.25 * root_total,
        }
    }
}
