//! Recording path vertices into the SD-tree after a pass (DESIGN §5).
//!
//! During a pass each rendering thread appends [`Record`]s to its own
//! [`RecordBuffer`]; nothing shared is written, so there is no contention.
//! After the pass [`record_pass`] consumes the buffers in thread-index order
//! and record order, so the result depends only on what each thread
//! recorded, never on scheduling. The work then fans out over spatial leaves
//! (each leaf's records in that fixed order), which is deterministic too.
//!
//! Per accepted record:
//! - spatial filter: the position is jittered uniformly within the box size
//!   of the leaf containing it (Müller 2017 §5.3, stochastic box filter),
//!   using an RNG seeded by the record's own `seed`;
//! - directional filter: the value is box-splatted into the recording
//!   quadtree of the leaf the jittered point falls in;
//! - the Adam step of the BSDF fraction is taken in the leaf that actually
//!   produced the sample (no jitter: α belongs to the vertex's leaf).
//!
//! Guards (each rejected record counted exactly once, in this order):
//! non-finite field or zero direction → `rejected_non_finite`; throughput·p_mix ≤
//! [`ZERO_PDF_EPSILON`] → `rejected_zero_pdf`; negative radiance or product →
//! `rejected_negative`.

use super::adam::{AdamStats, NonFiniteGradient};
use super::sdtree::SdTree;
use crate::directional::dir_to_square;
use crate::sampling::Rng;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Below this, throughput·p_mix means the vertex's radiance estimate came
/// from dividing by (nearly) nothing: such values are noise, not signal.
pub const ZERO_PDF_EPSILON: f32 = 1e-20;

/// One non-delta path vertex with the radiance that arrived along the
/// sampled direction. All scalars are luminance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    pub position: Vec3,
    /// Unit world direction towards which the incident radiance was measured
    /// (the sampled ω_i, pointing away from the vertex).
    pub direction: Vec3,
    /// L_i(ω_i) / p_mix(ω_i), p_mix being the mixture pdf actually used.
    pub radiance: f32,
    /// f(ω_o, ω_i)·|cos θ_i|·L_i(ω_i) / p_mix(ω_i): the Adam step's F/p.
    pub product: f32,
    /// Solid-angle pdfs of ω_i under BSDF sampling and under the guide.
    pub bsdf_pdf: f32,
    pub guide_pdf: f32,
    /// BSDF fraction α of the mixture used at this vertex.
    pub alpha: f32,
    /// Scalar path throughput up to the vertex times p_mix(ω_i); guards
    /// against estimates obtained by dividing by ~0.
    pub throughput_pdf: f32,
    /// False when the guide was unavailable (α forced to 1): such samples
    /// are recorded for the guide but carry no information about α.
    pub guided: bool,
    /// Any value unique to the vertex (e.g. a hash of pass, pixel, depth);
    /// seeds the spatial jitter so it does not depend on thread timing.
    pub seed: u64,
    /// The pass the path belongs to: a leaf's Adam steps are taken in
    /// pass order, whichever passes a render call traced together.
    pub pass: u64,
}

/// Counters of [`record_pass`]. Every record lands in exactly one of the
/// first four.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecordStats {
    pub accepted: u64,
    pub rejected_non_finite: u64,
    pub rejected_negative: u64,
    pub rejected_zero_pdf: u64,
    /// Accepted records that also fed an Adam step, and gradients refused.
    pub adam: AdamStats,
}

impl RecordStats {
    pub fn total(&self) -> u64 {
        self.accepted + self.rejected_non_finite + self.rejected_negative + self.rejected_zero_pdf
    }

    pub fn merge(&mut self, o: &RecordStats) {
        self.accepted += o.accepted;
        self.rejected_non_finite += o.rejected_non_finite;
        self.rejected_negative += o.rejected_negative;
        self.rejected_zero_pdf += o.rejected_zero_pdf;
        self.adam.merge(&o.adam);
    }
}

/// Why a record is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RecordReject {
    NonFinite,
    ZeroPdf,
    Negative,
}

/// Checks a record against the guards.
pub fn validate(r: &Record) -> Result<(), RecordReject> {
    let finite = r.position.is_finite()
        && r.direction.is_finite()
        && r.radiance.is_finite()
        && r.product.is_finite()
        && r.bsdf_pdf.is_finite()
        && r.guide_pdf.is_finite()
        && r.alpha.is_finite()
        && r.throughput_pdf.is_finite()
        // A zero direction has no point on the square: as unusable as NaN.
        && r.direction.length_squared() > 0.0;
    if !finite {
        return Err(RecordReject::NonFinite);
    }
    if r.throughput_pdf <= ZERO_PDF_EPSILON {
        return Err(RecordReject::ZeroPdf);
    }
    if r.radiance < 0.0 || r.product < 0.0 {
        return Err(RecordReject::Negative);
    }
    Ok(())
}

/// One rendering thread's records.
#[derive(Clone, Debug, Default)]
pub struct RecordBuffer {
    pub records: Vec<Record>,
}

impl RecordBuffer {
    #[inline]
    pub fn push(&mut self, r: Record) {
        self.records.push(r);
    }

    pub fn clear(&mut self) {
        self.records.clear();
    }
}

/// Memory a record takes while a training call holds it: itself in its
/// thread's buffer, then its splat and Adam sample in [`record_pass`]'s
/// per-leaf work.
pub const RECORD_BYTES: u64 =
    (size_of::<Record>() + size_of::<(Vec2, f32)>() + size_of::<AdamSample>()) as u64;

/// Memory the path records of one training call may fill (the buffers'
/// capacity, grown by doubling, may reach twice that). A call renders up
/// to 16 passes and holds all their records until it ends: 108 bytes per
/// recorded vertex (staircase at 360×640: 87 MB a pass), so at 1920×1080 a
/// 16-pass call would have held some 12 GB, and more than the machine has
/// at 4K. Training calls are cut to the passes that fit. Every record is
/// still recorded; between the extra calls Adam's BSDF fractions move on,
/// as they do between the calls a time budget cuts. Staircase, radiance guiding,
/// 64 spp, two threads: peak memory 1.84 → 1.41 GB, time unchanged
/// (18.8 and 18.2 s); at 16 spp no call is cut (identical image).
pub const RECORD_BUDGET_BYTES: u64 = 1 << 30;

/// At most `n` passes, and no more than keep a call's records within
/// [`RECORD_BUDGET_BYTES`], given the records a pass produced so far (or,
/// before any, a path of `max_records_per_path` records at every one of
/// `pixels`); at least one.
pub fn passes_within_record_budget(
    n: u64,
    records_per_pass: Option<f64>,
    pixels: usize,
    max_records_per_path: u32,
) -> u64 {
    let per_pass = records_per_pass.unwrap_or(pixels as f64 * max_records_per_path as f64)
        * RECORD_BYTES as f64;
    let fit = if per_pass > 0.0 {
        (RECORD_BUDGET_BYTES as f64 / per_pass) as u64
    } else {
        n
    };
    n.min(fit).max(1)
}

/// One Adam sample: (pass, [F/p, p_bsdf, p_guide, α used]).
type AdamSample = (u64, [f32; 4]);

/// Work for one leaf: directional splats and Adam samples, in record order.
/// The Adam inputs are copied here rather than indexed: the leaves visit
/// the records in scattered order, and fetching whole records by index
/// cost more than the Adam steps themselves.
#[derive(Default)]
struct LeafWork {
    splats: Vec<(Vec2, f32)>,
    adam: Vec<AdamSample>,
}

/// The splats and Adam samples of `buffers`' records, per leaf, in record
/// order, with the counts of the guards.
fn leaf_work(tree: &SdTree, buffers: &[RecordBuffer]) -> (Vec<LeafWork>, RecordStats) {
    let mut stats = RecordStats::default();
    let mut work: Vec<LeafWork> = (0..tree.leaves().len())
        .map(|_| LeafWork::default())
        .collect();
    for r in buffers.iter().flat_map(|b| b.records.iter()) {
        match validate(r) {
            Err(RecordReject::NonFinite) => stats.rejected_non_finite += 1,
            Err(RecordReject::ZeroPdf) => stats.rejected_zero_pdf += 1,
            Err(RecordReject::Negative) => stats.rejected_negative += 1,
            Ok(()) => {
                stats.accepted += 1;
                let own = tree.lookup(r.position);
                let leaf = tree.leaf(own);
                let mut rng = Rng::new(r.seed, 0x5d7e);
                let jitter = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
                let target = tree.lookup(r.position + jitter * leaf.size);
                let dir = r.direction.normalize();
                work[target as usize]
                    .splats
                    .push((dir_to_square(dir), r.radiance));
                if r.guided {
                    work[own as usize]
                        .adam
                        .push((r.pass, [r.product, r.bsdf_pdf, r.guide_pdf, r.alpha]));
                }
            }
        }
    }
    (work, stats)
}

/// Records all buffers (in index order) into `tree`'s recording quadtrees
/// and steps the leaves' BSDF fractions. Buffers are left untouched so the
/// caller may reuse their allocations.
///
/// Both stages run in parallel and keep the record order: contiguous runs
/// of buffers are sorted into per-leaf work side by side, and each leaf
/// then takes its runs' work in run order. Sorting the records into leaves
/// on one thread had left the other core idle for a third of each
/// training call (staircase, 64 spp, two threads: 1.35 s of a 4.0 s call).
pub fn record_pass(tree: &mut SdTree, buffers: &[RecordBuffer]) -> RecordStats {
    // Two runs per thread balance the load; one thread needs one run.
    let threads = rayon::current_num_threads().max(1);
    let runs = if threads == 1 { 1 } else { 2 * threads };
    let run_len = buffers.len().div_ceil(runs).max(1);
    let parts: Vec<(Vec<LeafWork>, RecordStats)> = buffers
        .par_chunks(run_len)
        .map(|b| leaf_work(tree, b))
        .collect();
    let mut stats = RecordStats::default();
    // Each leaf's work from every run, in run order.
    let mut per_leaf: Vec<Vec<LeafWork>> = (0..tree.leaves().len())
        .map(|_| Vec::with_capacity(parts.len()))
        .collect();
    for (work, s) in parts {
        stats.merge(&s);
        for (leaf, w) in per_leaf.iter_mut().zip(work) {
            leaf.push(w);
        }
    }
    let adam_cfg = tree.config.adam;
    let leaf_adam: Vec<AdamStats> = tree
        .leaves_mut()
        .par_iter_mut()
        .zip(per_leaf.into_par_iter())
        .map(|(leaf, mut works)| {
            for w in &works {
                for &(p, v) in &w.splats {
                    // Validated above: the quadtree's own guard cannot fire.
                    let _ = leaf.recording.record_box(p, v);
                }
            }
            // A render call traces a pixel's passes one after the other;
            // Adam, which steps sample by sample, sees them pass by pass (a
            // stable sort: within a pass, in image order), as if the passes
            // had been traced one at a time. Consecutive steps on one
            // pixel's correlated samples had let the momentum drift
            // (staircase, 16 spp: +12 % variance).
            let mut adam = match works.len() {
                1 => std::mem::take(&mut works[0].adam),
                _ => works.iter().flat_map(|w| w.adam.iter().copied()).collect(),
            };
            adam.sort_by_key(|&(pass, _)| pass);
            let mut s = AdamStats::default();
            for (_, [product, bsdf_pdf, guide_pdf, alpha]) in adam {
                let _: Result<(), NonFiniteGradient> = leaf
                    .fraction
                    .step_sample(&adam_cfg, product, bsdf_pdf, guide_pdf, alpha, &mut s);
            }
            s
        })
        .collect();
    for s in &leaf_adam {
        stats.adam.merge(s);
    }
    stats
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A call's records stay within the budget: the measured records per
    /// pass (or the worst case before any) bound the passes, a pass too
    /// large for the budget still renders alone, and small images keep the
    /// full call.
    #[test]
    fn training_calls_keep_their_records_within_the_budget() {
        let bytes = |passes: u64, per_pass: f64| passes as f64 * per_pass * RECORD_BYTES as f64;
        // Staircase-like: 0.8 M records a pass.
        let n = passes_within_record_budget(16, Some(8e5), 230_400, 10);
        assert!(n < 16 && bytes(n, 8e5) <= RECORD_BUDGET_BYTES as f64, "{n}");
        assert!(
            bytes(n + 1, 8e5) > RECORD_BUDGET_BYTES as f64,
            "{n}: one more would fit"
        );
        // 4K at 4 records a path: over the budget in one pass, still 1.
        assert_eq!(
            passes_within_record_budget(16, Some(4.0 * 8.3e6), 8_294_400, 10),
            1
        );
        // Before any measurement: every pixel's path at the depth limit.
        let first = passes_within_record_budget(16, None, 230_400, 10);
        assert!(bytes(first, 2.304e6) <= RECORD_BUDGET_BYTES as f64 && first >= 1);
        // A small image, or no records: the full call.
        assert_eq!(passes_within_record_budget(16, Some(1e4), 10_000, 10), 16);
        assert_eq!(passes_within_record_budget(16, Some(0.0), 10_000, 10), 16);
    }
}
