//! The `diagnose` plot: held-out speed measured, with the baseline and with the verdict's
//! effect; the residuals before and after; the baseline's misfit by regime.

use super::data::Data;
use super::report::DiagnoseReport;
use crate::csvio::OwnedRecord;
use crate::plot::{draw, Panel, Series};
use anyhow::{anyhow, bail, Result};
use motor_id_shared::fit::objective::Objective;
use motor_id_shared::ModelParams;
use plotters::style::{RGBColor, BLUE, RED};
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
    for (k, r) in data.holdout.iter().enumerate() {
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
    let panels = [
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
        },
    ];
    if regimes.is_empty() {
        bail!("no regime to plot");
    }
    draw(path, &panels)
}
