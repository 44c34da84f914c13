//! Line plots for the reports (the `plotters` crate): one series per curve, as SVG and as
//! PNG. The PNG's text needs a font file: plotters' bitmap backend draws with `ab_glyph` from
//! a font registered at run time, the first of [`FONTS`] found on the machine (a system font
//! rather than one shipped in the repository, whose licence and bytes the project would then
//! carry). Plotters lays the SVG's text out with the same font's metrics, so without one
//! no plot is drawn: [`Plot::render`] then returns no file, and the index shows none.

use plotters::coord::Shift;
use plotters::prelude::*;
use std::sync::OnceLock;

/// One curve: its label and `(x, y)` points in order of `x`.
pub(super) struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// A plot a target asks for: its file stem (written as `STEM.svg`, and `STEM.png` where a
/// font is at hand), title, axes' labels and curves.
pub(super) struct Plot {
    pub stem: &'static str,
    pub title: String,
    pub x_label: &'static str,
    pub y_label: &'static str,
    pub series: Vec<Series>,
    /// Names for x = 0, 1, 2, ... where the x axis is categorical (scenes, layouts); empty
    /// for a numeric axis.
    pub categories: Vec<String>,
}

impl Plot {
    /// The plot's files: SVG, then PNG where a font is at hand; none without a point.
    pub fn render(&self) -> Vec<(String, Vec<u8>)> {
        let mut out = Vec::new();
        if let Some(text) = svg(self) {
            out.push((format!("{}.svg", self.stem), text.into_bytes()));
            if let Some(bytes) = png(self) {
                out.push((format!("{}.png", self.stem), bytes));
            }
        }
        out
    }
}

const SIZE: (u32, u32) = (720, 480);

/// Sans-serif fonts where Debian and other systems put them.
const FONTS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/Library/Fonts/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// Registers the first font of [`FONTS`] found as plotters' "sans-serif", once; the file it
/// read, or `None` where there is none.
pub(super) fn font() -> Option<&'static str> {
    static FONT: OnceLock<Option<&'static str>> = OnceLock::new();
    *FONT.get_or_init(|| {
        FONTS.iter().copied().find(|path| {
            let Ok(bytes) = std::fs::read(path) else {
                return false;
            };
            // Registered once for the process's life: plotters keeps a `'static` slice.
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok()
        })
    })
}

/// The axes' ranges from the data (y from 0), or `None` when there is nothing to plot.
fn ranges(series: &[Series]) -> Option<((f64, f64), f64)> {
    let points = || series.iter().flat_map(|s| s.points.iter());
    let (x0, x1) = points().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let y1 = points().fold(0.0f64, |a, p| a.max(p.1));
    if !(x0.is_finite() && x1.is_finite() && y1.is_finite()) {
        return None;
    }
    let x = if x1 > x0 {
        (x0, x1)
    } else {
        (x0 - 1.0, x1 + 1.0)
    };
    Some((x, if y1 > 0.0 { y1 * 1.05 } else { 1.0 }))
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, plot: &Plot) -> Option<()> {
    let (title, series) = (&plot.title, &plot.series);
    let ((x0, x1), y1) = ranges(series)?;
    // A categorical axis gets half a step of room either side of its first and last name.
    let (x0, x1) = if plot.categories.is_empty() {
        (x0, x1)
    } else {
        (-0.5, plot.categories.len() as f64 - 0.5)
    };
    let name = |x: &f64| {
        let k = x.round();
        if (x - k).abs() < 1e-6 && k >= 0.0 {
            plot.categories.get(k as usize).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    };
    root.fill(&WHITE).ok()?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, 0.0..y1)
        .ok()?;
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(plot.x_label).y_desc(plot.y_label);
    if !plot.categories.is_empty() {
        mesh.x_labels(plot.categories.len() + 1)
            .x_label_formatter(&name)
            .disable_x_mesh();
    }
    mesh.draw().ok()?;
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
    root.present().ok()
}

/// An SVG line plot of `series`; `None` when there is no point to plot or no font.
fn svg(plot: &Plot) -> Option<String> {
    // Plotters lays text out with the registered font's metrics, in SVG too.
    font()?;
    let mut out = String::new();
    draw(
        SVGBackend::with_string(&mut out, SIZE).into_drawing_area(),
        plot,
    )?;
    Some(out)
}

/// The same plot as PNG bytes; `None` when there is no point to plot or no font to draw the
/// text with ([`font`]).
fn png(plot: &Plot) -> Option<Vec<u8>> {
    font()?;
    let mut rgb = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    draw(
        BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area(),
        plot,
    )?;
    let image = image::RgbImage::from_raw(SIZE.0, SIZE.1, rgb)?;
    let mut out = std::io::Cursor::new(Vec::new());
    image.write_to(&mut out, image::ImageFormat::Png).ok()?;
    Some(out.into_inner())
}
