//! Pools the runs of several comparisons of one scene into one: a study
//! made with `compare --runs 3` gains three more seeds from a later
//! `compare --runs 3 --first-run 3`, instead of rendering the first three
//! again. The CSVs hold every snapshot of every run, so the pooled curves,
//! final-error table and time-to-error table are computed exactly as
//! `compare` computes its own, from the pooled rows.
//!
//! Only comparisons of the same thing are pooled: the same scene, budget,
//! methods and path settings, and no run (seed) twice. Anything else is
//! refused before a file is written.

use super::compare::run_seed;
use super::cost::{
    COST_CSV, CostRow, cost_coverage_note, cost_section, parse_cost_csv, to_cost_csv,
};
use super::curves::{
    CurveRow, MeanCurve, mean_curve, methods_in_order, parse_csv, run_numbers, to_csv,
};
use super::plot::curves_svg;
use super::study_folder::{StudyRecord, existing_study, occupied_error, remove_comparison_files};
use super::summary_text::{
    PLAN_HEADING, SUMMARY_TITLE_SUFFIX, curves_title, final_errors_table, runs_phrase,
    runs_phrase_span, seeds_phrase, speedup_section, summary_items, summary_time_base,
    time_axis_label,
};
use crate::film::{resolved_path, write_atomic};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// What [`merge`] wrote.
#[derive(Debug)]
pub struct Merged {
    pub rows: usize,
    pub runs: Vec<u32>,
    pub methods: Vec<String>,
    pub summary: String,
}

/// The parts of a compare summary that pooling keeps or checks.
#[derive(Debug)]
struct SourceSummary {
    scene: String,
    /// "Budget … s per run (training included), ".
    budget: String,
    /// What follows the runs in the budget line: threads and machine.
    machine: String,
    /// The "Path settings: …" line.
    settings: String,
    /// The items of the "Per-scene plan" and "Guards" sections.
    plan: Vec<String>,
    guards: Vec<String>,
    /// What its machine line records (nothing, in summaries before it).
    record: StudyRecord,
}

const BUDGET_PREFIX: &str = "Budget ";
const SETTINGS_PREFIX: &str = "Path settings: ";

fn parse_summary(text: &str) -> Result<SourceSummary, String> {
    let mut lines = text.lines();
    let scene = lines
        .next()
        .and_then(|l| l.strip_prefix("# "))
        .and_then(|l| l.strip_suffix(SUMMARY_TITLE_SUFFIX))
        .ok_or_else(|| {
            format!(
                "not a compare summary (its first line should be '# SCENE{SUMMARY_TITLE_SUFFIX}')"
            )
        })?
        .to_string();
    let budget_line = text
        .lines()
        .find(|l| l.starts_with(BUDGET_PREFIX))
        .ok_or("no 'Budget …' line")?;
    let (budget_end, runs_end) = runs_phrase_span(budget_line)?;
    let after_runs = budget_line[runs_end..]
        .strip_prefix(", ")
        .ok_or("the budget line names no machine after its runs")?;
    let machine = after_runs.strip_suffix('.').unwrap_or(after_runs);
    let settings = text
        .lines()
        .find(|l| l.starts_with(SETTINGS_PREFIX))
        .ok_or("no 'Path settings: …' line")?;
    let items = |heading: &str| summary_items(text, heading);
    Ok(SourceSummary {
        scene,
        budget: budget_line[..budget_end].to_string(),
        machine: machine.to_string(),
        settings: settings.to_string(),
        plan: items(PLAN_HEADING),
        guards: items("## Guards"),
        record: StudyRecord::parse(text)?,
    })
}

/// Pools the comparisons in `sources` (folders written by `compare --out`)
/// into `out`: `curves.csv` with every source's rows, `curves.svg`, and
/// `summary.md` with the pooled tables, each source's runs and plan lines.
/// `out` may be one of the sources (its images stay) or an earlier merge's
/// output; a folder holding another comparison is refused unless
/// `overwrite`, which removes that comparison's files. Nothing is written
/// unless every source reads, parses and matches the others.
pub fn merge(out: &Path, sources: &[PathBuf], overwrite: bool) -> Result<Merged, String> {
    if sources.len() < 2 {
        return Err("merge needs at least two comparison folders".into());
    }
    let replaces = replaced_study(out, sources);
    if !replaces.is_empty() && !overwrite {
        return Err(occupied_error("merge", out, &replaces));
    }
    let mut parsed = Vec::new();
    for dir in sources {
        let read = |name: &str| {
            let path = dir.join(name);
            std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))
        };
        let csv_path = dir.join("curves.csv");
        let rows =
            parse_csv(&read("curves.csv")?).map_err(|e| format!("{}: {e}", csv_path.display()))?;
        if rows.is_empty() {
            return Err(format!("{}: no rows", csv_path.display()));
        }
        let summary = parse_summary(&read("summary.md")?)
            .map_err(|e| format!("{}: {e}", dir.join("summary.md").display()))?;
        let costs = read_costs(dir, &rows)?;
        parsed.push(Source {
            dir,
            rows,
            summary,
            costs,
        });
    }
    let (first_dir, first) = (parsed[0].dir, &parsed[0].summary);
    let methods = methods_in_order(&parsed[0].rows);
    let mut seen: Vec<(u32, &PathBuf)> = Vec::new();
    // What the first source to record each field recorded: every other
    // recorded value is checked against it.
    let recorded = StudyRecord {
        budget: parsed.iter().find_map(|p| p.summary.record.budget),
        reference: parsed
            .iter()
            .find_map(|p| p.summary.record.reference.clone()),
    };
    for Source {
        dir,
        rows,
        summary: s,
        ..
    } in &parsed
    {
        let differs = |what: &str, a: &str, b: &str| {
            format!(
                "{} and {} differ in {what} ('{a}' against '{b}'): only comparisons of the same \
                 study can be pooled",
                first_dir.display(),
                dir.display()
            )
        };
        if s.scene != first.scene {
            return Err(differs("scene", &first.scene, &s.scene));
        }
        if s.budget != first.budget {
            return Err(differs("budget", &first.budget, &s.budget));
        }
        // The text rounds the budget to 0.1 s: where both recorded it, the
        // exact budgets must agree too.
        if let (Some(a), Some(b)) = (recorded.budget, s.record.budget)
            && a != b
        {
            return Err(differs("budget", &format!("{a} s"), &format!("{b} s")));
        }
        if let (Some(a), Some(b)) = (&recorded.reference, &s.record.reference)
            && a != b
        {
            return Err(differs("reference", a, b));
        }
        if s.settings != first.settings {
            return Err(differs("path settings", &first.settings, &s.settings));
        }
        // The budget is per thread (`--clock cpu`) or per run (`wall`), so
        // runs on other thread counts or another machine had other compute
        // for the same budget: pooled, their means would mix the two.
        if s.machine != first.machine {
            return Err(differs("threads or machine", &first.machine, &s.machine));
        }
        let m = methods_in_order(rows);
        if m != methods {
            return Err(differs("methods", &methods.join(","), &m.join(",")));
        }
        // Every method must hold the same runs, or the pooled means would
        // set different seeds side by side.
        let runs = run_numbers(rows);
        for method in &methods {
            let mut own: Vec<u32> = rows
                .iter()
                .filter(|r| &r.method == method)
                .map(|r| r.run)
                .collect();
            own.sort_unstable();
            own.dedup();
            if own != runs {
                return Err(format!(
                    "{}: {method} has runs {own:?} but the comparison has {runs:?}",
                    dir.join("curves.csv").display()
                ));
            }
        }
        for &run in &runs {
            if let Some((_, other)) = seen.iter().find(|(r, _)| *r == run) {
                return Err(format!(
                    "run {run} (seed {}) is in both {} and {}: pooling it twice would count one \
                     seed as two runs (give the later comparison --first-run past the earlier's runs)",
                    run_seed(run),
                    other.display(),
                    dir.display()
                ));
            }
            seen.push((run, dir));
        }
    }
    // Rows by method, then run, each run's snapshots in their own order.
    let mut pooled: Vec<CurveRow> = Vec::new();
    for method in &methods {
        let mut runs: Vec<(u32, Vec<CurveRow>)> = Vec::new();
        for Source { rows, .. } in &parsed {
            for run in run_numbers(rows) {
                let own = rows
                    .iter()
                    .filter(|r| &r.method == method && r.run == run)
                    .cloned()
                    .collect();
                runs.push((run, own));
            }
        }
        runs.sort_by_key(|(run, _)| *run);
        pooled.extend(runs.into_iter().flat_map(|(_, rows)| rows));
    }
    let csv = to_csv(&pooled);
    let mut pooled_costs: Vec<CostRow> = parsed
        .iter()
        .filter_map(|source| source.costs.as_ref())
        .flatten()
        .cloned()
        .collect();
    pooled_costs.sort_by_key(|r| {
        (
            methods
                .iter()
                .position(|m| *m == r.method)
                .unwrap_or(usize::MAX),
            r.run,
        )
    });
    let cost_csv = to_cost_csv(&pooled_costs);
    // As in `compare`: every figure from the rows as the CSV holds them.
    let rows = parse_csv(&csv)?;
    let curves: Vec<MeanCurve> = methods.iter().map(|m| mean_curve(&rows, m)).collect();
    let runs = run_numbers(&rows);
    let svg = curves_svg(
        &curves_title(&first.scene, runs.len()),
        time_axis_label(summary_time_base(&first.budget)),
        &curves,
    )?;
    let pooled_costs = parse_cost_csv(&cost_csv)?;
    let summary = pooled_summary(&parsed, &rows, &curves, &pooled_costs);
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create '{}': {e}", out.display()))?;
    if !replaces.is_empty() {
        remove_comparison_files(out)?;
    }
    write_atomic(&out.join("curves.csv"), csv.as_bytes())?;
    let cost_path = out.join(COST_CSV);
    if pooled_costs.is_empty() {
        // No source recorded costs: a runs.csv left in `out` by an earlier
        // comparison would describe runs the pooled CSV does not hold.
        match std::fs::remove_file(&cost_path) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(format!("{}: {e}", cost_path.display())),
        }
    } else {
        write_atomic(&cost_path, cost_csv.as_bytes())?;
    }
    write_atomic(&out.join("curves.svg"), svg.as_bytes())?;
    write_atomic(&out.join("summary.md"), summary.as_bytes())?;
    Ok(Merged {
        rows: rows.len(),
        runs,
        methods,
        summary,
    })
}

/// The files of a comparison in `out` that pooling would replace: none when
/// `out` holds no study, is one of the sources, or holds an earlier merge's
/// output (which a new merge rewrites whole, as pooling into a page's folder
/// again relies on).
fn replaced_study(out: &Path, sources: &[PathBuf]) -> Vec<PathBuf> {
    let existing = existing_study(out);
    if existing.is_empty() {
        return existing;
    }
    let out_dir = resolved_path(out);
    if sources
        .iter()
        .any(|source| resolved_path(source) == out_dir)
    {
        return Vec::new();
    }
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap_or_default();
    if summary.lines().any(|l| l.starts_with(POOLED_PREFIX)) {
        return Vec::new();
    }
    existing
}

/// The opening of a pooled summary's line naming its sources: what marks a
/// folder as a merge's output.
const POOLED_PREFIX: &str = "Pooled by `ltcguide merge` from ";

/// A source's `runs.csv`, if it has one (comparisons before it have none).
/// It must hold exactly the runs of each method that `curves.csv` holds.
fn read_costs(dir: &Path, rows: &[CurveRow]) -> Result<Option<Vec<CostRow>>, String> {
    let path = dir.join(COST_CSV);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("{}: {e}", path.display())),
    };
    let costs = parse_cost_csv(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut in_costs: Vec<(&str, u32)> = costs.iter().map(|r| (r.method.as_str(), r.run)).collect();
    let mut in_curves: Vec<(&str, u32)> = rows.iter().map(|r| (r.method.as_str(), r.run)).collect();
    for v in [&mut in_costs, &mut in_curves] {
        v.sort_unstable();
    }
    let before = in_costs.len();
    in_costs.dedup();
    in_curves.dedup();
    if in_costs.len() != before || in_costs != in_curves {
        return Err(format!(
            "{} does not hold one row for each run of each method in curves.csv",
            path.display()
        ));
    }
    Ok(Some(costs))
}

/// One comparison folder as `merge` read it.
struct Source<'a> {
    dir: &'a PathBuf,
    rows: Vec<CurveRow>,
    summary: SourceSummary,
    /// Its `runs.csv`, if it has one.
    costs: Option<Vec<CostRow>>,
}

fn pooled_summary(
    parsed: &[Source],
    rows: &[CurveRow],
    curves: &[MeanCurve],
    costs: &[CostRow],
) -> String {
    let first = &parsed[0].summary;
    let mut s = String::new();
    let _ = writeln!(s, "# {}{SUMMARY_TITLE_SUFFIX}\n", first.scene);
    // `merge` pools only sources of one machine phrase.
    let _ = writeln!(
        s,
        "{}{}, {}.\n",
        first.budget,
        runs_phrase(rows),
        first.machine
    );
    let sources: Vec<String> = parsed
        .iter()
        .map(|Source { dir, rows, .. }| {
            let runs = run_numbers(rows);
            format!("`{}` (seeds {})", dir.display(), seeds_phrase(&runs))
        })
        .collect();
    let _ = writeln!(
        s,
        "{POOLED_PREFIX}{} comparisons: {}.\n",
        parsed.len(),
        sources.join(", ")
    );
    let unchecked: Vec<String> = parsed
        .iter()
        .filter(|p| p.summary.record.reference.is_none())
        .map(|p| format!("`{}`", p.dir.display()))
        .collect();
    if !unchecked.is_empty() {
        let _ = writeln!(
            s,
            "The reference could not be checked for {}: {} no record of the reference its errors \
             were measured against (made before summaries recorded it), so these runs are pooled \
             on trust that it is the same.\n",
            unchecked.join(", "),
            if unchecked.len() == 1 {
                "its summary holds"
            } else {
                "their summaries hold"
            }
        );
    }
    let _ = writeln!(s, "{}\n", first.settings);
    s.push_str(&final_errors_table(rows, curves));
    s.push_str(&speedup_section(curves));
    let methods: Vec<String> = curves.iter().map(|c| c.method.clone()).collect();
    let plan_items: Vec<String> = parsed
        .iter()
        .flat_map(|source| source.summary.plan.iter().cloned())
        .collect();
    s.push_str(&cost_section(
        costs,
        &methods,
        summary_time_base(&first.budget),
        &plan_items,
    ));
    s.push_str(&cost_coverage_note(&run_numbers(rows), costs));
    let section = |s: &mut String, heading: &str, pick: fn(&SourceSummary) -> &Vec<String>| {
        if parsed
            .iter()
            .any(|source| !pick(&source.summary).is_empty())
        {
            let _ = writeln!(s, "\n{heading}\n");
            for Source {
                dir, summary: src, ..
            } in parsed
            {
                for item in pick(src) {
                    // A pooled source's items already name their comparison.
                    if item.starts_with('`') && item.contains("`: ") {
                        let _ = writeln!(s, "- {item}");
                    } else {
                        let _ = writeln!(s, "- `{}`: {item}", dir.display());
                    }
                }
            }
        }
    };
    section(&mut s, PLAN_HEADING, |src| &src.plan);
    section(&mut s, "## Guards", |src| &src.guards);
    let _ = writeln!(
        s,
        "\nFiles: `curves.csv` (every snapshot of every run), {}`curves.svg`; the final images of \
         each comparison's first run stay in its folder.",
        if costs.is_empty() {
            String::new()
        } else {
            format!(
                "`{COST_CSV}` (the wall and CPU seconds, image spp and traced spp of every run that \
                 recorded them), "
            )
        }
    );
    // A field is recorded for the pool only where every source recorded it
    // (and the checks made them agree): a later merge must not take runs
    // that were never checked for checked ones.
    let all = |pick: fn(&StudyRecord) -> bool| parsed.iter().all(|p| pick(&p.summary.record));
    let record = StudyRecord {
        budget: first.record.budget.filter(|_| all(|r| r.budget.is_some())),
        reference: first
            .record
            .reference
            .clone()
            .filter(|_| all(|r| r.reference.is_some())),
    };
    s.push_str(&record.line());
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summaries_parse_into_their_parts() {
        let text = format!(
            "# staircase{SUMMARY_TITLE_SUFFIX}\n\nBudget 240.0 s per run (training included), 3 runs per \
             method (seeds 1000…), the methods of a run side by side on 1 of 2 threads each, AMD EPYC.\n\n\
             Path settings: pt: NEE. Per-scene plan: off.\n\n| method |\n\n## Per-scene plan\n\n- pt: plan a\n\
             - radiance: plan b\n\nFiles: x\n"
        );
        let s = parse_summary(&text).unwrap();
        assert_eq!(s.scene, "staircase");
        assert_eq!(s.budget, "Budget 240.0 s per run (training included), ");
        assert_eq!(
            s.machine,
            "the methods of a run side by side on 1 of 2 threads each, AMD EPYC"
        );
        assert_eq!(s.settings, "Path settings: pt: NEE. Per-scene plan: off.");
        assert_eq!(s.plan, ["pt: plan a", "radiance: plan b"]);
        assert!(s.guards.is_empty());
        assert!(parse_summary("# x\n").is_err());
    }
}
