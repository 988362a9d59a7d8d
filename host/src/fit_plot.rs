//! The plot of one fit: measured vs fitted speed (and current, when fitted), the residual,
//! and the convergence trace.

use crate::csvio::OwnedRecord;
use crate::fit::Fit;
use crate::plot::{draw, Panel, Series, MAX_POINTS};
use anyhow::{anyhow, Result};
use motor_id_shared::fit::objective::Objective;
use plotters::style::{RGBColor, BLUE, RED};
use std::path::Path;

/// Measured vs fitted speed, residual, convergence.
pub fn plot_fit(path: &Path, records: &[OwnedRecord], f: &Fit) -> Result<()> {
    let borrowed = OwnedRecord::as_records(records, f.with_current);
    let objective = Objective::new(&borrowed).map_err(|e| anyhow!("{e}"))?;
    // Records side by side on one time axis, only the points drawn kept: a long record
    // costs its simulation (8 bytes a sample, one record at a time), not a copy per series.
    let total: usize = records.iter().map(OwnedRecord::len).sum();
    let stride = total.div_ceil(MAX_POINTS).max(1);
    let (mut t, mut measured, mut fitted, mut residual) = (vec![], vec![], vec![], vec![]);
    let (mut current, mut current_fit) = (vec![], vec![]);
    let (mut offset, mut first) = (0.0, 0);
    for (k, r) in records.iter().enumerate() {
        let mut w = vec![0.0; r.len()];
        let mut i = vec![0.0; r.len()];
        objective
            .simulate(&f.result.params, k, &mut w, &mut i)
            .map_err(|e| anyhow!("{e}"))?;
        // The first sample of this record on the common stride.
        let start = (stride - first % stride) % stride;
        for s in (start..r.len()).step_by(stride) {
            t.push(offset + s as f64 * r.dt as f64);
            measured.push(r.omega[s]);
            fitted.push(w[s]);
            residual.push(r.omega[s] - w[s]);
            if let (true, Some(c)) = (f.with_current, &r.current) {
                current.push(c[s]);
                current_fit.push(i[s]);
            }
        }
        offset += r.len() as f64 * r.dt as f64;
        first += r.len();
    }
    let evals: Vec<f64> = f
        .result
        .trace
        .iter()
        .map(|p| p.evaluations as f64)
        .collect();
    let best: Vec<f32> = f.result.trace.iter().map(|p| p.best).collect();
    let green = RGBColor(0, 140, 0);
    let mut panels = vec![
        Panel {
            title: format!(
                "speed: measured vs fitted (rmse {:.4} rad/s)",
                f.result.cost.rmse_omega
            ),
            x_label: "t [s] (records side by side)",
            y_label: "omega [rad/s]",
            series: vec![
                Series {
                    label: "measured",
                    x: &t,
                    y: &measured,
                    color: BLUE,
                },
                Series {
                    label: "fitted",
                    x: &t,
                    y: &fitted,
                    color: RED,
                },
            ],
            log_y: false,
            categories: None,
            spans: vec![],
        },
        Panel {
            title: "residual (measured - fitted)".into(),
            x_label: "t [s]",
            y_label: "omega error [rad/s]",
            series: vec![Series {
                label: "residual",
                x: &t,
                y: &residual,
                color: green,
            }],
            log_y: false,
            categories: None,
            spans: vec![],
        },
        Panel {
            title: "convergence (paper's Fig. 10)".into(),
            x_label: "model evaluations",
            y_label: if f.with_current {
                "best fitness [noise-weighted, in speed units]"
            } else {
                "best fitness: speed rmse [rad/s]"
            },
            series: vec![Series {
                label: "best",
                x: &evals,
                y: &best,
                color: BLUE,
            }],
            log_y: true,
            categories: None,
            spans: vec![],
        },
    ];
    if f.with_current {
        panels.insert(
            1,
            Panel {
                title: format!(
                    "current: measured vs fitted (rmse {:.4} A)",
                    f.result.cost.rmse_current.unwrap_or(f32::NAN)
                ),
                x_label: "t [s] (records side by side)",
                y_label: "i [A]",
                series: vec![
                    Series {
                        label: "measured",
                        x: &t,
                        y: &current,
                        color: BLUE,
                    },
                    Series {
                        label: "fitted",
                        x: &t,
                        y: &current_fit,
                        color: RED,
                    },
                ],
                log_y: false,
                categories: None,
                spans: vec![],
            },
        );
    }
    draw(path, &panels)
}
