//! The SD-tree as a [`Guide`] for the shared path loop: at each non-delta
//! vertex, the spatial leaf's quadtree is descended with a child-weight
//! function (radiance for PPG, radiance × LTC integral for product
//! guiding), mixed with BSDF sampling by the leaf's learned α.

use super::descent::{self, ChildWeights, RadianceWeights};
use super::quadtree::QuadTree;
use super::record::{Record, RecordBuffer};
use super::sdtree::SdTree;
use crate::integrator::guide::{Guide, GuideVertex, PathVertex, VertexContext};
use crate::math::luminance;
use glam::{Vec2, Vec3};

/// Chooses the child-weight function at a vertex.
pub trait WeightModel: Sync {
    type Weights<'a>: ChildWeights
    where
        Self: 'a;

    /// The weights at a vertex; `None` means the guide cannot help here
    /// (e.g. the product vanishes everywhere): sample the BSDF.
    fn weights<'a>(&'a self, ctx: &VertexContext) -> Option<Self::Weights<'a>>;

    /// The reflected radiance towards ω_o (the adjoint ADRRS needs), given
    /// the descent's root normaliser Σ_k w_k.
    fn adjoint(&self, weights: &Self::Weights<'_>, ctx: &VertexContext, root_total: f32) -> f32;

    /// What the weights are, for reports.
    fn name(&self) -> &'static str;

    /// The same guide with cheaper child weights (product → radiance), for
    /// runs that measure whether the expensive weights pay. `None`: nothing
    /// cheaper exists.
    fn cheaper(&self) -> Option<Self>
    where
        Self: Sized,
    {
        None
    }
}

/// Practical path guiding: child weights are the stored radiance.
pub struct RadianceModel;

impl WeightModel for RadianceModel {
    type Weights<'a> = RadianceWeights;

    fn weights<'a>(&'a self, _ctx: &VertexContext) -> Option<RadianceWeights> {
        Some(RadianceWeights)
    }

    fn name(&self) -> &'static str {
        "radiance"
    }

    /// Σ_k L_k over the four root cells is 4× the mean incident radiance;
    /// without a BSDF integral, the reflected radiance is estimated as
    /// albedo × mean incident radiance (exact for a diffuse surface under
    /// uniform light).
    fn adjoint(&self, _weights: &RadianceWeights, ctx: &VertexContext, root_total: f32) -> f32 {
        ctx.bsdf.albedo_estimate(ctx.wo_local) * 0.25 * root_total
    }
}

/// The SD-tree guide. `learning` is on during training iterations, when
/// finished paths are recorded.
pub struct SdGuide<'t, M: WeightModel> {
    pub tree: &'t SdTree,
    pub model: &'t M,
    pub learning: bool,
    /// Salt for the records' jitter seeds (e.g. the pass index).
    pub pass: u64,
    /// A fixed BSDF fraction instead of the learned one.
    pub fixed_alpha: Option<f32>,
}

pub struct SdVertex<'a, W: ChildWeights> {
    tree: &'a QuadTree,
    weights: W,
    alpha: f32,
    adjoint: f32,
}

impl<W: ChildWeights> GuideVertex for SdVertex<'_, W> {
    fn bsdf_fraction(&self) -> f32 {
        self.alpha
    }

    fn sample(&mut self, u: Vec2) -> Option<(Vec3, f32)> {
        descent::sample_direction(self.tree, &mut self.weights, u)
    }

    fn pdf(&mut self, dir: Vec3) -> f32 {
        descent::pdf_direction(self.tree, &mut self.weights, dir)
    }

    fn adjoint_estimate(&self) -> Option<f32> {
        (self.adjoint > 0.0 && self.adjoint.is_finite()).then_some(self.adjoint)
    }
}

impl<'t, M: WeightModel> Guide for SdGuide<'t, M> {
    type Vertex<'a>
        = SdVertex<'a, M::Weights<'a>>
    where
        Self: 'a;
    type Recorder = RecordBuffer;

    fn vertex<'a>(&'a self, ctx: &VertexContext) -> Option<Self::Vertex<'a>> {
        let id = self.tree.lookup(ctx.p);
        let leaf = self.tree.leaf(id);
        if leaf.sampling.node_count() == 0 {
            return None;
        }
        let mut weights = self.model.weights(ctx)?;
        // The root normaliser: with product weights, Σ L_k·D_k estimates the
        // reflected radiance (the adjoint); with radiance weights, the
        // incident radiance integral.
        let root_total = descent::root_total(&leaf.sampling, &mut weights);
        if !(root_total > 0.0 && root_total.is_finite()) {
            return None;
        }
        let adjoint = self.model.adjoint(&weights, ctx, root_total);
        Some(SdVertex {
            tree: &leaf.sampling,
            weights,
            alpha: self
                .fixed_alpha
                .unwrap_or_else(|| self.tree.bsdf_fraction(id)),
            adjoint,
        })
    }

    fn new_recorder(&self) -> RecordBuffer {
        RecordBuffer::default()
    }

    fn learning(&self) -> bool {
        self.learning
    }

    fn record(&self, recorder: &mut RecordBuffer, vertices: &[PathVertex]) {
        for v in vertices.iter().filter(|v| v.guided) {
            let p_mix = v.pdf_mix;
            let incident = luminance(v.radiance);
            recorder.push(Record {
                position: v.p,
                direction: v.dir,
                radiance: incident / p_mix,
                product: luminance(v.bsdf_value * v.radiance) / p_mix,
                bsdf_pdf: v.pdf_bsdf,
                guide_pdf: v.pdf_guide,
                alpha: v.bsdf_fraction,
                throughput_pdf: v.throughput_pdf,
                guided: v.guide_used,
                seed: record_seed(self.pass, v),
            });
        }
    }
}

/// A seed unique to a vertex of a pass, independent of thread timing.
fn record_seed(pass: u64, v: &PathVertex) -> u64 {
    let h = |x: u64| {
        let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    let pos = (v.p.x.to_bits() as u64)
        ^ ((v.p.y.to_bits() as u64) << 21)
        ^ ((v.p.z.to_bits() as u64) << 42);
    h(pass ^ h(pos ^ h(v.depth as u64)))
}
