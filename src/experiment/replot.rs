//! Redraws a comparison's mean curves and its time-to-error table from the
//! runs' `curves.csv`, without rendering again. The CSV keeps every
//! snapshot of every run, so whatever the aggregation computes can be
//! recomputed from it: pages made before the aggregation was fixed are
//! corrected this way rather than by hours of new renders.

use super::cost::{COST_CSV, COST_HEADING, cost_coverage_note, cost_section, parse_cost_csv};
use super::curves::{MeanCurve, mean_curve, methods_in_order, parse_csv, run_numbers};
use super::plot::curves_svg;
use super::summary_text::{
    FINAL_ERRORS_HEADER_START, PLAN_HEADING, SPEEDUP_HEADING, SUMMARY_TITLE_SUFFIX, curves_title,
    final_errors_table, runs_phrase, runs_phrase_span, speedup_section, summary_items,
    summary_time_base, time_axis_label,
};
use crate::film::write_atomic;
use std::path::Path;

/// What [`replot`] rewrote in one comparison folder.
#[derive(Debug)]
pub struct Replotted {
    pub rows: usize,
    pub methods: Vec<String>,
    /// The summary's time-to-error section before and after (empty when
    /// the summary has none, i.e. no radiance runs).
    pub old_section: String,
    pub new_section: String,
    /// The cost section was rewritten from `runs.csv` (false: the folder
    /// has none, as comparisons before it).
    pub cost_rewritten: bool,
}

/// Rewrites `dir/curves.svg`, and the budget line's run count, the
/// final-errors table and the time-to-error section of `dir/summary.md`
/// from `dir/curves.csv`, and the cost section from
/// `dir/runs.csv` and the summary's plan lines where the folder has one. Both files must exist (a
/// `compare` output folder); nothing is written when either cannot be read
/// or parsed.
pub fn replot(dir: &Path) -> Result<Replotted, String> {
    let read = |name: &str| {
        let path = dir.join(name);
        std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))
    };
    let csv = read("curves.csv")?;
    let summary = read("summary.md")?;
    let rows = parse_csv(&csv).map_err(|e| format!("{}: {e}", dir.join("curves.csv").display()))?;
    if rows.is_empty() {
        return Err(format!("{}: no rows", dir.join("curves.csv").display()));
    }
    let methods = methods_in_order(&rows);
    let curves: Vec<MeanCurve> = methods.iter().map(|m| mean_curve(&rows, m)).collect();
    let name = summary
        .lines()
        .next()
        .and_then(|l| l.strip_prefix("# "))
        .and_then(|l| l.strip_suffix(SUMMARY_TITLE_SUFFIX))
        .ok_or_else(|| {
            format!(
                "{}: not a compare summary (its first line should be '# SCENE{SUMMARY_TITLE_SUFFIX}')",
                dir.join("summary.md").display()
            )
        })?;
    let svg = curves_svg(
        &curves_title(name, run_numbers(&rows).len()),
        time_axis_label(summary_time_base(&summary)),
        &curves,
    )?;
    let new_section = speedup_section(&curves);
    let in_summary = |e: String| format!("{}: {e}", dir.join("summary.md").display());
    let (old_section, mut new_summary) =
        replace_section(&summary, SPEEDUP_HEADING, &new_section).map_err(in_summary)?;
    // The run count and final errors come from the CSV too, so that a run
    // taken out of it leaves no line still counting it.
    new_summary = replace_runs_phrase(&new_summary, &runs_phrase(&rows)).map_err(in_summary)?;
    new_summary =
        replace_table(&new_summary, &final_errors_table(&rows, &curves)).map_err(in_summary)?;
    let cost_path = dir.join(COST_CSV);
    let cost_rewritten = match std::fs::read_to_string(&cost_path) {
        Ok(text) => {
            let costs =
                parse_cost_csv(&text).map_err(|e| format!("{}: {e}", cost_path.display()))?;
            let plans = summary_items(&summary, PLAN_HEADING);
            let section = cost_section(&costs, &methods, summary_time_base(&summary), &plans)
                + &cost_coverage_note(&run_numbers(&rows), &costs);
            new_summary = replace_section(&new_summary, COST_HEADING, &section)
                .map_err(in_summary)?
                .1;
            true
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => false,
        Err(e) => return Err(format!("{}: {e}", cost_path.display())),
    };
    write_atomic(&dir.join("curves.svg"), svg.as_bytes())?;
    write_atomic(&dir.join("summary.md"), new_summary.as_bytes())?;
    Ok(Replotted {
        rows: rows.len(),
        methods,
        old_section,
        new_section,
        cost_rewritten,
    })
}

/// The summary with its budget line's "N runs per method (seeds …)" replaced
/// by `phrase`.
fn replace_runs_phrase(summary: &str, phrase: &str) -> Result<String, String> {
    let start = summary.find("\nBudget ").ok_or("no 'Budget …' line")? + 1;
    let line_end = summary[start..]
        .find('\n')
        .map_or(summary.len(), |i| start + i);
    let (from, to) = runs_phrase_span(&summary[start..line_end])?;
    Ok(format!(
        "{}{phrase}{}",
        &summary[..start + from],
        &summary[start + to..]
    ))
}

/// The summary with its final-errors table (its header line and every
/// table line after it) replaced by `table`.
fn replace_table(summary: &str, table: &str) -> Result<String, String> {
    // Found by its first columns, so that a table written before the
    // trimmed relMSE column is replaced too.
    let start = summary
        .find(&format!("\n{FINAL_ERRORS_HEADER_START}"))
        .ok_or("no final-errors table")?
        + 1;
    let mut end = start;
    for line in summary[start..].split_inclusive('\n') {
        if !line.starts_with('|') {
            break;
        }
        end += line.len();
    }
    Ok(format!("{}{table}{}", &summary[..start], &summary[end..]))
}

/// The section it held, and the summary with its section under `heading`
/// (from the heading to the next heading or the closing "Files:" line)
/// replaced by `section`. A summary without the section must get none.
fn replace_section(
    summary: &str,
    heading: &str,
    section: &str,
) -> Result<(String, String), String> {
    let Some(start) = summary.find(&format!("\n{heading}\n")) else {
        if section.is_empty() {
            return Ok((String::new(), summary.to_string()));
        }
        return Err(format!("no '{heading}' section to replace"));
    };
    let rest = &summary[start + 1..];
    let end = [rest.find("\n## "), rest.find("\nFiles:")]
        .into_iter()
        .flatten()
        .min()
        .map_or(summary.len(), |i| start + 1 + i);
    let old = summary[start..end].to_string();
    let mut s = String::with_capacity(summary.len());
    s.push_str(&summary[..start]);
    s.push_str(section);
    s.push_str(&summary[end..]);
    Ok((old, s))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_section_is_replaced_between_its_heading_and_the_next() {
        let summary = format!(
            "# s: equal-time comparison\n\n| table |\n\n{SPEEDUP_HEADING}\n\nold\n| pt | 1× |\n\n## Per-scene plan\n\n- x\n\nFiles: y\n"
        );
        let new = format!("\n{SPEEDUP_HEADING}\n\nnew\n");
        let (old, s) = replace_section(&summary, SPEEDUP_HEADING, &new).unwrap();
        assert_eq!(old, format!("\n{SPEEDUP_HEADING}\n\nold\n| pt | 1× |\n"));
        assert_eq!(
            s,
            format!(
                "# s: equal-time comparison\n\n| table |\n\n{SPEEDUP_HEADING}\n\nnew\n\n## Per-scene plan\n\n- x\n\nFiles: y\n"
            )
        );
        // Without a later heading, the section ends at "Files:".
        let short = format!("a\n{SPEEDUP_HEADING}\n\nold\n\nFiles: y\n");
        let (old, s) = replace_section(&short, SPEEDUP_HEADING, &new).unwrap();
        assert_eq!(old, format!("\n{SPEEDUP_HEADING}\n\nold\n"));
        assert_eq!(s, format!("a{new}\nFiles: y\n"));
        // No radiance runs: no section before or after.
        assert_eq!(
            replace_section("a\n", SPEEDUP_HEADING, "").unwrap().1,
            "a\n"
        );
        assert!(replace_section("a\n", SPEEDUP_HEADING, &new).is_err());
    }
}
