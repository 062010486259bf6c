//! `ltcguide ablation`: the paper's Table 1 — the cost of a fixed number of
//! samples per pixel for each product kernel, as a percentage of the naive
//! one, with the paper's product at every vertex, cosine lobes included —
//! and what the per-scene plan and radiance weights at deeper and cosine
//! vertices save.

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
        let mut row = run(Method::Product, k, true, true)?;
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
    let _ = writeln!(md, "| run | seconds for {spp} spp | saving |");
    let _ = writeln!(md, "|---|---|---|");
    let without = plan[plan.len() - 1].seconds.max(1e-9);
    for r in &plan {
        let _ = writeln!(
            md,
            "| {} | {:.2} | {:.0} % |",
            r.variant,
            r.seconds,
            100.0 * (1.0 - r.seconds / without)
        );
    }
    Ok(AblationOutcome {
        kernels,
        plan,
        plan_line,
        markdown: md,
    })
}
