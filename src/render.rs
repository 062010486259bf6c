//! Whole renders: a budget in samples per pixel or seconds, a method, and
//! the statistics every run reports.

use crate::film::image::{Film, Image};
use crate::guiding::guide::RadianceModel;
use crate::guiding::product::{CosineLobes, ProductModel};
use crate::guiding::sdtree::SdTree;
use crate::guiding::train::{GuidingStats, render_guided};
use crate::ltc::{LtcTable, ProductKernel};
use std::sync::OnceLock;

/// The committed LTC table, decoded once.
pub fn default_ltc_table() -> Result<&'static LtcTable, String> {
    static TABLE: OnceLock<Result<LtcTable, String>> = OnceLock::new();
    TABLE
        .get_or_init(LtcTable::load_default)
        .as_ref()
        .map_err(|e| e.clone())
}
use crate::integrator::guide::NoGuide;
use crate::integrator::path::PathSettings;
use crate::integrator::stats::RenderCounters;
use crate::integrator::{render_passes_into, thread_pool};
use crate::scene::Scene;
use serde::Serialize;
use std::time::Instant;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    Spp(u32),
    Seconds(f64),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Unguided path tracing.
    Pt,
    /// Practical path guiding: SD-tree, radiance-proportional descent.
    Radiance,
    /// Product guiding: descent proportional to radiance × LTC-integrated BSDF.
    Product,
}

/// A wall clock that can leave out time spent on bookkeeping (snapshots), so
/// taking snapshots does not change what a run's timings mean.
#[derive(Clone, Debug)]
pub struct RenderClock {
    start: Instant,
    excluded: f64,
}

impl RenderClock {
    pub fn start() -> Self {
        RenderClock {
            start: Instant::now(),
            excluded: 0.0,
        }
    }

    /// Seconds of rendering so far.
    pub fn seconds(&self) -> f64 {
        self.start.elapsed().as_secs_f64() - self.excluded
    }

    /// Runs `f` without charging its time to the render.
    pub fn excluding<T>(&mut self, f: impl FnOnce() -> T) -> T {
        let t0 = Instant::now();
        let out = f();
        self.excluded += t0.elapsed().as_secs_f64();
        out
    }
}

/// The estimate a method would return if stopped at `seconds`.
#[derive(Clone, Debug)]
pub struct Snapshot {
    pub seconds: f64,
    pub spp: u32,
    pub image: Image,
}

/// Takes snapshots at the given render times (seconds, ascending).
#[derive(Clone, Debug, Default)]
pub struct SnapshotPlan {
    pub times: Vec<f64>,
    next: usize,
    pub taken: Vec<Snapshot>,
}

impl SnapshotPlan {
    /// Roughly geometric time points from `first` to `last`, `per_doubling` per doubling.
    pub fn geometric(first: f64, last: f64, per_doubling: u32) -> Self {
        let mut times = Vec::new();
        let ratio = 2f64.powf(1.0 / per_doubling.max(1) as f64);
        let mut t = first.max(1e-3);
        while t < last {
            times.push(t);
            t *= ratio;
        }
        SnapshotPlan {
            times,
            next: 0,
            taken: Vec::new(),
        }
    }

    /// The next snapshot's time, if any is left.
    pub fn next_time(&self) -> Option<f64> {
        self.times.get(self.next).copied()
    }

    /// True when the clock has passed the next snapshot time.
    pub fn due(&self, seconds: f64) -> bool {
        self.next < self.times.len() && seconds >= self.times[self.next]
    }

    /// Records an estimate (taken outside the render clock by the caller).
    pub fn take(&mut self, seconds: f64, spp: u32, image: Image) {
        while self.due(seconds) {
            self.next += 1;
        }
        self.taken.push(Snapshot {
            seconds,
            spp,
            image,
        });
    }
}

/// Most passes one pixel-major call renders (so the progress bar moves).
const MAX_PASSES_PER_CALL: u64 = 16;

/// Chooses how many passes each call of `render_passes_into` renders.
///
/// A call traces each pixel's paths one after the other: their first hits
/// stay in cache, and product guiding reuses a first product lobe across a
/// pixel's paths and its neighbours' (`guiding::pixel_reuse`). But the
/// clock is read only between calls, so:
/// - a sample budget renders what is left of it;
/// - a deadline or a snapshot some seconds away takes about half of that
///   time, judged by the last call's seconds per pass, so the calls shrink
///   towards it; before any call has been timed, one pass;
/// - a timed run ends when less than half a pass is left before its
///   deadline ([`deadline_reached`](Self::deadline_reached)), so it ends
///   within half a pass of it on either side. Ending at the first pass past
///   the deadline gave a slow method up to a whole pass (9 % of a 30 s
///   living-room run) more than its budget in an equal-time comparison.
#[derive(Default)]
pub struct PassPacer {
    seconds_per_pass: Option<f64>,
}

impl PassPacer {
    /// Whether a timed run should end at `now`: its deadline has passed,
    /// or less than half a pass (at the last call's pace) is left before it.
    pub fn deadline_reached(&self, now: f64, deadline: f64) -> bool {
        now >= deadline
            || self
                .seconds_per_pass
                .is_some_and(|s| deadline - now < 0.5 * s)
    }

    /// At most `n` passes, fewer where the deadline comes within `n` passes
    /// at the known pace: about half the time left, at least one pass.
    /// Unlike [`next_call`](Self::next_call) it ignores snapshots (a late
    /// snapshot is taken at its real time) and keeps `n` while no pace is
    /// known, for calls whose size matters (the strategy trial).
    pub fn bound_by_deadline(&self, n: u64, now: f64, deadline: Option<f64>) -> u64 {
        match (deadline, self.seconds_per_pass) {
            (Some(end), Some(s)) if s > 0.0 => half_of(n, end - now, s),
            _ => n,
        }
    }

    /// Passes for a call starting at `now`, with `passes_left` of a sample
    /// budget or a `deadline`, and the snapshots still to take.
    pub fn next_call(
        &self,
        now: f64,
        passes_left: Option<u64>,
        deadline: Option<f64>,
        snapshots: &SnapshotPlan,
    ) -> u64 {
        let mut n = MAX_PASSES_PER_CALL;
        if let Some(p) = passes_left {
            n = n.min(p);
        }
        let next = [deadline, snapshots.next_time()].into_iter().flatten();
        if let Some(t) = next.map(|t| t - now).reduce(f64::min) {
            n = match self.seconds_per_pass {
                Some(s) if s > 0.0 && t.is_finite() => half_of(n, t, s),
                _ => 1,
            };
        }
        n.max(1)
    }

    /// Records that a call rendered `passes` in `seconds`.
    pub fn called(&mut self, passes: u64, seconds: f64) {
        self.seconds_per_pass = Some(seconds / passes as f64);
    }
}

/// At most `n` passes, and no more than fit in half of `seconds_left` at
/// `seconds_per_pass` (at least one).
fn half_of(n: u64, seconds_left: f64, seconds_per_pass: f64) -> u64 {
    n.min((0.5 * seconds_left / seconds_per_pass).max(0.0) as u64)
        .max(1)
}

#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub method: Method,
    pub budget: Budget,
    pub seed: u64,
    /// 0 = all cores.
    pub threads: usize,
    pub path: PathSettings,
    pub progress: bool,
    /// Snapshot times for error-versus-time curves (empty: none).
    pub snapshot_times: Vec<f64>,
    /// Guided methods: a fixed BSDF-sampling fraction instead of the learned one.
    pub bsdf_fraction: Option<f32>,
    /// Product guiding: which child-integral implementation.
    pub product_kernel: ProductKernel,
    /// Product guiding: the weights of vertices whose lobes are all cosines.
    pub cosine_lobes: CosineLobes,
    /// Product guiding: the first this many vertices of a path take product
    /// weights (0: every vertex).
    pub product_vertices: u32,
    /// Product guiding: the paths of a pixel and its neighbours reuse a
    /// first vertex's product lobe while it matches
    /// (`guiding::pixel_reuse`); off: the paper's lobe per vertex.
    pub pixel_reuse: bool,
    /// Follow the per-scene plan (and drop guiding where it does not pay).
    /// Off for measuring what the plan saves, and for comparing the guided
    /// methods as such.
    pub use_plan: bool,
    /// Guided methods: c in the SD-tree's spatial split threshold c·√(2^k);
    /// `None`: scaled to the image size, see
    /// [`crate::guiding::sdtree::default_split_threshold`].
    pub spatial_threshold: Option<f64>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            method: Method::Pt,
            budget: Budget::Spp(16),
            seed: 0,
            threads: 0,
            path: PathSettings {
                nee: true,
                max_depth: Some(10),
                roulette: crate::integrator::path::RouletteMode::Classic,
                adrrs_window: crate::guiding::adrrs::PAPER_WINDOW,
            },
            progress: false,
            snapshot_times: Vec::new(),
            bsdf_fraction: None,
            product_kernel: ProductKernel::default(),
            cosine_lobes: CosineLobes::default(),
            product_vertices: crate::guiding::product::DEFAULT_PRODUCT_VERTICES,
            pixel_reuse: true,
            use_plan: true,
            spatial_threshold: None,
        }
    }
}

#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq, Eq)]
pub struct Guards {
    /// Path contributions that were NaN/Inf/negative (replaced by zero).
    pub image_nonfinite_samples: u64,
    /// BSDF or guide samples with unusable pdf or weight (path ended).
    pub invalid_scattering: u64,
    /// Learning records rejected before they could reach the SD-tree.
    pub tree_records_non_finite: u64,
    pub tree_records_negative: u64,
    pub tree_records_zero_pdf: u64,
    /// Adam steps rejected (non-finite gradient, vanishing mixture pdf).
    pub optimizer_rejected: u64,
    /// ADRRS decisions without usable estimates (no roulette played).
    pub adrrs_invalid_estimate: u64,
    /// Non-finite LTC inputs or outputs zeroed.
    pub ltc_nonfinite: u64,
}

impl Guards {
    pub fn total(&self) -> u64 {
        self.image_nonfinite_samples
            + self.invalid_scattering
            + self.tree_records_non_finite
            + self.tree_records_negative
            + self.tree_records_zero_pdf
            + self.optimizer_rejected
            + self.adrrs_invalid_estimate
            + self.ltc_nonfinite
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct RenderStats {
    pub scene: String,
    pub method: Method,
    pub spp: u32,
    pub seconds: f64,
    pub paths_per_second: f64,
    /// CPU time of all threads during the render (snapshots included): on
    /// a shared machine it compares builds where wall time cannot.
    pub cpu_seconds: f64,
    pub rays_per_second: f64,
    pub threads: usize,
    pub seed: u64,
    pub nee: bool,
    pub max_depth: Option<u32>,
    pub width: usize,
    pub height: usize,
    pub counters: RenderCounters,
    pub mean_rgb: [f32; 3],
    /// Every non-finite or degenerate-value guard that fired, by place. A
    /// render of a normal scene reports zeros.
    pub guards: Guards,
    /// The per-scene plan: which machinery this run uses (one line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plan: Option<String>,
    /// Guided methods: iterations, tree sizes and learning counters.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub guiding: Option<GuidingStats>,
}

pub struct RenderResult {
    pub image: Image,
    /// Per-pixel variance of the estimate (of the mean), channel average.
    pub variance: Vec<f32>,
    pub stats: RenderStats,
    pub snapshots: Vec<Snapshot>,
    /// The learned guide of a guided method.
    pub tree: Option<SdTree>,
}

/// A progress bar on a terminal, nothing otherwise.
pub fn progress_bar(enabled: bool, len: u64, what: &str) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    if !enabled || !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} ({eta})",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar.set_message(what.to_string());
    Some(bar)
}

/// CPU time consumed so far by every thread of the process.
fn process_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid timespec for the call to fill in.
    if unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) } != 0 {
        return f64::NAN;
    }
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// The plan a run with `opts` follows: the per-scene plan, or with
/// `use_plan` off every part of the requested method.
pub fn run_plan(scene: &Scene, opts: &RenderOptions) -> crate::plan::ScenePlan {
    let mut plan = crate::plan::plan(
        scene,
        opts.method,
        opts.path.nee,
        opts.cosine_lobes,
        opts.product_vertices,
        opts.pixel_reuse,
    );
    if !opts.use_plan {
        plan.method = opts.method;
        plan.guiding = opts.method != Method::Pt;
        plan.reasons = vec!["plan disabled".into()];
    }
    plan
}

pub fn render(scene: &Scene, opts: &RenderOptions) -> Result<RenderResult, String> {
    let pool = thread_pool(opts.threads)?;
    let threads = pool.current_num_threads();
    let plan = run_plan(scene, opts);
    let ltc_guards_before = crate::ltc::nonfinite_guard_count();
    let cpu_before = process_cpu_seconds();
    let mut clock = RenderClock::start();
    let mut snapshots = SnapshotPlan {
        times: opts.snapshot_times.clone(),
        ..Default::default()
    };
    let (len, what) = match opts.budget {
        Budget::Spp(n) => (n as u64, format!("{:?} spp", opts.method)),
        Budget::Seconds(s) => ((s * 1000.0) as u64, format!("{:?} ms", opts.method)),
    };
    let bar = progress_bar(opts.progress, len, &what.to_lowercase());
    let (image, variance, spp, counters, guiding, tree) =
        pool.install(|| -> Result<_, String> {
            let guided = |out: crate::guiding::train::GuidedOutput| {
                (
                    out.image,
                    out.variance,
                    out.spp,
                    out.counters,
                    Some(out.stats),
                    Some(out.tree),
                )
            };
            // A product run where every vertex would take radiance weights
            // is radiance guiding, without the LTC table or a weights check.
            let runs = match opts.method {
                Method::Product if opts.use_plan && !plan.product_weights => Method::Radiance,
                m => m,
            };
            Ok(match runs {
                Method::Pt => {
                    let (film, counters) =
                        render_unguided(scene, opts, &mut clock, &mut snapshots, bar.as_ref());
                    (
                        film.image(),
                        film.variance_of_mean(),
                        film.spp,
                        counters,
                        None,
                        None,
                    )
                }
                Method::Radiance => guided(render_guided(
                    scene,
                    opts,
                    &RadianceModel,
                    &mut clock,
                    &mut snapshots,
                    bar.as_ref(),
                )),
                Method::Product => {
                    // Only product guiding needs the LTC table (decoded once per process).
                    let model = ProductModel {
                        table: default_ltc_table()?,
                        kernel: opts.product_kernel,
                        options: crate::guiding::product::guiding_ltc_options(),
                        radiance_only: false,
                        cosine_lobes: opts.cosine_lobes,
                        product_vertices: opts.product_vertices,
                        reuse_in_pixel: opts.pixel_reuse,
                    };
                    guided(render_guided(
                        scene,
                        opts,
                        &model,
                        &mut clock,
                        &mut snapshots,
                        bar.as_ref(),
                    ))
                }
            })
        })?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let seconds = clock.seconds();
    let cpu_seconds = process_cpu_seconds() - cpu_before;
    let mean = image.mean_rgb();
    let guards = Guards {
        image_nonfinite_samples: counters.nonfinite_samples,
        invalid_scattering: counters.invalid_scattering,
        tree_records_non_finite: guiding
            .as_ref()
            .map_or(0, |g| g.records_rejected_non_finite),
        tree_records_negative: guiding.as_ref().map_or(0, |g| g.records_rejected_negative),
        tree_records_zero_pdf: guiding.as_ref().map_or(0, |g| g.records_rejected_zero_pdf),
        optimizer_rejected: guiding.as_ref().map_or(0, |g| g.adam_rejected),
        adrrs_invalid_estimate: counters.adrrs.invalid_estimate,
        // Process-wide counter: concurrent renders in one process share it.
        ltc_nonfinite: crate::ltc::nonfinite_guard_count() - ltc_guards_before,
    };
    let stats = RenderStats {
        scene: scene.name.clone(),
        method: plan.method,
        spp,
        seconds,
        paths_per_second: counters.paths as f64 / seconds.max(1e-9),
        cpu_seconds,
        rays_per_second: (counters.rays + counters.shadow_rays) as f64 / seconds.max(1e-9),
        threads,
        seed: opts.seed,
        nee: opts.path.nee,
        max_depth: opts.path.max_depth,
        width: image.width,
        height: image.height,
        counters,
        mean_rgb: mean.to_array(),
        guards,
        plan: Some({
            let mut line = plan.line();
            for note in guiding.iter().flat_map(|g| [&g.weights_check, &g.fallback]) {
                if !note.is_empty() {
                    line = format!("{line} | {note}");
                }
            }
            line
        }),
        guiding,
    };
    Ok(RenderResult {
        image,
        variance,
        stats,
        snapshots: snapshots.taken,
        tree,
    })
}

fn render_unguided(
    scene: &Scene,
    opts: &RenderOptions,
    clock: &mut RenderClock,
    snapshots: &mut SnapshotPlan,
    bar: Option<&indicatif::ProgressBar>,
) -> (Film, RenderCounters) {
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    let mut counters = RenderCounters::default();
    let deadline = match opts.budget {
        Budget::Spp(_) => None,
        Budget::Seconds(s) => Some(s),
    };
    let mut pass = 0u64;
    let mut pacer = PassPacer::default();
    loop {
        match (opts.budget, deadline) {
            (Budget::Spp(n), _) if pass >= n as u64 => break,
            (_, Some(s)) if pass > 0 && pacer.deadline_reached(clock.seconds(), s) => break,
            _ => {}
        }
        let start = clock.seconds();
        let passes_left = match opts.budget {
            Budget::Spp(n) => Some(n as u64 - pass),
            Budget::Seconds(_) => None,
        };
        let n = pacer.next_call(start, passes_left, deadline, snapshots);
        let (c, _) = render_passes_into(
            scene,
            &NoGuide,
            &opts.path,
            opts.seed,
            pass..pass + n,
            None,
            &mut film,
        );
        counters.add(&c);
        pass += n;
        let now = clock.seconds();
        pacer.called(n, now - start);
        if snapshots.due(now) {
            clock.excluding(|| snapshots.take(now, film.spp, film.image()));
        }
        if let Some(b) = bar {
            match deadline {
                Some(_) => b.set_position((clock.seconds() * 1000.0) as u64),
                None => b.set_position(pass),
            }
        }
    }
    (film, counters)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Calls take what is left of a sample budget (at most 16 passes), one
    /// pass until a timed budget has a pace, then about half the time left
    /// before the deadline or the next snapshot, whichever is nearer.
    #[test]
    fn the_pacer_takes_half_the_time_left() {
        let none = SnapshotPlan::default();
        let mut pacer = PassPacer::default();
        assert_eq!(pacer.next_call(0.0, Some(40), None, &none), 16);
        assert_eq!(pacer.next_call(0.0, Some(3), None, &none), 3);
        assert_eq!(pacer.next_call(0.0, None, Some(10.0), &none), 1);
        pacer.called(2, 0.25);
        assert_eq!(pacer.next_call(0.0, None, Some(1.0), &none), 4);
        assert_eq!(pacer.next_call(0.0, None, Some(100.0), &none), 16);
        assert_eq!(pacer.next_call(2.0, None, Some(1.0), &none), 1, "past it");
        let snapshots = SnapshotPlan {
            times: vec![0.6],
            ..Default::default()
        };
        assert_eq!(pacer.next_call(0.0, None, Some(10.0), &snapshots), 2);
        assert_eq!(pacer.next_call(0.0, Some(40), None, &snapshots), 2);
    }

    /// A timed run stops when less than half a pass is left (so it ends
    /// within half a pass of its deadline), and a deadline bounds a call of
    /// fixed size only once a pace is known.
    #[test]
    fn the_pacer_ends_within_half_a_pass_of_the_deadline() {
        let mut pacer = PassPacer::default();
        assert!(!pacer.deadline_reached(9.9, 10.0), "no pace yet");
        assert!(pacer.deadline_reached(10.0, 10.0));
        assert_eq!(
            pacer.bound_by_deadline(4, 9.0, Some(10.0)),
            4,
            "no pace yet"
        );
        pacer.called(1, 0.5);
        assert!(
            !pacer.deadline_reached(9.7, 10.0),
            "0.3 s left of a 0.5 s pass"
        );
        assert!(pacer.deadline_reached(9.8, 10.0), "0.2 s left");
        assert_eq!(pacer.bound_by_deadline(4, 0.0, Some(10.0)), 4);
        assert_eq!(pacer.bound_by_deadline(4, 8.0, Some(10.0)), 2);
        assert_eq!(pacer.bound_by_deadline(4, 9.7, Some(10.0)), 1);
        assert_eq!(pacer.bound_by_deadline(4, 12.0, Some(10.0)), 1, "past it");
        assert_eq!(pacer.bound_by_deadline(4, 8.0, None), 4, "sample budget");
    }
}
