//! The study commands: equal-time comparisons (`compare`), their redrawing
//! and pooling (`replot`, `merge`), the paper's Table 1 (`ablation`) and
//! the product's attribution (`attribute`).

use crate::{GuidedArgs, ProductArgs, load};
use clap::Args;
use ltcguide::experiment::compare::NeeChoice;
use ltcguide::film::exr_io::read_valid_image;
use ltcguide::integrator::path::{PathSettings, RouletteMode};
use ltcguide::render::{Budget, Method, TimeBase};
use ltcguide::scene::Scene;
use std::path::{Path, PathBuf};

#[derive(Args, Clone)]
pub struct CompareArgs {
    /// Scene file (Mitsuba 3 XML subset), or a folder holding scene.xml.
    scene: PathBuf,
    /// Reference image (e.g. the pack's reference.exr, or a long ltcguide render).
    #[arg(long)]
    reference: PathBuf,
    /// Budget per run in seconds (of --clock), training included.
    #[arg(long)]
    time: f64,
    /// What --time, the snapshots and training measure: wall-clock seconds,
    /// or each run's own CPU seconds per thread. Side by side, cpu compares
    /// the methods at equal CPU time however the scheduler shares the cores
    /// among the runs (it does not share them evenly: `src/cpu_clock.rs`).
    #[arg(long, value_enum, default_value_t = TimeBase::Wall)]
    clock: TimeBase,
    /// Methods to compare, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "pt,radiance")]
    methods: Vec<Method>,
    /// Runs per method (different seeds).
    #[arg(long, default_value_t = 3)]
    runs: u32,
    /// Number of the first run: runs K.. take seeds 1000 + K.., so that a
    /// later comparison adds new seeds to an earlier one (see `merge`).
    #[arg(long, default_value_t = 0)]
    first_run: u32,
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Which methods use next-event estimation.
    #[arg(long, value_enum, default_value_t = NeeChoice::Paper)]
    nee: NeeChoice,
    /// Russian roulette of the guided methods (pt keeps Mitsuba's classic
    /// rule). The paper's setting is adrrs; with NEE, adrrs's weight window
    /// can cost more variance than the time it saves (docs/results-reading.md).
    #[arg(long, value_enum, default_value_t = RouletteMode::Adrrs)]
    guided_rr: RouletteMode,
    /// ADRRS's weight-window ratio s for the guided methods (as for render).
    #[arg(long, default_value_t = ltcguide::guiding::adrrs::PAPER_WINDOW)]
    adrrs_window: f32,
    #[command(flatten)]
    guided: GuidedArgs,
    #[command(flatten)]
    product: ProductArgs,
    /// Guided methods: λ of the learned BSDF fraction's L2 term (as for
    /// render; default 0.01). A λ other than the default enters the summary's
    /// settings line, so `merge` refuses to pool runs across it.
    #[arg(long)]
    bsdf_fraction_l2: Option<f64>,
    /// Render the methods of each run at the same time, each on an equal
    /// share of --threads (at least one), instead of one after the other: on
    /// a shared host every method then meets the same load, so their ratios
    /// are side-by-side measurements.
    #[arg(long)]
    side_by_side: bool,
    /// Run every method as such throughout, as `render --no-plan` does: no
    /// run falls back to path tracing or to cheaper weights, so the
    /// methods themselves are compared.
    #[arg(long)]
    no_plan: bool,
    /// Output directory. One that already holds a comparison is refused
    /// unless --overwrite is given.
    #[arg(long)]
    out: PathBuf,
    /// Replace the comparison already in --out: its files (curves, runs,
    /// summary and every method's images, no other file) are removed before
    /// the first run, so that none of the earlier study stays beside the new one.
    #[arg(long)]
    overwrite: bool,
}

/// Each method's default setting: PT with NEE and Mitsuba's roulette (the
/// reference renderer's setting); guided methods as in the paper, without
/// NEE, with adjoint-driven roulette.
pub fn default_path_settings(scene: &Scene, method: Method) -> PathSettings {
    let guided = method != Method::Pt;
    PathSettings {
        nee: !guided,
        max_depth: scene.max_depth,
        roulette: if guided {
            RouletteMode::Adrrs
        } else {
            RouletteMode::Classic
        },
        adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
        defer_guide_pdf: true,
    }
}

pub fn cmd_compare(args: &CompareArgs) -> Result<(), String> {
    // The arguments first: a bad one fails before a scene is loaded.
    Budget::Seconds(args.time).check()?;
    ltcguide::experiment::compare::check_methods(&args.methods)?;
    ltcguide::guiding::adrrs::check_window(args.adrrs_window)?;
    if let Some(lambda) = args.bsdf_fraction_l2 {
        ltcguide::guiding::adam::check_l2(lambda)?;
    }
    ltcguide::guiding::defensive::check_radiance_share(args.product.radiance_share)?;
    let scene = load(&args.scene)?;
    let reference = read_valid_image(&args.reference)?;
    let product_kernels =
        args.methods.contains(&Method::Product) && ltcguide::plan::lobe_inventory(&scene).glossy;
    if let Some(note) = ltcguide::ltc::lanes::layout_note(product_kernels) {
        eprintln!("{note}");
    }
    let opts = ltcguide::experiment::compare::CompareOptions {
        methods: args.methods.clone(),
        seconds: args.time,
        time_base: args.clock,
        runs: args.runs,
        first_run: args.first_run,
        threads: args.threads,
        out_dir: args.out.clone(),
        path_for: default_path_settings,
        nee: args.nee,
        guided_roulette: Some((args.guided_rr, args.adrrs_window)),
        defer_guide_pdf: !args.guided.eager_guide_pdf,
        training_stop: args.guided.training_stop,
        cosine_lobes: args.product.cosine_lobes,
        product_vertices: args.product.product_vertices,
        pixel_reuse: !args.product.no_pixel_reuse,
        radiance_share: args.product.radiance_share(),
        guide_support: args.guided.guide_support,
        bsdf_fraction_l2: args.bsdf_fraction_l2,
        bsdf_fraction_learning: args.guided.bsdf_fraction_learning,
        side_by_side: args.side_by_side,
        use_plan: !args.no_plan,
        progress: true,
        reference_file: Some(args.reference.clone()),
        overwrite: args.overwrite,
    };
    let outcome = ltcguide::experiment::compare::run_compare(&scene, &reference, &opts)?;
    println!("{}", outcome.summary);
    Ok(())
}

pub fn cmd_ablation(path: &Path, spp: u32, threads: usize) -> Result<(), String> {
    Budget::Spp(spp).check()?;
    let scene = load(path)?;
    let settings = default_path_settings(&scene, Method::Product);
    let out = ltcguide::experiment::ablation::run_ablation(&scene, spp, threads, settings, true)?;
    println!("{}", out.markdown);
    Ok(())
}

pub fn cmd_attribute(
    args: &ltcguide::experiment::attribution::AttributeArgs,
) -> Result<(), String> {
    use ltcguide::experiment::attribution::{check, run_attribution};
    // The arguments first: a bad one fails before a scene is loaded.
    check(&args.options(None))?;
    let scene = load(&args.scene)?;
    let out = run_attribution(&scene, &args.options(scene.max_depth))?;
    println!("{}", out.markdown);
    Ok(())
}

pub fn cmd_replot(dirs: &[PathBuf]) -> Result<(), String> {
    dirs.iter().try_for_each(|d| {
        let r = ltcguide::experiment::replot::replot(d)?;
        let cost = if r.cost_rewritten {
            ", the cost section from runs.csv"
        } else {
            ""
        };
        println!(
            "{}: curves.svg and the time-to-error table redrawn from {} rows ({}){cost}",
            d.display(),
            r.rows,
            r.methods.join(", ")
        );
        Ok(())
    })
}

pub fn cmd_merge(out: &Path, sources: &[PathBuf], overwrite: bool) -> Result<(), String> {
    let merged = ltcguide::experiment::merge::merge(out, sources, overwrite)?;
    eprintln!(
        "{}: {} runs per method pooled from {} comparisons, {} rows ({})",
        out.display(),
        merged.runs.len(),
        sources.len(),
        merged.rows,
        merged.methods.join(", ")
    );
    println!("{}", merged.summary);
    Ok(())
}
