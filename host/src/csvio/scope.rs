//! The oscilloscope import of the seed's workflow: a trace of tacho volts to a record.

use super::time::uniform_step;
use super::OwnedRecord;
use anyhow::{anyhow, Context, Result};
use motor_id_shared::model::record::MIN_SAMPLES;
use std::path::Path;

/// How to turn an oscilloscope trace of tacho volts into a record.
#[derive(Clone, Debug)]
pub struct ScopeImport {
    /// Tacho gain [rad/s per V] (the seed's 35).
    pub gain: f32,
    /// The trace was captured inverted (the seed's "inverted option"): negate it.
    pub inverted: bool,
    /// Zero-based column of time.
    pub time_column: usize,
    /// Zero-based column of the tacho channel.
    pub channel: usize,
    /// Armature voltage applied [V].
    pub voltage: f32,
    /// Time at which the voltage is switched on [s]; before it 0 V.
    pub step_at: f64,
}

/// Read a scope CSV: lines whose needed fields are not numbers (headers, units, settings)
/// are skipped; the rest must be uniform in time.
pub fn import_scope(path: &Path, s: &ScopeImport) -> Result<OwnedRecord> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let sep = if text.lines().any(|l| l.contains(';')) && !text.lines().any(|l| l.contains(',')) {
        ';'
    } else {
        ','
    };
    let mut t = Vec::new();
    let mut omega = Vec::new();
    let mut lines = Vec::new();
    for (number, line) in text.lines().enumerate() {
        let fields: Vec<&str> = line
            .split(sep)
            .map(|f| f.trim().trim_matches('"'))
            .collect();
        let get = |c: usize| {
            fields
                .get(c)
                .and_then(|f| f.parse::<f64>().ok())
                .filter(|x| x.is_finite())
        };
        if let (Some(time), Some(volts)) = (get(s.time_column), get(s.channel)) {
            t.push(time);
            lines.push(number as u64 + 1);
            let w = volts as f32 * s.gain;
            omega.push(if s.inverted { -w } else { w });
        }
    }
    let context = || path.display().to_string();
    if t.len() < MIN_SAMPLES {
        return Err(anyhow!(
            "found {} numeric rows in columns {} and {} (need at least {MIN_SAMPLES})",
            t.len(),
            s.time_column,
            s.channel
        ))
        .with_context(context);
    }
    let dt = uniform_step(&t, &lines).with_context(context)?;
    let (first, last) = (t[0], t[t.len() - 1]);
    if s.step_at > last {
        return Err(anyhow!(
            "--step-at {} s is after the trace's end ({last} s): the record would have no voltage",
            s.step_at
        ))
        .with_context(context);
    }
    if s.step_at < first {
        return Err(anyhow!(
            "--step-at {} s is before the trace's start ({first} s): the step from rest is not in it",
            s.step_at
        ))
        .with_context(context);
    }
    let v = t
        .iter()
        .map(|&ti| if ti >= s.step_at { s.voltage } else { 0.0 })
        .collect();
    let rec = OwnedRecord {
        path: path.to_path_buf(),
        t0: t[0],
        dt,
        v,
        omega,
        current: None,
        load: None,
        coast_from: None,
    };
    rec.as_record(false)
        .validate()
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Ok(rec)
}
