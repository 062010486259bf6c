//! `ltcguide render`: one render of a scene with its options, written as an
//! EXR image with an optional PNG preview, alpha AOV and statistics JSON.
//! Every output is checked before the render starts.

use crate::{GuidedArgs, ProductArgs, load};
use clap::Args;
use ltcguide::film::exr_io::write_rgb;
use ltcguide::film::png_io::write_png;
use ltcguide::integrator::path::{PathSettings, RouletteMode};
use ltcguide::ltc::ProductKernel;
use ltcguide::render::{Budget, Method, RenderOptions, TimeBase, render};
use std::path::PathBuf;

const DEFAULT_SCENE: &str = "scenes/cornell-glossy/scene.xml";

#[derive(Args, Clone)]
pub struct RenderArgs {
    /// Scene file (Mitsuba 3 XML subset), or a folder holding scene.xml.
    #[arg(default_value = DEFAULT_SCENE)]
    scene: PathBuf,
    /// Samples per pixel (64 when neither --spp nor --time is given).
    #[arg(long, conflicts_with = "time")]
    spp: Option<u32>,
    /// A budget in seconds (of --clock) instead of a sample count.
    #[arg(long)]
    time: Option<f64>,
    /// What --time and training measure: wall-clock seconds, or the
    /// render's own CPU seconds per thread (a budget other processes'
    /// load does not eat into).
    #[arg(long, value_enum, default_value_t = TimeBase::Wall)]
    clock: TimeBase,
    /// Output EXR; a PNG preview is written next to it.
    #[arg(long, default_value = "out/render.exr")]
    out: PathBuf,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Next-event estimation (light sampling with MIS).
    #[arg(long, overrides_with = "no_nee")]
    nee: bool,
    /// Disable next-event estimation.
    #[arg(long, overrides_with = "nee")]
    no_nee: bool,
    /// Maximum path segments, camera ray included (overrides the scene; -1 = unlimited).
    #[arg(long, allow_negative_numbers = true)]
    max_depth: Option<i64>,
    #[arg(long, value_enum, default_value_t = Method::Pt)]
    method: Method,
    /// Russian roulette strategy.
    #[arg(long, value_enum, default_value_t = RouletteMode::Classic)]
    rr: RouletteMode,
    /// ADRRS's weight-window ratio s (upper/lower bound, ≥ 1): paths whose
    /// expected contribution is below 2/(1+s) of the pixel's are played.
    /// The paper's 5 kills the most; wider windows add less variance.
    #[arg(long, default_value_t = ltcguide::guiding::adrrs::PAPER_WINDOW)]
    adrrs_window: f32,
    /// Write render statistics as JSON.
    #[arg(long)]
    stats_json: Option<PathBuf>,
    /// Product guiding: child-integral implementation (the paper's Table 1 variants).
    #[arg(long, value_enum, default_value_t = KernelArg::Simd)]
    product_kernel: KernelArg,
    #[command(flatten)]
    product: ProductArgs,
    #[command(flatten)]
    guided: GuidedArgs,
    /// Guided methods: fixed probability of BSDF sampling (default: learned per spatial leaf by Adam).
    #[arg(long)]
    bsdf_fraction: Option<f32>,
    /// Extra images: `alpha` writes the learned BSDF fraction at the first
    /// vertex (guided methods) as OUT-alpha.exr and a false-colour PNG.
    #[arg(long, value_enum)]
    aov: Vec<Aov>,
    /// Run every part of the method even where the per-scene plan would
    /// leave it out or fall back to unguided path tracing.
    #[arg(long)]
    no_plan: bool,
    /// Guided methods: c in the SD-tree's spatial split rule (a leaf splits
    /// once it holds more than c·√(2^k) samples after iteration k).
    /// Default: 12000 (Müller et al.'s value for 1280×720) scaled by the
    /// image's pixel count, so leaves see the same share of each pass.
    #[arg(long)]
    spatial_threshold: Option<f64>,
    /// Guided methods: λ of the learned BSDF fraction's L2 term λθ²/2, which
    /// pulls α towards ½ (default 0.01, Müller's; 0.1 lowered both guided
    /// methods' relMSE on three glossy pack scenes at 32 and 128 spp and
    /// raised the product's on veach-ajar, and lowered both on all four at
    /// 240 CPU s over five seeds, docs/results-reading.md, sessions 41–43).
    #[arg(long, conflicts_with = "bsdf_fraction")]
    bsdf_fraction_l2: Option<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum Aov {
    Alpha,
}

/// `--product-kernel`: naive = exact clipping, no diffuse precomputation,
/// scalar f64; optimized = sphere clipping + precomputed diffuse form
/// factors, scalar f32; simd = optimized, 16 lanes wide.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum KernelArg {
    Naive,
    Optimized,
    Simd,
}

impl From<KernelArg> for ProductKernel {
    fn from(k: KernelArg) -> Self {
        match k {
            KernelArg::Naive => ProductKernel::Naive,
            KernelArg::Optimized => ProductKernel::Optimized,
            KernelArg::Simd => ProductKernel::Simd,
        }
    }
}

const ALPHA_NEEDS_GUIDING: &str =
    "--aov alpha needs a guided method (--method radiance or product)";

pub fn cmd_render(args: &RenderArgs) -> Result<(), String> {
    // The arguments first: a bad one fails before a scene is loaded.
    let budget = match (args.spp, args.time) {
        (Some(n), _) => Budget::Spp(n),
        (None, Some(t)) => Budget::Seconds(t),
        (None, None) => Budget::Spp(64),
    };
    budget.check()?;
    if args.clock == TimeBase::Cpu && !matches!(budget, Budget::Seconds(_)) {
        return Err("--clock cpu measures a --time budget; a sample budget has no clock".into());
    }
    if let Some(d) = args.max_depth
        && d != -1
        && d < 1
    {
        return Err(format!("--max-depth must be -1 or at least 1, got {d}"));
    }
    if let Some(c) = args.spatial_threshold {
        ltcguide::guiding::sdtree::check_split_threshold(c)?;
    }
    if let Some(l) = args.bsdf_fraction_l2 {
        ltcguide::guiding::adam::check_l2(l)?;
    }
    ltcguide::guiding::adrrs::check_window(args.adrrs_window)?;
    ltcguide::render::check_guide_support(args.method, args.guided.guide_support)?;
    ltcguide::guiding::defensive::check_radiance_share(args.product.radiance_share)?;
    if let Some(a) = args.bsdf_fraction {
        ltcguide::render::check_bsdf_fraction(a)?;
        if a == 0.0 {
            eprintln!(
                "warning: --bsdf-fraction 0 disables BSDF sampling; directions the guide does not cover get no samples, so the image can be biased"
            );
        }
    }
    if args.out.extension().and_then(|e| e.to_str()) != Some("exr") {
        return Err(format!(
            "--out must name an .exr file, got '{}'",
            args.out.display()
        ));
    }
    if args.method == Method::Pt && args.rr == RouletteMode::Adrrs {
        // It ran, and played Mitsuba's roulette: path tracing holds no
        // adjoint estimate for ADRRS to aim at.
        return Err(
            "--rr adrrs needs a guide's adjoint estimates, which --method pt has none of; \
             use --method radiance or product, or --rr classic"
                .into(),
        );
    }
    let alpha_aov = args.aov.contains(&Aov::Alpha);
    if alpha_aov && args.method == Method::Pt {
        return Err(ALPHA_NEEDS_GUIDING.into());
    }
    let scene = load(&args.scene)?;
    let max_depth = match args.max_depth {
        None => scene.max_depth,
        Some(-1) => None,
        Some(d) => Some(d as u32),
    };
    let nee = if args.no_nee {
        false
    } else {
        args.nee || args.method == Method::Pt
    };
    let opts = RenderOptions {
        method: args.method,
        budget,
        seed: args.seed,
        threads: args.threads,
        path: PathSettings {
            nee,
            max_depth,
            roulette: args.rr,
            adrrs_window: args.adrrs_window,
            defer_guide_pdf: !args.guided.eager_guide_pdf,
        },
        progress: true,
        snapshot_times: Vec::new(),
        bsdf_fraction: args.bsdf_fraction,
        product_kernel: args.product_kernel.into(),
        training_stop: args.guided.training_stop,
        cosine_lobes: args.product.cosine_lobes,
        product_vertices: args.product.product_vertices,
        pixel_reuse: !args.product.no_pixel_reuse,
        radiance_share: args.product.radiance_share(),
        guide_support: args.guided.guide_support,
        use_plan: !args.no_plan,
        spatial_threshold: args.spatial_threshold,
        bsdf_fraction_l2: args.bsdf_fraction_l2,
        bsdf_fraction_learning: args.guided.bsdf_fraction_learning,
        time_base: args.clock,
    };
    let plan = ltcguide::render::run_plan(&scene, &opts);
    if alpha_aov && !plan.guiding {
        return Err(format!(
            "--aov alpha: this run learns no BSDF fraction ({}); --no-plan forces guiding",
            plan.reasons.join("; ")
        ));
    }
    // Every file the render will write, checked before it starts: a path
    // named twice would have one output replace another, and an unwritable
    // one would fail after the render with half the outputs written.
    let png = args.out.with_extension("png");
    let mut outputs = vec![
        ("--out", args.out.clone()),
        ("the PNG preview", png.clone()),
    ];
    if alpha_aov {
        let (exr, png) = ltcguide::guiding::aov::alpha_aov_paths(&args.out);
        outputs.push(("the alpha AOV", exr));
        outputs.push(("the alpha AOV's PNG", png));
    }
    if let Some(path) = &args.stats_json {
        outputs.push(("--stats-json", path.clone()));
    }
    ltcguide::film::check_distinct_outputs(&outputs)?;
    for (_, path) in &outputs {
        ltcguide::film::ensure_writable(path)?;
    }
    eprintln!("{}", plan.line());
    let product_kernels = plan.method == Method::Product && plan.ltc_glossy;
    if let Some(note) = ltcguide::ltc::lanes::layout_note(product_kernels) {
        eprintln!("{note}");
    }
    let result = render(&scene, &opts)?;
    write_rgb(
        &args.out,
        result.image.width,
        result.image.height,
        &result.image.pixels,
    )?;
    write_png(&png, &result.image)?;
    let s = &result.stats;
    if let Some(g) = s.guiding.as_ref() {
        for note in [&g.weights_check, &g.fallback, &g.fallback_declined] {
            if !note.is_empty() {
                eprintln!("{note}");
            }
        }
    }
    let left_out = s.guiding.as_ref().map_or(0, |g| g.left_out_spp);
    let spp = if left_out > 0 {
        format!(
            "{} spp ({left_out} guided spp before the fallback left out)",
            s.spp
        )
    } else {
        format!("{} spp", s.spp)
    };
    if s.clock_read_failures > 0 {
        eprintln!(
            "warning: {} reads of the CPU clock failed; the clock advanced by wall time there",
            s.clock_read_failures
        );
    }
    let cpu_time = match s.time_base {
        TimeBase::Cpu if s.threads > 1 => format!(
            ", {:.2} CPU s per thread, {:.2} s of it single-threaded work charged in full",
            s.clock_seconds, s.clock_serial_seconds
        ),
        TimeBase::Cpu => format!(", {:.2} CPU s per thread", s.clock_seconds),
        TimeBase::Wall => String::new(),
    };
    eprintln!(
        "{}: {spp} in {:.2} s{cpu_time} ({:.3} Mpaths/s, {:.2} Mrays/s, {} threads) -> {} and {}",
        s.scene,
        s.seconds,
        s.paths_per_second / 1e6,
        s.rays_per_second / 1e6,
        s.threads,
        args.out.display(),
        png.display()
    );
    if let Some(learned) = s
        .guiding
        .as_ref()
        .map(|g| g.learned_shares)
        .filter(|l| l.leaves > 0)
    {
        eprintln!(
            "learned radiance share: {:.3} weighted by steps over {} leaves (p10 {:.3}, median {:.3}, p90 {:.3})",
            learned.mean, learned.leaves, learned.p10, learned.median, learned.p90
        );
    }
    let guarded = s.guards.total();
    if guarded > 0 {
        println!("guards: {}", s.guards.describe());
        eprintln!("warning: {guarded} NaN/Inf or degenerate values guarded (zeroed or left out)");
    }
    if alpha_aov {
        let Some(tree) = &result.tree else {
            return Err(ALPHA_NEEDS_GUIDING.into());
        };
        if s.plan
            .as_deref()
            .is_some_and(|p| p.contains(ltcguide::guiding::trial::FALLBACK_IMAGE))
        {
            eprintln!(
                "note: the image holds path tracing's passes alone; the alpha AOV shows the \
                 fractions guiding had learned when its trial ended"
            );
        }
        ltcguide::guiding::aov::write_alpha_aov(&scene, tree, args.bsdf_fraction, &args.out)?;
    }
    if let Some(path) = &args.stats_json {
        let json = serde_json::to_string_pretty(s).map_err(|e| e.to_string())?;
        ltcguide::film::write_atomic(path, json.as_bytes())?;
    }
    Ok(())
}
