//! `ltcguide compare`: every method for the same wall-clock budget (training
//! included), several seeds, error against time from snapshots, and the
//! files a user reads: curves.csv, curves.svg, summary.md, final images and
//! error maps.

use super::colormap::log_scale_rgb;
use super::cost::{COST_CSV, CostRow, cost_section, parse_cost_csv, to_cost_csv};
use super::curves::{CurveRow, MeanCurve, mean_curve, parse_csv, run_numbers, to_csv};
use super::plot::curves_svg;
use super::study_folder::{
    StudyRecord, check_reference_not_output, check_writable, existing_study, occupied_error,
    reference_fingerprint, remove_comparison_files,
};
use super::summary_text::{
    PLAN_HEADING, SUMMARY_TITLE_SUFFIX, budget_phrase, curves_title, final_errors_table,
    runs_phrase, speedup_section, time_axis_label,
};
use crate::film::exr_io::write_rgb;
use crate::film::image::Image;
use crate::film::metrics::{mae, relmse, relmse_trimmed};
use crate::film::png_io::{write_png, write_png_rgb8};
use crate::film::write_atomic;
use crate::guiding::product::CosineLobes;
use crate::guiding::schedule::TrainingStop;
use crate::guiding::support::GuideSupport;
use crate::integrator::path::{PathSettings, RouletteMode};
use crate::render::{
    Budget, Method, RenderOptions, SnapshotPlan, TimeBase, render, render_side_by_side,
    resolve_threads, side_by_side_share,
};
use crate::scene::Scene;
use std::fmt::Write;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug)]
pub struct CompareOptions {
    pub methods: Vec<Method>,
    pub seconds: f64,
    /// What `seconds`, the snapshots and training measure.
    pub time_base: TimeBase,
    pub runs: u32,
    /// The first run's number: runs first_run.. take seeds 1000 + run, so a
    /// later study can add runs with new seeds to an earlier one (`merge`).
    pub first_run: u32,
    pub threads: usize,
    pub out_dir: PathBuf,
    /// Path settings per method (NEE and roulette differ by method).
    pub path_for: fn(&Scene, Method) -> PathSettings,
    /// Overrides `path_for`'s NEE choice.
    pub nee: NeeChoice,
    /// Overrides `path_for`'s roulette for the guided methods, with ADRRS's
    /// window ratio s (`None`: as `path_for` says). Unguided path tracing
    /// keeps its own, since ADRRS needs a guide's adjoint estimates.
    pub guided_roulette: Option<(RouletteMode, f32)>,
    /// [`PathSettings::defer_guide_pdf`] for every method.
    pub defer_guide_pdf: bool,
    /// Guided methods: the rule that ends training.
    pub training_stop: TrainingStop,
    /// Product guiding's weights at vertices whose lobes are all cosines.
    pub cosine_lobes: CosineLobes,
    /// Product guiding's vertices per path with product weights (0: all).
    pub product_vertices: u32,
    /// Guided methods: the radiance weights over the sphere or on a
    /// reflecting surface's hemisphere.
    pub guide_support: GuideSupport,
    /// Product guiding's reuse of a first-vertex lobe across a pixel's
    /// paths and its neighbours'.
    pub pixel_reuse: bool,
    /// Product guiding's share of radiance samples (`guiding::defensive`).
    pub radiance_share: crate::guiding::defensive::RadianceShare,
    /// Guided methods: λ of the learned BSDF fraction's L2 term (`None`:
    /// Adam's default, Müller's 0.01).
    pub bsdf_fraction_l2: Option<f64>,
    /// How the guided methods' leaves learn their BSDF fraction.
    pub bsdf_fraction_learning: crate::guiding::adam::FractionLearning,
    /// Render the methods of a run at the same time, each on an equal share
    /// of the threads, instead of one after the other.
    pub side_by_side: bool,
    /// Follow the per-scene plan (its strategy trial may hand a guided run
    /// to path tracing); off: every method runs as such throughout.
    pub use_plan: bool,
    pub progress: bool,
    /// The reference's file, where there is one: a study must not write
    /// over the image it measures against.
    pub reference_file: Option<PathBuf>,
    /// Replace a comparison already in `out_dir` (its files, no other)
    /// instead of refusing the folder.
    pub overwrite: bool,
}

/// Which methods use next-event estimation in a comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum NeeChoice {
    /// As `path_for` says (the paper's setting: pt with NEE, the guided
    /// methods without).
    Paper,
    /// Every method with NEE (MIS with BSDF and guide sampling): what a
    /// production renderer would run.
    All,
    /// No method uses NEE.
    None,
}

/// What `compare` found, for callers that build reports.
pub struct CompareOutcome {
    pub rows: Vec<CurveRow>,
    pub curves: Vec<MeanCurve>,
    pub summary: String,
}

/// The settings line's words for a non-default L2 weight or learning of
/// the BSDF fraction. The defaults say nothing, so that the line stays that
/// of the runs made before the options existed and `merge` still pools with
/// them, while runs at another λ or learning differ and are refused.
pub(super) fn fraction_phrase(
    lambda: Option<f64>,
    learning: crate::guiding::adam::FractionLearning,
) -> String {
    let mut phrase = match lambda {
        Some(l) if l != crate::guiding::adam::AdamConfig::default().l2 => {
            format!(", BSDF fraction's L2 λ = {l}")
        }
        _ => String::new(),
    };
    if learning != crate::guiding::adam::FractionLearning::Kl {
        phrase += &format!(", BSDF fraction learned by {learning}");
    }
    phrase
}

/// The guide support `method` runs with: only radiance guiding has a
/// choice (the product's glossy vertices clip at the horizon already).
fn support_for(method: Method, opts: &CompareOptions) -> GuideSupport {
    if method == Method::Radiance {
        opts.guide_support
    } else {
        GuideSupport::Sphere
    }
}

/// The guide support in a settings line, when it is not the default, so
/// that `merge` refuses to pool runs across it.
fn support_phrase(support: GuideSupport) -> &'static str {
    match support {
        GuideSupport::Sphere => "",
        GuideSupport::Hemisphere => ", guide support: hemisphere",
    }
}

/// A method's path settings in this comparison: `path_for`'s, with the
/// study's NEE and roulette overrides.
fn path_settings(scene: &Scene, method: Method, opts: &CompareOptions) -> PathSettings {
    let base = (opts.path_for)(scene, method);
    PathSettings {
        nee: match opts.nee {
            NeeChoice::Paper => base.nee,
            NeeChoice::All => true,
            NeeChoice::None => false,
        },
        defer_guide_pdf: opts.defer_guide_pdf,
        ..match opts.guided_roulette {
            Some((roulette, adrrs_window)) if method != Method::Pt => PathSettings {
                roulette,
                adrrs_window,
                ..base
            },
            _ => base,
        }
    }
}

pub fn method_name(m: Method) -> String {
    format!("{m:?}").to_lowercase()
}

/// Refuses a method named twice: its runs would share run numbers and
/// seeds, so its curves and tables would count each run twice.
pub fn check_methods(methods: &[Method]) -> Result<(), String> {
    for (i, m) in methods.iter().enumerate() {
        if methods[..i].contains(m) {
            return Err(format!(
                "--methods names {} twice: each method is compared once",
                method_name(*m)
            ));
        }
    }
    Ok(())
}

/// Snapshot times: geometric from budget/64 to the budget, 3 per doubling.
pub fn snapshot_times(seconds: f64) -> Vec<f64> {
    SnapshotPlan::geometric(seconds / 64.0, seconds, 3).times
}

pub fn run_compare(
    scene: &Scene,
    reference: &Image,
    opts: &CompareOptions,
) -> Result<CompareOutcome, String> {
    if reference.width != scene.camera.width || reference.height != scene.camera.height {
        return Err(format!(
            "the reference is {}×{} but the scene renders {}×{}",
            reference.width, reference.height, scene.camera.width, scene.camera.height
        ));
    }
    reference.check_valid("the reference")?;
    if opts.methods.is_empty() || opts.runs == 0 || !(opts.seconds > 0.0) {
        return Err("compare needs at least one method, one run and a positive time".into());
    }
    check_methods(&opts.methods)?;
    // Every run of a method differs only in its seed, so checking the first
    // run's options checks them all, before the folder is made.
    for &method in &opts.methods {
        run_options(scene, method, opts.first_run, opts).check()?;
    }
    if opts.first_run.checked_add(opts.runs).is_none() {
        return Err(format!(
            "--first-run {} with --runs {} passes the largest run number ({})",
            opts.first_run,
            opts.runs,
            u32::MAX
        ));
    }
    if let Some(reference) = &opts.reference_file {
        check_reference_not_output(reference, &opts.out_dir)?;
    }
    let existing = existing_study(&opts.out_dir);
    if !existing.is_empty() && !opts.overwrite {
        return Err(occupied_error("compare", &opts.out_dir, &existing));
    }
    check_writable(&opts.out_dir, &opts.methods)?;
    if opts.overwrite {
        remove_comparison_files(&opts.out_dir)?;
    }
    let record = StudyRecord {
        budget: Some(opts.seconds),
        reference: Some(reference_fingerprint(reference)),
    };
    let mut rows = Vec::new();
    let mut cost_rows = Vec::new();
    // One list per method, so that a method's runs stand together in the summary.
    let mut plan_notes = vec![Vec::new(); opts.methods.len()];
    let mut guard_notes = Vec::new();
    let mut outcome = None;
    // Runs outer, methods inner: a shared machine's load drifts over a
    // study, and interleaving makes every method's runs meet the same drift
    // instead of one method taking the quiet start and another the busy end.
    // Side by side, the methods of a run also share every moment of it.
    for (index, run) in (opts.first_run..opts.first_run + opts.runs).enumerate() {
        let results = if opts.side_by_side {
            if opts.progress {
                eprintln!(
                    "compare: run {} of {}, {} methods side by side, each on {} of {} threads, {:.0} s",
                    index + 1,
                    opts.runs,
                    opts.methods.len(),
                    side_by_side_threads(opts),
                    total_threads(opts),
                    opts.seconds
                );
            }
            let runs: Vec<RenderOptions> = opts
                .methods
                .iter()
                .map(|&m| run_options(scene, m, run, opts))
                .collect();
            render_side_by_side(scene, &runs)
        } else {
            opts.methods
                .iter()
                .map(|&m| {
                    if opts.progress {
                        eprintln!(
                            "compare: {}, run {} of {}, {:.0} s",
                            method_name(m),
                            index + 1,
                            opts.runs,
                            opts.seconds
                        );
                    }
                    render(scene, &run_options(scene, m, run, opts))
                })
                .collect()
        };
        for ((&method, result), method_plans) in
            opts.methods.iter().zip(results).zip(&mut plan_notes)
        {
            let result = result?;
            let name = method_name(method);
            for s in &result.snapshots {
                rows.push(CurveRow {
                    method: name.clone(),
                    run,
                    seconds: s.seconds,
                    spp: s.spp,
                    mae: mae(&s.image, reference)?,
                    relmse: relmse(&s.image, reference)?,
                    relmse_trimmed: relmse_trimmed(&s.image, reference)?,
                });
            }
            rows.push(CurveRow {
                method: name.clone(),
                run,
                seconds: result.stats.clock_seconds,
                spp: result.stats.spp,
                mae: mae(&result.image, reference)?,
                relmse: relmse(&result.image, reference)?,
                relmse_trimmed: relmse_trimmed(&result.image, reference)?,
            });
            cost_rows.push(CostRow {
                method: name.clone(),
                run,
                seconds: result.stats.seconds,
                cpu_seconds: Some(result.stats.cpu_seconds).filter(|c| c.is_finite()),
                spp: result.stats.spp,
                traced_spp: Some(result.stats.traced_spp()),
            });
            let seed = result.stats.seed;
            let guards = &result.stats.guards;
            if guards.total() > 0 {
                guard_notes.push(format!("{name}, seed {seed}: {}", guards.describe()));
            }
            if result.stats.clock_read_failures > 0 {
                guard_notes.push(format!(
                    "{name}, seed {seed}: {} reads of the CPU clock failed (the clock advanced by \
                     wall time there)",
                    result.stats.clock_read_failures
                ));
            }
            // Every run's plan, not the first's alone: a trial decides per run whether a guided
            // method keeps guiding, and a ratio of runs that decided differently means something else.
            if let Some(plan) = &result.stats.plan {
                method_plans.push(format!("{name}, seed {seed}: {plan}"));
            }
            if index == 0 {
                write_final_images(&opts.out_dir, &name, &result.image, reference)?;
            }
        }
        // The folder is a whole smaller study after every run, so that an
        // interrupted one keeps the runs it finished (and `replot` and
        // `merge` read it as it stands).
        outcome = Some(write_study(
            scene,
            opts,
            &rows,
            &cost_rows,
            &plan_notes.concat(),
            &guard_notes,
            &record,
        )?);
    }
    outcome.ok_or_else(|| "compare ran no run".into())
}

/// Writes the CSVs, the curves and the summary of the runs so far.
fn write_study(
    scene: &Scene,
    opts: &CompareOptions,
    rows: &[CurveRow],
    cost_rows: &[CostRow],
    notes: &[String],
    guard_notes: &[String],
    record: &StudyRecord,
) -> Result<CompareOutcome, String> {
    let csv = to_csv(rows);
    write_atomic(&opts.out_dir.join("curves.csv"), csv.as_bytes())?;
    // Every figure below comes from the rows as the CSV holds them, so that
    // `replot` recomputes the curves and the summary exactly from the CSV.
    let rows = parse_csv(&csv)?;
    let cost_csv = to_cost_csv(cost_rows);
    write_atomic(&opts.out_dir.join(COST_CSV), cost_csv.as_bytes())?;
    let cost_rows = parse_cost_csv(&cost_csv)?;
    let curves: Vec<MeanCurve> = opts
        .methods
        .iter()
        .map(|&m| mean_curve(&rows, &method_name(m)))
        .collect();
    let svg = curves_svg(
        &curves_title(&scene.name, run_numbers(&rows).len()),
        time_axis_label(opts.time_base),
        &curves,
    )?;
    write_atomic(&opts.out_dir.join("curves.svg"), svg.as_bytes())?;
    let mut summary = summary_markdown(scene, opts, &rows, &cost_rows, &curves, notes, guard_notes);
    summary.push_str(&record.line());
    write_atomic(&opts.out_dir.join("summary.md"), summary.as_bytes())?;
    Ok(CompareOutcome {
        rows,
        curves,
        summary,
    })
}

/// The seed of run `run`.
pub fn run_seed(run: u32) -> u64 {
    1000 + run as u64
}

/// Each method's render options in run `run`: what the comparison renders.
pub fn run_options(
    scene: &Scene,
    method: Method,
    run: u32,
    opts: &CompareOptions,
) -> RenderOptions {
    RenderOptions {
        method,
        budget: Budget::Seconds(opts.seconds),
        seed: run_seed(run),
        threads: if opts.side_by_side {
            side_by_side_threads(opts)
        } else {
            opts.threads
        },
        path: path_settings(scene, method, opts),
        // Concurrent bars would overwrite each other.
        progress: opts.progress && !opts.side_by_side,
        snapshot_times: snapshot_times(opts.seconds),
        training_stop: opts.training_stop,
        cosine_lobes: opts.cosine_lobes,
        product_vertices: opts.product_vertices,
        pixel_reuse: opts.pixel_reuse,
        radiance_share: opts.radiance_share,
        guide_support: support_for(method, opts),
        bsdf_fraction_l2: opts.bsdf_fraction_l2,
        bsdf_fraction_learning: opts.bsdf_fraction_learning,
        use_plan: opts.use_plan,
        time_base: opts.time_base,
        ..Default::default()
    }
}

/// The comparison's threads (0: every core).
fn total_threads(opts: &CompareOptions) -> usize {
    resolve_threads(opts.threads)
}

/// Side by side, each method gets an equal share of the threads.
fn side_by_side_threads(opts: &CompareOptions) -> usize {
    side_by_side_share(opts.threads, opts.methods.len())
}

fn write_final_images(
    dir: &Path,
    name: &str,
    image: &Image,
    reference: &Image,
) -> Result<(), String> {
    write_rgb(
        &dir.join(format!("{name}.exr")),
        image.width,
        image.height,
        &image.pixels,
    )?;
    write_png(&dir.join(format!("{name}.png")), image)?;
    // Per-pixel relative error |I − R| / (R + 0.01) on a log scale.
    let err: Vec<f32> = image
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(i, r)| {
            let e = (*i - *r).abs() / (r.abs() + glam::Vec3::splat(0.01));
            (e.x + e.y + e.z) / 3.0
        })
        .collect();
    let rgb = log_scale_rgb(&err, 1e-3, 10.0);
    write_png_rgb8(
        &dir.join(format!("{name}-error.png")),
        image.width,
        image.height,
        &rgb,
    )
}

/// The product's settings name a build whose kernels hold their lanes in
/// two 256-bit halves on an AVX-512 machine: it computes the default
/// build's images at another speed, so `merge` must not pool the two.
fn lanes_phrase(layout: &str) -> &'static str {
    if layout == "ymm-kernels" {
        ", LTC kernels in 256-bit halves (ymm-kernels build)"
    } else {
        ""
    }
}

/// The CPU model, from /proc/cpuinfo where available.
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string())
}

fn summary_markdown(
    scene: &Scene,
    opts: &CompareOptions,
    rows: &[CurveRow],
    cost_rows: &[CostRow],
    curves: &[MeanCurve],
    notes: &[String],
    guard_notes: &[String],
) -> String {
    let mut s = String::new();
    let threads = if opts.side_by_side {
        format!(
            "the methods of a run side by side on {} of {} threads each",
            side_by_side_threads(opts),
            total_threads(opts)
        )
    } else {
        format!(
            "{} threads, methods one after the other",
            total_threads(opts)
        )
    };
    let _ = writeln!(s, "# {}{SUMMARY_TITLE_SUFFIX}\n", scene.name);
    let _ = writeln!(
        s,
        "{} (training included), {}, {}, {}.\n",
        budget_phrase(opts.seconds, opts.time_base),
        runs_phrase(rows),
        threads,
        cpu_model()
    );
    let settings: Vec<String> = opts
        .methods
        .iter()
        .map(|&m| {
            let p = path_settings(scene, m, opts);
            let nee = if p.nee { "NEE" } else { "no NEE" };
            let mut rr = format!("{:?}", p.roulette).to_lowercase();
            if p.roulette == RouletteMode::Adrrs {
                rr += &format!(" (window s = {})", p.adrrs_window);
            }
            let cosine = if m == Method::Product {
                format!(
                    ", {}{}",
                    crate::guiding::product::product_scope_phrase(
                        opts.product_vertices,
                        opts.pixel_reuse,
                        opts.radiance_share,
                        opts.cosine_lobes
                    ),
                    lanes_phrase(crate::ltc::lanes::LAYOUT)
                )
            } else {
                String::new()
            };
            let training = if m == Method::Pt {
                String::new()
            } else {
                format!(", training stops: {:?}", opts.training_stop).to_lowercase()
                    + &fraction_phrase(opts.bsdf_fraction_l2, opts.bsdf_fraction_learning)
                    + support_phrase(support_for(m, opts))
            };
            format!("{}: {nee}, roulette {rr}{training}{cosine}", method_name(m))
        })
        .collect();
    let _ = writeln!(
        s,
        "Path settings: {}. Per-scene plan: {}.\n",
        settings.join("; "),
        if opts.use_plan {
            "on (a guided run may fall back to path tracing)"
        } else {
            "off (every method as such throughout)"
        }
    );
    s.push_str(&final_errors_table(rows, curves));
    s.push_str(&speedup_section(curves));
    let methods: Vec<String> = opts.methods.iter().map(|&m| method_name(m)).collect();
    s.push_str(&cost_section(cost_rows, &methods, opts.time_base, notes));
    if !notes.is_empty() {
        let _ = writeln!(s, "\n{PLAN_HEADING}\n");
        for n in notes {
            let _ = writeln!(s, "- {n}");
        }
    }
    if !guard_notes.is_empty() {
        let _ = writeln!(
            s,
            "\n## Guards\n\nThese runs zeroed, rejected or left out NaN/Inf or degenerate \
             values (counts by guard, as in `render --stats-json`); their errors may be biased.\n"
        );
        for n in guard_notes {
            let _ = writeln!(s, "- {n}");
        }
    }
    let _ = writeln!(
        s,
        "\nFiles: `curves.csv` (every snapshot of every run), `{COST_CSV}` (every run's wall and CPU \
         seconds, its image's spp and the spp it traced), `curves.svg`, `<method>.exr/png` (first run), \
         `<method>-error.png` (|I − R|/(R + 0.01), log scale 1e-3…10)."
    );
    s
}
