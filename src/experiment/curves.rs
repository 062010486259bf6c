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
}

pub const CSV_HEADER: &str = "method,run,seconds,spp,mae,relmse";

pub fn to_csv(rows: &[CurveRow]) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{:.6},{},{:.9e},{:.9e}",
            r.method, r.run, r.seconds, r.spp, r.mae, r.relmse
        );
    }
    s
}

pub fn parse_csv(text: &str) -> Result<Vec<CurveRow>, String> {
    let mut lines = text.lines();
    if lines.next() != Some(CSV_HEADER) {
        return Err("missing or wrong CSV header".into());
    }
    lines
        .filter(|l| !l.is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            if f.len() != 6 {
                return Err(format!("bad row '{l}'"));
            }
            let num = |s: &str| {
                s.parse::<f64>()
                    .map_err(|_| format!("bad number '{s}' in '{l}'"))
            };
            Ok(CurveRow {
                method: f[0].to_string(),
                run: f[1].parse().map_err(|_| format!("bad run in '{l}'"))?,
                seconds: num(f[2])?,
                spp: f[3].parse().map_err(|_| format!("bad spp in '{l}'"))?,
                mae: num(f[4])?,
                relmse: num(f[5])?,
            })
        })
        .collect()
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

/// A method's curve averaged over runs: snapshot k of every run is averaged
/// (runs take their snapshots at the same nominal times).
#[derive(Clone, Debug)]
pub struct MeanCurve {
    pub method: String,
    pub seconds: Vec<f64>,
    pub mae: Vec<(f64, f64)>,
    pub relmse: Vec<(f64, f64)>,
}

pub fn mean_curve(rows: &[CurveRow], method: &str) -> MeanCurve {
    let mut runs: Vec<Vec<&CurveRow>> = Vec::new();
    for r in rows.iter().filter(|r| r.method == method) {
        let run = r.run as usize;
        if runs.len() <= run {
            runs.resize(run + 1, Vec::new());
        }
        runs[run].push(r);
    }
    runs.retain(|r| !r.is_empty());
    let len = runs.iter().map(Vec::len).min().unwrap_or(0);
    let mut c = MeanCurve {
        method: method.to_string(),
        seconds: Vec::new(),
        mae: Vec::new(),
        relmse: Vec::new(),
    };
    for k in 0..len {
        let col = |f: &dyn Fn(&CurveRow) -> f64| runs.iter().map(|r| f(r[k])).collect::<Vec<f64>>();
        c.seconds.push(mean_std(&col(&|r| r.seconds)).0);
        c.mae.push(mean_std(&col(&|r| r.mae)));
        c.relmse.push(mean_std(&col(&|r| r.relmse)));
    }
    c
}

/// First time at which a (log-log interpolated) mean curve reaches `error`,
/// or `None` if it never does within its time range.
pub fn time_to_error(seconds: &[f64], errors: &[f64], error: f64) -> Option<f64> {
    if let (Some(&t0), Some(&e0)) = (seconds.first(), errors.first())
        && e0 <= error
    {
        return Some(t0);
    }
    for k in 1..seconds.len() {
        let (e0, e1) = (errors[k - 1], errors[k]);
        if e1 <= error && e0 > error && e0 > 0.0 && e1 > 0.0 {
            let (lt0, lt1) = (seconds[k - 1].ln(), seconds[k].ln());
            let f = (error.ln() - e0.ln()) / (e1.ln() - e0.ln());
            return Some((lt0 + f * (lt1 - lt0)).exp());
        }
    }
    None
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
                })
            })
            .collect();
        let back = parse_csv(&to_csv(&rows)).unwrap();
        assert_eq!(back.len(), 6);
        assert!((back[4].mae - rows[4].mae).abs() < 1e-12);
        let c = mean_curve(&rows, "pt");
        assert_eq!(c.seconds, vec![1.0, 2.0, 3.0]);
        assert!((c.mae[0].0 - 0.105).abs() < 1e-12);
        // std of {0.1, 0.11} = 0.00707…
        assert!((c.mae[0].1 - 0.01 / 2f64.sqrt()).abs() < 1e-12);
        assert!(parse_csv("nope\n").is_err());
    }

    #[test]
    fn time_to_error_interpolates_in_log_log() {
        // error = 1/t: reaching 0.25 takes t = 4, between samples at 2 and 8.
        let t = [1.0, 2.0, 8.0];
        let e = [1.0, 0.5, 0.125];
        assert!((time_to_error(&t, &e, 0.25).unwrap() - 4.0).abs() < 1e-9);
        assert_eq!(time_to_error(&t, &e, 2.0), Some(1.0));
        assert_eq!(time_to_error(&t, &e, 0.01), None);
        let (m, s) = mean_std(&[1.0, 2.0, 3.0]);
        assert_eq!((m, s), (2.0, 1.0));
    }
}
