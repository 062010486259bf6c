//! The interface between the path loop and a directional guide. Plain path
//! tracing, radiance guiding and product guiding all run the same loop
//! (`path.rs`); they differ only in the [`Guide`] they plug in.

use crate::bsdf::Bsdf;
use crate::math::{Frame, Spectrum};
use glam::{Vec2, Vec3};

/// What a guide may look at when it builds a vertex's sampling distribution.
pub struct VertexContext<'a> {
    pub p: Vec3,
    pub ng: Vec3,
    pub frame: &'a Frame,
    pub wo_local: Vec3,
    pub bsdf: &'a Bsdf,
    /// Whether roulette will ask this vertex for its adjoint estimate (an
    /// estimate that costs work is then skipped where nothing reads it).
    pub needs_adjoint: bool,
    /// Index of the vertex along its path (0: the camera ray's hit).
    pub vertex_index: u32,
    /// The vertex is built again at the path's end, for a pdf the path loop
    /// deferred (`super::deferred_pdf`): caches do not count it as a reuse.
    pub revisit: bool,
}

/// A per-vertex guiding distribution over world directions, mixed with BSDF
/// sampling by one-sample MIS: p = (1 − α)·p_guide + α·p_bsdf.
pub trait GuideVertex {
    /// α, the probability of BSDF sampling.
    fn bsdf_fraction(&self) -> f32;
    /// A world direction and its solid-angle pdf under the guide.
    fn sample(&mut self, u: Vec2) -> Option<(Vec3, f32)>;
    /// Solid-angle pdf under the guide of a world direction.
    fn pdf(&mut self, dir: Vec3) -> f32;
    /// The guide's estimate of the radiance reflected towards wo (for
    /// adjoint-driven Russian roulette), if it computed one: as computed,
    /// zero or non-finite included, so that the roulette can count the
    /// unusable ones.
    fn adjoint_estimate(&self) -> Option<f32> {
        None
    }
    /// The share of the guide's samples drawn from a second, defensive
    /// distribution when the guide learns it from the recorded paths
    /// (`guiding::share_learning`); 0 where nothing is learned.
    fn learned_share(&self) -> f32 {
        0.0
    }
}

/// One scattering vertex of a finished path, as the learning step needs it.
#[derive(Clone, Copy, Debug)]
pub struct PathVertex {
    pub p: Vec3,
    pub dir: Vec3,
    /// Radiance arriving at the vertex from `dir` (filled in as the path
    /// continues): the sum of contributions after the vertex divided by the
    /// throughput up to and including the vertex's sampling weight.
    pub radiance: Spectrum,
    /// Throughput at the vertex including its own sampling weight f·cos/p.
    pub throughput: Spectrum,
    /// f·cos of the sampled direction (for the product learning signal).
    pub bsdf_value: Spectrum,
    pub pdf_mix: f32,
    pub pdf_bsdf: f32,
    pub pdf_guide: f32,
    pub bsdf_fraction: f32,
    /// [`GuideVertex::learned_share`] of the vertex's guide (0: none).
    pub learned_share: f32,
    /// The vertex lies where the tree guides (its material has a non-delta
    /// lobe): it is recorded, as a sample of the mixture drawn there.
    pub recorded: bool,
    /// A delta lobe was sampled (smooth plastic's coat): the sample counts
    /// in the tree's statistical weight but splats no radiance, since no
    /// solid-angle direction was drawn (`bsdf_value` is the lobe's mass and
    /// `pdf_bsdf` its probability).
    pub delta: bool,
    /// True when a guide distribution took part in the mixture (so the
    /// sample says something about the BSDF fraction).
    pub guide_used: bool,
    /// Scalar throughput before the vertex times the mixture pdf: a vertex
    /// whose estimate came from dividing by ~0 is not worth learning from.
    pub throughput_pdf: f32,
    /// Index of the vertex along the path (0 = first hit).
    pub depth: u32,
}

/// Per-worker memory a guide keeps between the paths of one row block
/// (its pixels in order, each pixel's paths one after the other). The
/// render loop ends it after every block, so what a path sees depends only
/// on the earlier paths of its own block, never on which blocks a worker
/// happened to render before (images stay reproducible for a seed and
/// thread count).
pub trait VertexCache: Default + Send {
    /// Forgets the block and adds what the cache counted to `counters`.
    fn end_block(&mut self, counters: &mut crate::integrator::stats::RenderCounters);
}

impl VertexCache for () {
    fn end_block(&mut self, _counters: &mut crate::integrator::stats::RenderCounters) {}
}

pub trait Guide: Sync {
    type Vertex<'a>: GuideVertex
    where
        Self: 'a;
    /// Per-thread storage for learning records.
    type Recorder: Send;
    /// Per-worker memory shared by the paths of a row block.
    type Cache: VertexCache;

    /// Where a point lies in the guide's structure.
    type Location: Copy;

    /// Finds where the non-delta hit `p` lies and starts loading what
    /// [`Self::vertex`] will read there. Called before the hit's texture
    /// lookup, so that the cache misses overlap the work in between.
    fn locate(&self, p: Vec3) -> Self::Location;

    /// The sampling distribution at a non-delta vertex located at `at` (by
    /// [`Self::locate`] of `ctx.p`); `None` means BSDF sampling only. The
    /// vertex may keep what it computes in `cache`, and counts any guard
    /// that fires in `counters`.
    fn vertex<'a>(
        &'a self,
        ctx: &VertexContext,
        at: Self::Location,
        cache: &'a mut Self::Cache,
        counters: &mut crate::integrator::stats::RenderCounters,
    ) -> Option<Self::Vertex<'a>>;

    fn new_recorder(&self) -> Self::Recorder;

    /// Empties `recorder` for another call, keeping its memory: a buffer
    /// grown anew every call faults in fresh pages for the kernel to zero,
    /// one kept does so only when a call outgrows it (staircase, 150 CPU s:
    /// peak memory 1.7–2.4 GB before, 1.7–1.8 GB after; speed unchanged
    /// within noise).
    fn clear_recorder(&self, recorder: &mut Self::Recorder);

    /// True while the guide is learning and wants finished paths.
    fn learning(&self) -> bool;

    /// Records a finished path's vertices; `pass` is the path's pass index.
    fn record(&self, recorder: &mut Self::Recorder, vertices: &[PathVertex], pass: u64);
}

/// Plain path tracing: no guide.
pub struct NoGuide;

pub enum Never {}

impl GuideVertex for Never {
    fn bsdf_fraction(&self) -> f32 {
        match *self {}
    }
    fn sample(&mut self, _u: Vec2) -> Option<(Vec3, f32)> {
        match *self {}
    }
    fn pdf(&mut self, _dir: Vec3) -> f32 {
        match *self {}
    }
}

impl Guide for NoGuide {
    type Vertex<'a> = Never;
    type Recorder = ();
    type Cache = ();
    type Location = ();

    fn locate(&self, _p: Vec3) {}

    fn vertex<'a>(
        &'a self,
        _ctx: &VertexContext,
        _at: (),
        _cache: &'a mut (),
        _counters: &mut crate::integrator::stats::RenderCounters,
    ) -> Option<Never> {
        None
    }

    fn new_recorder(&self) {}

    fn clear_recorder(&self, _recorder: &mut ()) {}

    fn learning(&self) -> bool {
        false
    }

    fn record(&self, _recorder: &mut (), _vertices: &[PathVertex], _pass: u64) {}
}
