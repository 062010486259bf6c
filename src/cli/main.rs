//! The `ltcguide` command line.

// `!(x > 0.0)` rejects NaN with the non-positive values (as in the library).
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod render_command;
mod study_commands;

use clap::{Args, Parser, Subcommand};
use ltcguide::film::exr_io::read_valid_image;
use ltcguide::film::metrics::{WORST_PIXEL_FRACTION, mae, mean_bias, relmse, relmse_tail};
use ltcguide::guiding::adam::FractionLearning;
use ltcguide::guiding::product::CosineLobes;
use ltcguide::guiding::schedule::TrainingStop;
use ltcguide::guiding::support::GuideSupport;
use ltcguide::scene::{Scene, load_scene};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Practical product path guiding with Linearly Transformed Cosines.
#[derive(Parser)]
#[command(name = "ltcguide", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to an EXR and a PNG preview.
    Render(render_command::RenderArgs),
    /// Print MAE and relMSE of an image against a reference (DESIGN.md §6), the share of
    /// relMSE in the worst 0.1 % of pixels with relMSE over the rest (fireflies or broad noise),
    /// and the ratio of the image's mean to the reference's with its z-score from 16×16-pixel
    /// blocks (bias beyond the noise of both images).
    Error { image: PathBuf, reference: PathBuf },
    /// Print what a scene contains.
    Info {
        /// Scene file (Mitsuba 3 XML subset), or a folder holding scene.xml.
        scene: PathBuf,
    },
    /// Equal-time comparison of methods: error-versus-time curves, summary and images.
    Compare(study_commands::CompareArgs),
    /// Redraw a compare folder's curves.svg, run count, final-errors and time-to-error tables from
    /// its curves.csv, without rendering (for pages made before the curves' aggregation changed).
    Replot {
        /// Folders written by `compare --out`.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
    },
    /// Pool the runs of several comparisons of one scene (same budget, methods and settings,
    /// different seeds: `compare --first-run`) into one folder: curves, summary and
    /// time-to-error table recomputed from the pooled curves.csv.
    Merge {
        /// Output folder (may be one of the sources, their images staying where they are, or an
        /// earlier merge's output; another comparison there is refused without --overwrite).
        #[arg(long)]
        out: PathBuf,
        /// Replace a comparison in --out that is neither a source nor an earlier merge's output:
        /// its files (curves, runs, summary, images; no other file) are removed first.
        #[arg(long)]
        overwrite: bool,
        /// Folders written by `compare --out`.
        #[arg(required = true, num_args = 2..)]
        sources: Vec<PathBuf>,
    },
    /// The paper's Table 1: cost of N spp per product kernel (naive, optimized, simd), and what the per-scene plan saves.
    Ablation {
        /// Scene file (Mitsuba 3 XML subset), or a folder holding scene.xml.
        scene: PathBuf,
        #[arg(long, default_value_t = 64)]
        spp: u32,
        #[arg(long, default_value_t = 0)]
        threads: usize,
    },
    /// Where product guiding wins or loses against radiance guiding: per-sample variance,
    /// cost, the guide distributions at a fixed BSDF fraction, approximation error and roulette,
    /// each a side-by-side ratio.
    Attribute(ltcguide::experiment::attribution::AttributeArgs),
    /// Fit the LTC table to GGX·cos (Heitz et al. 2016) and write it with its error summary.
    FitLtc {
        /// Output directory (the committed table lives in data/).
        #[arg(long, default_value = "data")]
        out: PathBuf,
        /// Nodes per axis over (α, θ_o).
        #[arg(long, default_value_t = 128)]
        resolution: usize,
        #[arg(long, default_value_t = 0)]
        threads: usize,
    },
}

/// The guided methods' training schedule and guide support, shared by
/// render and compare.
#[derive(Args, Clone, Debug)]
pub struct GuidedArgs {
    /// Radiance guiding: where its weights send samples. `sphere` (default,
    /// Müller et al. 2017): over the whole sphere, so at a surface some fall
    /// below it and end their path (26 % of its guided samples on
    /// staircase). `hemisphere`: each cell's radiance times its share above
    /// the shading plane, at surfaces that only reflect (0.2 % below). It
    /// measured slower at equal time: the paths it no longer ends cost 1.5×
    /// per sample for little less variance per sample (docs/results-reading.md,
    /// session 46).
    #[arg(long, value_enum, default_value_t = GuideSupport::Sphere)]
    pub guide_support: GuideSupport,
    /// Guided methods: when training ends and the final iteration starts.
    /// `budget` (default): once the next iteration would leave less than its
    /// own length (Müller 2017). `variance`: also once the extrapolated
    /// final variance rises (Müller 2019), which stopped training early on
    /// scenes whose learning sets in late (docs/results-reading.md, session 32).
    #[arg(long, value_enum, default_value_t = TrainingStop::Budget)]
    pub training_stop: TrainingStop,
    /// Guided methods: how each spatial leaf learns its BSDF fraction α.
    /// `kl` (default, Müller 2019): Adam on the KL divergence to the
    /// integrand. `variance-grid`: the fraction of a fixed grid whose
    /// estimated second moment over the leaf's training samples is least.
    #[arg(long, value_enum, default_value_t = FractionLearning::Kl)]
    pub bsdf_fraction_learning: FractionLearning,
    /// Guided methods without NEE: compute the guide's pdf of every BSDF
    /// sample at once. By default the pdf of a BSDF sample at a path's first
    /// guided vertex (a descent, two under product weights) is computed
    /// only if the path brings radiance, which most paths without NEE do
    /// not; the estimator is the same, only roulette reads a stand-in
    /// meanwhile (docs/results-reading.md, session 62).
    #[arg(long)]
    pub eager_guide_pdf: bool,
}

/// Product guiding's settings, shared by render and compare.
#[derive(Args, Clone, Debug)]
pub struct ProductArgs {
    /// Product guiding at vertices whose lobes are all cosines (diffuse,
    /// GGX with α > 0.5): `radiance` weights (default; the cosine product
    /// measured at half their efficiency with NEE, and without NEE less
    /// variance per sample but more time, so less efficient at equal time,
    /// docs/results-reading.md, sessions 7 and 67) or the paper's cosine
    /// `product`.
    #[arg(long, value_enum, default_value_t = CosineLobes::Radiance)]
    pub cosine_lobes: CosineLobes,
    /// Product guiding: the first N vertices of each path take product
    /// weights, deeper ones radiance weights (default 1: with NEE deeper
    /// vertices' product measured at 13–32 % of the run's CPU for no
    /// resolvable variance; without NEE it lowers the variance per sample
    /// but costs more than it saves at equal time, docs/results-reading.md,
    /// sessions 7 and 67); 0 = every vertex, the paper's setting.
    #[arg(long, default_value_t = ltcguide::guiding::product::DEFAULT_PRODUCT_VERTICES)]
    pub product_vertices: u32,
    /// Product guiding: every path computes its own first product lobe, as
    /// in the paper. By default the paths of a pixel and of its neighbours
    /// in a row block reuse a first vertex's lobe and its child integrals
    /// while it matches theirs (same lobes within 30 %, normal and ω_o
    /// within α/10); product then runs at 0.84–0.93× radiance guiding's
    /// spp/s on staircase, about 0.88× on average (docs/results-reading.md).
    #[arg(long)]
    pub no_pixel_reuse: bool,
    /// Product guiding: the share β of guided samples at product-weighted
    /// vertices drawn from the radiance descent instead of the product's,
    /// in [0, 1); the pdf is the mixture. The tree's radiance is blurred
    /// over a leaf, and inside that blur the product follows the BSDF
    /// where the light may not be (docs/results-reading.md, session 52).
    /// 0: the paper's product alone.
    #[arg(long, default_value_t = ltcguide::guiding::defensive::DEFAULT_RADIANCE_SHARE)]
    pub radiance_share: f32,
    /// Product guiding: learn the radiance share per spatial leaf, starting
    /// from --radiance-share, by the BSDF fraction's Adam on the same KL
    /// loss (`true` or `false`).
    #[arg(long, default_value_t = ltcguide::guiding::defensive::DEFAULT_SHARE_LEARNING, action = clap::ArgAction::Set)]
    pub learn_radiance_share: bool,
    /// Product guiding: what a learned radiance share minimises, the KL
    /// divergence to the integrand (as the BSDF fraction) or the
    /// estimator's variance.
    #[arg(long, value_enum, default_value_t = ltcguide::guiding::share_learning::ShareLearning::default())]
    pub radiance_share_learning: ltcguide::guiding::share_learning::ShareLearning,
}

impl ProductArgs {
    pub fn radiance_share(&self) -> ltcguide::guiding::defensive::RadianceShare {
        ltcguide::guiding::defensive::RadianceShare {
            value: self.radiance_share,
            learned: self.learn_radiance_share,
            learning: self.radiance_share_learning,
        }
    }
}

/// Bad input (scene, image, arguments): exit code 2, like clap's own errors.
const EXIT_BAD_INPUT: u8 = 2;

/// Keeps memory the renderer frees for its next allocations instead of
/// returning it to the system. Each guided training iteration allocates
/// hundreds of MB of path records and per-leaf work and frees them;
/// glibc's dynamic thresholds handed such blocks back (munmap, heap
/// trimming), and the next iteration faulted them in and zeroed them
/// again. Blocks under 32 MiB (the largest threshold glibc accepts) now
/// come from the heap, which is never trimmed. Measured on staircase
/// (radiance guiding, 16 spp, one thread): system time 0.47–0.79 s →
/// 0.29–0.35 s (a path tracer's: 0.16 s), CPU time 3–7 % lower side by
/// side; the peak is reached either way (two threads: 0.77–0.80 →
/// 0.85 GB, each thread's heap keeping its own).
fn keep_freed_memory() {
    // SAFETY: mallopt only sets allocator parameters; it is called before
    // any thread starts. The return values (0 on failure) only mean that
    // the defaults stay, which is correct, only slower.
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
    }
}

fn main() -> ExitCode {
    // Output piped into `head` and the like: end quietly when the reader
    // closes the pipe, as Unix tools do, instead of panicking in println!.
    // SAFETY: restoring a signal's default action before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    keep_freed_memory();
    let cli = Cli::parse();
    // No subcommand: render the default scene with default settings.
    let command = cli
        .command
        .or_else(|| Cli::parse_from(["ltcguide", "render"]).command)
        .expect("the render subcommand parses without arguments");
    let result = match command {
        Command::Render(args) => render_command::cmd_render(&args),
        Command::Error { image, reference } => cmd_error(&image, &reference),
        Command::Info { scene } => cmd_info(&scene),
        Command::Compare(args) => study_commands::cmd_compare(&args),
        Command::Replot { dirs } => study_commands::cmd_replot(&dirs),
        Command::Merge {
            out,
            sources,
            overwrite,
        } => study_commands::cmd_merge(&out, &sources, overwrite),
        Command::Ablation {
            scene,
            spp,
            threads,
        } => study_commands::cmd_ablation(&scene, spp, threads),
        Command::Attribute(args) => study_commands::cmd_attribute(&args),
        Command::FitLtc {
            out,
            resolution,
            threads,
        } => cmd_fit_ltc(out, resolution, threads),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(EXIT_BAD_INPUT)
        }
    }
}

/// Finds the scene relative to the working directory, or to the crate root
/// for the default scene, so `cargo run --release` works from anywhere.
fn resolve_scene(path: &Path) -> PathBuf {
    if path.exists() || path.is_absolute() {
        return path.to_path_buf();
    }
    let in_crate = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    if in_crate.exists() {
        in_crate
    } else {
        path.to_path_buf()
    }
}

pub fn load(path: &Path) -> Result<Scene, String> {
    let scene = load_scene(&resolve_scene(path)).map_err(|e| e.to_string())?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    Ok(scene)
}

fn cmd_fit_ltc(out_dir: PathBuf, resolution: usize, threads: usize) -> Result<(), String> {
    if resolution < 2 {
        return Err("--resolution must be at least 2".into());
    }
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| format!("cannot create '{}': {e}", out_dir.display()))?;
    let opts = ltcguide::ltc::FitOptions {
        out_dir,
        resolution,
        threads,
        verbose: std::io::IsTerminal::is_terminal(&std::io::stderr()),
        ..Default::default()
    };
    let report = ltcguide::ltc::run_fit(&opts)?;
    println!(
        "fitted {r}×{r} in {:.1} s: L1 mean {:.4}, median {:.4}, p95 {:.4}, max {:.4}",
        report.seconds,
        report.mean_l1,
        report.median_l1,
        report.p95_l1,
        report.max_l1,
        r = resolution
    );
    println!("table   {}", report.table_path.display());
    println!("errors  {}", report.csv_path.display());
    println!("summary {}", report.summary_path.display());
    Ok(())
}

/// Side of the pixel blocks whose means give `error`'s mean-ratio noise:
/// large enough that neighbouring blocks' errors are nearly independent,
/// small enough that a 512×512 image has 1,024 of them.
const BIAS_BLOCK_PIXELS: usize = 16;

fn cmd_error(image: &Path, reference: &Path) -> Result<(), String> {
    let img = read_valid_image(image)?;
    let reference = read_valid_image(reference)?;
    println!("mae {:.6e}", mae(&img, &reference)?);
    println!("relmse {:.6e}", relmse(&img, &reference)?);
    // How much of relMSE a few firefly pixels carry (see RelmseTail). An
    // image of one pixel has no tail, and still gets every other line.
    match relmse_tail(&img, &reference, WORST_PIXEL_FRACTION) {
        Ok(tail) => {
            println!(
                "relmse_worst_0.1%_share {:.4} ({} pixels)",
                tail.worst_share, tail.worst_pixels
            );
            println!("relmse_without_worst_0.1% {:.6e}", tail.without_worst);
        }
        Err(why) => println!("relmse_worst_0.1% not computed: {why}"),
    }
    // Whether the image is biased, beyond the noise of both images.
    // A small image or a black reference still gets the metrics above.
    match mean_bias(&img, &reference, BIAS_BLOCK_PIXELS) {
        Ok(bias) => println!(
            "mean_ratio {:.5} (image {:.6e}, reference {:.6e}; difference {:+.3e} ± {:.2e}, z {:+.2}, {} blocks of {b}×{b} pixels)",
            bias.ratio(),
            bias.image_mean,
            bias.reference_mean,
            bias.difference(),
            bias.standard_error,
            bias.z(),
            bias.blocks,
            b = BIAS_BLOCK_PIXELS
        ),
        Err(why) => println!("mean_ratio not computed: {why}"),
    }
    Ok(())
}

fn cmd_info(path: &Path) -> Result<(), String> {
    let scene = load(path)?;
    println!("scene      {}", scene.name);
    println!("file       {}", scene.file.display());
    println!("image      {}x{}", scene.camera.width, scene.camera.height);
    println!("triangles  {}", scene.triangle_count());
    println!("primitives {}", scene.geometry.len());
    println!("shapes     {}", scene.shapes.len());
    println!("materials  {}", scene.materials.len());
    println!("lights     {}", scene.lights.lights.len());
    println!(
        "max_depth  {}",
        scene
            .max_depth
            .map(|d| d.to_string())
            .unwrap_or_else(|| "unlimited".into())
    );
    println!("bounds     {:?} .. {:?}", scene.bounds.0, scene.bounds.1);
    println!("bvh        {}", scene.accel.summary());
    Ok(())
}
