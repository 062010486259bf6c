//! `ltcguide attribute`: where product guiding wins or loses against
//! radiance guiding on one scene, factor by factor.
//!
//! The equal-time question ("is the product better?") mixes four things:
//! how much less variance a product sample carries, how much more it costs,
//! how much of the mixture the learned BSDF fraction α leaves to the guide,
//! and how roulette trades path length for variance. Each factor here is a
//! ratio of two renders of the same scene with the same seed and settings,
//! run side by side on equal shares of the threads (so that a shared
//! machine's drift meets both), with every part of the method forced on
//! (`use_plan` off). A ratio below 1 favours the product.
//!
//! Variances come from the renders' own samples, so no reference image is
//! needed:
//! - *variance per sample* is the final iteration's mean over pixels of the
//!   single-sample variance (what one more sample costs in variance);
//! - *relative variance per sample* is the same, each pixel's variance
//!   over (R² + 0.01) as below: the gain per sample where relMSE weighs it,
//!   the dark pixels as much as the bright ones;
//! - *expected relMSE* is the mean over pixels of the combined image's
//!   variance over (R² + 0.01), the normaliser of DESIGN §6's relMSE, with
//!   R the mean of the pair's two images (one normaliser for both, so that
//!   neither image's noise enters its own scale);
//! - *equal-time relMSE* is expected relMSE × seconds: relMSE falls as
//!   1/time, so this ratio is what the two methods reach in equal time at
//!   this budget, training included, without the noise of an error against
//!   a reference.
//!
//! Heavy-tailed estimators (a firefly carries most of a hard scene's
//! relMSE) make every variance from a few samples an underestimate of the
//! tail: read the per-seed columns before the mean.

use super::attribution_report::{class_markdown, glossy_markdown, markdown};
use super::pixel_classes::{PixelClass, class_counts, class_sums, classify};
use crate::film::image::Image;
use crate::film::metrics::RELMSE_EPSILON;
use crate::guiding::aov::alpha_aov;
use crate::guiding::product::CosineLobes;
use crate::guiding::sdtree::SdTree;
use crate::integrator::path::{PathSettings, RouletteMode};
use crate::ltc::ProductKernel;
use crate::render::{
    Budget, Method, RenderOptions, RenderResult, TimeBase, render_side_by_side, side_by_side_share,
};
use crate::scene::Scene;

/// `ltcguide attribute`'s arguments.
#[derive(clap::Args, Clone, Debug)]
pub struct AttributeArgs {
    /// Scene file (Mitsuba 3 XML subset), or a folder holding scene.xml.
    pub scene: std::path::PathBuf,
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// Seeds 1..=N; each factor is one side-by-side pair per seed.
    #[arg(long, default_value_t = 2)]
    pub seeds: u32,
    /// Split evenly between the two renders of a pair (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Next-event estimation for both methods (the paper's setting is off).
    #[arg(long)]
    pub nee: bool,
    /// Roulette of both methods (the paper's: adrrs).
    #[arg(long, value_enum, default_value_t = RouletteMode::Adrrs)]
    pub rr: RouletteMode,
    /// The roulette the roulette factor compares with.
    #[arg(long, value_enum, default_value_t = RouletteMode::Classic)]
    pub other_rr: RouletteMode,
    /// BSDF fraction of the guide-distribution factor, in [0, 1).
    #[arg(long, default_value_t = 0.2)]
    pub guide_fraction: f32,
    /// Leave out the exact-integrals factor (its product runs ~3× longer).
    #[arg(long)]
    pub no_exact: bool,
    /// λ of the learned BSDF fraction's L2 term, for both methods' learned
    /// fractions (as for render; default 0.01).
    #[arg(long)]
    pub bsdf_fraction_l2: Option<f64>,
    /// How both methods' leaves learn their BSDF fraction (as for render).
    #[arg(long, value_enum, default_value_t = crate::guiding::adam::FractionLearning::Kl)]
    pub bsdf_fraction_learning: crate::guiding::adam::FractionLearning,
    /// The product's share of guided samples drawn from radiance weights
    /// (as for render; 0: the paper's product alone).
    #[arg(long, default_value_t = crate::guiding::defensive::DEFAULT_RADIANCE_SHARE)]
    pub radiance_share: f32,
    /// Learn the product's radiance share per spatial leaf, starting from
    /// --radiance-share (as for render).
    #[arg(long, default_value_t = crate::guiding::defensive::DEFAULT_SHARE_LEARNING, action = clap::ArgAction::Set)]
    pub learn_radiance_share: bool,
    /// What a learned radiance share minimises (as for render).
    #[arg(long, value_enum, default_value_t = crate::guiding::share_learning::ShareLearning::default())]
    pub radiance_share_learning: crate::guiding::share_learning::ShareLearning,
    /// The product's weights at vertices whose lobes are all cosines (as
    /// for render; `product` is the paper's).
    #[arg(long, value_enum, default_value_t = CosineLobes::Radiance)]
    pub cosine_lobes: CosineLobes,
    /// The first N vertices of each path take product weights (as for
    /// render; 0 = every vertex, the paper's).
    #[arg(long, default_value_t = crate::guiding::product::DEFAULT_PRODUCT_VERTICES)]
    pub product_vertices: u32,
    /// Every product path computes its own first lobe, as in the paper
    /// (as for render).
    #[arg(long)]
    pub no_pixel_reuse: bool,
    /// What the seconds factors measure: each render's own CPU seconds per
    /// thread (the two renders of a pair run at once, and the scheduler
    /// does not share the cores between them evenly: `src/cpu_clock.rs`),
    /// or wall-clock seconds.
    #[arg(long, value_enum, default_value_t = TimeBase::Cpu)]
    pub clock: TimeBase,
}

impl AttributeArgs {
    /// The options, with the scene's `max_depth`.
    pub fn options(&self, max_depth: Option<u32>) -> AttributionOptions {
        AttributionOptions {
            spp: self.spp,
            seeds: self.seeds,
            threads: self.threads,
            path: PathSettings {
                nee: self.nee,
                max_depth,
                roulette: self.rr,
                adrrs_window: crate::guiding::adrrs::PAPER_WINDOW,
                defer_guide_pdf: true,
            },
            guide_fraction: self.guide_fraction,
            other_roulette: self.other_rr,
            exact_integrals: !self.no_exact,
            bsdf_fraction_l2: self.bsdf_fraction_l2,
            bsdf_fraction_learning: self.bsdf_fraction_learning,
            radiance_share: crate::guiding::defensive::RadianceShare {
                value: self.radiance_share,
                learned: self.learn_radiance_share,
                learning: self.radiance_share_learning,
            },
            cosine_lobes: self.cosine_lobes,
            product_vertices: self.product_vertices,
            pixel_reuse: !self.no_pixel_reuse,
            clock: self.clock,
            progress: true,
        }
    }
}

#[derive(Clone, Debug)]
pub struct AttributionOptions {
    pub spp: u32,
    /// Seeds 1..=seeds, one pair of renders per factor and seed.
    pub seeds: u32,
    /// 0 = all cores, split evenly between the two sides of a pair.
    pub threads: usize,
    /// The settings both methods run with (the paper's: no NEE, ADRRS).
    pub path: PathSettings,
    /// The fixed BSDF fraction of the guide-distribution factor: small, so
    /// that most samples follow the guide and its distribution shows.
    pub guide_fraction: f32,
    /// The roulette the roulette factor compares against `path.roulette`.
    pub other_roulette: RouletteMode,
    /// Also run the exact f64 integrals (the slowest pair, ~3× a render).
    pub exact_integrals: bool,
    /// λ of the learned BSDF fraction's L2 term (`None`: Adam's default).
    pub bsdf_fraction_l2: Option<f64>,
    /// How the learned BSDF fractions learn.
    pub bsdf_fraction_learning: crate::guiding::adam::FractionLearning,
    /// The product's radiance share (`guiding::defensive`).
    pub radiance_share: crate::guiding::defensive::RadianceShare,
    /// The product's weights at cosine-only vertices.
    pub cosine_lobes: CosineLobes,
    /// The first this many vertices take product weights (0: every one).
    pub product_vertices: u32,
    /// The product's first lobe reused across neighbouring paths.
    pub pixel_reuse: bool,
    /// The clock of the seconds factors. With several threads per render,
    /// the CPU clock counts the renders' serial phases at 1/threads.
    pub clock: TimeBase,
    pub progress: bool,
}

/// One row of the attribution: a name, what it isolates, and its value
/// per seed.
#[derive(Clone, Debug)]
pub struct Factor {
    pub name: String,
    pub isolates: &'static str,
    pub per_seed: Vec<f64>,
}

impl Factor {
    /// Geometric mean over the seeds (the factors are ratios).
    pub fn mean(&self) -> f64 {
        geometric_mean(&self.per_seed)
    }
}

pub(super) fn geometric_mean(values: &[f64]) -> f64 {
    let logs = values.iter().map(|x| x.ln()).sum::<f64>();
    (logs / values.len().max(1) as f64).exp()
}

/// Rows of [`AttributionOutcome::factors`] the summary line reads.
pub const EXPECTED_RELMSE: usize = 4;
pub const EQUAL_TIME: usize = 5;

/// The relative variance per sample of the final iteration, split by
/// what the product does at the pixels' first vertex.
#[derive(Clone, Debug)]
pub struct ClassSplit {
    pub class: PixelClass,
    /// Fraction of the image's pixels.
    pub pixels: f64,
    /// Fraction of radiance guiding's relative variance in these pixels,
    /// mean over the seeds.
    pub radiance_share: f64,
    /// Product / radiance within the class, per seed (NaN where radiance
    /// guiding has none there).
    pub per_seed: Vec<f64>,
}

pub struct AttributionOutcome {
    pub factors: Vec<Factor>,
    pub by_class: Vec<ClassSplit>,
    /// Where the product acts first (glossy first vertices), the relative
    /// variance per sample of the final iteration under each setting pair:
    /// see [`GLOSSY_ROWS`]. Empty when no pixel's first vertex is glossy.
    pub at_glossy: Vec<Factor>,
    /// Mean learned BSDF fraction at the first vertex, (product, radiance),
    /// per seed.
    pub alpha: Vec<(f64, f64)>,
    pub markdown: String,
}

/// The rows of [`AttributionOutcome::at_glossy`], in order: the learned
/// pair, the fixed-fraction pair, each method at the fixed fraction over
/// itself learned, and (with exact integrals) the product exact over the
/// guider's. Each ratio weighs its two renders by their mean image, so row
/// 2 is row 1 × row 3 / row 4 only up to the normalisers: rows 3 and 4 say
/// which method fixing α moved.
pub const GLOSSY_ROWS: [(&str, &str); 5] = [
    (
        "product / radiance, learned α",
        "the product's gain where it acts",
    ),
    (
        "product / radiance, BSDF fraction fixed",
        "the same with α the same for both",
    ),
    (
        "product: fixed / learned α",
        "what learning α does to the product there",
    ),
    (
        "radiance: fixed / learned α",
        "what learning α does to radiance guiding there",
    ),
    (
        "product: exact f64 integrals / the guider's",
        "the LTC approximation there (product against product)",
    ),
];

/// The name [`GLOSSY_ROWS`]' exact-integrals row starts with.
const EXACT_ROW: &str = "product: exact";

/// The final iteration's single-sample variance over the pixels whose first
/// vertex is glossy, each weighed by `norm`, summed.
fn glossy_relative_variance(glossy: &[bool], norm: &[f64], f: &Figures) -> f64 {
    if f.final_pixel_variance.len() != glossy.len() {
        return f64::NAN;
    }
    f.final_pixel_variance
        .iter()
        .zip(norm)
        .zip(glossy)
        .filter(|(_, g)| **g)
        .map(|((v, w), _)| v * w)
        .sum()
}

/// What one render contributes to the factors.
struct Figures {
    seconds: f64,
    final_seconds_per_spp: f64,
    final_variance: f64,
    /// The final iteration's per-pixel single-sample variance.
    final_pixel_variance: Vec<f64>,
    image: Image,
    variance: Vec<f64>,
    tree: Option<SdTree>,
}

impl Figures {
    /// Mean learned BSDF fraction at the pixels' first vertices (one
    /// camera ray per pixel, so only for the pair that reports it).
    fn mean_alpha(&self, scene: &Scene) -> f64 {
        let alphas: Vec<f32> = self
            .tree
            .as_ref()
            .map(|t| alpha_aov(scene, t).into_iter().flatten().collect())
            .unwrap_or_default();
        alphas.iter().map(|&a| a as f64).sum::<f64>() / alphas.len().max(1) as f64
    }
}

fn figures(r: RenderResult) -> Result<Figures, String> {
    let guiding = r
        .stats
        .guiding
        .as_ref()
        .ok_or("attribution needs guided renders")?;
    let last = guiding
        .iterations
        .last()
        .ok_or("a guided render reported no iteration")?;
    Ok(Figures {
        // The clock's seconds, as the iterations' (wall seconds on the
        // wall clock).
        seconds: r.stats.clock_seconds,
        final_seconds_per_spp: last.seconds / last.spp.max(1) as f64,
        final_variance: last.mean_variance,
        final_pixel_variance: r.last_iteration_variance,
        image: r.image,
        variance: r.variance,
        tree: r.tree,
    })
}

/// Per pixel, 1/(R² + 0.01) with R the mean of the pair's two images (one
/// normaliser for both, so that neither image's noise enters its own
/// scale), channel average.
fn pair_normalisers(a: &Figures, b: &Figures) -> Vec<f64> {
    a.image
        .pixels
        .iter()
        .zip(&b.image.pixels)
        .map(|(pa, pb)| {
            let r = ((*pa + *pb) * 0.5).to_array().map(|c| c as f64);
            r.iter()
                .map(|c| 1.0 / (c * c + RELMSE_EPSILON))
                .sum::<f64>()
                / 3.0
        })
        .collect()
}

/// Means over pixels of two per-pixel variances, each times the pair's
/// normaliser `norm`; NaN when a variance does not cover the image.
fn relative_means(norm: &[f64], va: &[f64], vb: &[f64]) -> (f64, f64) {
    let n = norm.len();
    if va.len() != n || vb.len() != n || n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let sum = |v: &[f64]| v.iter().zip(norm).map(|(&v, w)| v * w).sum::<f64>();
    (sum(va) / n as f64, sum(vb) / n as f64)
}

/// Expected relMSE of each image of a pair, both normalised by the pair's
/// mean image.
fn expected_relmse(a: &Figures, b: &Figures) -> (f64, f64) {
    relative_means(&pair_normalisers(a, b), &a.variance, &b.variance)
}

/// Renders `a` and `b` side by side.
fn side_by_side(
    scene: &Scene,
    a: RenderOptions,
    b: RenderOptions,
) -> Result<(Figures, Figures), String> {
    let mut results = render_side_by_side(scene, &[a, b]).into_iter();
    let mut next = || {
        results
            .next()
            .ok_or("a render is missing")?
            .and_then(figures)
    };
    Ok((next()?, next()?))
}

/// Training takes 1 + 2 spp before the final iteration (or 1 + 2 + 4
/// and a final one of at least 4), which needs 4 for a variance.
const MIN_SPP: u32 = 8;

/// Rejects options no attribution can run with.
pub fn check(opts: &AttributionOptions) -> Result<(), String> {
    if opts.spp < MIN_SPP {
        return Err(format!(
            "--spp must be at least {MIN_SPP}: the final iteration needs 4 samples per pixel for its variance"
        ));
    }
    if opts.seeds == 0 {
        return Err("--seeds must be at least 1".into());
    }
    if !(opts.guide_fraction >= 0.0 && opts.guide_fraction < 1.0) {
        return Err(format!(
            "--guide-fraction must be in [0, 1) (1 would never sample the guide), got {}",
            opts.guide_fraction
        ));
    }
    if opts.other_roulette == opts.path.roulette {
        return Err("the roulette factor needs a roulette other than the run's".into());
    }
    // What every render of the attribution shares, by the renders' own rules.
    RenderOptions {
        budget: Budget::Spp(opts.spp),
        path: opts.path,
        bsdf_fraction_l2: opts.bsdf_fraction_l2,
        bsdf_fraction_learning: opts.bsdf_fraction_learning,
        radiance_share: opts.radiance_share,
        ..Default::default()
    }
    .check()
}

pub fn run_attribution(
    scene: &Scene,
    opts: &AttributionOptions,
) -> Result<AttributionOutcome, String> {
    check(opts)?;
    let side = side_by_side_share(opts.threads, 2);
    let base = |method: Method, seed: u64| RenderOptions {
        method,
        budget: Budget::Spp(opts.spp),
        seed,
        threads: side,
        path: opts.path,
        use_plan: false,
        bsdf_fraction_l2: opts.bsdf_fraction_l2,
        bsdf_fraction_learning: opts.bsdf_fraction_learning,
        radiance_share: opts.radiance_share,
        cosine_lobes: opts.cosine_lobes,
        product_vertices: opts.product_vertices,
        pixel_reuse: opts.pixel_reuse,
        time_base: opts.clock,
        ..Default::default()
    };
    let roulette_name = |r: RouletteMode| format!("{r:?}").to_lowercase();
    let mut rows: Vec<Factor> = [
        (
            "seconds per spp, final iteration",
            "overhead per sample once trained",
        ),
        ("seconds, whole run", "overhead, training included"),
        (
            "variance per sample, final iteration",
            "the product's gain per sample, learned α",
        ),
        (
            "relative variance per sample, final iteration",
            "the same gain, each pixel over (R² + 0.01) as relMSE weighs it",
        ),
        (
            "expected relMSE of the image",
            "the gain at equal spp, training included",
        ),
        ("equal-time relMSE", "the headline: gain × cost"),
    ]
    .into_iter()
    .map(|(name, isolates)| Factor {
        name: name.into(),
        isolates,
        per_seed: Vec::new(),
    })
    .collect();
    let mut fixed = Factor {
        name: format!(
            "variance per sample, BSDF fraction fixed at {}",
            opts.guide_fraction
        ),
        isolates: "the guide distributions themselves, mostly guided",
        per_seed: Vec::new(),
    };
    let mut exact = Factor {
        name: "variance per sample, exact f64 integrals / the guider's".into(),
        isolates: "approximation error (product against product; < 1: exact helps)",
        per_seed: Vec::new(),
    };
    let mut roulette = Factor {
        name: format!(
            "equal-time relMSE, roulette {} instead of {}",
            roulette_name(opts.other_roulette),
            roulette_name(opts.path.roulette)
        ),
        isolates: "roulette",
        per_seed: Vec::new(),
    };
    let mut alpha = Vec::new();
    let classes = classify(scene);
    let counts = class_counts(&classes);
    let mut class_seeds: Vec<([f64; 4], [f64; 4])> = Vec::new();
    let glossy_pixels: Vec<bool> = classes
        .iter()
        .map(|c| matches!(c, PixelClass::Glossy | PixelClass::GlossyCoat))
        .collect();
    let any_glossy = glossy_pixels.contains(&true);
    let mut at_glossy: Vec<Factor> = GLOSSY_ROWS
        .iter()
        .filter(|(name, _)| opts.exact_integrals || !name.starts_with(EXACT_ROW))
        .map(|&(name, isolates)| Factor {
            name: name.into(),
            isolates,
            per_seed: Vec::new(),
        })
        .collect();
    let say = |what: &str, seed: u64| {
        if opts.progress {
            eprintln!("attribute: {what}, seed {seed}, {} spp", opts.spp);
        }
    };
    for seed in 1..=opts.seeds as u64 {
        say("product and radiance, learned α", seed);
        let (p, r) = side_by_side(
            scene,
            base(Method::Product, seed),
            base(Method::Radiance, seed),
        )?;
        let norm = pair_normalisers(&p, &r);
        let (ep, er) = relative_means(&norm, &p.variance, &r.variance);
        let (fp, fr) = relative_means(&norm, &p.final_pixel_variance, &r.final_pixel_variance);
        let by_class = |f: &Figures| {
            let v = f.final_pixel_variance.iter().zip(&norm);
            class_sums(&classes, v.map(|(&v, w)| v * w))
        };
        class_seeds.push((by_class(&p), by_class(&r)));
        // Each ratio weighs its two renders by their own mean image, as the
        // pairs do: a firefly then raises its pixel's normaliser too, where a
        // third render's dark pixel would weigh it by up to 1/0.01.
        let at = |a: &Figures, b: &Figures| {
            let norm = pair_normalisers(a, b);
            glossy_relative_variance(&glossy_pixels, &norm, a)
                / glossy_relative_variance(&glossy_pixels, &norm, b)
        };
        let values = [
            p.final_seconds_per_spp / r.final_seconds_per_spp,
            p.seconds / r.seconds,
            p.final_variance / r.final_variance,
            fp / fr,
            ep / er,
            (ep * p.seconds) / (er * r.seconds),
        ];
        for (row, v) in rows.iter_mut().zip(values) {
            row.per_seed.push(v);
        }
        alpha.push((p.mean_alpha(scene), r.mean_alpha(scene)));

        say("product and radiance, fixed BSDF fraction", seed);
        // A fixed fraction learns nothing, whichever learning the run names.
        let with_fraction = |m| RenderOptions {
            bsdf_fraction: Some(opts.guide_fraction),
            bsdf_fraction_learning: crate::guiding::adam::FractionLearning::Kl,
            ..base(m, seed)
        };
        let (pf, rf) = side_by_side(
            scene,
            with_fraction(Method::Product),
            with_fraction(Method::Radiance),
        )?;
        fixed.per_seed.push(pf.final_variance / rf.final_variance);
        let mut glossy_values = vec![at(&p, &r), at(&pf, &rf), at(&pf, &p), at(&rf, &r)];

        if opts.exact_integrals {
            say("product, exact integrals and the guider's", seed);
            let naive = RenderOptions {
                product_kernel: ProductKernel::Naive,
                ..base(Method::Product, seed)
            };
            let (pn, ps) = side_by_side(scene, naive, base(Method::Product, seed))?;
            exact.per_seed.push(pn.final_variance / ps.final_variance);
            glossy_values.push(at(&pn, &ps));
        }
        if any_glossy {
            for (row, v) in at_glossy.iter_mut().zip(glossy_values) {
                row.per_seed.push(v);
            }
        }

        say("product and radiance, the other roulette", seed);
        let other = |m| {
            let mut o = base(m, seed);
            o.path.roulette = opts.other_roulette;
            o
        };
        let (po, ro) = side_by_side(scene, other(Method::Product), other(Method::Radiance))?;
        let (epo, ero) = expected_relmse(&po, &ro);
        roulette
            .per_seed
            .push((epo * po.seconds) / (ero * ro.seconds));
    }
    rows.push(fixed);
    if opts.exact_integrals {
        rows.push(exact);
    }
    rows.push(roulette);
    if !any_glossy {
        at_glossy.clear();
    }
    for row in rows.iter().chain(&at_glossy) {
        if let Some(bad) = row.per_seed.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
            return Err(format!(
                "'{}' came out {bad}: a render had no usable variance (too few spp?)",
                row.name
            ));
        }
    }
    let n = classes.len().max(1) as f64;
    let by_class: Vec<ClassSplit> = PixelClass::ALL
        .iter()
        .enumerate()
        .filter(|&(c, _)| counts[c] > 0)
        .map(|(c, &class)| ClassSplit {
            class,
            pixels: counts[c] as f64 / n,
            radiance_share: class_seeds
                .iter()
                .map(|(_, r)| r[c] / r.iter().sum::<f64>())
                .sum::<f64>()
                / class_seeds.len().max(1) as f64,
            per_seed: class_seeds
                .iter()
                .map(|(p, r)| if r[c] > 0.0 { p[c] / r[c] } else { f64::NAN })
                .collect(),
        })
        .collect();
    let mut markdown = markdown(scene, opts, side, &rows, &alpha);
    markdown.push_str(&class_markdown(&by_class, opts.cosine_lobes));
    markdown.push_str(&glossy_markdown(&at_glossy, opts.guide_fraction));
    Ok(AttributionOutcome {
        factors: rows,
        by_class,
        at_glossy,
        alpha,
        markdown,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometric_mean_of_ratios() {
        let f = Factor {
            name: String::new(),
            isolates: "",
            per_seed: vec![0.5, 2.0],
        };
        assert!((f.mean() - 1.0).abs() < 1e-12);
    }

    /// The seconds factors are on the renders' clock: a render on the CPU
    /// clock gives the figures its own CPU time per thread, whatever its
    /// wall time (here made absurd, as a starved render's would be).
    #[test]
    fn figures_time_a_render_on_its_clock() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/analytic/sphere_over_plane.xml");
        let scene = crate::scene::load_scene(&path).unwrap();
        let opts = RenderOptions {
            method: Method::Radiance,
            budget: Budget::Spp(4),
            threads: 1,
            use_plan: false,
            time_base: TimeBase::Cpu,
            ..Default::default()
        };
        let mut r = crate::render::render(&scene, &opts).unwrap();
        assert_eq!(r.stats.time_base, TimeBase::Cpu);
        let clock = r.stats.clock_seconds;
        assert!(
            clock > 0.0 && clock <= r.stats.cpu_seconds + 1e-6,
            "{clock}"
        );
        r.stats.seconds = 1e6;
        let f = figures(r).unwrap();
        assert_eq!(f.seconds, clock);
        assert!(f.final_seconds_per_spp > 0.0 && f.final_seconds_per_spp <= clock);
    }
}
