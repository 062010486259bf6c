//! The text of a comparison's `summary.md` that `compare` writes and
//! `merge` and `replot` read back or rewrite: the budget line and its time
//! base, the headings, the phrases for runs and seeds, and the tables
//! computed from the curves.

use super::compare::run_seed;
use super::curves::{CurveRow, MeanCurve, mean_std, run_numbers, time_to_error};
use crate::render::TimeBase;
use std::fmt::Write;

/// The opening of a summary's budget line, which names the time base:
/// `merge` pools only sources whose budget lines agree.
pub fn budget_phrase(seconds: f64, base: TimeBase) -> String {
    match base {
        TimeBase::Wall => format!("Budget {seconds:.1} s per run"),
        TimeBase::Cpu => format!("Budget {seconds:.1} {CPU_BUDGET_UNIT} per run"),
    }
}

const CPU_BUDGET_UNIT: &str = "CPU s per thread";

/// The time base a summary's budget line names (wall unless it says CPU).
pub fn summary_time_base(summary: &str) -> TimeBase {
    let budget = summary.lines().find(|l| l.starts_with("Budget "));
    match budget {
        Some(l) if l.contains(CPU_BUDGET_UNIT) => TimeBase::Cpu,
        _ => TimeBase::Wall,
    }
}

/// The items ("- …" lines) of a summary's section under `heading`, up to the
/// next section or the closing "Files:" line.
pub fn summary_items(summary: &str, heading: &str) -> Vec<String> {
    summary
        .lines()
        .skip_while(|l| !l.starts_with(heading))
        .skip(1)
        .take_while(|l| !l.starts_with("## ") && !l.starts_with("Files:"))
        .filter_map(|l| l.strip_prefix("- ").map(str::to_string))
        .collect()
}

/// Heading of a summary's section listing every run's plan line.
pub const PLAN_HEADING: &str = "## Per-scene plan";

/// The curves' time axis.
pub fn time_axis_label(base: TimeBase) -> &'static str {
    match base {
        TimeBase::Wall => "seconds (training included)",
        TimeBase::Cpu => "CPU seconds per thread (training included)",
    }
}

/// The seeds of runs `runs` (increasing): a range where they are
/// consecutive, else each of them.
pub fn seeds_phrase(runs: &[u32]) -> String {
    let seeds: Vec<u64> = runs.iter().map(|&r| run_seed(r)).collect();
    match seeds.as_slice() {
        [] => String::from("none"),
        [one] => one.to_string(),
        [first, .., last] if last - first + 1 == seeds.len() as u64 => format!("{first}–{last}"),
        _ => seeds
            .iter()
            .map(u64::to_string)
            .collect::<Vec<_>>()
            .join(", "),
    }
}

/// "N runs per method (seeds …)" for the runs the rows hold.
pub fn runs_phrase(rows: &[CurveRow]) -> String {
    let runs = run_numbers(rows);
    format!(
        "{} runs per method (seeds {})",
        runs.len(),
        seeds_phrase(&runs)
    )
}

/// The table of final errors: per method, the mean spp and the mean and
/// standard deviation over its runs of their last rows' relMSE, relMSE
/// without the worst 0.1 % of pixels (— unless every run has it: files
/// from before it was recorded do not), and MAE.
pub fn final_errors_table(rows: &[CurveRow], curves: &[MeanCurve]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{FINAL_ERRORS_HEADER}");
    let _ = writeln!(s, "|---|---|---|---|---|");
    let runs = run_numbers(rows);
    for c in curves {
        let finals: Vec<&CurveRow> = runs
            .iter()
            .filter_map(|&run| rows.iter().rfind(|r| r.method == c.method && r.run == run))
            .collect();
        let (rm, rs) = mean_std(&finals.iter().map(|r| r.relmse).collect::<Vec<_>>());
        let trimmed: Option<Vec<f64>> = finals.iter().map(|r| r.relmse_trimmed).collect();
        let trimmed = match trimmed {
            Some(t) if !t.is_empty() => {
                let (tm, ts) = mean_std(&t);
                format!("{tm:.4e} ± {ts:.1e}")
            }
            _ => "—".to_string(),
        };
        let (mm, ms) = mean_std(&finals.iter().map(|r| r.mae).collect::<Vec<_>>());
        let spp = finals.iter().map(|r| r.spp as f64).sum::<f64>() / finals.len().max(1) as f64;
        let _ = writeln!(
            s,
            "| {} | {:.0} | {:.4e} ± {:.1e} | {trimmed} | {:.4e} ± {:.1e} |",
            c.method, spp, rm, rs, mm, ms
        );
    }
    s
}

/// The final-errors table's header row. The middle relMSE column is
/// robust to fireflies: a ratio of relMSE that it does not share is a few
/// pixels' doing.
pub const FINAL_ERRORS_HEADER: &str = "| method | spp (mean) | relMSE (mean ± std) | relMSE without the worst 0.1 % of pixels | MAE (mean ± std) |";

/// How every version of the final-errors table's header starts.
pub const FINAL_ERRORS_HEADER_START: &str = "| method | spp (mean) |";

/// What follows the scene's name in the summary's first line, "# NAME…"
/// (`replot` reads the name back from it).
pub const SUMMARY_TITLE_SUFFIX: &str = ": equal-time comparison";

/// Title of `curves.svg` for `runs` runs on `scene`.
pub fn curves_title(scene: &str, runs: usize) -> String {
    format!("{scene} — error vs time ({runs} runs)")
}

/// Heading of the summary's time-to-error section (`replot` finds it by it).
pub const SPEEDUP_HEADING: &str = "## Time-to-error speedup relative to `radiance`";

/// The summary's time-to-error section: how much sooner each mean curve
/// reaches `radiance`'s final mean error. Empty without a radiance curve.
pub fn speedup_section(curves: &[MeanCurve]) -> String {
    let mut s = String::new();
    if let Some(base) = curves.iter().find(|c| c.method == "radiance") {
        let _ = writeln!(s, "\n{SPEEDUP_HEADING}\n");
        let _ = writeln!(
            s,
            "How much sooner each method's mean curve reaches the final mean error of `radiance` \
             and stays at or below it (ratio of times; > 1 means faster; — means it does not end \
             there within the budget; ≥ means the curve was there at its first point, so the \
             speedup is at least that). The mean curves average the runs at common times.\n"
        );
        let _ = writeln!(s, "| method | relMSE | MAE |");
        let _ = writeln!(s, "|---|---|---|");
        let target = |pick: fn(&MeanCurve) -> &Vec<(f64, f64)>| -> Option<(f64, f64)> {
            let errs: Vec<f64> = pick(base).iter().map(|e| e.0).collect();
            let t_base = *base.seconds.last()?;
            Some((*errs.last()?, t_base))
        };
        for c in curves {
            let cell = |pick: fn(&MeanCurve) -> &Vec<(f64, f64)>| -> String {
                match target(pick) {
                    Some((err, t_base)) => {
                        let errs: Vec<f64> = pick(c).iter().map(|e| e.0).collect();
                        match time_to_error(&c.seconds, &errs, err) {
                            Some(t) => format!(
                                "{}{:.2}×",
                                if t.at_first_point { "≥ " } else { "" },
                                t_base / t.seconds
                            ),
                            None => "—".into(),
                        }
                    }
                    None => "—".into(),
                }
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} |",
                c.method,
                cell(|c| &c.relmse),
                cell(|c| &c.mae)
            );
        }
    }
    s
}

/// Where a summary's budget line ("Budget B s per run (training included),
/// N runs per method (seeds …), MACHINE.") holds its runs phrase: the byte
/// range of "N runs per method (seeds …)" within `line`.
pub fn runs_phrase_span(line: &str) -> Result<(usize, usize), String> {
    let runs_at = line
        .find(" runs per method (")
        .ok_or("the budget line names no runs")?;
    let from = line[..runs_at]
        .rfind(", ")
        .ok_or("the budget line has no runs after its budget")?
        + 2;
    let to = line[runs_at..]
        .find(')')
        .ok_or("the budget line's seeds are not closed")?
        + runs_at
        + 1;
    Ok((from, to))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(method: &str, seconds: &[f64], errors: &[f64]) -> MeanCurve {
        let e: Vec<(f64, f64)> = errors.iter().map(|&e| (e, 0.0)).collect();
        MeanCurve {
            method: method.into(),
            seconds: seconds.to_vec(),
            mae: e.clone(),
            relmse: e,
        }
    }

    /// A curve already below the target at its first point got there at or
    /// before that point: its speedup is a lower bound, and says so.
    #[test]
    fn a_speedup_from_the_first_point_is_a_lower_bound() {
        let radiance = curve("radiance", &[1.0, 2.0, 4.0], &[4.0, 2.0, 1.0]);
        let early = curve("pt", &[0.5, 2.0, 4.0], &[0.9, 0.5, 0.25]);
        let crossing = curve("product", &[1.0, 2.0, 4.0], &[2.0, 1.0, 0.5]);
        let s = speedup_section(&[radiance, early, crossing]);
        assert!(s.contains("| pt | ≥ 8.00× | ≥ 8.00× |"), "{s}");
        assert!(s.contains("| product | 2.00× | 2.00× |"), "{s}");
        assert!(s.contains("| radiance | 1.00× | 1.00× |"), "{s}");
    }

    fn final_row(run: u32, relmse: f64, relmse_trimmed: Option<f64>) -> CurveRow {
        CurveRow {
            method: "pt".into(),
            run,
            seconds: 1.0,
            spp: 4,
            mae: 0.5,
            relmse,
            relmse_trimmed,
        }
    }

    /// The trimmed column averages the runs' figures, and shows — when a
    /// run lacks one (a file from before the column) rather than a mean
    /// over the others.
    #[test]
    fn the_trimmed_column_needs_every_run() {
        let curves = [curve("pt", &[1.0], &[1.0])];
        let rows = [final_row(0, 2.0, Some(1.0)), final_row(1, 4.0, Some(3.0))];
        let t = final_errors_table(&rows, &curves);
        assert!(t.starts_with(FINAL_ERRORS_HEADER), "{t}");
        assert!(
            t.contains("| pt | 4 | 3.0000e0 ± 1.4e0 | 2.0000e0 ± 1.4e0 | 5.0000e-1 ± 0.0e0 |"),
            "{t}"
        );
        let rows = [final_row(0, 2.0, Some(1.0)), final_row(1, 4.0, None)];
        let t = final_errors_table(&rows, &curves);
        assert!(
            t.contains("| pt | 4 | 3.0000e0 ± 1.4e0 | — | 5.0000e-1 ± 0.0e0 |"),
            "{t}"
        );
    }
}
