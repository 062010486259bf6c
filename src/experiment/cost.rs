//! What each run of a comparison cost: wall-clock seconds, the CPU seconds
//! of its own threads, the samples its image holds and the samples it
//! traced (`runs.csv`).
//!
//! An equal-time comparison fixes wall-clock time. Side by side, the
//! methods of a run share the cores through the OS scheduler, so a method's
//! sample count relative to another's is the product of two ratios: the CPU
//! time it was given (the scheduler's share) and the samples it takes per
//! CPU second (its own cost per sample). `curves.csv` holds wall-clock time
//! alone and cannot tell the two apart; this file can.

use super::curves::{non_negative_field, parse_records};
use super::summary_text::seeds_phrase;
use crate::guiding::trial::FALLBACK_IMAGE;
use crate::render::TimeBase;
use std::fmt::Write;

/// One run of one method.
#[derive(Clone, Debug, PartialEq)]
pub struct CostRow {
    pub method: String,
    pub run: u32,
    /// Wall-clock seconds of the render, training included.
    pub seconds: f64,
    /// CPU seconds of the render's own threads; `None` where the clock could
    /// not be read (the render reported NaN).
    pub cpu_seconds: Option<f64>,
    /// Samples per pixel of the image.
    pub spp: u32,
    /// Samples per pixel the run traced: the image's, and the passes it
    /// left out of the image (a strategy trial's guided passes before a
    /// fallback to path tracing). `None` in files written before the column.
    pub traced_spp: Option<u32>,
}

pub const COST_CSV_HEADER: &str = "method,run,seconds,cpu_seconds,spp,traced_spp";

/// The header of files written before `traced_spp`; they still parse.
const COST_CSV_HEADER_WITHOUT_TRACED: &str = "method,run,seconds,cpu_seconds,spp";

/// The file `compare` writes next to `curves.csv`.
pub const COST_CSV: &str = "runs.csv";

pub fn to_cost_csv(rows: &[CostRow]) -> String {
    let mut s = String::from(COST_CSV_HEADER);
    s.push('\n');
    for r in rows {
        // An unreadable clock stays an empty field, not a NaN in the file.
        let cpu = r.cpu_seconds.map_or(String::new(), |c| format!("{c:.6}"));
        let traced = r.traced_spp.map_or(String::new(), |t| t.to_string());
        let _ = writeln!(
            s,
            "{},{},{:.6},{cpu},{},{traced}",
            r.method, r.run, r.seconds, r.spp
        );
    }
    s
}

/// Parses `runs.csv`, with or without its `traced_spp` column.
pub fn parse_cost_csv(text: &str) -> Result<Vec<CostRow>, String> {
    parse_records(
        text,
        &[COST_CSV_HEADER, COST_CSV_HEADER_WITHOUT_TRACED],
        |l, f| {
            let num = |s: &str| non_negative_field(s, l);
            let spp: u32 = f[4].parse().map_err(|_| format!("bad spp in '{l}'"))?;
            let traced_spp = match f.get(5) {
                None | Some(&"") => None,
                Some(t) => match t.parse::<u32>() {
                    // A run traces at least the samples its image holds.
                    Ok(t) if t >= spp => Some(t),
                    _ => {
                        return Err(format!(
                            "bad traced_spp in '{l}' (an integer ≥ spp expected)"
                        ));
                    }
                },
            };
            Ok(CostRow {
                method: f[0].to_string(),
                run: f[1].parse().map_err(|_| format!("bad run in '{l}'"))?,
                seconds: num(f[2])?,
                cpu_seconds: if f[3].is_empty() {
                    None
                } else {
                    Some(num(f[3])?)
                },
                spp,
                traced_spp,
            })
        },
    )
}

/// One method's totals over its runs.
#[derive(Clone, Debug, PartialEq)]
pub struct MethodCost {
    pub method: String,
    pub mean_seconds: f64,
    /// `None` when any run lacks its CPU time: a mean over the others would
    /// set different runs against each other.
    pub mean_cpu_seconds: Option<f64>,
    pub mean_spp: f64,
    /// `None` when any run lacks its traced count.
    pub mean_traced_spp: Option<f64>,
}

impl MethodCost {
    /// Cores the method's threads kept busy on average.
    pub fn cores_used(&self) -> Option<f64> {
        self.mean_cpu_seconds.map(|c| c / self.mean_seconds)
    }

    /// Samples per CPU second: total samples over total CPU time, so that
    /// spp ratio = CPU ratio × this ratio holds exactly between methods.
    pub fn spp_per_cpu_second(&self) -> Option<f64> {
        ratio(Some(self.mean_spp), self.mean_cpu_seconds)
    }

    /// Traced samples per CPU second: the cost per sample whatever the
    /// image kept.
    pub fn traced_spp_per_cpu_second(&self) -> Option<f64> {
        ratio(self.mean_traced_spp, self.mean_cpu_seconds)
    }
}

/// Each method's totals, in `methods`' order (methods without rows are
/// left out).
pub fn method_costs(rows: &[CostRow], methods: &[String]) -> Vec<MethodCost> {
    methods
        .iter()
        .filter_map(|m| {
            let own: Vec<&CostRow> = rows.iter().filter(|r| &r.method == m).collect();
            if own.is_empty() {
                return None;
            }
            let n = own.len() as f64;
            let cpu: Option<Vec<f64>> = own.iter().map(|r| r.cpu_seconds).collect();
            let traced: Option<Vec<f64>> =
                own.iter().map(|r| r.traced_spp.map(f64::from)).collect();
            Some(MethodCost {
                method: m.clone(),
                mean_seconds: own.iter().map(|r| r.seconds).sum::<f64>() / n,
                mean_cpu_seconds: cpu.map(|c| c.iter().sum::<f64>() / n),
                mean_spp: own.iter().map(|r| r.spp as f64).sum::<f64>() / n,
                mean_traced_spp: traced.map(|t| t.iter().sum::<f64>() / n),
            })
        })
        .collect()
}

/// Heading of the summary's cost section.
pub const COST_HEADING: &str = "## Cost: wall clock, CPU and samples";

/// The summary's cost section: per method, mean wall and CPU seconds,
/// cores used and samples per CPU second, and the three ratios to
/// `radiance` (or to the first method without one) that decompose the
/// equal-time spp ratio. `plan_items` are the runs' plan lines ("METHOD,
/// seed S: plan: …"), which say which runs imaged path tracing's passes
/// alone: their spp is not what they traced.
pub fn cost_section(
    rows: &[CostRow],
    methods: &[String],
    time_base: TimeBase,
    plan_items: &[String],
) -> String {
    let costs = method_costs(rows, methods);
    let Some(base) = costs
        .iter()
        .find(|c| c.method == "radiance")
        .or_else(|| costs.first())
    else {
        return String::new();
    };
    let mut s = String::new();
    let _ = writeln!(s, "\n{COST_HEADING}\n");
    let clock = match time_base {
        TimeBase::Wall => {
            "At equal wall time, a method's CPU ratio is the share of the cores it was \
             given (side by side, the scheduler decides it)"
        }
        TimeBase::Cpu => {
            "At equal CPU time (`--clock cpu`), a method's CPU ratio is 1 but for where \
             each run stopped (within half a pass of its budget)"
        }
    };
    let _ = writeln!(
        s,
        "Means over each method's runs (`{COST_CSV}`). CPU is the CPU time of the render's own \
         threads. {clock}. A method's spp ratio to `{}` is its CPU ratio times its ratio of spp per \
         CPU second (its own cost per sample, as the machine ran it).\n",
        base.method
    );
    let _ = writeln!(
        s,
        "| method | wall s | CPU s | cores used | spp per CPU s | spp ratio | CPU ratio | spp per CPU s ratio |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
    for c in &costs {
        let _ = writeln!(
            s,
            "| {} | {:.1} | {} | {} | {} | {} | {} | {} |",
            c.method,
            c.mean_seconds,
            optional(c.mean_cpu_seconds, 1),
            optional(c.cores_used(), 2),
            optional(c.spp_per_cpu_second(), 3),
            optional(ratio(Some(c.mean_spp), Some(base.mean_spp)), 3),
            optional(ratio(c.mean_cpu_seconds, base.mean_cpu_seconds), 3),
            optional(ratio(c.spp_per_cpu_second(), base.spp_per_cpu_second()), 3),
        );
    }
    if costs.iter().any(|c| c.mean_cpu_seconds.is_none()) {
        let _ = writeln!(
            s,
            "\n— : a run of that method could not read its CPU clock; its CPU figures are left out."
        );
    }
    let handed_over: Vec<String> = costs
        .iter()
        .filter_map(|c| {
            let runs = rows.iter().filter(|r| r.method == c.method).count();
            let marker = format!("{}, seed ", c.method);
            let fell_back = plan_items
                .iter()
                .filter(|item| item.contains(&marker) && item.contains(FALLBACK_IMAGE))
                .count();
            (fell_back > 0).then(|| format!("{} {fell_back} of {runs}", c.method))
        })
        .collect();
    if !handed_over.is_empty() {
        let _ = writeln!(
            s,
            "\nRuns that handed the rest of their budget to path tracing and image its passes alone \
             (their plan lines say so): {}. Their spp counts the image's passes, not the samples \
             they traced, so for those methods spp per CPU second is not the cost per sample.",
            handed_over.join(", ")
        );
    }
    s.push_str(&traced_table(rows, &costs, base));
    s
}

/// Where some run left traced passes out of its image: every method's
/// traced samples per CPU second and their ratio to `base`'s, the cost per
/// sample that the image's spp no longer gives. Empty otherwise.
fn traced_table(rows: &[CostRow], costs: &[MethodCost], base: &MethodCost) -> String {
    if !rows.iter().any(|r| r.traced_spp.is_some_and(|t| t > r.spp)) {
        return String::new();
    }
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\nCounting every sample each run traced, its image's and those it left out \
         (`traced_spp`), the cost per sample is:\n"
    );
    let _ = writeln!(
        s,
        "| method | traced spp | traced spp per CPU s | traced spp per CPU s ratio |"
    );
    let _ = writeln!(s, "|---|---|---|---|");
    for c in costs {
        let rate = c.traced_spp_per_cpu_second();
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            c.method,
            optional(c.mean_traced_spp, 1),
            optional(rate, 3),
            optional(ratio(rate, base.traced_spp_per_cpu_second()), 3)
        );
    }
    if costs.iter().any(|c| c.mean_traced_spp.is_none()) {
        let _ = writeln!(
            s,
            "\n— : a run of that method predates `traced_spp` (or lacks its CPU time)."
        );
    }
    s
}

/// A table cell: the value to `digits` decimals, or a dash.
fn optional(x: Option<f64>, digits: usize) -> String {
    x.map_or("—".into(), |v| format!("{v:.digits$}"))
}

/// a / b where both are known and b > 0.
fn ratio(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => Some(a / b),
        _ => None,
    }
}

/// Where `costs` hold fewer runs than the comparison (`all_runs`, the runs
/// of its curves): which seeds the cost table covers and which predate
/// `runs.csv`. Empty when it covers them all, or none.
pub fn cost_coverage_note(all_runs: &[u32], costs: &[CostRow]) -> String {
    let mut covered: Vec<u32> = costs.iter().map(|c| c.run).collect();
    covered.sort_unstable();
    covered.dedup();
    let missing: Vec<u32> = all_runs
        .iter()
        .copied()
        .filter(|r| !covered.contains(r))
        .collect();
    if covered.is_empty() || missing.is_empty() {
        return String::new();
    }
    format!(
        "\nThe cost table covers seeds {}, the runs that recorded it; seeds {} predate \
         `{COST_CSV}` and are not in it.\n",
        seeds_phrase(&covered),
        seeds_phrase(&missing)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(method: &str, run: u32, seconds: f64, cpu: Option<f64>, spp: u32) -> CostRow {
        CostRow {
            method: method.into(),
            run,
            seconds,
            cpu_seconds: cpu,
            spp,
            traced_spp: Some(spp),
        }
    }

    #[test]
    fn csv_round_trips_and_rejects_bad_values() {
        let mut rows = vec![
            row("pt", 0, 10.0, Some(6.5), 100),
            row("radiance", 0, 10.25, None, 80),
            row("product", 0, 10.0, Some(6.0), 40),
        ];
        rows[1].traced_spp = Some(95);
        rows[2].traced_spp = None;
        assert_eq!(parse_cost_csv(&to_cost_csv(&rows)).unwrap(), rows);
        assert!(parse_cost_csv("method,run\n").is_err());
        for bad in ["nan", "inf", "-1", "x"] {
            let text = format!("{COST_CSV_HEADER}\npt,0,1.0,{bad},4,4\n");
            assert!(parse_cost_csv(&text).unwrap_err().contains(bad), "{bad}");
        }
        let short = format!("{COST_CSV_HEADER}\npt,0,1.0,4,4\n");
        assert!(parse_cost_csv(&short).is_err());
        // A run cannot trace fewer samples than its image holds.
        for bad in ["3", "-5", "4.5", "x"] {
            let text = format!("{COST_CSV_HEADER}\npt,0,1.0,1.0,4,{bad}\n");
            let err = parse_cost_csv(&text).unwrap_err();
            assert!(err.contains("traced_spp"), "{bad}: {err}");
        }
        // Files written before the column parse, without traced counts; a
        // row of the old width under the new header does not.
        let old = "method,run,seconds,cpu_seconds,spp\npt,0,1.0,0.5,4\n";
        let parsed = parse_cost_csv(old).unwrap();
        assert_eq!(parsed[0].traced_spp, None);
        assert_eq!(parsed[0].spp, 4);
        assert!(parse_cost_csv(&format!("{COST_CSV_HEADER}\npt,0,1.0,0.5,4\n")).is_err());
    }

    /// Only where a run left passes out of its image does the section add
    /// the traced table, with each method's traced rate and its ratio to
    /// radiance's; methods without traced counts get dashes.
    #[test]
    fn traced_samples_give_the_cost_per_sample_of_runs_that_left_passes_out() {
        let methods: Vec<String> = ["pt", "radiance", "product"].map(String::from).to_vec();
        let mut rows = vec![
            row("pt", 0, 10.0, Some(5.0), 100),
            row("radiance", 0, 10.0, Some(5.0), 40),
            row("product", 0, 10.0, Some(4.0), 30),
        ];
        let plain = cost_section(&rows, &methods, TimeBase::Cpu, &[]);
        assert!(!plain.contains("traced"), "{plain}");
        // The product traced 36 spp and kept 30: 9 traced spp per CPU s
        // against radiance's 8.
        rows[2].traced_spp = Some(36);
        let section = cost_section(&rows, &methods, TimeBase::Cpu, &[]);
        assert!(
            section.contains("| product | 36.0 | 9.000 | 1.125 |"),
            "{section}"
        );
        assert!(
            section.contains("| radiance | 40.0 | 8.000 | 1.000 |"),
            "{section}"
        );
        assert!(
            section.contains("| pt | 100.0 | 20.000 | 2.500 |"),
            "{section}"
        );
        assert!(
            section.contains(
                "\n\nCounting every sample each run traced, its image's and those it left out \
                 (`traced_spp`), the cost per sample is:\n\n| method | traced spp |"
            ),
            "{section}"
        );
        assert!(!section.contains("predates"));
        rows[0].traced_spp = None;
        let mixed = cost_section(&rows, &methods, TimeBase::Cpu, &[]);
        assert!(mixed.contains("| pt | — | — | — |"), "{mixed}");
        assert!(
            mixed.ends_with(
                "|\n\n— : a run of that method predates `traced_spp` (or lacks its CPU time).\n"
            ),
            "{mixed}"
        );
    }

    #[test]
    fn the_spp_ratio_is_the_cpu_ratio_times_the_spp_per_cpu_second_ratio() {
        let rows = vec![
            row("pt", 0, 10.0, Some(7.0), 140),
            row("radiance", 0, 10.0, Some(6.0), 60),
            row("product", 0, 10.0, Some(5.0), 40),
            row("pt", 1, 10.0, Some(6.0), 120),
            row("radiance", 1, 10.0, Some(7.0), 80),
            row("product", 1, 10.0, Some(6.0), 50),
        ];
        let methods: Vec<String> = ["pt", "radiance", "product"].map(String::from).to_vec();
        let costs = method_costs(&rows, &methods);
        let (r, p) = (&costs[1], &costs[2]);
        assert_eq!(r.mean_spp, 70.0);
        assert_eq!(p.mean_cpu_seconds, Some(5.5));
        assert!((p.cores_used().unwrap() - 0.55).abs() < 1e-12);
        let spp_ratio = p.mean_spp / r.mean_spp;
        let cpu_ratio = p.mean_cpu_seconds.unwrap() / r.mean_cpu_seconds.unwrap();
        let per_cpu = p.spp_per_cpu_second().unwrap() / r.spp_per_cpu_second().unwrap();
        assert!((spp_ratio - cpu_ratio * per_cpu).abs() < 1e-12);
        let section = cost_section(&rows, &methods, TimeBase::Wall, &[]);
        // Ratios are to radiance: 45/70, 5.5/6.5 and (45/5.5)/(70/6.5).
        let line = section
            .lines()
            .find(|l| l.starts_with("| product"))
            .unwrap();
        assert_eq!(
            line,
            format!(
                "| product | 10.0 | 5.5 | 0.55 | 8.182 | {:.3} | {:.3} | {:.3} |",
                45.0 / 70.0,
                5.5 / 6.5,
                (45.0 / 5.5) / (70.0 / 6.5)
            )
        );
        assert!(section.contains("spp ratio to `radiance`"));
        assert!(section.contains("At equal wall time"));
        assert!(!section.contains("could not read"));
        assert!(!section.contains("handed the rest of their budget"));
        // On the CPU clock the text says so; the table is the same.
        let cpu = cost_section(&rows, &methods, TimeBase::Cpu, &[]);
        assert!(cpu.contains("At equal CPU time"));
        assert!(cpu.contains(line));
    }

    /// Runs whose plan line says their image holds path tracing's passes
    /// alone are counted per method, and the section says their spp is not
    /// what they traced; other plan lines and methods are not counted.
    #[test]
    fn runs_that_fell_back_to_path_tracing_are_named() {
        let rows = vec![
            row("pt", 0, 10.0, Some(6.0), 60),
            row("radiance", 0, 10.0, Some(6.0), 60),
            row("radiance", 1, 10.0, Some(6.0), 60),
            row("product", 0, 10.0, Some(6.0), 40),
            row("product", 1, 10.0, Some(6.0), 50),
        ];
        let methods: Vec<String> = ["pt", "radiance", "product"].map(String::from).to_vec();
        let plans = [
            "pt, seed 1000: plan: method pt | guiding off".to_string(),
            format!(
                "radiance, seed 1000: plan: method radiance | guiding on | x: {FALLBACK_IMAGE}"
            ),
            "radiance, seed 1001: plan: method radiance | guiding on".to_string(),
            format!("`a`: product, seed 1000: plan: method product | y, and {FALLBACK_IMAGE}"),
            format!("`b`: product, seed 1001: plan: method product | z, and {FALLBACK_IMAGE}"),
        ];
        let section = cost_section(&rows, &methods, TimeBase::Wall, &plans);
        assert!(
            section.contains("their plan lines say so): radiance 1 of 2, product 2 of 2."),
            "{section}"
        );
    }

    #[test]
    fn a_run_without_cpu_time_blanks_its_method_and_says_so() {
        let rows = vec![
            row("radiance", 0, 10.0, Some(6.0), 60),
            row("product", 0, 10.0, None, 40),
            row("product", 1, 10.0, Some(6.0), 50),
        ];
        let methods: Vec<String> = ["radiance", "product"].map(String::from).to_vec();
        let section = cost_section(&rows, &methods, TimeBase::Wall, &[]);
        let line = section
            .lines()
            .find(|l| l.starts_with("| product"))
            .unwrap();
        assert_eq!(line, "| product | 10.0 | — | — | — | 0.750 | — | — |");
        assert!(section.contains("could not read its CPU clock"));
        // Without radiance runs the first method is the base.
        let only_pt = vec![row("pt", 0, 2.0, Some(2.0), 8)];
        let only_pt_section = cost_section(&only_pt, &["pt".into()], TimeBase::Wall, &[]);
        assert!(only_pt_section.contains("spp ratio to `pt`"));
        assert_eq!(cost_section(&[], &methods, TimeBase::Wall, &[]), "");
    }
}
