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
//! - the Adam steps of the BSDF fraction (and of the radiance share, where
//!   it is learned) are taken in the leaf that actually produced the
//!   sample (no jitter: α and β belong to the vertex's leaf).
//!
//! Guards (each rejected record counted exactly once, in this order):
//! non-finite field or zero direction → `rejected_non_finite`; throughput·p_mix ≤
//! [`ZERO_PDF_EPSILON`] → `rejected_zero_pdf`; negative radiance or product →
//! `rejected_negative`.

use super::adam::{AdamStats, FractionLearning, NonFiniteGradient};
use super::sdtree::SdTree;
use super::share_learning::{ShareLearning, ShareSample};
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
    /// Where the guide mixed its product with a learned radiance share:
    /// the radiance descent's pdf of ω_i (else 0).
    pub radiance_pdf: f32,
    /// The learned radiance share β the guide's mixture used (0: none to
    /// learn, `super::share_learning`).
    pub radiance_share: f32,
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
    /// The same for the learned radiance share's steps.
    pub share: AdamStats,
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
        self.share.merge(&o.share);
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
        && r.radiance_pdf.is_finite()
        && r.radiance_share.is_finite()
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
/// thread's buffer, then its leaves, its splat and its Adam sample in
/// [`record_pass`]'s per-run work.
pub const RECORD_BYTES: u64 = (size_of::<Record>()
    + size_of::<RecordLeaves>()
    + size_of::<(Vec2, f32)>()
    + size_of::<AdamSample>()) as u64;

/// Memory the path records of one training call may fill (the buffers'
/// capacity, grown by doubling, may reach twice that). A call renders up
/// to 16 passes and holds all their records until it ends: 128 bytes per
/// recorded vertex (staircase at 360×640: 102 MB a pass; 116 bytes before
/// the records carried the learned radiance share's inputs), so at 1920×1080 a
/// 16-pass call would have held some 13 GB, and more than the machine has
/// at 4K. Training calls are cut to the passes that fit. Every record is
/// still recorded; between the extra calls Adam's BSDF fractions move on,
/// as they do between the calls a time budget cuts.
///
/// Measured on staircase, radiance guiding: at 64 spp with two threads,
/// 1 GiB instead of no budget took peak memory from 1.84 to 1.41 GB, time
/// unchanged (18.8 and 18.2 s). At 128 spp with one thread (two builds side
/// by side), 256 MiB instead of 1 GiB took it from 1.50 to 0.83 GB, the
/// page faults from 346 k to 180 k, and the run from 95.9 to 93.7 s, at
/// the same error (relMSE 0.0473 and 0.0489, final-iteration variance
/// 0.01467 and 0.01458).
pub const RECORD_BUDGET_BYTES: u64 = 1 << 28;

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

/// One Adam sample: (pass, [F/p, p_bsdf, p_guide, α used, p_radiance,
/// β used]). A u32 pass (a render of 4·10⁹ passes is out of reach) keeps
/// it at 28 bytes.
type AdamSample = (u32, [f32; 6]);

/// A record's leaves: where its jittered splat lands ([`NO_LEAF`] when the
/// guards refused it), and the leaf whose BSDF fraction it steps
/// ([`NO_LEAF`] when it was not guided).
type RecordLeaves = (u32, u32);
const NO_LEAF: u32 = u32::MAX;

/// The memory [`record_pass_reusing`] keeps from one training call to the
/// next. Each run of buffers sorts its records' splats and Adam samples by
/// leaf into flat arrays (a stable counting sort), whose capacity stays.
/// Per-leaf lists allocated anew for every call took 43 % of a training
/// run's page faults (staircase, radiance guiding, 128 spp, one thread:
/// `perf record -e page-faults`), and the faults, 2.5 % of its time.
#[derive(Default)]
pub struct RecordScratch {
    runs: Vec<RunWork>,
}

/// One run's splats and Adam samples, grouped by leaf in record order:
/// leaf i's are `splats[splat_start[i]..splat_start[i + 1]]`, and likewise
/// for Adam. The Adam inputs are copied rather than indexed: the leaves
/// visit the records in scattered order, and fetching whole records by
/// index cost more than the Adam steps themselves.
#[derive(Default)]
struct RunWork {
    leaves: Vec<RecordLeaves>,
    splat_start: Vec<usize>,
    adam_start: Vec<usize>,
    splats: Vec<(Vec2, f32)>,
    adam: Vec<AdamSample>,
    stats: RecordStats,
}

impl RunWork {
    fn splats(&self, leaf: usize) -> &[(Vec2, f32)] {
        &self.splats[self.splat_start[leaf]..self.splat_start[leaf + 1]]
    }

    fn adam(&self, leaf: usize) -> &[AdamSample] {
        &self.adam[self.adam_start[leaf]..self.adam_start[leaf + 1]]
    }

    /// Sorts `buffers`' accepted records by leaf, counting the guards.
    /// The first sweep finds every record's leaves (two tree lookups and a
    /// jitter), the second places its splat and Adam sample.
    fn fill(&mut self, tree: &SdTree, buffers: &[RecordBuffer]) {
        let n_leaves = tree.leaves().len();
        self.stats = RecordStats::default();
        self.leaves.clear();
        self.splat_start.clear();
        self.splat_start.resize(n_leaves + 1, 0);
        self.adam_start.clear();
        self.adam_start.resize(n_leaves + 1, 0);
        let records = || buffers.iter().flat_map(|b| b.records.iter());
        for r in records() {
            let rejected = |count: &mut u64| {
                *count += 1;
                (NO_LEAF, NO_LEAF)
            };
            let leaves = match validate(r) {
                Err(RecordReject::NonFinite) => rejected(&mut self.stats.rejected_non_finite),
                Err(RecordReject::ZeroPdf) => rejected(&mut self.stats.rejected_zero_pdf),
                Err(RecordReject::Negative) => rejected(&mut self.stats.rejected_negative),
                Ok(()) => {
                    self.stats.accepted += 1;
                    let own = tree.lookup(r.position);
                    let leaf = tree.leaf(own);
                    let mut rng = Rng::new(r.seed, 0x5d7e);
                    let jitter = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
                    let target = tree.lookup(r.position + jitter * leaf.size);
                    self.splat_start[target as usize + 1] += 1;
                    let adam_leaf = if r.guided {
                        self.adam_start[own as usize + 1] += 1;
                        own
                    } else {
                        NO_LEAF
                    };
                    (target, adam_leaf)
                }
            };
            self.leaves.push(leaves);
        }
        for i in 0..n_leaves {
            self.splat_start[i + 1] += self.splat_start[i];
            self.adam_start[i + 1] += self.adam_start[i];
        }
        // Every slot below is written once: the offsets count them.
        self.splats.clear();
        self.splats
            .resize(self.splat_start[n_leaves], (Vec2::ZERO, 0.0));
        self.adam.clear();
        self.adam.resize(self.adam_start[n_leaves], (0, [0.0; 6]));
        let mut next_splat = self.splat_start.clone();
        let mut next_adam = self.adam_start.clone();
        for (r, &(target, adam_leaf)) in records().zip(&self.leaves) {
            if target == NO_LEAF {
                continue;
            }
            let slot = &mut next_splat[target as usize];
            self.splats[*slot] = (dir_to_square(r.direction.normalize()), r.radiance);
            *slot += 1;
            if adam_leaf != NO_LEAF {
                let slot = &mut next_adam[adam_leaf as usize];
                self.adam[*slot] = (
                    u32::try_from(r.pass).unwrap_or(u32::MAX),
                    [
                        r.product,
                        r.bsdf_pdf,
                        r.guide_pdf,
                        r.alpha,
                        r.radiance_pdf,
                        r.radiance_share,
                    ],
                );
                *slot += 1;
            }
        }
    }
}

/// Leaves per parallel job of the record pass and the trees' rebuild.
pub const LEAVES_PER_JOB: usize = 8;

/// Records all buffers (in index order) into `tree`'s recording quadtrees
/// and steps the leaves' BSDF fractions, with memory of its own; see
/// [`record_pass_reusing`].
pub fn record_pass(tree: &mut SdTree, buffers: &[RecordBuffer]) -> RecordStats {
    record_pass_reusing(tree, buffers, &mut RecordScratch::default())
}

/// Records all buffers (in index order) into `tree`'s recording quadtrees
/// and steps the leaves' BSDF fractions, sorting the records in `scratch`,
/// whose memory a training run keeps across its calls. Buffers are left
/// untouched so the caller may reuse their allocations.
///
/// Both stages run in parallel and keep the record order: contiguous runs
/// of buffers are sorted into leaves side by side, and each leaf then takes
/// its runs' work in run order. Sorting the records into leaves on one
/// thread had left the other core idle for a third of each training call
/// (staircase, 64 spp, two threads: 1.35 s of a 4.0 s call).
pub fn record_pass_reusing(
    tree: &mut SdTree,
    buffers: &[RecordBuffer],
    scratch: &mut RecordScratch,
) -> RecordStats {
    // Two runs per thread balance the load; one thread needs one run.
    let threads = rayon::current_num_threads().max(1);
    let runs = if threads == 1 { 1 } else { 2 * threads };
    let run_len = buffers.len().div_ceil(runs).max(1);
    let chunks = buffers.len().div_ceil(run_len);
    scratch.runs.resize_with(chunks, RunWork::default);
    let work = &mut scratch.runs[..chunks];
    let shared_tree: &SdTree = tree;
    work.par_iter_mut()
        .zip(buffers.par_chunks(run_len))
        .for_each(|(run, b)| run.fill(shared_tree, b));
    let mut stats = RecordStats::default();
    for run in work.iter() {
        stats.merge(&run.stats);
    }
    let work = &*work;
    let adam_cfg = tree.config.adam;
    let share_learning = tree.config.share_learning;
    let leaf_adam: Vec<(AdamStats, AdamStats)> = tree
        .leaves_mut()
        .par_iter_mut()
        .enumerate()
        // Leaves differ in their records by orders of magnitude; small jobs
        // let an idle thread take over what another's run has left.
        .with_max_len(LEAVES_PER_JOB)
        .map_init(Vec::new, |steps, (i, leaf)| {
            for run in work {
                for &(p, v) in run.splats(i) {
                    // Validated above: the quadtree's own guard cannot fire.
                    let _ = leaf.recording.record_box(p, v);
                }
            }
            // A render call traces a pixel's passes one after the other;
            // Adam, which steps sample by sample, sees them pass by pass
            // (within a pass, in image order), as if the passes had been
            // traced one at a time. Consecutive steps on one pixel's
            // correlated samples had let the momentum drift (staircase,
            // 16 spp: +12 % variance). The record index makes the order
            // total, so the unstable sort, which needs no buffer, keeps it.
            steps.clear();
            let in_record_order = work.iter().flat_map(|run| run.adam(i));
            steps.extend(
                in_record_order
                    .enumerate()
                    .map(|(k, &(pass, sample))| (pass, k, sample)),
            );
            steps.sort_unstable_by_key(|&(pass, k, _)| (pass, k));
            let (mut s, mut share_stats) = (AdamStats::default(), AdamStats::default());
            for &(
                _,
                _,
                [
                    product,
                    bsdf_pdf,
                    guide_pdf,
                    alpha,
                    radiance_pdf,
                    share_used,
                ],
            ) in steps.iter()
            {
                // α learns at the guide's mixture at the current share
                // (the one used, unless the share is learned), so that α
                // and β follow one loss at one point.
                let sample = ShareSample {
                    product,
                    bsdf_pdf,
                    guide_pdf,
                    radiance_pdf,
                    share_used,
                    alpha_used: alpha,
                };
                let learns_share = share_used != 0.0;
                let alpha_now = leaf.fraction.alpha(&adam_cfg);
                let guide_pdf_now = if learns_share {
                    sample.guide_pdf_at(leaf.share.share()) as f32
                } else {
                    guide_pdf
                };
                let _: Result<(), NonFiniteGradient> = match adam_cfg.learning {
                    FractionLearning::Kl => leaf.fraction.step_sample(
                        &adam_cfg,
                        product,
                        bsdf_pdf,
                        guide_pdf_now,
                        alpha,
                        &mut s,
                    ),
                    FractionLearning::VarianceGrid => leaf.fraction.add_to_grid(
                        product,
                        bsdf_pdf,
                        guide_pdf,
                        guide_pdf_now,
                        alpha,
                        &mut s,
                    ),
                };
                if !learns_share {
                    continue;
                }
                let _: Result<(), NonFiniteGradient> = match share_learning {
                    ShareLearning::VarianceGrid => {
                        leaf.share.add_to_grid(&sample, alpha_now, &mut share_stats)
                    }
                    _ => leaf.share.step_sample(
                        &adam_cfg,
                        share_learning,
                        &sample,
                        alpha_now,
                        leaf.fraction.product_mean(),
                        &mut share_stats,
                    ),
                };
            }
            if adam_cfg.learning == FractionLearning::VarianceGrid && s.steps > 0 {
                leaf.fraction.choose_from_grid();
            }
            if share_learning == ShareLearning::VarianceGrid && share_stats.steps > 0 {
                leaf.share.choose_from_grid();
            }
            (s, share_stats)
        })
        .collect();
    for (s, share) in &leaf_adam {
        stats.adam.merge(s);
        stats.share.merge(share);
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
        // What RECORD_BUDGET_BYTES's docs state.
        assert_eq!(RECORD_BYTES, 128);
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
        let first = passes_within_record_budget(16, None, 160_000, 10);
        assert!(bytes(first, 1.6e6) <= RECORD_BUDGET_BYTES as f64 && first >= 1);
        assert!(bytes(first + 1, 1.6e6) > RECORD_BUDGET_BYTES as f64);
        // A small image, or no records: the full call.
        assert_eq!(passes_within_record_budget(16, Some(1e4), 10_000, 10), 16);
        assert_eq!(passes_within_record_budget(16, Some(0.0), 10_000, 10), 16);
    }
}
