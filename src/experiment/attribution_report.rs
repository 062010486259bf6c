//! The tables `ltcguide attribute` prints: the factors per seed, the split
//! by the pixels' first vertex, and the ratios at the glossy first vertices.

use super::attribution::{
    AttributionOptions, ClassSplit, EQUAL_TIME, EXPECTED_RELMSE, Factor, geometric_mean,
};
use crate::guiding::product::CosineLobes;
use crate::render::TimeBase;
use crate::scene::Scene;
use std::fmt::Write;

pub(super) fn markdown(
    scene: &Scene,
    opts: &AttributionOptions,
    side: usize,
    rows: &[Factor],
    alpha: &[(f64, f64)],
) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "Attribution on {}: product / radiance, {} spp, seeds 1–{}, side by side ({side} thread(s) each), \
         NEE {}{}, every part of the method forced on, {}, seconds {}. < 1 favours the product.\n",
        scene.name,
        opts.spp,
        opts.seeds,
        if opts.path.nee { "on" } else { "off" },
        super::compare::fraction_phrase(opts.bsdf_fraction_l2, opts.bsdf_fraction_learning),
        crate::guiding::product::product_scope_phrase(
            opts.product_vertices,
            opts.pixel_reuse,
            opts.radiance_share,
            opts.cosine_lobes
        ),
        match opts.clock {
            TimeBase::Cpu => "of each render's own CPU time per thread",
            TimeBase::Wall => "of wall-clock time",
        },
    );
    factor_table(&mut md, "factor", opts.seeds as usize, rows);
    let values: String = alpha
        .iter()
        .map(|(p, r)| format!(" {p:.2} / {r:.2} |"))
        .collect();
    let _ = writeln!(
        md,
        "| learned BSDF fraction α at the first vertex, product / radiance (pixel mean) | \
         how much of the mixture is left to the guide |{values} |"
    );
    let _ = writeln!(
        md,
        "\nAt zero overhead the product would reach {:.2}× radiance's relMSE in equal time \
         (its gain at equal spp); with its measured cost it reaches {:.2}×.",
        rows[EXPECTED_RELMSE].mean(),
        rows[EQUAL_TIME].mean()
    );
    md
}

/// The split of the final iteration's relative variance by the pixels'
/// first vertex.
pub(super) fn class_markdown(split: &[ClassSplit], cosine_lobes: CosineLobes) -> String {
    let where_product_acts = match cosine_lobes {
        CosineLobes::Radiance => {
            "the product acts first only at glossy vertices; cosine-only ones take radiance weights"
        }
        CosineLobes::Product => "cosine-only vertices take the cosine product",
    };
    let mut md = format!(
        "\nThe final iteration's relative variance per sample by the first non-delta vertex \
         seen through each pixel's centre, product / radiance per seed ({where_product_acts}):\n\n",
    );
    let seeds = split.first().map_or(0, |s| s.per_seed.len());
    let head: String = (1..=seeds).map(|s| format!(" seed {s} |")).collect();
    let rule: String = (0..seeds).map(|_| "---|").collect();
    let _ = writeln!(
        md,
        "| first vertex | pixels | radiance's relative variance there |{head} mean |"
    );
    let _ = writeln!(md, "|---|---|---|{rule}---|");
    for c in split {
        let values: String = c
            .per_seed
            .iter()
            .map(|v| {
                if v.is_finite() {
                    format!(" {v:.3} |")
                } else {
                    " – |".into()
                }
            })
            .collect();
        let finite: Vec<f64> = c
            .per_seed
            .iter()
            .copied()
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect();
        let mean = if finite.is_empty() {
            "–".to_string()
        } else {
            format!("{:.3}", geometric_mean(&finite))
        };
        let _ = writeln!(
            md,
            "| {} | {:.1} % | {:.1} % |{values} {mean} |",
            c.class.label(),
            100.0 * c.pixels,
            100.0 * c.radiance_share
        );
    }
    md
}

/// The table of [`AttributionOutcome::at_glossy`] (nothing without
/// glossy pixels).
pub(super) fn glossy_markdown(rows: &[Factor], fraction: f32) -> String {
    let Some(first) = rows.first() else {
        return String::new();
    };
    let mut md = format!(
        "\nAt the glossy first vertices (where the product acts first), the final iteration's \
         relative variance per sample under each pair of settings (the fixed BSDF fraction is \
         {fraction}; each ratio's two renders weighed by the (R² + 0.01) of their mean image R):\n\n"
    );
    factor_table(&mut md, "ratio", first.per_seed.len(), rows);
    md
}

/// A table of factors: name, what it isolates, its value per seed and
/// their geometric mean.
fn factor_table(md: &mut String, label: &str, seeds: usize, rows: &[Factor]) {
    let head: String = (1..=seeds).map(|s| format!(" seed {s} |")).collect();
    let rule: String = (0..seeds).map(|_| "---|").collect();
    let _ = writeln!(md, "| {label} | isolates |{head} mean |");
    let _ = writeln!(md, "|---|---|{rule}---|");
    for row in rows {
        let values: String = row.per_seed.iter().map(|v| format!(" {v:.3} |")).collect();
        let _ = writeln!(
            md,
            "| {} | {} |{values} {:.3} |",
            row.name,
            row.isolates,
            row.mean()
        );
    }
}
