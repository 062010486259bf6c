//! Whole renders: a budget in samples per pixel or seconds, a method, and
//! the statistics every run reports.

use crate::cpu_clock::PoolCpuClock;
use crate::film::image::{Film, Image};
use crate::guards::drain_pool;
use crate::guiding::guide::RadianceModel;
use crate::guiding::product::{CosineLobes, ProductModel};
use crate::guiding::schedule::TrainingStop;
use crate::guiding::sdtree::SdTree;
use crate::guiding::support::GuideSupport;
use crate::guiding::train::{GuidingStats, render_guided};
use crate::integrator::guide::NoGuide;
use crate::integrator::path::PathSettings;
use crate::integrator::stats::RenderCounters;
use crate::integrator::{render_passes_into, thread_pool};
use crate::ltc::{LtcTable, ProductKernel};
use crate::scene::Scene;
use serde::Serialize;
use std::sync::OnceLock;

/// The guard counters every run reports live in [`crate::guards`].
pub use crate::guards::Guards;
/// The run's clock, snapshots and call sizes live in [`crate::pacing`].
pub use crate::pacing::{PassPacer, RenderClock, Snapshot, SnapshotPlan, TimeBase};

/// The committed LTC table, decoded once.
pub fn default_ltc_table() -> Result<&'static LtcTable, String> {
    static TABLE: OnceLock<Result<LtcTable, String>> = OnceLock::new();
    TABLE
        .get_or_init(LtcTable::load_default)
        .as_ref()
        .map_err(|e| e.clone())
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    Spp(u32),
    Seconds(f64),
}

impl Budget {
    /// At least 1 spp, or a positive finite time: a NaN or infinite
    /// deadline is never reached.
    pub fn check(self) -> Result<(), String> {
        match self {
            Budget::Spp(0) => Err("--spp must be at least 1".into()),
            Budget::Seconds(t) if !(t > 0.0 && t.is_finite()) => Err(format!(
                "--time must be a positive number of seconds, got {t}"
            )),
            _ => Ok(()),
        }
    }
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
    /// Guided methods: the rule that ends training.
    pub training_stop: TrainingStop,
    /// Product guiding: the weights of vertices whose lobes are all cosines.
    pub cosine_lobes: CosineLobes,
    /// Product guiding: the first this many vertices of a path take product
    /// weights (0: every vertex).
    pub product_vertices: u32,
    /// Product guiding: the paths of a pixel and its neighbours reuse a
    /// first vertex's product lobe while it matches
    /// (`guiding::pixel_reuse`); off: the paper's lobe per vertex.
    pub pixel_reuse: bool,
    /// Product guiding: the share β of guided samples at product-weighted
    /// vertices drawn from the radiance descent (`guiding::defensive`),
    /// fixed or learned per leaf (`guiding::share_learning`).
    pub radiance_share: crate::guiding::defensive::RadianceShare,
    /// Guided methods: the radiance weights over the sphere or on a
    /// reflecting surface's hemisphere.
    pub guide_support: GuideSupport,
    /// Follow the per-scene plan (and drop guiding where it does not pay).
    /// Off for measuring what the plan saves, and for comparing the guided
    /// methods as such.
    pub use_plan: bool,
    /// Guided methods: c in the SD-tree's spatial split threshold c·√(2^k);
    /// `None`: scaled to the image size, see
    /// [`crate::guiding::sdtree::default_split_threshold`].
    pub spatial_threshold: Option<f64>,
    /// Guided methods: λ of the learned BSDF fraction's L2 term, which pulls
    /// α towards ½; `None`: [`crate::guiding::adam::AdamConfig`]'s default.
    pub bsdf_fraction_l2: Option<f64>,
    /// Guided methods: how each leaf learns its BSDF fraction (Adam on the
    /// KL divergence, or the grid of least second moment).
    pub bsdf_fraction_learning: crate::guiding::adam::FractionLearning,
    /// What the budget, the snapshot times and the training schedule are
    /// measured in.
    pub time_base: TimeBase,
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
                defer_guide_pdf: true,
            },
            progress: false,
            snapshot_times: Vec::new(),
            bsdf_fraction: None,
            product_kernel: ProductKernel::default(),
            training_stop: TrainingStop::default(),
            cosine_lobes: CosineLobes::default(),
            product_vertices: crate::guiding::product::DEFAULT_PRODUCT_VERTICES,
            pixel_reuse: true,
            radiance_share: crate::guiding::defensive::RadianceShare::default(),
            guide_support: GuideSupport::Sphere,
            use_plan: true,
            spatial_threshold: None,
            bsdf_fraction_l2: None,
            bsdf_fraction_learning: crate::guiding::adam::FractionLearning::Kl,
            time_base: TimeBase::Wall,
        }
    }
}

impl RenderOptions {
    /// Refuses options no render can run, before any work: the command
    /// line checks its flags with the same rules, and a library caller gets
    /// the same errors from [`render`] instead of a hang (a NaN deadline is
    /// never reached), an image of 0 spp, or a NaN in the tree's α.
    pub fn check(&self) -> Result<(), String> {
        self.budget.check()?;
        if self.path.max_depth == Some(0) {
            return Err("--max-depth must be -1 or at least 1, got 0".into());
        }
        crate::guiding::adrrs::check_window(self.path.adrrs_window)?;
        if let Some(a) = self.bsdf_fraction {
            check_bsdf_fraction(a)?;
            if self.bsdf_fraction_learning != crate::guiding::adam::FractionLearning::Kl {
                return Err(format!(
                    "--bsdf-fraction {a} fixes α, so --bsdf-fraction-learning {} would learn nothing",
                    self.bsdf_fraction_learning
                ));
            }
        }
        if let Some(c) = self.spatial_threshold {
            crate::guiding::sdtree::check_split_threshold(c)?;
        }
        if let Some(l) = self.bsdf_fraction_l2 {
            crate::guiding::adam::check_l2(l)?;
        }
        check_guide_support(self.method, self.guide_support)?;
        self.radiance_share.check()?;
        SnapshotPlan::check_times(&self.snapshot_times)
    }
}

/// Only radiance guiding has a choice of support: the product's glossy
/// vertices clip their weights at the horizon already.
pub fn check_guide_support(method: Method, support: GuideSupport) -> Result<(), String> {
    if support == GuideSupport::Hemisphere && method == Method::Product {
        return Err(
            "--guide-support hemisphere applies to --method radiance; product \
                    guiding already clips its glossy vertices' weights at the horizon"
                .into(),
        );
    }
    Ok(())
}

/// A fixed BSDF-sampling fraction (`--bsdf-fraction`) is a probability.
pub fn check_bsdf_fraction(a: f32) -> Result<(), String> {
    if (0.0..=1.0).contains(&a) {
        Ok(())
    } else {
        Err(format!("--bsdf-fraction must be in [0, 1], got {a}"))
    }
}

/// A guided vertex samples a delta lobe only through BSDF sampling, which a
/// fixed fraction of 0 never chooses: on a material with a delta lobe beside
/// its rough ones (smooth `plastic`'s coat) that light would be lost.
fn check_fraction_samples_delta_lobes(scene: &Scene, opts: &RenderOptions) -> Result<(), String> {
    if opts.method == Method::Pt || opts.bsdf_fraction != Some(0.0) {
        return Ok(());
    }
    if scene
        .materials
        .iter()
        .any(|m| m.has_delta_and_non_delta_lobes())
    {
        return Err(
            "--bsdf-fraction 0 never samples the delta lobe of the scene's smooth \
                    plastic (its coat), so that reflection would be lost; give a fraction above 0"
                .into(),
        );
    }
    Ok(())
}

#[derive(Clone, Debug, Serialize)]
pub struct RenderStats {
    pub scene: String,
    pub method: Method,
    pub spp: u32,
    /// Wall-clock seconds of rendering (snapshots left out), whatever the
    /// time base.
    pub seconds: f64,
    /// The time base of the budget and the snapshots, and the run's clock
    /// at its end in it (`seconds` under the wall clock).
    pub time_base: TimeBase,
    pub clock_seconds: f64,
    /// Reads of a CPU clock that failed, each advancing the clock by wall
    /// time instead (0 on any normal system).
    pub clock_read_failures: u64,
    /// Of `clock_seconds` on the CPU clock, the seconds charged beyond the
    /// pool's per-thread mean for single-threaded work between render
    /// calls (tree refinement, the iterations' combination, …): what a
    /// per-thread mean alone would have left out with more than one
    /// thread. 0 on the wall clock and with one thread.
    pub clock_serial_seconds: f64,
    pub paths_per_second: f64,
    /// CPU time of the render's own threads (snapshots included; NaN if
    /// the clock cannot be read). On a shared machine it compares builds
    /// where wall time cannot; side by side, it holds this render's share
    /// of the cores alone.
    pub cpu_seconds: f64,
    pub rays_per_second: f64,
    pub threads: usize,
    /// How this build holds the LTC kernels' 16 lanes
    /// ([`crate::ltc::lanes::LAYOUT`]): builds that differ here render the
    /// same image at different speeds.
    pub ltc_lanes: String,
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

impl RenderStats {
    /// Samples per pixel the render traced: its image's, and the guided
    /// passes a fallback to path tracing left out of it
    /// ([`GuidingStats::left_out_spp`]).
    pub fn traced_spp(&self) -> u32 {
        self.spp + self.guiding.as_ref().map_or(0, |g| g.left_out_spp)
    }
}

pub struct RenderResult {
    pub image: Image,
    /// Per-pixel variance of the estimate (of the mean), channel average.
    pub variance: Vec<f64>,
    /// Guided methods: the last iteration's per-pixel single-sample
    /// variance (see [`crate::guiding::train::GuidedOutput`]).
    pub last_iteration_variance: Vec<f64>,
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
        opts.radiance_share,
    );
    if !opts.use_plan {
        plan.method = opts.method;
        plan.guiding = opts.method != Method::Pt;
        plan.reasons = vec!["plan disabled".into()];
    }
    if plan.guiding && opts.guide_support == GuideSupport::Hemisphere {
        plan.reasons.push(
            "guide support: hemisphere (radiance times each cell's share above the shading plane)"
                .into(),
        );
    }
    plan
}

/// Renders `scene` with `opts`; refuses options [`RenderOptions::check`]
/// rejects before starting a thread.
pub fn render(scene: &Scene, opts: &RenderOptions) -> Result<RenderResult, String> {
    opts.check()?;
    check_fraction_samples_delta_lobes(scene, opts)?;
    let pool = thread_pool(opts.threads)?;
    let threads = pool.current_num_threads();
    let plan = run_plan(scene, opts);
    let cpu = PoolCpuClock::of(&pool);
    let cpu_before = cpu.as_ref().ok().and_then(PoolCpuClock::total_seconds);
    let mut clock = match opts.time_base {
        TimeBase::Wall => RenderClock::start(),
        TimeBase::Cpu => RenderClock::on_cpu(cpu.clone()?)?,
    };
    let mut snapshots = SnapshotPlan::at(opts.snapshot_times.clone());
    let (len, what) = match opts.budget {
        Budget::Spp(n) => (n as u64, format!("{:?} spp", opts.method)),
        Budget::Seconds(s) => ((s * 1000.0) as u64, format!("{:?} ms", opts.method)),
    };
    let bar = progress_bar(opts.progress, len, &what.to_lowercase());
    let (image, variance, spp, counters, guiding, tree, last_iteration_variance) =
        pool.install(|| -> Result<_, String> {
            let guided = |out: crate::guiding::train::GuidedOutput| {
                (
                    out.image,
                    out.variance,
                    out.spp,
                    out.counters,
                    Some(out.stats),
                    Some(out.tree),
                    out.last_iteration_variance,
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
                        Vec::new(),
                    )
                }
                Method::Radiance => guided(render_guided(
                    scene,
                    opts,
                    &RadianceModel {
                        support: opts.guide_support,
                    },
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
                        radiance_share: opts.radiance_share.value,
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
    let seconds = clock.wall_seconds();
    let clock_seconds = clock.seconds();
    let cpu_seconds = match (&cpu, cpu_before) {
        (Ok(c), Some(before)) => c.total_seconds().map_or(f64::NAN, |t| t - before),
        _ => f64::NAN,
    };
    let mean = image.mean_rgb();
    // The pool's threads were started for this render, so every event
    // their counts hold is this render's (see crate::guards).
    let events = drain_pool(&pool);
    let guards = Guards {
        image_nonfinite_samples: counters.nonfinite_samples,
        invalid_scattering: counters.invalid_scattering,
        bsdf_nonfinite: counters.bsdf_nonfinite,
        guide_root_nonfinite: counters.guide_root_nonfinite,
        tree_records_non_finite: guiding
            .as_ref()
            .map_or(0, |g| g.records_rejected_non_finite),
        tree_records_negative: guiding.as_ref().map_or(0, |g| g.records_rejected_negative),
        tree_records_zero_pdf: guiding.as_ref().map_or(0, |g| g.records_rejected_zero_pdf),
        optimizer_rejected: guiding.as_ref().map_or(0, |g| {
            g.adam_rejected + g.learned_shares.rejected_non_finite
        }),
        adrrs_invalid_estimate: counters.adrrs.invalid_estimate,
        iterations_dropped_nonfinite_variance: guiding
            .as_ref()
            .map_or(0, |g| g.iterations_dropped_nonfinite_variance),
        ..Guards::default()
    }
    .with_events(&events);
    let stats = RenderStats {
        scene: scene.name.clone(),
        method: plan.method,
        spp,
        seconds,
        time_base: clock.base(),
        clock_seconds,
        clock_read_failures: clock.failed_reads(),
        clock_serial_seconds: clock.serial_seconds(),
        paths_per_second: counters.paths as f64 / seconds.max(1e-9),
        cpu_seconds,
        rays_per_second: (counters.rays + counters.shadow_rays) as f64 / seconds.max(1e-9),
        threads,
        ltc_lanes: crate::ltc::lanes::LAYOUT.to_string(),
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
            for note in guiding
                .iter()
                .flat_map(|g| [&g.weights_check, &g.fallback, &g.fallback_declined])
            {
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
        last_iteration_variance,
        stats,
        snapshots: snapshots.taken,
        tree,
    })
}

/// The threads a `threads` setting means (0: every core).
pub fn resolve_threads(threads: usize) -> usize {
    if threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        threads
    }
}

/// Each of `renders` renders run side by side gets an equal share of
/// `threads` (0: every core), at least one (more renders than cores share
/// the cores through the OS scheduler).
pub fn side_by_side_share(threads: usize, renders: usize) -> usize {
    (resolve_threads(threads) / renders.max(1)).max(1)
}

/// Renders every option set at the same time, each on its own pool (its
/// `threads`): on a shared host they all meet the same load, so ratios
/// between them are side-by-side measurements.
pub fn render_side_by_side(
    scene: &Scene,
    runs: &[RenderOptions],
) -> Vec<Result<RenderResult, String>> {
    std::thread::scope(|s| {
        let handles: Vec<_> = runs
            .iter()
            .map(|opts| s.spawn(move || render(scene, opts)))
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|_| Err("a render panicked".into())))
            .collect()
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
        let c = clock.parallel(|| {
            render_passes_into(
                scene,
                &NoGuide,
                &opts.path,
                opts.seed,
                pass..pass + n,
                None,
                &mut film,
                &mut Vec::new(),
            )
        });
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
