//! Error-versus-time plots (SVG via plotters): one log-log panel for relMSE
//! and one for MAE, each method's mean over runs with a ±1 std band.

use super::curves::MeanCurve;
use plotters::prelude::*;

const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

pub fn curves_svg(title: &str, time_label: &str, curves: &[MeanCurve]) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1200, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let root = root
            .titled(title, ("sans-serif", 20))
            .map_err(|e| e.to_string())?;
        let (left, right) = root.split_horizontally(600);
        panel(&left, "relMSE", time_label, curves, |c| &c.relmse)?;
        panel(&right, "MAE", time_label, curves, |c| &c.mae)?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

fn panel(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    metric: &str,
    time_label: &str,
    curves: &[MeanCurve],
    pick: impl Fn(&MeanCurve) -> &Vec<(f64, f64)>,
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    let positive = |x: f64| x.is_finite() && x > 0.0;
    let mut t = (f64::INFINITY, f64::NEG_INFINITY);
    let mut y = (f64::INFINITY, f64::NEG_INFINITY);
    for c in curves {
        for (k, &s) in c.seconds.iter().enumerate() {
            let (m, sd) = pick(c)[k];
            if positive(s) && positive(m) {
                t = (t.0.min(s), t.1.max(s));
                y = (y.0.min((m - sd).max(m * 0.1)), y.1.max(m + sd));
            }
        }
    }
    if !(t.0 < t.1) {
        t = (0.1, 1.0);
    }
    if !(y.0 < y.1) {
        y = (1e-3, 1.0);
    }
    let mut chart = ChartBuilder::on(area)
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (t.0 * 0.9..t.1 * 1.1).log_scale(),
            // From just below a whole decade: plotters ticks a log axis
            // from its first decade on (found through a rounded logarithm,
            // so exactly at 0.01 it starts at 0.1), which left the lower
            // errors unlabelled.
            (0.999 * 10f64.powf((y.0 * 0.8).log10().floor())..y.1 * 1.25).log_scale(),
        )
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(time_label)
        .y_desc(metric)
        .x_label_formatter(&|v| nice_label(*v).map_or(String::new(), |(m, e)| plain(m, e)))
        .y_label_formatter(&|v| nice_label(*v).map_or(String::new(), |(m, e)| format!("{m}e{e}")))
        // The minor lines bunch up into grey bands where plotters repeats a
        // tick; the labelled lines are grid enough.
        .light_line_style(TRANSPARENT)
        .draw()
        .map_err(err)?;
    for (i, c) in curves.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        let pts: Vec<(f64, f64, f64)> = c
            .seconds
            .iter()
            .zip(pick(c))
            .filter(|(s, (m, _))| positive(**s) && positive(*m))
            .map(|(&s, &(m, sd))| (s, m, sd))
            .collect();
        if pts.is_empty() {
            continue;
        }
        let mut band: Vec<(f64, f64)> = pts.iter().map(|&(s, m, sd)| (s, m + sd)).collect();
        band.extend(
            pts.iter()
                .rev()
                .map(|&(s, m, sd)| (s, (m - sd).max(m * 0.1))),
        );
        chart
            .draw_series(std::iter::once(Polygon::new(
                band,
                color.mix(0.15).filled(),
            )))
            .map_err(err)?;
        chart
            .draw_series(LineSeries::new(
                pts.iter().map(|&(s, m, _)| (s, m)),
                color.stroke_width(2),
            ))
            .map_err(err)?
            .label(c.method.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(err)?;
    Ok(())
}

/// A log axis's tick as (mantissa, decade exponent) when the mantissa is
/// 1, 2 or 5, else `None`. plotters puts a tick at every integer multiple
/// of each decade (and the next decade twice), whose labels ran into each
/// other ("8.09.010.0"); only these are labelled, the rest keep their grid
/// line.
fn nice_label(v: f64) -> Option<(u32, i32)> {
    if !(v.is_finite() && v > 0.0) {
        return None;
    }
    let mut e = v.log10().floor() as i32;
    let mut m = v / 10f64.powi(e);
    if m > 9.999 {
        (m, e) = (m / 10.0, e + 1);
    }
    [1u32, 2, 5]
        .into_iter()
        .find(|&k| (m - k as f64).abs() < 1e-3 * k as f64)
        .map(|k| (k, e))
}

/// m·10^e written out (0.5, 2, 50, 100), for the time axis.
fn plain(m: u32, e: i32) -> String {
    if e >= 0 {
        format!("{}", m as u64 * 10u64.pow(e as u32))
    } else {
        format!("{:.*}", (-e) as usize, m as f64 * 10f64.powi(e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_ticks_are_labelled_at_one_two_and_five_only() {
        assert_eq!(nice_label(1.0), Some((1, 0)));
        assert_eq!(nice_label(0.02), Some((2, -2)));
        assert_eq!(nice_label(50.000001), Some((5, 1)));
        // The next decade, reached by accumulating a step of 1.
        assert_eq!(nice_label(9.9999999), Some((1, 1)));
        assert_eq!(nice_label(8.0), None);
        assert_eq!(nice_label(3.0e-3), None);
        assert_eq!(nice_label(0.0), None);
        assert_eq!(nice_label(f64::NAN), None);
        assert_eq!(plain(5, -1), "0.5");
        assert_eq!(plain(2, 2), "200");
        assert_eq!(plain(1, 0), "1");
    }

    /// Errors between 0.02 and 0.3: the lower decade is labelled, and no
    /// tick but 1, 2 and 5 times a power of ten is.
    #[test]
    fn the_axes_label_the_lower_decade_and_nothing_crowded() {
        let c = MeanCurve {
            method: "pt".into(),
            seconds: vec![0.8, 3.0, 30.0],
            mae: vec![(0.3, 0.0), (0.1, 0.0), (0.02, 0.0)],
            relmse: vec![(0.3, 0.0), (0.1, 0.0), (0.02, 0.0)],
        };
        let svg = curves_svg("t", "seconds", &[c]).unwrap();
        let labels: Vec<&str> = svg
            .split("<text")
            .skip(1)
            .filter_map(|t| t.split('>').nth(1))
            .map(|t| t.split('<').next().unwrap().trim())
            .filter(|t| !t.is_empty())
            .collect();
        for want in ["1e-2", "2e-2", "5e-2", "1e-1", "1", "2", "5", "10", "20"] {
            assert!(labels.contains(&want), "{want} missing from {labels:?}");
        }
        for crowded in ["3", "8", "9", "3e-2", "1.0e-1", "8.0"] {
            assert!(!labels.contains(&crowded), "{crowded} in {labels:?}");
        }
    }

    #[test]
    fn svg_has_both_panels_and_every_method() {
        let c = |name: &str, k: f64| MeanCurve {
            method: name.into(),
            seconds: vec![1.0, 2.0, 4.0],
            mae: vec![(k, k * 0.1), (k / 2.0, 0.0), (k / 4.0, 0.01)],
            relmse: vec![(k, 0.0), (k / 2.0, 0.0), (k / 4.0, 0.0)],
        };
        let svg = curves_svg("test", "seconds", &[c("pt", 1.0), c("radiance", 0.5)]).unwrap();
        assert!(svg.starts_with("<svg"));
        assert!(svg.contains("relMSE") && svg.contains("MAE"));
        // plotters writes each label on its own line inside <text>.
        assert_eq!(
            svg.matches("\npt\n").count(),
            2,
            "one legend entry per panel"
        );
        assert_eq!(svg.matches("\nradiance\n").count(), 2);
        assert!(svg.matches("<polyline").count() >= 4);
    }
}
