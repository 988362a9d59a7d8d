//! The `diagnose` plot: held-out speed measured, with the baseline and with the verdict's
//! effect; the residuals before and after; the baseline's misfit by regime; and, for each
//! held-out record whose input alternates too fast to read on the overview (a chirp, a
//! sine), a zoom on the few periods where the baseline misfits most, its window shaded on
//! the overview.

use super::data::Data;
use super::report::DiagnoseReport;
use crate::csvio::OwnedRecord;
use crate::plot::{draw_rows, Panel, Series};
use anyhow::{anyhow, bail, Result};
use motor_id_shared::fit::objective::Objective;
use motor_id_shared::ModelParams;
use plotters::style::{RGBColor, BLUE, RED};
use std::ops::Range;
use std::path::Path;

/// Draw the plot of `report` into `path`: `base` the baseline's parameters, `chosen` the
/// verdict's model.
pub fn plot(
    path: &Path,
    data: &Data,
    base: &ModelParams,
    chosen: Option<&ModelParams>,
    report: &DiagnoseReport,
) -> Result<()> {
    let recs = OwnedRecord::as_records(&data.holdout, data.with_current);
    let obj = Objective::new(&recs).map_err(|e| anyhow!("{e}"))?;
    let (mut t, mut meas, mut wb, mut we, mut rb, mut re) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    let mut offset = 0.0;
    // Where each record's samples start in the overview's arrays.
    let mut starts = Vec::new();
    for (k, r) in data.holdout.iter().enumerate() {
        starts.push(t.len());
        let n = r.len();
        let (mut b, mut e, mut i) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        obj.simulate(base, k, &mut b, &mut i)
            .map_err(|e| anyhow!("{e}"))?;
        obj.simulate(chosen.unwrap_or(base), k, &mut e, &mut i)
            .map_err(|e| anyhow!("{e}"))?;
        for s in 0..n {
            t.push(offset + s as f64 * r.dt as f64);
            meas.push(r.omega[s]);
            wb.push(b[s]);
            we.push(e[s]);
            rb.push(r.omega[s] - b[s]);
            re.push(r.omega[s] - e[s]);
        }
        offset += n as f64 * r.dt as f64;
    }
    let regimes = &report.where_.regimes;
    let labels: Vec<String> = regimes.iter().map(|r| r.short.to_string()).collect();
    let share: Vec<f32> = regimes.iter().map(|r| r.share_of_misfit as f32).collect();
    let samples: Vec<f32> = regimes.iter().map(|r| r.share_of_samples as f32).collect();
    let named: Vec<&str> = report.verdict.effects.iter().map(|e| e.name).collect();
    let label = if named.is_empty() {
        "no effect".to_string()
    } else {
        named.join(" + ")
    };
    let green = RGBColor(0, 140, 0);
    let mut panels = [
        Panel {
            title: "held-out speed: measured, baseline, with the verdict's effects".into(),
            x_label: "t [s] (held-out records side by side)",
            y_label: "omega [rad/s]",
            series: vec![
                Series {
                    label: "measured",
                    x: &t,
                    y: &meas,
                    color: BLUE,
                },
                Series {
                    label: "baseline",
                    x: &t,
                    y: &wb,
                    color: RED,
                },
                Series {
                    label: &label,
                    x: &t,
                    y: &we,
                    color: green,
                },
            ],
            log_y: false,
            categories: None,
            spans: vec![],
        },
        Panel {
            title: "held-out residual before / after".into(),
            x_label: "t [s]",
            y_label: "omega error [rad/s]",
            series: vec![
                Series {
                    label: "baseline",
                    x: &t,
                    y: &rb,
                    color: RED,
                },
                Series {
                    label: &label,
                    x: &t,
                    y: &re,
                    color: green,
                },
            ],
            log_y: false,
            categories: None,
            spans: vec![],
        },
        Panel {
            title: "baseline misfit by regime (train and held-out records)".into(),
            x_label: "regime",
            y_label: "share",
            series: vec![
                Series {
                    label: "share of misfit",
                    x: &[],
                    y: &share,
                    color: RED,
                },
                Series {
                    label: "share of samples",
                    x: &[],
                    y: &samples,
                    color: BLUE,
                },
            ],
            log_y: false,
            categories: Some(labels),
            spans: vec![],
        },
    ];
    if regimes.is_empty() {
        bail!("no regime to plot");
    }
    // The zooms: the fastest-alternating records first, at most MAX_ZOOMS of them.
    let total = offset;
    let overview_t = &t;
    let mut fast: Vec<(usize, Vec<usize>)> = data
        .holdout
        .iter()
        .enumerate()
        .map(|(k, r)| (k, r.len() as f64 * r.dt as f64 / total, sign_changes(&r.v)))
        .filter(|(_, share, c)| alternates_fast(c.len(), *share))
        .map(|(k, _, c)| (k, c))
        .collect();
    fast.sort_by_key(|(_, c)| std::cmp::Reverse(c.len()));
    fast.truncate(MAX_ZOOMS);
    fast.sort_by_key(|(k, _)| *k);
    let zooms: Vec<Zoom> = fast
        .iter()
        .map(|(k, changes)| {
            let r = &data.holdout[*k];
            let at = starts[*k];
            let window = worst_window(changes, &rb[at..at + r.len()]);
            let t: Vec<f64> = window
                .clone()
                .map(|s| r.t0 + s as f64 * r.dt as f64)
                .collect();
            let slice = |y: &[f32]| y[at + window.start..at + window.end].to_vec();
            Zoom {
                title: format!(
                    "{}, the {ZOOM_PERIODS} periods of largest baseline misfit",
                    r.name()
                ),
                overview: overview_t[at + window.start]..overview_t[at + window.end - 1],
                x_label: format!("t in {} [s]", r.name()),
                t,
                meas: slice(&meas),
                wb: slice(&wb),
                we: slice(&we),
                rb: slice(&rb),
                re: slice(&re),
            }
        })
        .collect();
    // Where the zooms are, shaded on the overview's two panels.
    for panel in &mut panels[..2] {
        panel.spans = zooms.iter().map(|z| z.overview.clone()).collect();
        if !zooms.is_empty() {
            panel.title.push_str(" (shaded: zoomed in below)");
        }
    }
    let zoom_panels: Vec<[Panel; 2]> = zooms
        .iter()
        .map(|z| {
            let line = |label, y, color| Series {
                label,
                x: &z.t,
                y,
                color,
            };
            [
                Panel {
                    title: format!("zoom on {}", z.title),
                    x_label: &z.x_label,
                    y_label: "omega [rad/s]",
                    series: vec![
                        line("measured", &z.meas, BLUE),
                        line("baseline", &z.wb, RED),
                        line(&label, &z.we, green),
                    ],
                    log_y: false,
                    categories: None,
                    spans: vec![],
                },
                Panel {
                    title: "its residual before / after".into(),
                    x_label: &z.x_label,
                    y_label: "omega error [rad/s]",
                    series: vec![line("baseline", &z.rb, RED), line(&label, &z.re, green)],
                    log_y: false,
                    categories: None,
                    spans: vec![],
                },
            ]
        })
        .collect();
    let mut rows: Vec<&[Panel]> = vec![&panels[0..1], &panels[1..2]];
    rows.extend(zoom_panels.iter().map(|p| &p[..]));
    rows.push(&panels[2..3]);
    draw_rows(path, &rows)
}

/// Most held-out records zoomed into.
const MAX_ZOOMS: usize = 3;

/// Periods of the input a zoom spans.
const ZOOM_PERIODS: usize = 3;

/// Width of the overview's plotting area [px] (of the 1,200 px image).
const OVERVIEW_PX: f64 = 1100.0;

/// Narrowest half period of the input that reads on the overview [px]: a record whose half
/// periods are narrower on average gets a zoom.
const READABLE_PX: f64 = 60.0;

/// One zoom: a window of one held-out record, in the record's own time.
struct Zoom {
    /// What it shows (record and window).
    title: String,
    /// Its window on the overview's time axis [s] (records side by side).
    overview: Range<f64>,
    /// The time axis's label.
    x_label: String,
    /// Time [s].
    t: Vec<f64>,
    /// Measured speed [rad/s].
    meas: Vec<f32>,
    /// The baseline's speed [rad/s].
    wb: Vec<f32>,
    /// The verdict's model's speed [rad/s].
    we: Vec<f32>,
    /// The baseline's residual [rad/s].
    rb: Vec<f32>,
    /// The verdict's model's residual [rad/s].
    re: Vec<f32>,
}

/// The samples at which the input `v` changes sign: the first sample of each new sign.
/// Samples within 1 % of the peak voltage have no sign (a ramp through zero, noise at rest).
fn sign_changes(v: &[f32]) -> Vec<usize> {
    let peak = v.iter().fold(0.0f32, |m, x| m.max(x.abs()));
    let mut last = 0.0f32;
    let mut out = Vec::new();
    for (k, &x) in v.iter().enumerate() {
        if x.abs() <= 0.01 * peak || !x.is_finite() {
            continue;
        }
        let sign = x.signum();
        if last != 0.0 && sign != last {
            out.push(k);
        }
        last = sign;
    }
    out
}

/// Whether a record with `changes` sign changes of its input, taking `share` of the
/// overview's time axis, alternates too fast to read there: two periods at least, and half
/// periods narrower than [`READABLE_PX`] on average.
fn alternates_fast(changes: usize, share: f64) -> bool {
    changes >= 4 && share * OVERVIEW_PX / (changes as f64) < READABLE_PX
}

/// The samples of [`ZOOM_PERIODS`] periods of the input (between its sign changes `changes`)
/// over which `residual` has the largest mean square; the whole record when it has fewer.
fn worst_window(changes: &[usize], residual: &[f32]) -> Range<usize> {
    let half = 2 * ZOOM_PERIODS;
    if changes.len() <= half {
        return 0..residual.len();
    }
    let mut sum = vec![0.0f64; residual.len() + 1];
    for (k, x) in residual.iter().enumerate() {
        let x = if x.is_finite() { *x as f64 } else { 0.0 };
        sum[k + 1] = sum[k] + x * x;
    }
    let mean_square = |w: &Range<usize>| (sum[w.end] - sum[w.start]) / w.len().max(1) as f64;
    changes
        .windows(half + 1)
        .map(|w| w[0]..w[half])
        .max_by(|a, b| mean_square(a).total_cmp(&mean_square(b)))
        .unwrap_or(0..residual.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sign_changes_skip_the_dead_band() {
        let v = [0.0, 1.0, 0.005, -1.0, -1.0, 0.0, 1.0, 1.0];
        assert_eq!(sign_changes(&v), [3, 6]);
        assert!(sign_changes(&[0.0, 2.0, 2.0, 0.0]).is_empty());
    }

    #[test]
    fn a_chirp_on_two_thirds_of_the_axis_is_zoomed_a_lone_slow_sine_is_not() {
        // The lab's chirp_1 (62 sign changes, 20 s of 33 s) and sine_1 (9, 10 s of 33 s).
        assert!(alternates_fast(62, 20.0 / 33.0));
        assert!(alternates_fast(9, 10.0 / 33.0));
        // Eight reversals filling the whole axis read well; a step has none.
        assert!(!alternates_fast(8, 1.0));
        assert!(!alternates_fast(0, 0.1));
    }

    #[test]
    fn the_window_is_the_periods_with_the_largest_misfit() {
        // A square wave of period 20 samples; the residual is large in samples 100..140.
        let v: Vec<f32> = (0..400)
            .map(|k| if (k / 10) % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let residual: Vec<f32> = (0..400)
            .map(|k| if (100..140).contains(&k) { 5.0 } else { 0.1 })
            .collect();
        let changes = sign_changes(&v);
        let w = worst_window(&changes, &residual);
        assert_eq!(w.len(), 2 * ZOOM_PERIODS * 10);
        assert!(w.start <= 100 && w.end >= 140, "{w:?}");
        // Fewer periods than a window: the whole record.
        assert_eq!(worst_window(&changes[..3], &residual), 0..400);
    }
}
