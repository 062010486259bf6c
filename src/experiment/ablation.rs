//! `ltcguide ablation`: the paper's Table 1 — the cost of a fixed number of
//! samples per pixel for each product kernel, as a percentage of the naive
//! one, with the paper's product at every vertex, cosine lobes included,
//! and no plan, so that every kernel runs throughout — and what the
//! per-scene plan and radiance weights at deeper and cosine vertices save.
//!
//! With the plan, a run's strategy trial may hand the rest of its samples
//! to radiance weights or to path tracing; a slower kernel loses that trial
//! sooner, so a kernel timed under the plan would time a different mix of
//! strategies. The plan rows therefore say what each run ended with.

use crate::guiding::product::CosineLobes;
use crate::integrator::path::PathSettings;
use crate::ltc::ProductKernel;
use crate::render::{Budget, Method, RenderOptions, render};
use crate::scene::Scene;
use std::fmt::Write;

#[derive(Clone, Debug)]
pub struct AblationRow {
    pub variant: String,
    pub seconds: f64,
    pub spp: u32,
    pub paths_per_second: f64,
    /// What the run rendered after its strategy trial, from its plan line
    /// ("no trial" for the plan rows run without the plan).
    pub outcome: &'static str,
}

/// What a run whose plan line is `plan` rendered once its strategy trial
/// ended (every run without a trial renders its method as such).
pub fn trial_outcome(plan: Option<&str>) -> &'static str {
    let plan = plan.unwrap_or("");
    if plan.contains(crate::guiding::trial::FALLBACK_IMAGE) {
        "path tracing with NEE: the image holds its passes alone"
    } else if plan.contains(crate::guiding::trial::CHEAPER_WEIGHTS) {
        "radiance weights"
    } else {
        "the method as such"
    }
}

pub struct AblationOutcome {
    pub kernels: Vec<AblationRow>,
    pub plan: Vec<AblationRow>,
    pub plan_line: String,
    pub markdown: String,
}

fn kernel_name(k: ProductKernel) -> &'static str {
    match k {
        ProductKernel::Naive => "naive",
        ProductKernel::Optimized => "optimized",
        ProductKernel::Simd => "simd",
    }
}

pub fn run_ablation(
    scene: &Scene,
    spp: u32,
    threads: usize,
    path: PathSettings,
    progress: bool,
) -> Result<AblationOutcome, String> {
    let options = |method: Method, kernel: ProductKernel, use_plan: bool, paper: bool| {
        RenderOptions {
            method,
            budget: Budget::Spp(spp),
            seed: 1,
            threads,
            path,
            progress,
            product_kernel: kernel,
            // The paper's product: at every vertex, cosine lobes included.
            cosine_lobes: if paper {
                CosineLobes::Product
            } else {
                CosineLobes::Radiance
            },
            product_vertices: if paper {
                0
            } else {
                crate::guiding::product::DEFAULT_PRODUCT_VERTICES
            },
            // ... and its own lobe at every vertex.
            pixel_reuse: !paper,
            // ... and the product's samples alone.
            radiance_share: if paper {
                crate::guiding::defensive::RadianceShare::fixed(0.0)
            } else {
                crate::guiding::defensive::RadianceShare::default()
            },
            use_plan,
            ..Default::default()
        }
    };
    let run = |method: Method,
               kernel: ProductKernel,
               use_plan: bool,
               paper: bool|
     -> Result<AblationRow, String> {
        let r = render(scene, &options(method, kernel, use_plan, paper))?;
        Ok(AblationRow {
            variant: String::new(),
            seconds: r.stats.seconds,
            spp: r.stats.spp,
            paths_per_second: r.stats.paths_per_second,
            outcome: trial_outcome(r.stats.plan.as_deref()),
        })
    };
    let mut kernels = Vec::new();
    for k in [
        ProductKernel::Naive,
        ProductKernel::Optimized,
        ProductKernel::Simd,
    ] {
        if progress {
            eprintln!("ablation: product, {} kernel, {spp} spp", kernel_name(k));
        }
        let mut row = run(Method::Product, k, false, true)?;
        row.variant = kernel_name(k).to_string();
        kernels.push(row);
    }
    let mut plan = Vec::new();
    // The last row runs everything: the paper's product at every vertex.
    for (name, use_plan, paper) in [
        ("product, per-scene plan", true, false),
        ("product, plan disabled", false, false),
        (
            "product, plan disabled, at every vertex, cosine product",
            false,
            true,
        ),
    ] {
        if progress {
            eprintln!("ablation: {name}, {spp} spp");
        }
        let mut row = run(Method::Product, ProductKernel::Simd, use_plan, paper)?;
        row.variant = name.to_string();
        if !use_plan {
            row.outcome = "no trial";
        }
        plan.push(row);
    }
    // The plan the "per-scene plan" row followed.
    let plan_line = crate::render::run_plan(
        scene,
        &options(Method::Product, ProductKernel::Simd, true, false),
    )
    .line();
    let naive = kernels[0].seconds.max(1e-9);
    let mut md = String::new();
    let _ = writeln!(
        md,
        "| kernel | seconds for {spp} spp | % of naive | paths/s |"
    );
    let _ = writeln!(md, "|---|---|---|---|");
    for r in &kernels {
        let _ = writeln!(
            md,
            "| {} | {:.2} | {:.0} % | {:.0} |",
            r.variant,
            r.seconds,
            100.0 * r.seconds / naive,
            r.paths_per_second
        );
    }
    let _ = writeln!(md, "\n`{plan_line}`\n");
    let _ = writeln!(
        md,
        "| run | seconds for {spp} spp | saving | after the strategy trial |"
    );
    let _ = writeln!(md, "|---|---|---|---|");
    let without = plan[plan.len() - 1].seconds.max(1e-9);
    for r in &plan {
        let _ = writeln!(
            md,
            "| {} | {:.2} | {:.0} % | {} |",
            r.variant,
            r.seconds,
            100.0 * (1.0 - r.seconds / without),
            r.outcome
        );
    }
    Ok(AblationOutcome {
        kernels,
        plan,
        plan_line,
        markdown: md,
    })
}
