//! Record CSV (docs/CONTRACTS.md): a header row; columns `t` (s, uniform step), `v` (V),
//! `omega` (rad/s), optional `i` (A), `tl` (N m) and `bridge`; other columns ignored. Plus
//! the oscilloscope import of the paper's workflow (tacho volts to rad/s).
//!
//! **Memory.** A record is read as a stream ([`rows`]): one row at a time into a reused
//! buffer, never the whole file. It keeps only what the fit needs, the f32 columns (4 bytes
//! each: `v`, `omega`, and `i`, `tl` when present, so 8 to 16 bytes a sample); the time
//! column is checked on the fly ([`time`]) and the bridge column becomes one index. The
//! samples held over all the records of a command are bounded by `--max-samples`
//! ([`ReadOptions`]); `--decimate K` keeps one sample in `K` rows ([`samples`]).

mod bounded;
mod reader;
mod rows;
mod samples;
mod scope;
mod time;
mod writer;

use anyhow::Result;
use motor_id_shared::Record;
pub use reader::{ReadOptions, RecordReader};
pub use scope::{import_scope, ScopeImport};
use std::path::{Path, PathBuf};

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
    /// Drive readings each sample's readings are the mean of, over the step that ends at
    /// it (the `averaged` column; 1: readings at the instants): the core's
    /// `Record::averaged`.
    pub averaged: u32,
}

impl OwnedRecord {
    /// A record `name` of samples `dt` apart: the voltage `v`, the speed `omega` and the
    /// current, when given (for tests: no load, no coast-down, single readings).
    #[cfg(test)]
    pub fn readings(
        name: &str,
        dt: f32,
        v: Vec<f32>,
        omega: Vec<f32>,
        current: Option<Vec<f32>>,
    ) -> OwnedRecord {
        OwnedRecord {
            path: name.into(),
            t0: 0.0,
            dt,
            v,
            omega,
            current,
            load: None,
            coast_from: None,
            averaged: 1,
        }
    }

    /// Borrow as the core's record; `use_current = false` drops the current column.
    pub fn as_record(&self, use_current: bool) -> Record<'_> {
        Record {
            dt: self.dt,
            v: &self.v,
            omega: &self.omega,
            current: self.current.as_deref().filter(|_| use_current),
            load: self.load.as_deref(),
            coast_from: self.coast_from,
            averaged: self.averaged,
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

    /// Read and validate a record CSV, within the default bound of [`ReadOptions`].
    pub fn read(path: &Path) -> Result<OwnedRecord> {
        RecordReader::new(&ReadOptions::default()).read(path)
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
}

#[cfg(test)]
mod fuzz;

#[cfg(test)]
mod tests {
    use super::*;

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
            averaged: 1,
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

    /// Write `text` as `name` in `dir` and read it with `options`.
    fn read_text(dir: &Path, name: &str, text: &str, options: &ReadOptions) -> Result<OwnedRecord> {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        RecordReader::new(options).read(&path)
    }

    /// Options with decimation `k` and the default bound.
    fn decimate(k: u64) -> ReadOptions {
        ReadOptions {
            decimate: k,
            ..ReadOptions::default()
        }
    }

    /// The record streamed from a file many times the read buffer is the record a
    /// whole-file parse gives (the reader's way before it streamed), value for value.
    #[test]
    fn a_streamed_record_equals_the_whole_file_parsed() {
        let dir = tempfile::tempdir().unwrap();
        let n = 60_000;
        let mut seed = 12345u64;
        let mut noise = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut text = String::from("t, V ,omega,i,note,tl,bridge\r\n");
        for k in 0..n {
            let (w, i) = (300.0 * noise(), 1e-3 * noise());
            text += &format!(
                "{},{},{w:.9e}, {i} ,x,{},{}\r\n",
                0.25 + k as f64 * 1e-4,
                (k / 1000) as f64 * 0.5 - 7.25,
                0.01 * noise(),
                u8::from(k < n - 500)
            );
        }
        assert!(text.len() > 3 << 20, "several read buffers");
        let rec = read_text(dir.path(), "r.csv", &text, &ReadOptions::default()).unwrap();
        let rows: Vec<Vec<f64>> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').filter_map(|f| f.trim().parse().ok()).collect())
            .collect();
        let column = |c: usize| -> Vec<f32> { rows.iter().map(|r| r[c] as f32).collect() };
        assert_eq!(rec.len(), n);
        assert_eq!(rec.t0, 0.25);
        assert_eq!(
            rec.dt,
            ((rows[n - 1][0] - rows[0][0]) / (n - 1) as f64) as f32
        );
        assert_eq!(rec.v, column(1));
        assert_eq!(rec.omega, column(2));
        assert_eq!(rec.current, Some(column(3)));
        assert_eq!(rec.load, Some(column(4)));
        assert_eq!(rec.coast_from, Some(n - 500));
    }

    /// With `--decimate K` a sample's readings are the mean of its block of K rows, which
    /// belongs to the block's middle, and its inputs are the voltage-seconds of its new step,
    /// from that middle on for K rows (a row on the edge counts half).
    #[test]
    fn decimation_averages_readings_and_takes_the_inputs_of_the_new_step() {
        let dir = tempfile::tempdir().unwrap();
        let step_row = 7.0;
        for k in [3usize, 4] {
            let n = 10 * k + 2; // two rows past the last whole block: dropped
            let mut text = String::from("t,v,omega,i,tl\n");
            for r in 0..n {
                let v = if (r as f64) < step_row { 0 } else { 12 };
                text += &format!(
                    "{},{v},{},{},0.25\n",
                    1.0 + r as f64 * 1e-3,
                    2 * r + 1,
                    0.5 * r as f64
                );
            }
            let rec = read_text(dir.path(), "d.csv", &text, &decimate(k as u64)).unwrap();
            assert_eq!(rec.len(), 10, "K {k}");
            assert!(
                (rec.dt as f64 - k as f64 * 1e-3).abs() < 1e-9,
                "K {k}: {}",
                rec.dt
            );
            let middle = (k - 1) as f64 / 2.0;
            assert!(
                (rec.t0 - (1.0 + middle * 1e-3)).abs() < 1e-12,
                "K {k}: {}",
                rec.t0
            );
            for m in 0..10 {
                let start = (m * k) as f64 + middle;
                assert_eq!(
                    rec.omega[m],
                    (2.0 * start + 1.0) as f32,
                    "K {k}, sample {m}"
                );
                assert_eq!(rec.current.as_ref().unwrap()[m], (0.5 * start) as f32);
                let applied = (start + k as f64 - step_row).clamp(0.0, k as f64);
                assert_eq!(
                    rec.v[m],
                    (12.0 * applied / k as f64) as f32,
                    "K {k}, sample {m}"
                );
                assert_eq!(rec.load.as_ref().unwrap()[m], 0.25);
            }
        }
    }

    /// A coast-down decimated: the bridge opens at the first sample whose step lies mostly
    /// after the opening, the voltage of the open rows (not applied) is not averaged in, and
    /// an opening too near either end for the decimation is refused.
    #[test]
    fn a_decimated_coast_down_opens_at_the_nearest_step() {
        let dir = tempfile::tempdir().unwrap();
        let record = |n: usize, open: usize| {
            let mut text = String::from("t,v,omega,bridge\n");
            for r in 0..n {
                let driven = r < open;
                let v = if driven { 10 } else { 0 };
                text += &format!("{},{v},{},{}\n", r as f64 * 0.01, 100 - r, u8::from(driven));
            }
            read_text(dir.path(), "c.csv", &text, &decimate(4))
        };
        // Step 6 spans rows 25.5 .. 29.5, step 7 rows 29.5 .. 33.5: mostly after row 30.
        let rec = record(48, 30).unwrap();
        assert_eq!(rec.coast_from, Some(7));
        assert!(rec.v.iter().all(|&v| v == 10.0), "{:?}", rec.v);
        let err = format!("{:#}", record(48, 2).unwrap_err());
        assert!(err.contains("starts within the first 4 rows"), "{err}");
        let err = format!("{:#}", record(50, 49).unwrap_err());
        assert!(err.contains("shorter than half a sample"), "{err}");
    }

    /// A record decimated in memory (the widened search's, `OwnedRecord::decimated`) is the
    /// file read with `--decimate K`, value for value, with a coast-down too.
    #[test]
    fn a_record_decimated_in_memory_is_the_file_read_decimated() {
        let dir = tempfile::tempdir().unwrap();
        let mut text = String::from("t,v,omega,i,tl,bridge\n");
        for r in 0..200 {
            let v = if r < 37 { 0.0 } else { 12.0 - 0.01 * r as f64 };
            text += &format!(
                "{},{v},{},{},{},{}\n",
                r as f64 * 1e-3,
                (r * r) % 17,
                0.5 * r as f64,
                0.001 * (r % 5) as f64,
                u8::from(r < 150)
            );
        }
        let whole = read_text(dir.path(), "m.csv", &text, &ReadOptions::default()).unwrap();
        for k in [2usize, 3, 4] {
            let read = read_text(dir.path(), "m.csv", &text, &decimate(k as u64)).unwrap();
            let decimated = whole.decimated(k).expect("decimated");
            assert_eq!(decimated.v, read.v, "K {k}");
            assert_eq!(decimated.omega, read.omega, "K {k}");
            assert_eq!(decimated.current, read.current, "K {k}");
            assert_eq!(decimated.load, read.load, "K {k}");
            assert_eq!(decimated.coast_from, read.coast_from, "K {k}");
            assert!((decimated.t0 - read.t0).abs() < 1e-9, "K {k}");
            assert!((decimated.dt - read.dt).abs() < 1e-9, "K {k}");
        }
        // Too few samples left: not decimated.
        assert!(whole.decimated(50).is_none());
    }

    /// A record beyond `--max-samples` is refused in one line with the decimation that
    /// fits it; the bound counts the samples of every record the reader has read.
    #[test]
    fn a_record_beyond_the_bound_is_refused_with_the_decimation_that_fits() {
        let dir = tempfile::tempdir().unwrap();
        let mut text = String::from("t,v,omega\n");
        for r in 0..100 {
            text += &format!("{},1,{r}\n", r as f64 * 0.01);
        }
        let bounded = |max_samples: u64, decimate: u64| ReadOptions {
            max_samples,
            decimate,
        };
        let err = format!(
            "{:#}",
            read_text(dir.path(), "b.csv", &text, &bounded(30, 1)).unwrap_err()
        );
        assert!(
            err.ends_with("b.csv: 100 rows, more than --max-samples 30 (8 bytes a sample, 0.00024 MB); keep one sample in 4 rows with --decimate 4, or raise --max-samples"),
            "{err}"
        );
        assert!(!err.contains('\n'));
        assert_eq!(
            read_text(dir.path(), "b.csv", &text, &bounded(30, 4))
                .unwrap()
                .len(),
            25
        );
        let mut reader = RecordReader::new(&bounded(40, 4));
        let path = dir.path().join("b.csv");
        assert_eq!(reader.read(&path).unwrap().len(), 25);
        let err = format!("{:#}", reader.read(&path).unwrap_err());
        assert!(
            err.contains("100 rows (25 samples with --decimate 4), more than the 15 samples left of --max-samples 40 by the records before it")
                && err.contains("--decimate 7"),
            "{err}"
        );
    }
}
