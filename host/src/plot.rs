//! PNG plots (plotters bitmap backend; text through ab_glyph with the bundled DejaVu font,
//! so no system font library is needed).

use crate::output::write_atomically;
use anyhow::{anyhow, Result};
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::Once;

/// Most points drawn per series (longer series are decimated).
const MAX_POINTS: usize = 4000;

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bundled font always parses; a failure would only lose text.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

/// One line of a panel.
pub struct Series<'a> {
    /// Legend label.
    pub label: &'a str,
    /// x values.
    pub x: &'a [f64],
    /// y values.
    pub y: &'a [f32],
    /// Colour.
    pub color: RGBColor,
}

/// One panel: title, axis labels, lines; `log_y` for convergence plots.
pub struct Panel<'a> {
    /// Title.
    pub title: String,
    /// x axis label.
    pub x_label: &'a str,
    /// y axis label.
    pub y_label: &'a str,
    /// Lines.
    pub series: Vec<Series<'a>>,
    /// Logarithmic y axis (drawn linear when the values span less than a decade).
    pub log_y: bool,
    /// Draw the series as grouped bars over these category labels (series `x` ignored)
    /// instead of lines.
    pub categories: Option<Vec<String>>,
}

fn decimated(s: &Series) -> Vec<(f64, f64)> {
    let n = s.x.len().min(s.y.len());
    let stride = n.div_ceil(MAX_POINTS).max(1);
    (0..n)
        .step_by(stride)
        .map(|k| (s.x[k], s.y[k] as f64))
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect()
}

fn range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values {
        if log && v <= 0.0 {
            continue;
        }
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() || !hi.is_finite() {
        return if log { (1e-3, 1.0) } else { (0.0, 1.0) };
    }
    if log {
        return (lo / 1.5, hi * 1.5);
    }
    let pad = ((hi - lo) * 0.05).max(1e-9 + lo.abs() * 1e-6);
    (lo - pad, hi + pad)
}

/// Draw `panels` stacked vertically into a PNG.
pub fn draw(path: &Path, panels: &[Panel]) -> Result<()> {
    write_atomically(path, |tmp| draw_to(tmp, path, panels))
}

/// [`draw`] into the file `tmp` (`path` names it in errors).
fn draw_to(tmp: &Path, path: &Path, panels: &[Panel]) -> Result<()> {
    register_font();
    let height = 330 * panels.len() as u32;
    let root = BitMapBackend::new(tmp, (1200, height)).into_drawing_area();
    let err = |e: &dyn std::fmt::Display| anyhow!("cannot draw {}: {e}", path.display());
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let areas = root.split_evenly((panels.len(), 1));
    for (panel, area) in panels.iter().zip(areas.iter()) {
        if let Some(labels) = &panel.categories {
            draw_bars(area, panel, labels).map_err(|e| err(&e))?;
            continue;
        }
        let points: Vec<Vec<(f64, f64)>> = panel.series.iter().map(decimated).collect();
        let (x0, x1) = range(points.iter().flatten().map(|p| p.0), false);
        // A logarithmic axis labels only powers of ten: a range within one decade would show
        // no label at all, so it is drawn linear.
        let (lo, hi) = range(points.iter().flatten().map(|p| p.1), true);
        let log_y = panel.log_y && hi / lo >= 10.0;
        let (y0, y1) = range(points.iter().flatten().map(|p| p.1), log_y);
        let mut builder = ChartBuilder::on(area);
        builder
            .caption(&panel.title, ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(80);
        macro_rules! finish {
            ($chart:expr) => {{
                let mut chart = $chart;
                chart
                    .configure_mesh()
                    .x_desc(panel.x_label)
                    .y_desc(panel.y_label)
                    .label_style(("sans-serif", 14))
                    .draw()
                    .map_err(|e| err(&e))?;
                for (s, pts) in panel.series.iter().zip(points.iter()) {
                    let color = s.color;
                    chart
                        .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(1)))
                        .map_err(|e| err(&e))?
                        .label(s.label)
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
                }
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.8))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 14))
                    .draw()
                    .map_err(|e| err(&e))?;
            }};
        }
        if log_y {
            finish!(builder
                .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
                .map_err(|e| err(&e))?);
        } else {
            finish!(builder
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| err(&e))?);
        }
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// Grouped bars: one group per category, one bar per series.
fn draw_bars(
    area: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    panel: &Panel,
    labels: &[String],
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    let n = labels.len();
    let top = panel
        .series
        .iter()
        .flat_map(|s| s.y.iter())
        .fold(0.0f64, |m, y| m.max(*y as f64))
        .max(1e-9)
        * 1.1;
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(-0.5f64..(n as f64 - 0.5), 0.0f64..top)?;
    chart
        .configure_mesh()
        .x_labels(n)
        .x_label_formatter(&|x| {
            let k = x.round();
            if (x - k).abs() < 1e-6 && k >= 0.0 {
                labels.get(k as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .y_desc(panel.y_label)
        .label_style(("sans-serif", 12))
        .disable_x_mesh()
        .draw()?;
    let groups = panel.series.len().max(1) as f64;
    let width = 0.8 / groups;
    for (g, s) in panel.series.iter().enumerate() {
        let color = s.color;
        let left = |k: usize| k as f64 - 0.4 + g as f64 * width;
        chart
            .draw_series(s.y.iter().enumerate().map(|(k, y)| {
                Rectangle::new(
                    [(left(k), 0.0), (left(k) + width, *y as f64)],
                    color.filled(),
                )
            }))?
            .label(s.label)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 15, y + 5)], color.filled()));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()?;
    Ok(())
}
