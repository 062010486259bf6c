//! Error-versus-time rows and their aggregation over runs.

use std::fmt::Write;

/// One snapshot of one run.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveRow {
    pub method: String,
    pub run: u32,
    pub seconds: f64,
    pub spp: u32,
    pub mae: f64,
    pub relmse: f64,
    /// relMSE without the worst 0.1 % of the pixels
    /// ([`crate::film::metrics::relmse_trimmed`]); `None` in files written
    /// before the column existed, and where it is undefined.
    pub relmse_trimmed: Option<f64>,
}

/// The run numbers the rows hold, in increasing order.
pub fn run_numbers(rows: &[CurveRow]) -> Vec<u32> {
    let mut runs: Vec<u32> = rows.iter().map(|r| r.run).collect();
    runs.sort_unstable();
    runs.dedup();
    runs
}

/// The methods of the rows, in their order of first appearance.
pub fn methods_in_order(rows: &[CurveRow]) -> Vec<String> {
    let mut methods: Vec<String> = Vec::new();
    for r in rows {
        if !methods.contains(&r.method) {
            methods.push(r.method.clone());
        }
    }
    methods
}

pub const CSV_HEADER: &str = "method,run,seconds,spp,mae,relmse,relmse_trimmed";

/// The header of files written before the trimmed relMSE: still read, with
/// `relmse_trimmed` left `None`.
const CSV_HEADER_WITHOUT_TRIMMED: &str = "method,run,seconds,spp,mae,relmse";

/// An empty `relmse_trimmed` field stands for `None`.
pub fn to_csv(rows: &[CurveRow]) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for r in rows {
        let trimmed = r
            .relmse_trimmed
            .map(|t| format!("{t:.9e}"))
            .unwrap_or_default();
        let _ = writeln!(
            s,
            "{},{},{:.6},{},{:.9e},{:.9e},{trimmed}",
            r.method, r.run, r.seconds, r.spp, r.mae, r.relmse
        );
    }
    s
}

pub fn parse_csv(text: &str) -> Result<Vec<CurveRow>, String> {
    parse_records(text, &[CSV_HEADER, CSV_HEADER_WITHOUT_TRIMMED], |l, f| {
        let num = |s: &str| non_negative_field(s, l);
        Ok(CurveRow {
            method: f[0].to_string(),
            run: f[1].parse().map_err(|_| format!("bad run in '{l}'"))?,
            seconds: num(f[2])?,
            spp: f[3].parse().map_err(|_| format!("bad spp in '{l}'"))?,
            mae: num(f[4])?,
            relmse: num(f[5])?,
            relmse_trimmed: match f.get(6) {
                None | Some(&"") => None,
                Some(t) => Some(num(t)?),
            },
        })
    })
}

/// The rows of a CSV file that must start with one of `headers` (the
/// current one first, then those of files written by older builds), each
/// parsed by `row` from its line and its fields (as many as the file's
/// header has; empty lines are skipped).
pub fn parse_records<T>(
    text: &str,
    headers: &[&str],
    row: impl Fn(&str, &[&str]) -> Result<T, String>,
) -> Result<Vec<T>, String> {
    let mut lines = text.lines();
    let first = lines.next();
    let Some(header) = headers.iter().find(|&&h| first == Some(h)) else {
        return Err(format!(
            "missing or wrong CSV header (expected '{}')",
            headers.first().copied().unwrap_or_default()
        ));
    };
    let fields = header.split(',').count();
    lines
        .filter(|l| !l.is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            if f.len() != fields {
                return Err(format!("bad row '{l}'"));
            }
            row(l, &f)
        })
        .collect()
}

/// A CSV field that must be a finite number ≥ 0 (times, errors, CPU
/// seconds): a NaN or a negative value would pass silently into every mean
/// and plot. `line` is the row, for the error.
pub fn non_negative_field(field: &str, line: &str) -> Result<f64, String> {
    match field.parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err(format!(
            "bad number '{field}' in '{line}' (a finite value ≥ 0 expected)"
        )),
    }
}

/// Mean and standard deviation (n − 1) of a sample.
pub fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let m = v.iter().sum::<f64>() / n;
    let var = if v.len() > 1 {
        v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)
    } else {
        0.0
    };
    (m, var.sqrt())
}

/// A method's curve averaged over runs, on one time axis.
#[derive(Clone, Debug)]
pub struct MeanCurve {
    pub method: String,
    pub seconds: Vec<f64>,
    pub mae: Vec<(f64, f64)>,
    pub relmse: Vec<(f64, f64)>,
}

/// The runs of `method` averaged at every time any of them took a
/// snapshot, from the latest first snapshot on.
///
/// Runs do not take the same snapshots: an iteration may span two nominal
/// times, and a plan's fallback restarts the image. Averaging snapshot k
/// of every run (as this did before) therefore mixed times, and cut every
/// run to the shortest one's count, dropping the final images of the
/// others. Here each run's error is interpolated at the common times,
/// log-log as in [`time_to_error`], and a run holds its final error after
/// its own last row (its budget is spent), so the curve ends at the mean of
/// the runs' final errors: the figure of the summary's table.
pub fn mean_curve(rows: &[CurveRow], method: &str) -> MeanCurve {
    // By run id; a map, since ids come from a CSV and need not be dense.
    let mut by_run: std::collections::BTreeMap<u32, Vec<&CurveRow>> = Default::default();
    for r in rows.iter().filter(|r| r.method == method) {
        by_run.entry(r.run).or_default().push(r);
    }
    let mut runs: Vec<Vec<&CurveRow>> = by_run.into_values().collect();
    for run in &mut runs {
        run.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
    }
    let start = runs
        .iter()
        .map(|r| r[0].seconds)
        .fold(f64::NEG_INFINITY, f64::max);
    let mut times: Vec<f64> = runs
        .iter()
        .flatten()
        .map(|r| r.seconds)
        .filter(|&t| t >= start)
        .collect();
    times.sort_by(f64::total_cmp);
    times.dedup();
    let mut c = MeanCurve {
        method: method.to_string(),
        seconds: Vec::new(),
        mae: Vec::new(),
        relmse: Vec::new(),
    };
    for t in times {
        let at = |pick: fn(&CurveRow) -> f64| -> (f64, f64) {
            let values: Vec<f64> = runs.iter().map(|r| value_at(r, t, pick)).collect();
            mean_std(&values)
        };
        c.seconds.push(t);
        c.mae.push(at(|r| r.mae));
        c.relmse.push(at(|r| r.relmse));
    }
    c
}

/// One run's value at time `t` (rows in time order): interpolated log-log
/// between the rows around it (linearly where a value or time is not
/// positive), the first row's before it, the last row's after it.
fn value_at(run: &[&CurveRow], t: f64, pick: fn(&CurveRow) -> f64) -> f64 {
    let after = run.partition_point(|r| r.seconds <= t);
    if after == 0 {
        return pick(run[0]);
    }
    if after == run.len() {
        return pick(run[after - 1]);
    }
    let (a, b) = (run[after - 1], run[after]);
    let (ta, tb, ea, eb) = (a.seconds, b.seconds, pick(a), pick(b));
    if ta > 0.0 && ea > 0.0 && eb > 0.0 {
        let f = (t / ta).ln() / (tb / ta).ln();
        (ea.ln() + f * (eb / ea).ln()).exp()
    } else {
        ea + (eb - ea) * (t - ta) / (tb - ta)
    }
}

/// When a curve reaches an error: the time, and whether the curve was
/// already there at its first point (then the time is an upper bound: the
/// curve got there at or before its first snapshot).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reached {
    pub seconds: f64,
    pub at_first_point: bool,
}

/// The time from which a (log-log interpolated) mean curve is at or below
/// `error` up to its end, or `None` if its last point is above it.
///
/// Not the first time it dips below: relMSE curves are not monotone (a
/// firefly, the combination of a new iteration, a plan's fallback that
/// restarts the image), and a curve that dips below the target and ends
/// above it has not reached it. So a method whose final mean error is above
/// the target never gets there, and one whose curve is monotone gets there
/// at its first crossing.
pub fn time_to_error(seconds: &[f64], errors: &[f64], error: f64) -> Option<Reached> {
    let n = seconds.len().min(errors.len());
    if n == 0 || !(errors[n - 1] <= error) {
        return None;
    }
    let Some(k) = (0..n).rev().find(|&k| !(errors[k] <= error)) else {
        return Some(Reached {
            seconds: seconds[0],
            at_first_point: true,
        });
    };
    let (e0, e1) = (errors[k], errors[k + 1]);
    let (t0, t1) = (seconds[k], seconds[k + 1]);
    let seconds = if e0 > 0.0 && e1 > 0.0 && error > 0.0 && t0 > 0.0 {
        let f = (error.ln() - e0.ln()) / (e1.ln() - e0.ln());
        (t0.ln() + f * (t1 / t0).ln()).exp()
    } else {
        t1
    };
    Some(Reached {
        seconds,
        at_first_point: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_round_trips_and_means_are_exact() {
        let rows: Vec<CurveRow> = (0..2)
            .flat_map(|run| {
                (0..3).map(move |k| CurveRow {
                    method: "pt".into(),
                    run,
                    seconds: (k + 1) as f64,
                    spp: 4 * (k + 1),
                    mae: 0.1 / (k + 1) as f64 + run as f64 * 0.01,
                    relmse: 0.2 / (k + 1) as f64,
                    relmse_trimmed: (k > 0).then_some(0.1 / (k + 1) as f64),
                })
            })
            .collect();
        let back = parse_csv(&to_csv(&rows)).unwrap();
        assert_eq!(back.len(), 6);
        assert!((back[4].mae - rows[4].mae).abs() < 1e-12);
        // The trimmed relMSE round-trips, a missing one as an empty field.
        assert_eq!(back[0].relmse_trimmed, None);
        assert!((back[4].relmse_trimmed.unwrap() - 0.05).abs() < 1e-12);
        let c = mean_curve(&rows, "pt");
        assert_eq!(c.seconds, vec![1.0, 2.0, 3.0]);
        assert!((c.mae[0].0 - 0.105).abs() < 1e-12);
        // std of {0.1, 0.11} = 0.00707…
        assert!((c.mae[0].1 - 0.01 / 2f64.sqrt()).abs() < 1e-12);
        assert!(parse_csv("nope\n").is_err());
        for bad in ["NaN", "inf", "-0.5", "x"] {
            let text = format!("{CSV_HEADER}\npt,0,1.0,4,{bad},0.1,0.1\n");
            assert!(parse_csv(&text).unwrap_err().contains(bad), "{bad}");
            let text = format!("{CSV_HEADER}\npt,0,1.0,4,0.1,0.1,{bad}\n");
            assert!(parse_csv(&text).unwrap_err().contains(bad), "{bad}");
        }
        // Files from before the trimmed column still read, without it; a
        // row of the other width is refused under either header.
        let old = "method,run,seconds,spp,mae,relmse\npt,0,1.0,4,0.1,0.2\n";
        let old_rows = parse_csv(old).unwrap();
        assert_eq!(
            (old_rows[0].relmse, old_rows[0].relmse_trimmed),
            (0.2, None)
        );
        assert!(parse_csv("method,run,seconds,spp,mae,relmse\npt,0,1.0,4,0.1,0.2,0.1\n").is_err());
        assert!(parse_csv(&format!("{CSV_HEADER}\npt,0,1.0,4,0.1,0.2\n")).is_err());
        // Sparse run ids are runs like any other.
        let sparse = format!("{CSV_HEADER}\npt,4000000000,1.0,4,0.1,0.2,\npt,7,1.0,4,0.3,0.4,\n");
        let c = mean_curve(&parse_csv(&sparse).unwrap(), "pt");
        assert!((c.mae[0].0 - 0.2).abs() < 1e-12, "{:?}", c.mae);
    }

    fn row(run: u32, seconds: f64, error: f64) -> CurveRow {
        CurveRow {
            method: "m".into(),
            run,
            seconds,
            spp: 1,
            mae: error,
            relmse: error,
            relmse_trimmed: Some(error),
        }
    }

    /// Runs that took different snapshots are averaged at common times,
    /// not snapshot by snapshot, and the curve ends at the mean of the
    /// runs' final errors. Run 1 missed the snapshot at 2 s and ends later.
    #[test]
    fn runs_with_different_snapshots_are_averaged_at_common_times() {
        let mut rows: Vec<CurveRow> = [1.0, 2.0, 4.0, 8.0]
            .iter()
            .map(|&t| row(0, t, 1.0 / t))
            .collect();
        rows.extend([1.0, 4.0, 8.5].iter().map(|&t| row(1, t, 2.0 / t)));
        let c = mean_curve(&rows, "m");
        assert_eq!(c.seconds, vec![1.0, 2.0, 4.0, 8.0, 8.5]);
        // At 2 s run 1 lies on its log-log segment 2/t: 1.0; run 0 is 0.5.
        assert!((c.relmse[1].0 - 0.75).abs() < 1e-12, "{:?}", c.relmse);
        // At 4 s both took a snapshot: 0.25 and 0.5.
        assert!((c.mae[2].0 - 0.375).abs() < 1e-12);
        // After 8 s run 0 holds its final 1/8; run 1 ends at 2/8.5.
        let end = (0.125 + 2.0 / 8.5) / 2.0;
        assert!((c.relmse[4].0 - end).abs() < 1e-12);
        // The old snapshot-by-snapshot mean stopped at 3 points and put
        // run 0's 2 s snapshot beside run 1's 4 s one.
        assert_eq!(c.seconds.len(), 5);
        // A curve that ends below another's final error reaches it.
        let base_final = 0.2;
        let errs: Vec<f64> = c.relmse.iter().map(|e| e.0).collect();
        assert!(end < base_final && time_to_error(&c.seconds, &errs, base_final).is_some());
    }

    /// A run that starts later than the others starts the curve: before
    /// its first row no mean over all runs exists.
    #[test]
    fn the_curve_starts_when_every_run_has_a_value() {
        let rows = vec![row(0, 0.5, 4.0), row(0, 1.0, 2.0), row(1, 1.5, 1.0)];
        let c = mean_curve(&rows, "m");
        assert_eq!(c.seconds, vec![1.5]);
        // Run 0 holds its last value 2.0 after 1 s.
        assert_eq!(c.relmse[0].0, 1.5);
        assert!(mean_curve(&rows, "other").seconds.is_empty());
    }

    #[test]
    fn time_to_error_interpolates_in_log_log() {
        // error = 1/t: reaching 0.25 takes t = 4, between samples at 2 and 8.
        let t = [1.0, 2.0, 8.0];
        let e = [1.0, 0.5, 0.125];
        let reached = time_to_error(&t, &e, 0.25).unwrap();
        assert!((reached.seconds - 4.0).abs() < 1e-9 && !reached.at_first_point);
        let first = Reached {
            seconds: 1.0,
            at_first_point: true,
        };
        assert_eq!(time_to_error(&t, &e, 2.0), Some(first));
        assert_eq!(time_to_error(&t, &e, 0.01), None);
        // A curve that dips below the target and rises above it again
        // reaches it at its last crossing, not its first; one that ends
        // above it never does.
        let t = [1.0, 2.0, 4.0, 8.0];
        let e = [1.0, 0.1, 0.5, 0.125];
        assert!((time_to_error(&t, &e, 0.25).unwrap().seconds - 4.0 * 2f64.sqrt()).abs() < 1e-9);
        assert_eq!(time_to_error(&t[..3], &e[..3], 0.25), None);
        assert_eq!(time_to_error(&[], &[], 1.0), None);
        let (m, s) = mean_std(&[1.0, 2.0, 3.0]);
        assert_eq!((m, s), (2.0, 1.0));
    }
}
