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

/// Depths below this get one memo slot each (deeper nodes are recomputed).
const MEMO_DEPTHS: usize = 24;

/// Per-vertex memo of child integrals, one slot per depth: `root_total`, the
/// sample descent and the pdf descents at one vertex all start at the root
/// and usually share their top levels, and a descent visits one node per
/// depth, so a slot per depth holds exactly the shared prefix. The value is
/// the same pure function of the cell whether it is computed or recalled, so
/// sample and pdf stay bit-identical.
#[derive(Clone, Debug)]
pub struct ChildMemo {
    /// (ix, iy) of the cell in each depth's slot; `u32::MAX` when empty.
    keys: [(u32, u32); MEMO_DEPTHS],
    values: [[f32; 4]; MEMO_DEPTHS],
}

impl Default for ChildMemo {
    fn default() -> Self {
        ChildMemo {
            keys: [(u32::MAX, u32::MAX); MEMO_DEPTHS],
            values: [[0.0; 4]; MEMO_DEPTHS],
        }
    }
}

impl ChildMemo {
    /// D of `cell`'s children, from the memo or computed by `f`.
    #[inline]
    pub fn get_or(&mut self, cell: Cell, f: impl FnOnce() -> [f32; 4]) -> [f32; 4] {
        let d = cell.depth as usize;
        if d >= MEMO_DEPTHS {
            return f();
        }
        if self.keys[d] == (cell.ix, cell.iy) {
            return self.values[d];
        }
        let v = f();
        self.keys[d] = (cell.ix, cell.iy);
        self.values[d] = v;
        v
    }
}

/// Per-vertex weights: the product, or the radiance fallback.
pub enum ProductWeights {
    Product {
        ltc: ShadingLtc,
        kernel: ProductKernel,
        memo: ChildMemo,
    },
    RadianceOnly {
        albedo: f32,
    },
}

impl ChildWeights for ProductWeights {
    #[inline]
    fn child_weights(&mut self, cell: Cell, radiance: [f32; 4]) -> [f32; 4] {
        match self {
            ProductWeights::Product { ltc, kernel, memo } => {
                let d = memo.get_or(cell, || ltc.child_integrals(cell, *kernel));
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
            memo: ChildMemo::default(),
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
