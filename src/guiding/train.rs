//! Training and rendering with an SD-tree guide (Müller et al. 2017/2019):
//! iterations of 1, 2, 4, … passes that record and refine the guide, a final
//! iteration with the rest of the budget, and the inverse-variance
//! combination of the iterations' images.
//! A run whose strategy trial falls back to path tracing images path
//! tracing's passes alone (`super::fallback_image`).

use super::adam::AdamConfig;
use super::combine::{combine, combine_counting, iteration_variance, pooled_mean};
use super::fallback_image::FallbackImage;
use super::guide::{SdGuide, WeightModel};
use super::record::{
    RecordBuffer, RecordScratch, RecordStats, passes_within_record_budget, record_pass_reusing,
};
use super::schedule::{
    Budget as ScheduleBudget, IterationReport, Schedule, Step, TrainingEnd, TrainingStop,
};
use super::sdtree::{SdTree, SdTreeConfig};
use super::trial::{Rest, RunSoFar, Strategy, StrategyTrial, TRIAL_PASSES};
use crate::film::image::{Film, Image};
use crate::integrator::guide::NoGuide;
use crate::integrator::path::{PathSettings, RouletteMode};
use crate::integrator::render_passes;
use crate::integrator::stats::RenderCounters;
use crate::math::{Spectrum, luminance};
use crate::render::{Budget, PassPacer, RenderClock, RenderOptions, SnapshotPlan};
use crate::scene::Scene;
use serde::Serialize;

/// The strategy trial (`super::trial`) runs in this training iteration
/// (2^k spp, its length [`TRIAL_PASSES`]), after 7 spp of training, with a
/// guide learned from the 4 spp before it. Earlier, the guide has seen too
/// few paths to judge it. Later (iteration 4, sessions 15–16), a run that
/// falls back keeps more guided passes without NEE in its image: the
/// earlier trial lowered relMSE in 19 of 20 side-by-side runs and changed
/// no fallback decision (docs/results-reading.md, session 17).
const STRATEGY_CHECK_ITERATION: u32 = 3;
const _: () = assert!(1 << STRATEGY_CHECK_ITERATION == TRIAL_PASSES);

#[derive(Clone, Debug, Serialize)]
pub struct IterationSummary {
    pub iteration: u32,
    pub spp: u32,
    pub seconds: f64,
    pub training: bool,
    /// Mean variance of the iteration's pixel estimates (unclamped).
    pub mean_variance: f64,
    /// Passes of the iteration in the image: all, or after a fallback its
    /// path-tracing passes only.
    pub image_spp: u32,
    /// Weight of the iteration in the final combination.
    pub weight: f64,
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct GuidingStats {
    pub iterations: Vec<IterationSummary>,
    pub tree_leaves: usize,
    pub tree_spatial_nodes: usize,
    pub tree_quadtree_nodes: usize,
    pub tree_max_quadtree_depth: u32,
    pub tree_bytes: usize,
    pub records_accepted: u64,
    pub records_rejected_non_finite: u64,
    pub records_rejected_negative: u64,
    pub records_rejected_zero_pdf: u64,
    pub adam_steps: u64,
    pub adam_rejected: u64,
    /// λ of the BSDF fraction's L2 term (`--bsdf-fraction-l2`).
    pub adam_l2: f64,
    /// How the leaves learned their BSDF fraction (`--bsdf-fraction-learning`).
    pub bsdf_fraction_learning: super::adam::FractionLearning,
    /// The product's learned radiance shares (all zero when not learned).
    pub learned_shares: super::share_learning::LearnedShareSummary,
    /// Iterations left out of the final image because their variance was
    /// not finite (see [`combine_counting`]).
    pub iterations_dropped_nonfinite_variance: u64,
    /// The rule that ends training (`--training-stop`).
    pub training_stop: TrainingStop,
    /// Which rule ended it; `None` when the budget ran out while training.
    pub training_ended_by: Option<TrainingEnd>,
    /// Non-empty when guiding was dropped because it did not pay.
    pub fallback: String,
    /// Guided passes rendered before a fallback and left out of the image.
    pub left_out_spp: u32,
    /// Non-empty when path tracing measured more efficient than guiding but
    /// the guided work a fallback would discard outweighed its gain
    /// (`super::trial::GUIDING_KEPT`).
    pub fallback_declined: String,
    /// The measured comparison of the model's child weights with its
    /// cheaper alternative (product vs radiance weights), when one ran, or
    /// the report of a strategy trial the budget cut short.
    pub weights_check: String,
}

pub struct GuidedOutput {
    pub image: Image,
    pub variance: Vec<f64>,
    /// Per-pixel single-sample variance of the last iteration about its
    /// own mean (channel average, corrected by n/(n − 1)); empty below 4
    /// spp, where it says little.
    pub last_iteration_variance: Vec<f64>,
    pub spp: u32,
    pub counters: RenderCounters,
    pub stats: GuidingStats,
    pub tree: SdTree,
}

/// The films the image combines: every iteration's (with the current one,
/// when given), or after a fallback the one film of path tracing's passes.
fn image_films<'a>(
    films: &'a [Film],
    current: Option<&'a Film>,
    fallback_image: &'a Option<FallbackImage>,
) -> Vec<&'a Film> {
    match fallback_image {
        Some(image) => vec![image.film()],
        None => films.iter().chain(current).collect(),
    }
}

/// Renders with an SD-tree guide whose child weights come from `model`.
pub fn render_guided<M: WeightModel>(
    scene: &Scene,
    opts: &RenderOptions,
    model: &M,
    clock: &mut RenderClock,
    snapshots: &mut SnapshotPlan,
    bar: Option<&indicatif::ProgressBar>,
) -> GuidedOutput {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let config = SdTreeConfig {
        split_threshold: opts
            .spatial_threshold
            .unwrap_or_else(|| super::sdtree::default_split_threshold(w * h)),
        adam: AdamConfig {
            l2: opts.bsdf_fraction_l2.unwrap_or(AdamConfig::default().l2),
            learning: opts.bsdf_fraction_learning,
            ..AdamConfig::default()
        },
        learned_radiance_share: opts
            .radiance_share
            .learned_start()
            .filter(|_| model.radiance_share() > 0.0),
        share_learning: opts.radiance_share.learning,
        ..SdTreeConfig::default()
    };
    let mut tree = SdTree::new(scene.bounds.0, scene.bounds.1, config);
    let mut schedule = Schedule::with_stop(
        match opts.budget {
            Budget::Spp(n) => ScheduleBudget::Spp(n as u64),
            Budget::Seconds(s) => ScheduleBudget::Seconds(s),
        },
        opts.training_stop,
    );
    let mut training_ended_by = None;
    let mut films: Vec<Film> = Vec::new();
    // The last film's per-pixel spread about its own mean (empty below 4
    // spp), kept from its `mean_variance` for `last_iteration_variance`.
    let mut last_pixel_variance: Vec<f64> = Vec::new();
    let mut summaries: Vec<IterationSummary> = Vec::new();
    let mut counters = RenderCounters::default();
    let mut records = RecordStats::default();
    // Records a training pass produced in the last training call.
    let mut records_per_pass: Option<f64> = None;
    // The training calls' record buffers, one per row block, kept from call
    // to call so that their memory is reused (`render_passes_into`).
    let mut record_buffers: Vec<RecordBuffer> = Vec::new();
    let mut record_scratch = RecordScratch::default();
    let mut pass = 0u64;
    // Set when the strategy trial measured path tracing more efficient.
    let mut fallback = String::new();
    // The cheaper child weights, when the plan may fall back to them.
    let cheaper = if opts.use_plan && opts.bsdf_fraction.is_none() {
        model.cheaper()
    } else {
        None
    };
    let cheaper_name = cheaper.as_ref().map(|c| c.name());
    // What renders outside the trial: the model's weights until the trial
    // decides otherwise.
    let mut chosen = Strategy::Model;
    let mut weights_check = String::new();
    let mut fallback_declined = String::new();
    // With the plan, one trial measures the strategies against each other
    // (`super::trial`).
    let mut trial: Option<StrategyTrial> = None;
    let mut strategy_decided = !opts.use_plan;
    let mut fallback_image: Option<FallbackImage> = None;
    // Kept across iterations: the final iteration's first call then knows
    // the pace, so a deadline bounds it (and the trial's calls).
    let mut pacer = PassPacer::default();
    let total_spp =
        |films: &[Film], current: &Film| films.iter().map(|f| f.spp).sum::<u32>() + current.spp;

    loop {
        let (step, end) = schedule.next_with_reason();
        training_ended_by = training_ended_by.or(end);
        let t0 = clock.seconds();
        let (iteration, training, target) = match step {
            Step::Done => break,
            Step::Train { iteration, spp } => (iteration, true, Budget::Spp(spp as u32)),
            Step::Final {
                iteration,
                remaining,
            } => (
                iteration,
                false,
                match remaining {
                    ScheduleBudget::Spp(n) => Budget::Spp(n as u32),
                    // The schedule's remaining seconds end at the total budget.
                    ScheduleBudget::Seconds(s) => Budget::Seconds(t0 + s),
                },
            ),
        };
        // ADRRS's pixel estimates: the combination of the finished iterations.
        let pixel_estimates: Option<Vec<f32>> = if opts.path.roulette == RouletteMode::Adrrs {
            let refs: Vec<&Film> = films.iter().collect();
            combine(&refs).map(|(img, _, _)| img.pixels.iter().map(|p| luminance(*p)).collect())
        } else {
            None
        };
        let mut film = Film::new(w, h);
        // The trial runs once: in the check iteration, or at the start of
        // the final one when training ended before it.
        // (A final iteration of a sample budget no longer than the trial
        // leaves nothing to decide for.)
        let check_here = match target {
            _ if training => iteration == STRATEGY_CHECK_ITERATION,
            Budget::Spp(n) => n > TRIAL_PASSES,
            Budget::Seconds(_) => true,
        };
        if !strategy_decided && trial.is_none() && check_here {
            trial = Some(StrategyTrial::new(w, h, cheaper.is_some()));
        }
        loop {
            match target {
                Budget::Spp(n) if film.spp >= n => break,
                Budget::Seconds(end)
                    if film.spp > 0 && pacer.deadline_reached(clock.seconds(), end) =>
                {
                    break;
                }
                _ => {}
            }
            let call_start = clock.seconds();
            let (passes_left, deadline) = match target {
                Budget::Spp(n) => (Some((n - film.spp) as u64), None),
                Budget::Seconds(end) => (None, Some(end)),
            };
            let (strategy, n) = match &trial {
                Some(t) => {
                    let (strategy, n) = t.next_call();
                    // A deadline bounds trial calls too: at four passes each
                    // they overran a slow scene's budget by seconds.
                    let n = pacer.bound_by_deadline(n as u64, call_start, deadline);
                    (strategy, passes_left.map_or(n, |left| n.min(left)))
                }
                None => (
                    chosen,
                    pacer.next_call(call_start, passes_left, deadline, snapshots),
                ),
            };
            let n = if training {
                // A path records at most one vertex per segment; without a
                // depth limit the first call assumes 64, and later calls
                // use the measured rate.
                let max_records = opts.path.max_depth.unwrap_or(u32::MAX).min(64);
                passes_within_record_budget(n, records_per_pass, w * h, max_records)
            } else {
                n
            };
            let passes = pass..pass + n;
            // Each call's film and render time: recording the guided
            // calls' paths into the tree comes after, as it would cost any
            // guided strategy alike, and a fallback's rendering has none.
            let (call_film, render_seconds) = if strategy != Strategy::Unguided {
                let active = match (&cheaper, strategy) {
                    (Some(c), Strategy::Cheaper) => c,
                    _ => model,
                };
                let guide = SdGuide {
                    tree: &tree,
                    model: active,
                    learning: training,
                    fixed_alpha: opts.bsdf_fraction,
                };
                if !training {
                    // No more records: the buffers' memory goes back.
                    record_buffers = Vec::new();
                    record_scratch = RecordScratch::default();
                }
                let out = clock.parallel(|| {
                    render_passes(
                        scene,
                        &guide,
                        &opts.path,
                        opts.seed,
                        passes,
                        pixel_estimates.as_deref(),
                        &mut record_buffers,
                    )
                });
                let render_seconds = clock.seconds() - call_start;
                counters.add(&out.counters);
                if training {
                    let call_records =
                        record_pass_reusing(&mut tree, &record_buffers, &mut record_scratch);
                    records_per_pass = Some(call_records.total() as f64 / n as f64);
                    records.merge(&call_records);
                }
                (out.film, render_seconds)
            } else {
                // The fallback is plain path tracing at its best: with NEE
                // and classic roulette.
                let unguided = PathSettings {
                    nee: true,
                    roulette: RouletteMode::Classic,
                    adrrs_window: crate::guiding::adrrs::PAPER_WINDOW,
                    ..opts.path
                };
                let out = clock.parallel(|| {
                    render_passes(
                        scene,
                        &NoGuide,
                        &unguided,
                        opts.seed,
                        passes,
                        None,
                        &mut Vec::new(),
                    )
                });
                counters.add(&out.counters);
                (out.film, clock.seconds() - call_start)
            };
            film.merge(&call_film);
            if let Some(image) = fallback_image.as_mut() {
                image.add(&call_film);
            }
            if let Some(t) = trial.as_mut() {
                t.record(&call_film, render_seconds);
                let now = clock.seconds();
                let run = RunSoFar {
                    films: &films,
                    seconds: now,
                    rest: match opts.budget {
                        Budget::Seconds(total) => Rest::Seconds((total - now).max(0.0)),
                        Budget::Spp(total) => Rest::Passes((total as u64).saturating_sub(pass + n)),
                    },
                };
                if let Some(d) = t.decision(&run, model.name(), cheaper_name) {
                    if d.strategy == Strategy::Unguided {
                        fallback_image = Some(FallbackImage::new(t.unguided_film(), films.len()));
                    }
                    chosen = d.strategy;
                    weights_check = d.weights_note;
                    fallback = d.fallback_note;
                    fallback_declined = d.declined_note;
                    strategy_decided = true;
                    trial = None;
                }
            }
            pass += n;
            let now = clock.seconds();
            pacer.called(n, now - call_start);
            if snapshots.due(now) {
                clock.excluding(|| {
                    let all = image_films(&films, Some(&film), &fallback_image);
                    // The image's passes, as the final `spp` counts them.
                    let spp = all.iter().map(|f| f.spp).sum();
                    if let Some((image, _, _)) = combine(&all) {
                        snapshots.take(now, spp, image);
                    }
                });
            }
            if let Some(b) = bar {
                match opts.budget {
                    Budget::Seconds(_) => b.set_position((clock.seconds() * 1000.0) as u64),
                    Budget::Spp(_) => b.set_position(total_spp(&films, &film) as u64),
                }
            }
        }
        if training {
            tree.refine(iteration);
        }
        // For the schedule's stopping rule: an iteration's own spread. Below
        // 4 spp it says little (most pixels of a hard scene saw no light at
        // all), so it is reported as unknown and the rule waits. About the
        // film's own mean, Σ(x − x̄)²/n is low by (n − 1)/n; corrected, so
        // that iterations of different lengths compare without bias.
        let mean_variance = if film.spp >= 4 {
            let n = film.spp as f64;
            let (mean, per_pixel) = iteration_variance(&film, &pooled_mean(&[&film]));
            last_pixel_variance = per_pixel;
            mean * n / (n - 1.0)
        } else {
            last_pixel_variance.clear();
            f64::INFINITY
        };
        let seconds = clock.seconds() - t0;
        schedule.report(
            step,
            IterationReport {
                spp: film.spp as u64,
                seconds,
                mean_variance,
            },
        );
        summaries.push(IterationSummary {
            iteration,
            spp: film.spp,
            seconds,
            training,
            mean_variance,
            image_spp: film.spp,
            weight: 0.0,
        });
        films.push(film);
    }

    if let Some(t) = trial {
        weights_check = t.unfinished_note(model.name(), cheaper_name);
    }
    let refs = image_films(&films, None, &fallback_image);
    let mut iterations_dropped = 0;
    let combined = combine_counting(&refs, &mut iterations_dropped);
    let (image, variance, weights) = combined.unwrap_or_else(|| {
        (
            Image {
                width: w,
                height: h,
                pixels: vec![Spectrum::ZERO; w * h],
            },
            vec![0.0; w * h],
            Vec::new(),
        )
    });
    let left_out_spp = match &fallback_image {
        Some(f) => f.account(&mut summaries, &films),
        None => {
            for (s, wgt) in summaries.iter_mut().zip(&weights) {
                s.weight = *wgt;
            }
            0
        }
    };
    let ts = tree.stats();
    let stats = GuidingStats {
        iterations: summaries,
        tree_leaves: ts.leaves,
        tree_spatial_nodes: ts.spatial_nodes,
        tree_quadtree_nodes: ts.quadtree_nodes,
        tree_max_quadtree_depth: ts.max_quadtree_depth,
        tree_bytes: ts.bytes,
        records_accepted: records.accepted,
        records_rejected_non_finite: records.rejected_non_finite,
        records_rejected_negative: records.rejected_negative,
        records_rejected_zero_pdf: records.rejected_zero_pdf,
        adam_steps: records.adam.steps,
        adam_rejected: records.adam.rejected_non_finite,
        adam_l2: tree.config.adam.l2,
        bsdf_fraction_learning: tree.config.adam.learning,
        learned_shares: if tree.config.learned_radiance_share.is_some() {
            super::share_learning::LearnedShareSummary::of(
                tree.leaves().iter().map(|l| &l.share),
                records.share,
            )
        } else {
            Default::default()
        },
        iterations_dropped_nonfinite_variance: iterations_dropped,
        training_stop: opts.training_stop,
        training_ended_by,
        fallback,
        left_out_spp,
        fallback_declined,
        weights_check,
    };
    // The same (n − 1)/n correction as the last iteration's mean_variance.
    let last_iteration_variance = match films.last() {
        Some(f) if !last_pixel_variance.is_empty() => {
            let n = f.spp as f64;
            last_pixel_variance
                .into_iter()
                .map(|v| v * n / (n - 1.0))
                .collect()
        }
        _ => Vec::new(),
    };
    GuidedOutput {
        image,
        variance,
        last_iteration_variance,
        spp: refs.iter().map(|f| f.spp).sum(),
        counters,
        stats,
        tree,
    }
}
