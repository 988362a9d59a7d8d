//! The oscilloscope import of the paper's workflow: a trace of tacho volts to a record. The
//! trace is read line by line, never whole, as a record CSV is.

use super::bounded::BoundedLines;
use super::time::TimeSteps;
use super::OwnedRecord;
use anyhow::{anyhow, Context, Result};
use motor_id_shared::model::record::MIN_SAMPLES;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

/// How to turn an oscilloscope trace of tacho volts into a record.
#[derive(Clone, Debug)]
pub struct ScopeImport {
    /// Tacho gain [rad/s per V] (the paper's 35).
    pub gain: f32,
    /// The trace was captured inverted (the paper's "inverted option"): negate it.
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

/// The time base of a Rigol export (`X,CH1,Start,Increment` over `Sequence,Volt,T0,DT`):
/// its first column counts samples, and sample `n` is at `T0 + n DT` seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
struct IndexedTime {
    start: f64,
    increment: f64,
}

impl IndexedTime {
    /// From a header line and the line after it, when they are a Rigol export's.
    fn of(header: &str, next: &str, sep: char) -> Option<IndexedTime> {
        let fields = |l: &str| -> Vec<String> {
            l.split(sep)
                .map(|f| f.trim().trim_matches('"').to_string())
                .collect()
        };
        let (h, n) = (fields(header), fields(next));
        let at = |name: &str| h.iter().position(|f| f.eq_ignore_ascii_case(name));
        let number = |k: usize| n.get(k)?.parse::<f64>().ok().filter(|x| x.is_finite());
        if !h.first()?.eq_ignore_ascii_case("x") {
            return None;
        }
        let (start, increment) = (number(at("start")?)?, number(at("increment")?)?);
        (increment > 0.0).then_some(IndexedTime { start, increment })
    }
}

/// Read a scope CSV: lines whose needed fields are not numbers (headers, units, settings)
/// are skipped; the rest must be uniform in time. A Rigol export's first column counts
/// samples: its time is then taken from the header's `Start` and `Increment`.
pub fn import_scope(path: &Path, s: &ScopeImport) -> Result<OwnedRecord> {
    let (mut semicolon, mut comma) = (false, false);
    // The first two lines, for a Rigol export's header.
    let mut head: Vec<String> = Vec::new();
    for_each_line(path, |_, line| {
        semicolon |= line.contains(';');
        comma |= line.contains(',');
        if head.len() < 2 {
            head.push(line.chars().take(200).collect());
        }
        Ok(())
    })?;
    let sep = if semicolon && !comma { ';' } else { ',' };
    let indexed = match head.as_slice() {
        [h, n] if s.time_column == 0 => IndexedTime::of(h, n, sep),
        _ => None,
    };
    // The time and the tacho volts of a line, when both are finite numbers.
    let numeric = |line: &str| {
        let get = |c: usize| {
            line.split(sep)
                .nth(c)
                .and_then(|f| f.trim().trim_matches('"').parse::<f64>().ok())
                .filter(|x| x.is_finite())
        };
        let time = get(s.time_column).map(|t| match indexed {
            Some(x) => x.start + t * x.increment,
            None => t,
        });
        time.zip(get(s.channel))
    };
    let mut times = TimeSteps::default();
    let mut v = Vec::new();
    let mut omega = Vec::new();
    for_each_line(path, |_, line| {
        if let Some((time, volts)) = numeric(line) {
            times.push(time);
            v.push(if time >= s.step_at { s.voltage } else { 0.0 });
            let w = volts as f32 * s.gain;
            omega.push(if s.inverted { -w } else { w });
        }
        Ok(())
    })?;
    let context = || path.display().to_string();
    if omega.len() < MIN_SAMPLES {
        return Err(anyhow!(
            "found {} numeric rows in columns {} and {} (need at least {MIN_SAMPLES})",
            omega.len(),
            s.time_column,
            s.channel
        ))
        .with_context(context);
    }
    let dt = times
        .step(|scan| {
            for_each_line(path, |number, line| match numeric(line) {
                Some((time, _)) => scan.push(time, number),
                None => Ok(()),
            })
        })
        .with_context(context)?;
    let (first, last) = (times.first(), times.last());
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
    let rec = OwnedRecord {
        path: path.to_path_buf(),
        t0: first,
        dt,
        v,
        omega,
        current: None,
        load: None,
        coast_from: None,
        averaged: 1,
    };
    rec.as_record(false)
        .validate()
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Ok(rec)
}

/// Call `f` with each line of `path` (numbered from 1, without its line ending), read one
/// at a time into one reused buffer; a line beyond [`super::bounded::MAX_LINE_BYTES`] is
/// refused.
fn for_each_line(path: &Path, mut f: impl FnMut(u64, &str) -> Result<()>) -> Result<()> {
    let cannot = || format!("cannot read {}", path.display());
    let file = BoundedLines::new(File::open(path).with_context(cannot)?);
    let mut reader = BufReader::with_capacity(1 << 20, file);
    let mut line = String::new();
    for number in 1.. {
        line.clear();
        if reader.read_line(&mut line).with_context(cannot)? == 0 {
            break;
        }
        let text = line
            .strip_suffix('\n')
            .map_or(line.as_str(), |l| l.strip_suffix('\r').unwrap_or(l));
        f(number, text)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options() -> ScopeImport {
        ScopeImport {
            gain: 35.0,
            inverted: true,
            time_column: 0,
            channel: 1,
            voltage: 12.0,
            step_at: 0.0,
        }
    }

    /// A `;`-separated trace with CRLF line ends, settings lines and quoted numbers: the
    /// numeric lines become the record, and a bad step is named by its file line.
    #[test]
    fn a_semicolon_trace_is_read_line_by_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scope.csv");
        let trace = |late: usize| {
            let mut text = String::from("Model;XYZ\r\nTime;CH1\r\ns;V\r\n");
            for k in 0..20 {
                let t = (k as f64 - 10.0) * 1e-3 + if k == late { 3e-4 } else { 0.0 };
                text += &format!("\"{t}\";{}\r\n", 0.1 * k as f64);
            }
            std::fs::write(&path, text).unwrap();
        };
        trace(usize::MAX);
        let rec = import_scope(&path, &options()).unwrap();
        assert_eq!(rec.len(), 20);
        assert_eq!(rec.t0, -0.01);
        assert!((rec.dt - 0.001).abs() < 1e-9, "{}", rec.dt);
        assert_eq!(rec.omega[4], -(0.4f32 * 35.0));
        assert_eq!(rec.v[9], 0.0);
        assert_eq!(rec.v[10], 12.0);
        trace(9); // the 10th numeric line, line 13 of the file
        let err = format!("{:#}", import_scope(&path, &options()).unwrap_err());
        assert!(err.contains("not uniform at line 13"), "{err}");
    }

    /// A Rigol export: the first column counts samples, the time base is in the header.
    /// Read as seconds, the index made a record of one sample per second.
    #[test]
    fn a_rigol_export_takes_its_time_from_start_and_increment() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rigol.csv");
        let mut text =
            String::from("X,CH1,Start,Increment,\nSequence,Volt,-1.000000e-02,1.000000e-03\n");
        for k in 0..20 {
            text += &format!("{k},{:.2},\n", 0.1 * k as f64);
        }
        std::fs::write(&path, text).unwrap();
        let rec = import_scope(&path, &options()).unwrap();
        assert_eq!(rec.len(), 20);
        assert!((rec.t0 + 0.01).abs() < 1e-12, "{}", rec.t0);
        assert!((rec.dt - 0.001).abs() < 1e-9, "{}", rec.dt);
        // The step at t = 0 is sample 10.
        assert_eq!((rec.v[9], rec.v[10]), (0.0, 12.0));
        assert_eq!(rec.omega[3], -(0.3f32 * 35.0));
    }
}
