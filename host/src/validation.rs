//! Identified parameters checked on records: the model of a report simulated on each
//! record, its misfit against the record's noise floor, where it misfits most, and a plot of
//! measured vs predicted speed (`validate`, and the end of `demo`).

use crate::csvio::OwnedRecord;
use crate::plot::{draw_rows, Panel, Series};
use crate::report::identify::ChannelQuality;
use crate::report::{ByParam, Num, SCHEMA_VERSION};
use anyhow::{anyhow, bail, Context, Result};
use motor_id_shared::fit::objective::Objective;
use motor_id_shared::{ModelParams, ParamId};
use plotters::style::{BLUE, RED};
use serde::Serialize;
use std::path::Path;

/// The `validate` report.
#[derive(Serialize, Debug)]
pub struct ValidateReport {
    /// Version of this report's schema.
    pub schema_version: u32,
    /// The parameters checked.
    pub params: ByParam<Num>,
    /// One entry per record.
    pub records: Vec<RecordCheck>,
    /// Every channel of every record is fitted to its noise.
    pub all_adequate: bool,
}

/// The parameters on one record.
#[derive(Serialize, Debug)]
pub struct RecordCheck {
    /// The record file.
    pub path: String,
    /// Speed RMSE of the prediction [rad/s].
    pub rmse_omega: Num,
    /// Measured speed noise of the record [rad/s].
    pub noise_omega: Num,
    /// The speed against its noise (the rule of `identify`'s `fit_quality`).
    pub speed: ChannelQuality,
    /// Current RMSE of the prediction [A], when the record has current.
    pub rmse_current: Option<Num>,
    /// Measured current noise [A].
    pub noise_current: Option<Num>,
    /// The current against its noise.
    pub current: Option<ChannelQuality>,
    /// The largest speed error: when and how large.
    pub largest_misfit: Misfit,
}

/// One point of a misfit.
#[derive(Serialize, Debug)]
pub struct Misfit {
    /// Time [s].
    pub t_s: Num,
    /// Measured minus predicted speed [rad/s].
    pub omega_error: Num,
}

/// The model of a report: the parameters under `verdict.params` (diagnose) or `params`.
pub fn read_params(path: &Path) -> Result<ModelParams> {
    read_params_report(path).map(|r| r.params)
}

/// What `--params` reads of a report, from one reading of it.
pub struct ParamsReport {
    /// The model ([`read_params`]).
    pub params: ModelParams,
    /// The parameters its identification did not pin: an `identify` report's
    /// `identifiability.not_pinned`, a `board` report's parameters whose `pinned` is false;
    /// empty for a report that says nothing of it (`diagnose`).
    pub unpinned: Vec<ParamId>,
}

/// The model of the report at `path` and what its identification did not pin.
pub fn read_params_report(path: &Path) -> Result<ParamsReport> {
    let json = read_report(path)?;
    let params = json["verdict"]["params"]
        .as_object()
        .or_else(|| json["params"].as_object())
        .ok_or_else(|| {
            anyhow!(
                "{}: no `params` (an identify or board report) nor `verdict.params` (a diagnose report)",
                path.display()
            )
        })?;
    let value = |id: ParamId| -> Result<Option<f32>> {
        match params.get(id.name()) {
            None => Ok(None),
            Some(v) => v
                .as_f64()
                .map(|x| Some(x as f32))
                .ok_or_else(|| anyhow!("{}: {} is not a number", path.display(), id.name())),
        }
    };
    let mut p = ModelParams::PAPER_MOTOR;
    for id in ParamId::ALL {
        match value(id)? {
            Some(x) => p.set(id, x),
            None if id.is_motor() => bail!("{}: the report has no {}", path.display(), id.name()),
            None => {}
        }
    }
    for name in params.keys() {
        if ParamId::from_name(name).is_none() {
            bail!("{}: unknown parameter {name}", path.display());
        }
    }
    p.validate()
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Ok(ParamsReport {
        params: p,
        unpinned: unpinned_of(&json),
    })
}

/// The JSON report at `path`, refused when it is not JSON or of a newer schema than this
/// motor-id reads.
fn read_report(path: &Path) -> Result<serde_json::Value> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let json: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| anyhow!("{}: not a JSON report ({e})", path.display()))?;
    if let Some(version) = json["schema_version"].as_u64() {
        if version > u64::from(SCHEMA_VERSION) {
            bail!(
                "{}: schema_version {version} is newer than this motor-id reads ({SCHEMA_VERSION}): update motor-id",
                path.display()
            );
        }
    }
    Ok(json)
}

/// [`ParamsReport::unpinned`] of a report.
fn unpinned_of(json: &serde_json::Value) -> Vec<ParamId> {
    let ident = &json["identifiability"];
    let names: Vec<&str> = match (
        ident["not_pinned"].as_array(),
        ident["parameters"].as_object(),
    ) {
        (Some(list), _) => list.iter().filter_map(|n| n.as_str()).collect(),
        (None, Some(params)) => params
            .iter()
            .filter(|(_, e)| e["pinned"] == false)
            .map(|(n, _)| n.as_str())
            .collect(),
        _ => Vec::new(),
    };
    names.into_iter().filter_map(ParamId::from_name).collect()
}

/// What the parameters predict for one record: its speed, and its current where the check
/// judges it.
pub struct Prediction {
    /// Predicted speed [rad/s].
    pub omega: Vec<f32>,
    /// Predicted current [A], where the record has current and the check judges it.
    pub current: Option<Vec<f32>>,
}

/// `p` checked on `records`, with each record's prediction.
pub fn check(
    p: &ModelParams,
    records: &[OwnedRecord],
    speed_only: bool,
) -> Result<(ValidateReport, Vec<Prediction>)> {
    let mut checks = Vec::new();
    let mut predicted = Vec::new();
    for r in records {
        let rec = [r.as_record(!speed_only)];
        let objective = Objective::new(&rec).map_err(|e| anyhow!("{}: {e}", r.name()))?;
        let (mut w, mut i) = (vec![0.0; r.len()], vec![0.0; r.len()]);
        objective
            .simulate(p, 0, &mut w, &mut i)
            .map_err(|e| anyhow!("{}: {e}", r.name()))?;
        let rms = |x: &mut dyn Iterator<Item = f32>| {
            let (s, n) = x.fold((0.0f64, 0usize), |(s, n), e| {
                (s + (e as f64).powi(2), n + 1)
            });
            (s / n.max(1) as f64).sqrt() as f32
        };
        let errors: Vec<f32> = r.omega.iter().zip(&w).map(|(m, s)| m - s).collect();
        let rmse_omega = rms(&mut errors.iter().copied());
        let noise_omega = objective.sigma_omega();
        let measured_current = r.current.as_deref().filter(|_| !speed_only);
        let rmse_current = measured_current.map(|c| rms(&mut c.iter().zip(&i).map(|(m, s)| m - s)));
        let noise_current = objective.sigma_current();
        let worst = errors
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .map_or(0, |(k, _)| k);
        let current = rmse_current
            .zip(noise_current)
            .map(|(rmse, sigma)| ChannelQuality::new(rmse, sigma));
        checks.push(RecordCheck {
            path: r.name(),
            rmse_omega: Num(rmse_omega),
            noise_omega: Num(noise_omega),
            speed: ChannelQuality::new(rmse_omega, noise_omega),
            rmse_current: rmse_current.map(Num),
            noise_current: noise_current.map(Num),
            current,
            largest_misfit: Misfit {
                t_s: Num((r.t0 + worst as f64 * r.dt as f64) as f32),
                omega_error: Num(errors[worst]),
            },
        });
        predicted.push(Prediction {
            omega: w,
            current: measured_current.map(|_| i),
        });
    }
    let all_adequate = checks
        .iter()
        .all(|c| c.speed.model_adequate && c.current.as_ref().is_none_or(|q| q.model_adequate));
    let params = ParamId::ALL
        .into_iter()
        .filter(|id| id.is_motor() || p.get(*id) != 0.0 && *id != ParamId::RippleCycles)
        .map(|id| (id, Num(p.get(id))))
        .collect();
    let report = ValidateReport {
        schema_version: SCHEMA_VERSION,
        params,
        records: checks,
        all_adequate,
    };
    Ok((report, predicted))
}

impl ValidateReport {
    /// The text summary: a table of the records.
    pub fn text(&self) -> String {
        let mut s = format!(
            "{:<32} {:>11} {:>9} {:>7}  {:>12} {:>9}  largest speed error\n",
            "record", "rmse rad/s", "noise", "ratio", "rmse_i A", "noise"
        );
        for c in &self.records {
            let name = Path::new(&c.path)
                .file_name()
                .map_or(c.path.clone(), |n| n.to_string_lossy().into_owned());
            let current = match (&c.rmse_current, &c.noise_current) {
                (Some(r), Some(n)) => format!("{:>12.4} {:>9.4}", r.0, n.0),
                _ => format!("{:>12} {:>9}", "-", "-"),
            };
            s += &format!(
                "{name:<32} {:>11.4} {:>9.4} {:>7.2}  {current}  {:.3} rad/s at {:.3} s{}\n",
                c.rmse_omega.0,
                c.noise_omega.0,
                c.speed.rmse_over_noise.0,
                c.largest_misfit.omega_error.0,
                c.largest_misfit.t_s.0,
                if c.speed.model_adequate && c.current.as_ref().is_none_or(|q| q.model_adequate) {
                    ""
                } else {
                    "  (not at the noise floor)"
                }
            );
        }
        s += if self.all_adequate {
            "the parameters predict every record to its noise floor\n"
        } else {
            "the parameters do not predict every record to its noise floor\n"
        };
        s
    }
}

/// Measured vs predicted speed of each record, one row each; beside it the current where
/// the check judged it.
pub fn plot(path: &Path, records: &[OwnedRecord], predicted: &[Prediction]) -> Result<()> {
    let times: Vec<Vec<f64>> = records
        .iter()
        .map(|r| (0..r.len()).map(|k| k as f64 * r.dt as f64).collect())
        .collect();
    let rows = rows_of(records, predicted, &times);
    let rows: Vec<&[Panel]> = rows.iter().map(|r| r.as_slice()).collect();
    draw_rows(path, &rows)
}

/// The plot's rows: per record its speed panel, and its current panel where judged.
fn rows_of<'a>(
    records: &'a [OwnedRecord],
    predicted: &'a [Prediction],
    times: &'a [Vec<f64>],
) -> Vec<Vec<Panel<'a>>> {
    let panel = |r: &OwnedRecord, what: &str, y_label, t, measured, predicted| Panel {
        title: format!(
            "{}: measured vs predicted {what}",
            r.path
                .file_name()
                .map_or(r.name(), |n| n.to_string_lossy().into_owned())
        ),
        x_label: "t [s]",
        y_label,
        series: vec![
            Series {
                label: "measured",
                x: t,
                y: measured,
                color: BLUE,
            },
            Series {
                label: "predicted",
                x: t,
                y: predicted,
                color: RED,
            },
        ],
        log_y: false,
        categories: None,
        spans: vec![],
    };
    records
        .iter()
        .zip(predicted)
        .zip(times)
        .map(|((r, p), t)| {
            let mut row = vec![panel(r, "speed", "omega [rad/s]", t, &r.omega, &p.omega)];
            if let (Some(measured), Some(current)) = (&r.current, &p.current) {
                row.push(panel(r, "current", "i [A]", t, measured, current));
            }
            row
        })
        .collect()
}

#[cfg(test)]
#[path = "validation_fuzz.rs"]
mod fuzz;

#[cfg(test)]
mod tests {
    use super::*;

    fn report(dir: &Path, text: &str) -> std::path::PathBuf {
        let p = dir.join("r.json");
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn the_plot_shows_the_current_where_the_check_judges_it() {
        let rec = |current: Option<Vec<f32>>| OwnedRecord {
            path: "r.csv".into(),
            t0: 0.0,
            dt: 0.01,
            v: vec![1.0; 3],
            omega: vec![0.0, 1.0, 2.0],
            current,
            load: None,
            coast_from: None,
            averaged: 1,
        };
        let records = [rec(Some(vec![0.5; 3])), rec(Some(vec![0.5; 3])), rec(None)];
        let predicted = [
            Prediction {
                omega: vec![0.0; 3],
                current: Some(vec![0.4; 3]),
            },
            // Judged on speed only (--speed-only): no current panel.
            Prediction {
                omega: vec![0.0; 3],
                current: None,
            },
            Prediction {
                omega: vec![0.0; 3],
                current: None,
            },
        ];
        let times = vec![vec![0.0, 0.01, 0.02]; 3];
        let rows = rows_of(&records, &predicted, &times);
        let panels: Vec<usize> = rows.iter().map(|r| r.len()).collect();
        assert_eq!(panels, [2, 1, 1]);
        assert!(
            rows[0][1].title.ends_with("current"),
            "{}",
            rows[0][1].title
        );
    }

    #[test]
    fn parameters_are_read_from_identify_board_and_diagnose_reports() {
        let d = tempfile::tempdir().unwrap();
        let motor = r#""ra":1,"la":0.1,"j":0.01,"b":0.005,"kv":0.5"#;
        let plain = read_params(&report(
            d.path(),
            &format!(r#"{{"params":{{{motor},"tc":0.2}}}}"#),
        ))
        .unwrap();
        assert_eq!(plain.get(ParamId::Kv), 0.5);
        assert_eq!(plain.get(ParamId::Tc), 0.2);
        // A diagnose report: the verdict's model, not the baseline's.
        let diag = format!(
            r#"{{"baseline":{{"params":{{{motor}}}}},"verdict":{{"params":{{{motor},"kq":1e-5}}}}}}"#
        );
        let p = read_params(&report(d.path(), &diag)).unwrap();
        assert_eq!(p.get(ParamId::Kq), 1e-5);
        for (text, expect) in [
            (r#"{"params":{"ra":1}}"#.to_string(), "has no la"),
            (
                format!(r#"{{"params":{{{motor},"zz":1}}}}"#),
                "unknown parameter zz",
            ),
            (r#"{"other":1}"#.to_string(), "no `params`"),
            (
                format!(r#"{{"schema_version":99,"params":{{{motor}}}}}"#),
                "is newer than",
            ),
            ("not json".to_string(), "not a JSON report"),
        ] {
            let err = read_params(&report(d.path(), &text))
                .unwrap_err()
                .to_string();
            assert!(err.contains(expect), "{text}: {err}");
        }
    }
}
