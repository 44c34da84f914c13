//! Line plots for the reports, as SVG (the `plotters` crate): one series per structure, the
//! x axis the scene's polygon count. PNG copies wait for a font the bitmap backend can draw
//! text with (plotters' `ttf` reads system fonts, which a CI machine may not have).

use plotters::prelude::*;

/// One curve: its label and `(x, y)` points in order of `x`.
pub(super) struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// An SVG line plot of `series` (axes from the data, y from 0); `None` when there is no
/// point to plot.
pub(super) fn svg(title: &str, x_label: &str, y_label: &str, series: &[Series]) -> Option<String> {
    let points = || series.iter().flat_map(|s| s.points.iter());
    let (x0, x1) = points().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let y1 = points().fold(0.0f64, |a, p| a.max(p.1));
    if !(x0.is_finite() && x1.is_finite() && y1.is_finite()) {
        return None;
    }
    let (x0, x1) = if x1 > x0 {
        (x0, x1)
    } else {
        (x0 - 1.0, x1 + 1.0)
    };
    let y1 = if y1 > 0.0 { y1 * 1.05 } else { 1.0 };
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (720, 480)).into_drawing_area();
        root.fill(&WHITE).ok()?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, 0.0..y1)
            .ok()?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .draw()
            .ok()?;
        for (k, s) in series.iter().enumerate() {
            let colour = Palette99::pick(k).to_rgba();
            chart
                .draw_series(LineSeries::new(
                    s.points.iter().copied(),
                    colour.stroke_width(2),
                ))
                .ok()?
                .label(s.label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour));
            chart
                .draw_series(s.points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .ok()?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .ok()?;
        root.present().ok()?;
    }
    Some(out)
}
