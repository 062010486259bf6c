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

pub fn curves_svg(title: &str, curves: &[MeanCurve]) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1200, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let root = root
            .titled(title, ("sans-serif", 20))
            .map_err(|e| e.to_string())?;
        let (left, right) = root.split_horizontally(600);
        panel(&left, "relMSE", curves, |c| &c.relmse)?;
        panel(&right, "MAE", curves, |c| &c.mae)?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

fn panel(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    metric: &str,
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
            (y.0 * 0.8..y.1 * 1.25).log_scale(),
        )
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("seconds (training included)")
        .y_desc(metric)
        .y_label_formatter(&|v| format!("{v:.1e}"))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svg_has_both_panels_and_every_method() {
        let c = |name: &str, k: f64| MeanCurve {
            method: name.into(),
            seconds: vec![1.0, 2.0, 4.0],
            mae: vec![(k, k * 0.1), (k / 2.0, 0.0), (k / 4.0, 0.01)],
            relmse: vec![(k, 0.0), (k / 2.0, 0.0), (k / 4.0, 0.0)],
        };
        let svg = curves_svg("test", &[c("pt", 1.0), c("radiance", 0.5)]).unwrap();
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
