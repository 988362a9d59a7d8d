//! The plot of one fit: measured vs fitted speed (and current, when fitted), the residual,
//! and the convergence trace.

use crate::csvio::OwnedRecord;
use crate::fit::Fit;
use crate::plot::{draw, Panel, Series};
use anyhow::{anyhow, Result};
use motor_id_shared::fit::objective::Objective;
use plotters::style::{RGBColor, BLUE, RED};
use std::path::Path;

/// Measured vs fitted speed, residual, convergence.
pub fn plot_fit(path: &Path, records: &[OwnedRecord], f: &Fit) -> Result<()> {
    let borrowed = OwnedRecord::as_records(records, f.with_current);
    let objective = Objective::new(&borrowed).map_err(|e| anyhow!("{e}"))?;
    // Records side by side on one time axis.
    let (mut t, mut measured, mut fitted, mut residual) = (vec![], vec![], vec![], vec![]);
    let (mut current, mut current_fit) = (vec![], vec![]);
    let mut offset = 0.0;
    for (k, r) in records.iter().enumerate() {
        let mut w = vec![0.0; r.len()];
        let mut i = vec![0.0; r.len()];
        objective
            .simulate(&f.result.params, k, &mut w, &mut i)
            .map_err(|e| anyhow!("{e}"))?;
        for (s, (&m, &sim)) in r.omega.iter().zip(w.iter()).enumerate() {
            t.push(offset + s as f64 * r.dt as f64);
            measured.push(m);
            fitted.push(sim);
            residual.push(m - sim);
        }
        if let (true, Some(c)) = (f.with_current, &r.current) {
            current.extend_from_slice(c);
            current_fit.extend_from_slice(&i);
        }
        offset += r.len() as f64 * r.dt as f64;
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
        },
        Panel {
            title: "convergence (seed Fig. 10)".into(),
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
            },
        );
    }
    draw(path, &panels)
}
