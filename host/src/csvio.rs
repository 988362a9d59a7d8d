//! Record CSV (docs/CONTRACTS.md): a header row; columns `t` (s, uniform step), `v` (V),
//! `omega` (rad/s), optional `i` (A), optional `tl` (N m); other columns ignored. Plus the
//! oscilloscope import of the seed's workflow (tacho volts to rad/s).

use crate::output::write_atomically;
use anyhow::{anyhow, bail, Context, Result};
use motor_id_shared::model::record::MIN_SAMPLES;
use motor_id_shared::Record;
use std::path::{Path, PathBuf};

/// Largest relative deviation of one time step from the mean step.
const STEP_TOLERANCE: f64 = 0.01;

/// A record read from or written to CSV.
#[derive(Clone, Debug, PartialEq)]
pub struct OwnedRecord {
    /// Where it came from (for messages).
    pub path: PathBuf,
    /// Time of the first sample [s].
    pub t0: f64,
    /// Sample step [s].
    pub dt: f32,
    /// Armature voltage [V].
    pub v: Vec<f32>,
    /// Speed [rad/s].
    pub omega: Vec<f32>,
    /// Armature current [A].
    pub current: Option<Vec<f32>>,
    /// Known load torque [N m].
    pub load: Option<Vec<f32>>,
    /// First sample of a coast-down (the `bridge` column is 0 from there to the end: every
    /// bridge switch off, no current, the voltage not applied), if the record has one.
    pub coast_from: Option<usize>,
}

impl OwnedRecord {
    /// Borrow as the core's record; `use_current = false` drops the current column.
    pub fn as_record(&self, use_current: bool) -> Record<'_> {
        Record {
            dt: self.dt,
            v: &self.v,
            omega: &self.omega,
            current: self.current.as_deref().filter(|_| use_current),
            load: self.load.as_deref(),
            coast_from: self.coast_from,
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.v.len()
    }

    /// The time of sample `k` as written: the step's shortest decimal (an f32 step of 1 ms is
    /// 0.001 s, not 0.0010000000474974513) times `k`, rounded to six digits below the step.
    pub fn time_text(&self, k: usize) -> String {
        let step: f64 = self.dt.to_string().parse().unwrap_or(self.dt as f64);
        let t = self.t0 + k as f64 * step;
        let decimals = (6.0 - step.log10().floor()).clamp(0.0, 17.0) as usize;
        let text = format!("{t:.decimals$}");
        let text = text.trim_end_matches('0');
        text.strip_suffix('.').unwrap_or(text).to_string()
    }

    /// File name for messages.
    pub fn name(&self) -> String {
        self.path.display().to_string()
    }

    /// Read and validate a record CSV.
    pub fn read(path: &Path) -> Result<OwnedRecord> {
        read_record(path).with_context(|| path.display().to_string())
    }

    /// Read and validate several record CSVs, stopping at the first that fails.
    pub fn read_all(paths: &[PathBuf]) -> Result<Vec<OwnedRecord>> {
        paths.iter().map(|p| OwnedRecord::read(p)).collect()
    }

    /// Borrow each of `records` as the core's record ([`OwnedRecord::as_record`]).
    pub fn as_records(records: &[OwnedRecord], use_current: bool) -> Vec<Record<'_>> {
        records.iter().map(|r| r.as_record(use_current)).collect()
    }

    /// The same samples as `other` (the same file, or a copy of it).
    pub fn same_data(&self, other: &OwnedRecord) -> bool {
        self.dt == other.dt
            && self.v == other.v
            && self.omega == other.omega
            && self.current == other.current
            && self.load == other.load
            && self.coast_from == other.coast_from
    }

    /// Write as record CSV.
    pub fn write(&self, path: &Path) -> Result<()> {
        write_atomically(path, |tmp| self.write_to(tmp, path))
    }

    /// Write as record CSV to `tmp` (`path` names it in errors).
    fn write_to(&self, tmp: &Path, path: &Path) -> Result<()> {
        let mut w = csv::Writer::from_path(tmp)
            .with_context(|| format!("cannot create {}", path.display()))?;
        let mut header = vec!["t", "v", "omega"];
        if self.current.is_some() {
            header.push("i");
        }
        if self.load.is_some() {
            header.push("tl");
        }
        if self.coast_from.is_some() {
            header.push("bridge");
        }
        w.write_record(&header)?;
        for k in 0..self.len() {
            let mut row = vec![
                self.time_text(k),
                self.v[k].to_string(),
                self.omega[k].to_string(),
            ];
            if let Some(c) = &self.current {
                row.push(c[k].to_string());
            }
            if let Some(l) = &self.load {
                row.push(l[k].to_string());
            }
            if let Some(c) = self.coast_from {
                row.push(if k < c { "1" } else { "0" }.into());
            }
            w.write_record(&row)?;
        }
        w.flush()
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(())
    }
}

/// Largest magnitude of a signal sample (V, rad/s, A, N m): a larger one is a unit or scale
/// error, and its squares would overflow the fit's f32 sums.
const MAX_MAGNITUDE: f64 = 1e9;

fn read_record(path: &Path) -> Result<OwnedRecord> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(path)
        .map_err(|e| anyhow!("cannot open: {}", csv_message(&e)))?;
    let header = reader
        .headers()
        .map_err(|e| anyhow!("{}", csv_message(&e)))?
        .clone();
    if header.is_empty() {
        bail!("empty file");
    }
    let col = |name: &str| header.iter().position(|h| h.eq_ignore_ascii_case(name));
    for name in ["t", "v", "omega", "i", "tl", "bridge"] {
        if header
            .iter()
            .filter(|h| h.eq_ignore_ascii_case(name))
            .count()
            > 1
        {
            bail!("column {name} appears more than once in the header: which one is meant?");
        }
    }
    let (t_col, v_col, w_col) = match (col("t"), col("v"), col("omega")) {
        (Some(t), Some(v), Some(w)) => (t, v, w),
        _ => {
            let missing: Vec<&str> = ["t", "v", "omega"]
                .into_iter()
                .filter(|c| col(c).is_none())
                .collect();
            let joined = header.iter().collect::<Vec<_>>().join(",");
            let hint = match [';', '\t'].into_iter().find(|s| joined.contains(*s)) {
                Some(';') => {
                    "; the file seems to separate fields with ';': records are comma-separated"
                }
                Some(_) => {
                    "; the file seems to separate fields with tabs: records are comma-separated"
                }
                None => "",
            };
            bail!(
                "missing column(s) {} (header is '{}'; need t, v, omega, optional i, tl, bridge){hint}",
                missing.join(", "),
                joined.escape_default()
            );
        }
    };
    let (i_col, tl_col, bridge_col) = (col("i"), col("tl"), col("bridge"));
    let mut bridge = Vec::new();
    let mut t = Vec::new();
    let mut v = Vec::new();
    let mut omega = Vec::new();
    let mut current = i_col.map(|_| Vec::new());
    let mut load = tl_col.map(|_| Vec::new());
    let mut lines = Vec::new();
    for (row, result) in reader.records().enumerate() {
        let rec = result.map_err(|e| {
            let line = e.position().map_or(row as u64 + 2, |p| p.line());
            anyhow!("line {line}: {}", csv_message(&e))
        })?;
        let line = rec.position().map_or(row as u64 + 2, |p| p.line());
        lines.push(line);
        // Every column is stored as f32 (time as f64): a value beyond f32 is refused here,
        // with its line, rather than later as an anonymous infinity.
        let field = |c: usize, name: &str| -> Result<f64> {
            let text = rec
                .get(c)
                .ok_or_else(|| anyhow!("line {line}: column {name} is missing"))?;
            let x: f64 = text.parse().map_err(|_| {
                // Escaped: a quoted field may hold a line break, and the error is one line.
                let text = text.escape_debug();
                anyhow!("line {line}: {name} = '{text}' is not a number")
            })?;
            if !x.is_finite() || !(x as f32).is_finite() {
                bail!("line {line}: {name} = '{text}' is not finite (as a 32-bit float)");
            }
            if name != "t" && x.abs() > MAX_MAGNITUDE {
                bail!(
                    "line {line}: {name} = '{text}' is beyond {MAX_MAGNITUDE:e} (a unit or scale error?)"
                );
            }
            Ok(x)
        };
        t.push(field(t_col, "t")?);
        v.push(field(v_col, "v")? as f32);
        omega.push(field(w_col, "omega")? as f32);
        if let (Some(c), Some(out)) = (i_col, current.as_mut()) {
            out.push(field(c, "i")? as f32);
        }
        if let (Some(c), Some(out)) = (tl_col, load.as_mut()) {
            out.push(field(c, "tl")? as f32);
        }
        if let Some(c) = bridge_col {
            let b = field(c, "bridge")?;
            if b != 0.0 && b != 1.0 {
                bail!("line {line}: bridge = {b}: 1 (driven) or 0 (open circuit)");
            }
            bridge.push((b == 1.0, line));
        }
    }
    if t.is_empty() {
        bail!("no data rows");
    }
    if t.len() < MIN_SAMPLES {
        bail!("only {} data rows (need at least {MIN_SAMPLES})", t.len());
    }
    if omega.iter().all(|w| *w == 0.0) {
        bail!("omega is zero throughout: the motor never turned, there is nothing to fit");
    }
    let dt = uniform_step(&t, &lines)?;
    let coast_from = coast_from(&bridge)?;
    let rec = OwnedRecord {
        path: path.to_path_buf(),
        t0: t[0],
        dt,
        v,
        omega,
        current,
        load,
        coast_from,
    };
    rec.as_record(true).validate().map_err(|e| anyhow!("{e}"))?;
    Ok(rec)
}

/// The first open-circuit sample of a `bridge` column (`(driven, line)` per row; empty: no
/// column): the model opens the bridge once, so the open part must run to the end, after a
/// driven start.
fn coast_from(bridge: &[(bool, u64)]) -> Result<Option<usize>> {
    let Some(first) = bridge.iter().position(|(driven, _)| !driven) else {
        return Ok(None);
    };
    if first == 0 {
        bail!(
            "line {}: bridge is 0 from the first row: a coast-down follows a driven part",
            bridge[0].1
        );
    }
    if let Some((_, line)) = bridge[first..].iter().find(|(driven, _)| *driven) {
        bail!(
            "line {line}: bridge is 1 again after the open circuit from line {}: the model opens the bridge once, to the end of the record",
            bridge[first].1
        );
    }
    Ok(Some(first))
}

/// The mean step of strictly increasing, uniformly spaced times (`lines[k]`: the file line
/// of `t[k]`, for messages).
fn uniform_step(t: &[f64], lines: &[u64]) -> Result<f32> {
    let n = t.len();
    let dt = (t[n - 1] - t[0]) / (n - 1) as f64;
    for k in 1..n {
        let step = t[k] - t[k - 1];
        let line = lines[k];
        if step <= 0.0 {
            bail!(
                "time is not increasing at line {line} (t = {} after {})",
                t[k],
                t[k - 1]
            );
        }
        if (step - dt).abs() > STEP_TOLERANCE * dt {
            bail!(
                "time step is not uniform at line {line}: {step} s where the mean step is {dt} s"
            );
        }
    }
    let dt32 = dt as f32;
    if !(dt32.is_finite() && dt32 > 0.0) {
        bail!("time step {dt} s is not representable");
    }
    Ok(dt32)
}

fn csv_message(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::Io(io) => io.to_string(),
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => {
            format!("{len} fields where the header has {expected_len}")
        }
        csv::ErrorKind::Utf8 { .. } => "not UTF-8 text".into(),
        _ => e.to_string(),
    }
}

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

#[cfg(test)]
#[path = "csvio_fuzz.rs"]
mod fuzz;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_are_written_as_the_steps_shortest_decimal() {
        let rec = OwnedRecord {
            path: "r.csv".into(),
            t0: 0.0,
            dt: 1e-3,
            v: vec![0.0; 4],
            omega: vec![0.0; 4],
            current: None,
            load: None,
            coast_from: None,
        };
        let times: Vec<String> = (0..4).map(|k| rec.time_text(k)).collect();
        assert_eq!(times, ["0", "0.001", "0.002", "0.003"]);
        // Far into a long record, no f32 residue either.
        assert_eq!(rec.time_text(3_600_000), "3600");
        let slow = OwnedRecord {
            dt: 0.25,
            t0: 1.5,
            ..rec
        };
        assert_eq!(slow.time_text(3), "2.25");
    }

    #[test]
    fn reads_optional_columns_ignores_others_and_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        let mut text = String::from("note, T ,V,Omega,i,tl\n");
        for k in 0..10 {
            text += &format!(
                "x,{},{},{},{},{}\n",
                0.5 + k as f64 * 0.002,
                12,
                k,
                0.1 * k as f64,
                0.01
            );
        }
        std::fs::write(&path, text).unwrap();
        let rec = OwnedRecord::read(&path).unwrap();
        assert_eq!(rec.len(), 10);
        assert!((rec.dt - 0.002).abs() < 1e-9);
        assert_eq!(rec.t0, 0.5);
        assert_eq!(rec.omega[3], 3.0);
        assert_eq!(rec.current.as_ref().unwrap()[2], 0.2);
        assert_eq!(rec.load.as_ref().unwrap()[9], 0.01);
        let again = dir.path().join("again.csv");
        rec.write(&again).unwrap();
        let back = OwnedRecord::read(&again).unwrap();
        assert_eq!(back.omega, rec.omega);
        assert_eq!(back.current, rec.current);
        assert_eq!(back.v, rec.v);
    }

    #[test]
    fn a_quoted_line_break_in_a_number_is_refused_on_one_line() {
        // Found by the csv fuzz target: the field was echoed as it was, on two lines.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        std::fs::write(&path, "t,v,omega\n0,\"1\n2\",1\n").unwrap();
        let err = format!("{:#}", OwnedRecord::read(&path).unwrap_err());
        assert!(
            err.ends_with("line 2: v = '1\\n2' is not a number"),
            "{err}"
        );
    }

    #[test]
    fn jittered_time_within_one_percent_is_uniform() {
        let t: Vec<f64> = (0..100)
            .map(|k| k as f64 * 0.001 + if k % 2 == 1 { 4e-6 } else { 0.0 })
            .collect();
        let lines: Vec<u64> = (2..102).collect();
        assert!(uniform_step(&t, &lines).is_ok());
        let mut bad = t.clone();
        bad[50] += 0.0005;
        let err = uniform_step(&bad, &lines).unwrap_err().to_string();
        assert!(err.contains("line 52"), "{err}");
    }
}
