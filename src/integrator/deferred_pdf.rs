//! The guide's pdf of a BSDF-sampled direction, computed only if the path
//! brings radiance.
//!
//! One-sample MIS weights a BSDF-sampled direction by
//! f / (α·p_bsdf + (1 − α)·p_guide), so every BSDF sample at a guided
//! vertex pays for the guide's pdf of its direction: under product weights a
//! product descent and the radiance descent of its defensive share, under
//! radiance weights a radiance descent. Yet that weight only scales what
//! arrives after the vertex, and without next-event estimation most paths
//! bring nothing at all: 80–93 % of the first vertices' BSDF samples on the
//! pack's glossy scenes (product, 32 spp, no NEE).
//!
//! So at the first guided vertex of a path whose direction the BSDF drew,
//! the path carries its throughput under the mixture's BSDF part alone,
//! p̃_mix = α·p_bsdf, and goes on. At the path's end, if anything arrived
//! after the vertex, the vertex is built again (within a pass the guide is a
//! pure function of the vertex) and the exact p_mix computed; everything
//! that arrived after it is scaled by p̃_mix / p_mix, which makes each
//! contribution the eager one. Where nothing arrived, p_guide is never
//! computed. One vertex per path: the first is where product weights are
//! (`guiding::product::DEFAULT_PRODUCT_VERTICES`), and its lobe is still in
//! the worker's first-vertex slot when it is built again.
//!
//! The one thing that reads the stand-in is Russian roulette after the
//! vertex, which decides on the throughput before the rescale. A survival
//! probability may be any function of the path so far, so this changes no
//! expectation, only which paths roulette ends. Since p̃_mix ≤ p_mix, the
//! throughput roulette reads is never below the exact one: roulette ends
//! fewer paths, and never divides a path by a survival probability smaller
//! than the exact throughput would have given (a stand-in of p_bsdf, which
//! can understate the throughput by 1/α, raised staircase's relMSE by 18 %).
//!
//! Learning records stay exact where they carry information: the rescale
//! reaches the recorded throughputs, contributions and the vertex's pdfs.
//! A vertex whose path brought nothing keeps the stand-in pdfs (p_guide = 0)
//! in its record, and the records after it the stand-in's throughput; their
//! radiance and Adam gradients are zero whatever the pdfs, and only the
//! guard on throughput·p_mix (`guiding::record`, which refuses values below
//! 1e-20) reads them: at the vertex at most the exact value, after it at
//! least.
//!
//! With NEE the MIS weight of the next emitter hit reads the mixture pdf at
//! once, and nearly every path brings radiance, so nothing is deferred.

use super::guide::{Guide, GuideVertex, PathVertex, VertexContext};
use super::stats::RenderCounters;
use crate::bsdf::Bsdf;
use crate::math::{Frame, Spectrum, luminance};
use glam::Vec3;

/// A BSDF sample whose guide pdf is left for the path's end.
#[derive(Clone, Copy, Debug)]
pub struct DeferredPdf<L> {
    p: Vec3,
    ng: Vec3,
    frame: Frame,
    wo_local: Vec3,
    bsdf: Bsdf,
    vertex_index: u32,
    location: L,
    dir: Vec3,
    alpha: f32,
    pdf_bsdf: f32,
    /// Scalar throughput before the vertex (its record's guard).
    throughput_before: f32,
    /// Index of the vertex in the path's learning records.
    record: usize,
}

impl<L: Copy> DeferredPdf<L> {
    pub fn new(
        ctx: &VertexContext,
        location: L,
        dir: Vec3,
        alpha: f32,
        pdf_bsdf: f32,
        throughput_before: Spectrum,
        record: usize,
    ) -> Self {
        DeferredPdf {
            p: ctx.p,
            ng: ctx.ng,
            frame: *ctx.frame,
            wo_local: ctx.wo_local,
            bsdf: *ctx.bsdf,
            vertex_index: ctx.vertex_index,
            location,
            dir,
            alpha,
            pdf_bsdf,
            throughput_before: luminance(throughput_before),
            record,
        }
    }

    /// The exact (guide pdf, mixture pdf) of the sampled direction, from the
    /// vertex built again; `None` where they are unusable (the caller counts
    /// it in `invalid_scattering` and drops what arrived after it).
    pub fn resolve<G: Guide<Location = L>>(
        &self,
        guide: &G,
        cache: &mut G::Cache,
        counters: &mut RenderCounters,
    ) -> Option<(f32, f32)> {
        let ctx = VertexContext {
            p: self.p,
            ng: self.ng,
            frame: &self.frame,
            wo_local: self.wo_local,
            bsdf: &self.bsdf,
            needs_adjoint: false,
            vertex_index: self.vertex_index,
            revisit: true,
        };
        let pdf_guide = guide
            .vertex(&ctx, self.location, cache, counters)?
            .pdf(self.dir);
        let pdf_mix = self.alpha * self.pdf_bsdf + (1.0 - self.alpha) * pdf_guide;
        (pdf_mix > 0.0 && pdf_mix.is_finite()).then_some((pdf_guide, pdf_mix))
    }

    /// The factor that turns what arrived after the vertex into its exact
    /// value, given the exact mixture pdf: the path's throughput holds
    /// α·p_bsdf, the mixture with the guide's part at 0.
    pub fn rescale(&self, pdf_mix: f32) -> f32 {
        self.alpha * self.pdf_bsdf / pdf_mix
    }

    /// Makes the path's learning records exact: the throughputs from the
    /// vertex on and the contributions after it scaled by `factor`, the
    /// vertex's pdfs the exact ones.
    pub fn fix_records(
        &self,
        vertices: &mut [PathVertex],
        contributions: &mut [(usize, Spectrum)],
        factor: f32,
        pdf_guide: f32,
        pdf_mix: f32,
    ) {
        for (count, c) in contributions.iter_mut() {
            if *count > self.record {
                *c *= factor;
            }
        }
        let Some((vertex, later)) = vertices[self.record..].split_first_mut() else {
            return;
        };
        vertex.throughput *= factor;
        vertex.pdf_guide = pdf_guide;
        vertex.pdf_mix = pdf_mix;
        vertex.throughput_pdf = self.throughput_before * pdf_mix;
        for v in later {
            v.throughput *= factor;
            v.throughput_pdf *= factor;
        }
    }

    /// Drops what arrived after a vertex whose exact pdf is unusable.
    pub fn drop_later(&self, contributions: &mut Vec<(usize, Spectrum)>) {
        contributions.retain(|(count, _)| *count <= self.record);
    }
}
