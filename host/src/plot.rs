//! PNG plots (plotters bitmap backend; text through ab_glyph with the bundled DejaVu font,
//! so no system font library is needed).

use crate::output::write_atomically;
use anyhow::{anyhow, Result};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::Once;

/// Shading of a panel's spans (light amber, behind the lines; a colour nothing else uses).
const SPAN_COLOR: RGBColor = RGBColor(255, 236, 179);

/// Most points drawn per series (longer series are decimated).
pub const MAX_POINTS: usize = 4000;

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
    /// x ranges shaded behind the lines (e.g. where another panel zooms in).
    pub spans: Vec<std::ops::Range<f64>>,
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

/// Height of a row of panels [px].
const ROW_HEIGHT: u32 = 350;

/// Height of a panel's head: its title, and below it the legend row [px].
const HEAD_HEIGHT: u32 = 52;

/// A drawing area of the PNG.
type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// Draw `panels` stacked vertically into a PNG.
pub fn draw(path: &Path, panels: &[Panel]) -> Result<()> {
    let rows: Vec<&[Panel]> = panels.chunks(1).collect();
    draw_rows(path, &rows)
}

/// Draw `rows` of panels stacked vertically into a PNG, the panels of a row side by side.
pub fn draw_rows(path: &Path, rows: &[&[Panel]]) -> Result<()> {
    write_atomically(path, |tmp| draw_to(tmp, path, rows))
}

/// [`draw_rows`] into the file `tmp` (`path` names it in errors).
fn draw_to(tmp: &Path, path: &Path, rows: &[&[Panel]]) -> Result<()> {
    register_font();
    let height = ROW_HEIGHT * rows.len() as u32;
    let root = BitMapBackend::new(tmp, (1200, height)).into_drawing_area();
    let err = |e: &dyn std::fmt::Display| anyhow!("cannot draw {}: {e}", path.display());
    root.fill(&WHITE).map_err(|e| err(&e))?;
    for (row, row_area) in rows.iter().zip(root.split_evenly((rows.len(), 1))) {
        for (panel, area) in row.iter().zip(row_area.split_evenly((1, row.len().max(1)))) {
            draw_panel(&area, panel).map_err(|e| err(&e))?;
        }
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// How a series is marked in the legend.
#[derive(Clone, Copy)]
enum Mark {
    /// A short line (a line series).
    Line,
    /// A filled square (a bar series).
    Bar,
}

/// The panel's head in `area`: its title centred on the first line and, on the second, the
/// legend (each series' mark and label, side by side and centred), so that no legend lies
/// over the data. The area below is returned.
fn head<'a>(
    area: &Area<'a>,
    panel: &Panel,
    mark: Mark,
) -> std::result::Result<Area<'a>, Box<dyn std::error::Error>> {
    let (top, body) = area.split_vertically(HEAD_HEIGHT);
    let width = top.dim_in_pixel().0 as i32;
    let title = ("sans-serif", 20)
        .into_font()
        .into_text_style(&top)
        .pos(Pos::new(HPos::Center, VPos::Top));
    top.draw_text(&panel.title, &title, (width / 2, 6))?;
    let font = ("sans-serif", 14).into_font().into_text_style(&top);
    let (mark_w, gap, spacing) = (22, 6, 24);
    let widths = panel
        .series
        .iter()
        .map(|s| Ok(top.estimate_text_size(s.label, &font)?.0 as i32))
        .collect::<std::result::Result<Vec<i32>, DrawingAreaErrorKind<_>>>()?;
    let total: i32 = widths.iter().map(|w| mark_w + gap + w).sum::<i32>()
        + spacing * (widths.len() as i32 - 1).max(0);
    let (mut x, y) = ((width - total).max(0) / 2, 38);
    let label = font.pos(Pos::new(HPos::Left, VPos::Center));
    for (s, w) in panel.series.iter().zip(&widths) {
        match mark {
            Mark::Line => top.draw(&PathElement::new(
                vec![(x, y), (x + mark_w, y)],
                s.color.stroke_width(2),
            ))?,
            Mark::Bar => top.draw(&Rectangle::new(
                [(x + 5, y - 6), (x + mark_w - 5, y + 6)],
                s.color.filled(),
            ))?,
        }
        top.draw_text(s.label, &label, (x + mark_w + gap, y))?;
        x += mark_w + gap + w + spacing;
    }
    Ok(body)
}

/// One panel in `area`: its head, then its lines (or bars).
fn draw_panel(
    area: &Area<'_>,
    panel: &Panel,
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    if let Some(labels) = &panel.categories {
        let body = head(area, panel, Mark::Bar)?;
        return draw_bars(&body, panel, labels);
    }
    let body = head(area, panel, Mark::Line)?;
    let points: Vec<Vec<(f64, f64)>> = panel.series.iter().map(decimated).collect();
    let (x0, x1) = range(points.iter().flatten().map(|p| p.0), false);
    // A logarithmic axis labels only powers of ten: a range within one decade would show no
    // label at all, so it is drawn linear.
    let (lo, hi) = range(points.iter().flatten().map(|p| p.1), true);
    let log_y = panel.log_y && hi / lo >= 10.0;
    let (y0, y1) = range(points.iter().flatten().map(|p| p.1), log_y);
    let mut builder = ChartBuilder::on(&body);
    builder
        .margin(10)
        .margin_top(4)
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
                .draw()?;
            let (lo, hi) = (y0, y1);
            chart.draw_series(
                panel
                    .spans
                    .iter()
                    .map(|x| Rectangle::new([(x.start, lo), (x.end, hi)], SPAN_COLOR.filled())),
            )?;
            for (s, pts) in panel.series.iter().zip(points.iter()) {
                chart.draw_series(LineSeries::new(
                    pts.iter().copied(),
                    s.color.stroke_width(1),
                ))?;
            }
        }};
    }
    if log_y {
        finish!(builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale())?);
    } else {
        finish!(builder.build_cartesian_2d(x0..x1, y0..y1)?);
    }
    Ok(())
}

/// Grouped bars: one group per category, one bar per series.
fn draw_bars(
    area: &Area<'_>,
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
        .margin(10)
        .margin_top(4)
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
        chart.draw_series(s.y.iter().enumerate().map(|(k, y)| {
            Rectangle::new(
                [(left(k), 0.0), (left(k) + width, *y as f64)],
                color.filled(),
            )
        }))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Columns of a 600x300 drawing of `panel` that hold the span's colour.
    fn shaded_columns(panel: &Panel) -> Vec<usize> {
        register_font();
        let (w, h) = (600usize, 300usize);
        let mut buf = vec![0u8; w * h * 3];
        {
            let area =
                BitMapBackend::with_buffer(&mut buf, (w as u32, h as u32)).into_drawing_area();
            area.fill(&WHITE).unwrap();
            draw_panel(&area, panel).unwrap();
            area.present().unwrap();
        }
        let shade = [SPAN_COLOR.0, SPAN_COLOR.1, SPAN_COLOR.2];
        (0..w)
            .filter(|&x| (0..h).any(|y| buf[(y * w + x) * 3..][..3] == shade))
            .collect()
    }

    #[test]
    fn a_span_is_shaded_over_its_x_range_only() {
        let x: Vec<f64> = (0..=100).map(f64::from).collect();
        let y: Vec<f32> = x.iter().map(|&t| (t as f32 * 0.2).sin()).collect();
        let panel = |spans: Vec<std::ops::Range<f64>>| Panel {
            title: "spans".into(),
            x_label: "t",
            y_label: "y",
            series: vec![Series {
                label: "y",
                x: &x,
                y: &y,
                color: BLUE,
            }],
            log_y: false,
            categories: None,
            spans,
        };
        assert!(shaded_columns(&panel(vec![])).is_empty());
        let cols = shaded_columns(&panel(vec![40.0..60.0]));
        // The plotting area spans about 500 of the 600 columns: 40..60 of 0..100 is about
        // 100 columns, in the middle.
        assert!((80..=120).contains(&cols.len()), "{} columns", cols.len());
        let (first, last) = (cols[0], cols[cols.len() - 1]);
        assert_eq!(last - first + 1, cols.len(), "one band");
        assert!(first > 250 && last < 450, "band at {first}..{last}");
    }
}
