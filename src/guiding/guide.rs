//! The SD-tree as a [`Guide`] for the shared path loop: at each non-delta
//! vertex, the spatial leaf's quadtree is descended with a child-weight
//! function (radiance for PPG, radiance × LTC integral for product
//! guiding), mixed with BSDF sampling by the leaf's learned α.

use super::defensive;
use super::descent::{self, ChildWeights, RadianceWeights};
use super::quadtree::QuadTree;
use super::record::{Record, RecordBuffer};
use super::sdtree::SdTree;
use super::support::{GuideSupport, HemisphereSlot, SupportWeights};
use crate::integrator::guide::{Guide, GuideVertex, PathVertex, VertexCache, VertexContext};
use crate::integrator::stats::RenderCounters;
use crate::math::{Frame, luminance};
use glam::{Vec2, Vec3};

/// Chooses the child-weight function at a vertex.
pub trait WeightModel: Sync {
    type Weights<'a>: ChildWeights
    where
        Self: 'a;
    /// Per-worker memory for the weights of a row block's paths.
    type Cache: VertexCache;

    /// The weights at a vertex; `None` means the guide cannot help here
    /// (e.g. the product vanishes everywhere): sample the BSDF.
    fn weights<'a>(
        &'a self,
        ctx: &VertexContext,
        cache: &'a mut Self::Cache,
    ) -> Option<Self::Weights<'a>>;

    /// The reflected radiance towards ω_o (the adjoint ADRRS needs), given
    /// the descent's root normaliser Σ_k w_k and the root cells' stored
    /// radiance L_k (mean radiance over each quarter sphere). Called only
    /// where roulette reads it.
    fn adjoint(
        &self,
        weights: &Self::Weights<'_>,
        ctx: &VertexContext,
        root_total: f32,
        root_radiance: [f32; 4],
    ) -> f32;

    /// What the weights are, for reports.
    fn name(&self) -> &'static str;

    /// Share of the guided samples drawn from the radiance descent where the
    /// weights are not the radiance already ([`super::defensive`]).
    fn radiance_share(&self) -> f32 {
        0.0
    }

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

/// Practical path guiding: child weights are the stored radiance, over the
/// whole sphere (Müller et al. 2017) or on a reflecting surface's
/// hemisphere ([`GuideSupport`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct RadianceModel {
    pub support: GuideSupport,
}

impl WeightModel for RadianceModel {
    type Weights<'a> = SupportWeights<'a>;
    type Cache = HemisphereSlot;

    #[inline]
    fn weights<'a>(
        &'a self,
        ctx: &VertexContext,
        slot: &'a mut HemisphereSlot,
    ) -> Option<SupportWeights<'a>> {
        Some(slot.weights(
            self.support,
            ctx.frame.n,
            ctx.wo_local,
            ctx.bsdf.reflects_only(),
        ))
    }

    fn name(&self) -> &'static str {
        "radiance"
    }

    fn adjoint(
        &self,
        _weights: &SupportWeights<'_>,
        ctx: &VertexContext,
        _root_total: f32,
        root_radiance: [f32; 4],
    ) -> f32 {
        let albedo = ctx.bsdf.albedo_estimate(ctx.wo_local);
        reflected_radiance_estimate(ctx.frame, ctx.wo_local, albedo, root_radiance)
    }
}

/// Without a BSDF integral, the reflected radiance towards ω_o is estimated
/// as albedo × the cosine-weighted mean of the root cells' radiance over
/// the hemisphere on ω_o's side (exact for a diffuse surface under uniform
/// light). The mean over the whole sphere, used before, also averaged in
/// the dark half behind the surface: for a wall lit from the front it
/// halved the adjoint, doubling ADRRS's weight window for radiance guiding
/// but not for the product, whose adjoint Σ L_k·D_k has the cosine in D_k.
pub fn reflected_radiance_estimate(
    frame: &Frame,
    wo_local: Vec3,
    albedo: f32,
    root_radiance: [f32; 4],
) -> f32 {
    let side = if wo_local.z < 0.0 { -1.0 } else { 1.0 };
    let share = crate::ltc::form_factor::cosine_root_children(frame.n * side);
    albedo * (0..4).map(|k| share[k] * root_radiance[k]).sum::<f32>()
}

/// The SD-tree guide. `learning` is on during training iterations, when
/// finished paths are recorded.
pub struct SdGuide<'t, M: WeightModel> {
    pub tree: &'t SdTree,
    pub model: &'t M,
    pub learning: bool,
    /// A fixed BSDF fraction instead of the learned one.
    pub fixed_alpha: Option<f32>,
}

pub struct SdVertex<'a, W: ChildWeights> {
    tree: &'a QuadTree,
    weights: W,
    alpha: f32,
    /// Computed where roulette reads it; possibly non-finite or zero.
    adjoint: Option<f32>,
    /// The model's [`WeightModel::radiance_share`], or the leaf's learned
    /// one.
    radiance_share: f32,
    /// The share is the leaf's learned one.
    share_learned: bool,
}

impl<W: ChildWeights> GuideVertex for SdVertex<'_, W> {
    fn bsdf_fraction(&self) -> f32 {
        self.alpha
    }

    fn sample(&mut self, u: Vec2) -> Option<(Vec3, f32)> {
        defensive::sample_direction(self.tree, &mut self.weights, self.radiance_share, u)
    }

    fn pdf(&mut self, dir: Vec3) -> f32 {
        defensive::pdf_direction(self.tree, &mut self.weights, self.radiance_share, dir)
    }

    fn adjoint_estimate(&self) -> Option<f32> {
        self.adjoint
    }

    fn learned_share(&self) -> f32 {
        if self.share_learned && defensive::mixes(&self.weights, self.radiance_share) {
            self.radiance_share
        } else {
            0.0
        }
    }
}

impl<'t, M: WeightModel> Guide for SdGuide<'t, M> {
    type Vertex<'a>
        = SdVertex<'a, M::Weights<'a>>
    where
        Self: 'a;
    type Recorder = RecordBuffer;
    type Cache = M::Cache;

    /// The leaf, with its quadtree root prefetched: every vertex reads the
    /// root's sums first, and that load was a guided vertex's hottest (a
    /// miss per vertex).
    type Location = u32;

    #[inline]
    fn locate(&self, p: Vec3) -> u32 {
        let id = self.tree.lookup(p);
        if let Some(root) = self.tree.leaf(id).sampling.nodes().first() {
            crate::huge::prefetch(root);
        }
        id
    }

    /// Inlined into the path loop: called out of line, its 40-byte result
    /// under product weights came back through memory, stored in five
    /// pieces and reloaded as one wider load, a store-forwarding stall at
    /// every vertex (on cornell-box, where the product is radiance guiding
    /// bit for bit, its CPU went from 1.06× radiance guiding's to 1.01×).
    #[inline]
    fn vertex<'a>(
        &'a self,
        ctx: &VertexContext,
        id: u32,
        cache: &'a mut M::Cache,
        counters: &mut RenderCounters,
    ) -> Option<Self::Vertex<'a>> {
        let leaf = self.tree.leaf(id);
        if leaf.sampling.node_count() == 0 {
            return None;
        }
        let mut weights = self.model.weights(ctx, cache)?;
        // The root normaliser: with product weights, Σ L_k·D_k estimates the
        // reflected radiance (the adjoint); with radiance weights, the
        // incident radiance integral.
        let root_total = descent::root_total(&leaf.sampling, &mut weights);
        if !(root_total > 0.0 && root_total.is_finite()) {
            // Zero: nothing to guide towards here, not an error.
            counters.guide_root_nonfinite += !root_total.is_finite() as u64;
            return None;
        }
        let adjoint = ctx.needs_adjoint.then(|| {
            let root_radiance = leaf.sampling.nodes()[0].sums;
            self.model.adjoint(&weights, ctx, root_total, root_radiance)
        });
        let fixed_share = self.model.radiance_share();
        // Under radiance weights the share is unused (`defensive::mixes`),
        // so it is not read: it lies about 300 bytes into the leaf, a cache
        // line no other read of the vertex touches. Images are bit-identical
        // either way; on cornell-box, where every vertex has radiance
        // weights, the CPU difference was within run-to-run noise (session 65).
        let learned_share = defensive::mixes(&weights, fixed_share)
            .then(|| self.tree.learned_radiance_share(id))
            .flatten();
        Some(SdVertex {
            tree: &leaf.sampling,
            weights,
            alpha: self
                .fixed_alpha
                .unwrap_or_else(|| self.tree.bsdf_fraction(id)),
            adjoint,
            radiance_share: learned_share.unwrap_or(fixed_share),
            share_learned: learned_share.is_some(),
        })
    }

    fn new_recorder(&self) -> RecordBuffer {
        RecordBuffer::default()
    }

    fn clear_recorder(&self, recorder: &mut RecordBuffer) {
        recorder.clear();
    }

    fn learning(&self) -> bool {
        self.learning
    }

    fn record(&self, recorder: &mut RecordBuffer, vertices: &[PathVertex], pass: u64) {
        for v in vertices.iter().filter(|v| v.recorded) {
            let p_mix = v.pdf_mix;
            let incident = luminance(v.radiance);
            recorder.push(Record {
                position: v.p,
                direction: v.dir,
                // ∫L dω over the sphere is estimated from every sample of
                // the mixture: a delta sample adds 0 to it but counts in N.
                radiance: if v.delta { 0.0 } else { incident / p_mix },
                product: luminance(v.bsdf_value * v.radiance) / p_mix,
                bsdf_pdf: v.pdf_bsdf,
                guide_pdf: v.pdf_guide,
                alpha: v.bsdf_fraction,
                radiance_pdf: if v.learned_share > 0.0 {
                    self.radiance_pdf(v.p, v.dir)
                } else {
                    0.0
                },
                radiance_share: v.learned_share,
                throughput_pdf: v.throughput_pdf,
                guided: v.guide_used,
                seed: record_seed(pass, v),
                pass,
            });
        }
    }
}

impl<M: WeightModel> SdGuide<'_, M> {
    /// The solid-angle pdf of `dir` under the radiance descent of the leaf
    /// at `p`: what the share learning compares the product with. Taken
    /// after the path rather than kept from the vertex, so that rendering
    /// pays nothing for it; the tree is the one the vertex sampled from.
    fn radiance_pdf(&self, p: Vec3, dir: Vec3) -> f32 {
        let leaf = self.tree.leaf(self.tree.lookup(p));
        descent::pdf_direction(&leaf.sampling, &mut RadianceWeights, dir)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Bsdf, BsdfModel};
    use crate::guiding::sdtree::SdTreeConfig;

    /// Radiance weights with an adjoint that is always NaN.
    struct NanAdjoint;

    impl WeightModel for NanAdjoint {
        type Weights<'a> = RadianceWeights;
        type Cache = ();
        fn weights(&self, _ctx: &VertexContext, _cache: &mut ()) -> Option<RadianceWeights> {
            Some(RadianceWeights)
        }
        fn adjoint(&self, _: &RadianceWeights, _: &VertexContext, _: f32, _: [f32; 4]) -> f32 {
            f32::NAN
        }
        fn name(&self) -> &'static str {
            "nan-adjoint"
        }
    }

    /// A vertex of a one-leaf tree whose root holds `root` in each cell.
    fn vertex_with<M: WeightModel>(
        model: &M,
        root: f32,
        counters: &mut RenderCounters,
    ) -> Option<Option<f32>> {
        let mut tree = SdTree::new(Vec3::ZERO, Vec3::ONE, SdTreeConfig::default());
        tree.leaves_mut()[0].sampling = QuadTree::uniform(root);
        let guide = SdGuide {
            tree: &tree,
            model,
            learning: false,
            fixed_alpha: None,
        };
        let bsdf = Bsdf {
            model: BsdfModel::Diffuse {
                reflectance: Vec3::splat(0.5),
            },
            two_sided: false,
        };
        let frame = Frame::from_normal(Vec3::Z);
        let ctx = VertexContext {
            p: Vec3::splat(0.5),
            ng: Vec3::Z,
            frame: &frame,
            wo_local: Vec3::Z,
            bsdf: &bsdf,
            needs_adjoint: true,
            vertex_index: 1,
            revisit: false,
        };
        let at = guide.locate(ctx.p);
        guide
            .vertex(&ctx, at, &mut M::Cache::default(), counters)
            .map(|v| v.adjoint_estimate())
    }

    /// Root weights whose total overflows (4 × f32::MAX) disable the
    /// vertex and are counted; a root without light disables it silently.
    #[test]
    fn a_non_finite_root_total_is_counted() {
        let mut counters = RenderCounters::default();
        assert!(vertex_with(&RadianceModel::default(), f32::MAX, &mut counters).is_none());
        assert_eq!(counters.guide_root_nonfinite, 1);
        assert!(vertex_with(&RadianceModel::default(), 0.0, &mut counters).is_none());
        assert_eq!(counters.guide_root_nonfinite, 1);
        let adjoint = vertex_with(&RadianceModel::default(), 1.0, &mut counters).unwrap();
        assert!(adjoint.unwrap() > 0.0);
        assert_eq!(counters.guide_root_nonfinite, 1);
    }

    /// A non-finite adjoint reaches the roulette, which counts it; it was
    /// turned into "no estimate" here, uncounted.
    #[test]
    fn a_non_finite_adjoint_is_passed_on() {
        let mut counters = RenderCounters::default();
        let adjoint = vertex_with(&NanAdjoint, 1.0, &mut counters).unwrap();
        assert!(adjoint.unwrap().is_nan());
    }

    /// Uniform radiance L over the upper half of the sphere (root cells 1
    /// and 3) and none below: a surface facing up reflects albedo × L, one
    /// facing down (or seen from below) nothing, a vertical one half; the
    /// whole-sphere mean gave albedo × L/2 facing up.
    #[test]
    fn reflected_radiance_weights_the_hemisphere_by_its_cosine() {
        let l = 3.0;
        let upper = [0.0, l, 0.0, l];
        let up = Frame::from_normal(Vec3::Z);
        let down = Frame::from_normal(-Vec3::Z);
        let side = Frame::from_normal(Vec3::new(0.6, 0.8, 0.0));
        let front = Vec3::new(0.1, 0.2, 0.97);
        let back = Vec3::new(0.1, 0.2, -0.97);
        let close = |a: f32, b: f32| (a - b).abs() < 1e-4 * l;
        assert!(close(
            reflected_radiance_estimate(&up, front, 0.5, upper),
            0.5 * l
        ));
        assert!(close(
            reflected_radiance_estimate(&up, back, 0.5, upper),
            0.0
        ));
        assert!(close(
            reflected_radiance_estimate(&down, back, 0.5, upper),
            0.5 * l
        ));
        assert!(close(
            reflected_radiance_estimate(&down, front, 0.5, upper),
            0.0
        ));
        assert!(close(
            reflected_radiance_estimate(&side, front, 0.5, upper),
            0.25 * l
        ));
    }
}
