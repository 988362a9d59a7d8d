//! Reading record CSVs as a stream into [`OwnedRecord`]s, within the memory bound and with
//! the decimation of [`ReadOptions`] (see the module doc of [`super`]).

use super::rows::Rows;
use super::samples::{decimated_time, Samples};
use super::time::TimeSteps;
use super::OwnedRecord;
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use motor_id_shared::model::record::MIN_SAMPLES;
use std::path::{Path, PathBuf};

/// Samples held at most over the records of one command, by default: an hour at 10 kHz with
/// room to spare, at most 640 MB (16 bytes a sample).
pub const DEFAULT_MAX_SAMPLES: u64 = 40_000_000;

/// How record CSVs are read: the memory bound and the decimation.
#[derive(Args, Clone, Debug)]
pub struct ReadOptions {
    /// Hold at most N samples in memory over all the records read, after --decimate: 4
    /// bytes for each of v, omega, i and tl, so at most 16 bytes a sample (640 MB for the
    /// default). A longer record is refused, with the --decimate that would fit it.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_MAX_SAMPLES,
          value_parser = clap::value_parser!(u64).range(MIN_SAMPLES as u64..))]
    pub max_samples: u64,
    /// Keep one sample in K rows: the mean of K readings (omega, i), the inputs (v, tl)
    /// averaged over the new step of K rows (docs/CONTRACTS.md). Only for dynamics much
    /// slower than K rows: the electrical time constant La/Ra too.
    #[arg(long, value_name = "K", default_value_t = 1,
          value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub decimate: u64,
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            max_samples: DEFAULT_MAX_SAMPLES,
            decimate: 1,
        }
    }
}

/// Reads record CSVs within one bound on the samples held ([`ReadOptions`]), counted over
/// every record it reads.
pub struct RecordReader {
    options: ReadOptions,
    /// Samples of the records read so far.
    held: u64,
    /// No progress bar while a large file is read.
    quiet: bool,
}

impl RecordReader {
    /// A reader that has read nothing yet.
    pub fn new(options: &ReadOptions) -> RecordReader {
        RecordReader {
            options: options.clone(),
            held: 0,
            quiet: false,
        }
    }

    /// This reader, showing no progress when `quiet` (a large file's reading shows its bytes
    /// on stderr otherwise, [`crate::progress::read_progress`]).
    pub fn quiet(mut self, quiet: bool) -> RecordReader {
        self.quiet = quiet;
        self
    }

    /// Read and validate a record CSV (errors name the file).
    pub fn read(&mut self, path: &Path) -> Result<OwnedRecord> {
        let rec = self
            .read_record(path)
            .with_context(|| path.display().to_string())?;
        self.held += rec.len() as u64;
        Ok(rec)
    }

    /// Read and validate several record CSVs, stopping at the first that fails. A record
    /// whose samples equal an earlier one's (the same file given twice, or a copy) is
    /// refused: fitted twice, it would shrink every uncertainty by a factor of √2 without
    /// a word.
    pub fn read_all(&mut self, paths: &[PathBuf]) -> Result<Vec<OwnedRecord>> {
        let mut records: Vec<OwnedRecord> = Vec::with_capacity(paths.len());
        for p in paths {
            let rec = self.read(p)?;
            if let Some(twin) = records.iter().find(|r| r.same_data(&rec)) {
                bail!(
                    "{} holds the same samples as {}: a record given twice would be fitted twice (its uncertainties shrunk by a factor of 1.41 without reason)",
                    p.display(),
                    twin.path.display()
                );
            }
            records.push(rec);
        }
        Ok(records)
    }

    fn read_record(&self, path: &Path) -> Result<OwnedRecord> {
        let mut rows = Rows::open(path)?;
        let columns = rows.columns;
        let k = self.options.decimate as usize;
        let mut samples = Samples::new(k, columns.current.is_some(), columns.load.is_some());
        let left = self.options.max_samples.saturating_sub(self.held);
        let mut times = TimeSteps::default();
        let mut bridge = BridgeCheck::default();
        let mut turned = false;
        let mut averaged = None;
        let mut n = 0;
        let size = std::fs::metadata(path).map_or(0, |m| m.len());
        let name = path
            .file_name()
            .map_or(String::new(), |f| f.to_string_lossy().to_string());
        let bar = crate::progress::read_progress(&name, size, self.quiet);
        while let Some(row) = rows.next_row()? {
            if n % 65_536 == 0 {
                bar.set_position(rows.bytes_read());
            }
            times.push(row.t);
            bridge.push(n, row.driven, row.line);
            turned |= row.omega != 0.0;
            match averaged {
                None => averaged = Some(row.averaged),
                Some(m) if m != row.averaged => bail!(
                    "line {}: averaged = {} where the rows before say {m}: every sample is the mean of the same number of readings",
                    row.line,
                    row.averaged
                ),
                Some(_) => {}
            }
            samples.push(&row);
            n += 1;
            if samples.len() as u64 > left {
                return Err(self.too_long(&mut rows, n as u64, &samples));
            }
        }
        bar.finish_and_clear();
        if n == 0 {
            bail!("no data rows");
        }
        if n < MIN_SAMPLES {
            bail!("only {n} data rows (need at least {MIN_SAMPLES})");
        }
        if !turned {
            bail!("omega is zero throughout: the motor never turned, there is nothing to fit");
        }
        let dt = times.step(|scan| {
            let mut again = Rows::open(path)?;
            while let Some(row) = again.next_row()? {
                scan.push(row.t, row.line)?;
            }
            Ok(())
        })?;
        let coast_row = bridge.coast_from()?;
        let averaged = averaged.unwrap_or(1);
        if averaged > 1 && k > 1 {
            bail!("its readings are means over each step (averaged = {averaged}): --decimate would take their means as readings at instants; leave it out");
        }
        samples.finish();
        if samples.len() < MIN_SAMPLES {
            bail!(
                "only {} samples of {n} rows with --decimate {k} (need at least {MIN_SAMPLES})",
                samples.len()
            );
        }
        let coast_from = coast_row.map(|r| samples.coast_from(r)).transpose()?;
        let time = match k {
            1 => (times.first(), dt),
            _ => decimated_time(times.first(), times.mean_step(), k),
        };
        let rec = samples.into_record(path.to_path_buf(), time, coast_from, averaged);
        rec.as_record(true).validate().map_err(|e| anyhow!("{e}"))?;
        Ok(rec)
    }

    /// The error of a record with more samples than the bound leaves it, after `read` rows
    /// of it: its rows counted to the end, and the `--decimate` that would fit it.
    fn too_long(&self, rows: &mut Rows, read: u64, samples: &Samples) -> anyhow::Error {
        let (rest, complete) = rows.count_rest();
        let total = read + rest;
        let (max, k) = (self.options.max_samples, self.options.decimate);
        let left = max.saturating_sub(self.held);
        let at_least = if complete { "" } else { "at least " };
        let kept = match k {
            1 => String::new(),
            _ => format!(
                " ({}{} samples with --decimate {k})",
                at_least,
                samples.kept_of(total)
            ),
        };
        let bound = match self.held {
            0 => format!("--max-samples {max}"),
            _ => format!("the {left} samples left of --max-samples {max} by the records before it"),
        };
        let bytes = 4 * samples.columns() as u64;
        let advice = match total / (left + 1) + 1 {
            fit if left >= MIN_SAMPLES as u64 => {
                format!(
                    "keep one sample in {fit} rows with --decimate {fit}, or raise --max-samples"
                )
            }
            _ => "raise --max-samples".into(),
        };
        anyhow!(
            "{at_least}{total} rows{kept}, more than {bound} ({bytes} bytes a sample, {} MB); {advice}",
            (max * bytes) as f64 / 1e6
        )
    }
}

/// The rule of a `bridge` column, checked row by row: its zeros run from some row after the
/// first to the end (the model opens the bridge once). A breach is said after the checks
/// of the whole record (row count, speed, time step), as when the column was checked whole.
#[derive(Default)]
struct BridgeCheck {
    /// The first open row, and its line.
    open_from: Option<(usize, u64)>,
    /// The first breach.
    error: Option<String>,
}

impl BridgeCheck {
    /// Take row `row` (at file line `line`), driven or open.
    fn push(&mut self, row: usize, driven: bool, line: u64) {
        if self.error.is_some() {
            return;
        }
        match (self.open_from, driven) {
            (None, false) if row == 0 => {
                self.error = Some(format!(
                    "line {line}: bridge is 0 from the first row: a coast-down follows a driven part"
                ));
            }
            (None, false) => self.open_from = Some((row, line)),
            (Some((_, from)), true) => {
                self.error = Some(format!(
                    "line {line}: bridge is 1 again after the open circuit from line {from}: the model opens the bridge once, to the end of the record"
                ));
            }
            _ => {}
        }
    }

    /// The first open row, if any, or the breach.
    fn coast_from(&self) -> Result<Option<usize>> {
        match &self.error {
            Some(e) => bail!("{e}"),
            None => Ok(self.open_from.map(|(row, _)| row)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record CSV of 20 rows whose `averaged` column holds `counts(k)` on row `k`.
    fn averaged_text(counts: impl Fn(usize) -> String) -> String {
        let mut text = String::from("t,v,omega,averaged\n");
        for k in 0..20 {
            text += &format!("{},12,{},{}\n", k as f64 * 0.01, k, counts(k));
        }
        text
    }

    fn read(text: &str, decimate: u64) -> Result<OwnedRecord> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        std::fs::write(&path, text).unwrap();
        let options = ReadOptions {
            decimate,
            ..ReadOptions::default()
        };
        RecordReader::new(&options).read(&path)
    }

    #[test]
    fn an_averaged_column_makes_the_readings_means_over_each_step() {
        let rec = read(&averaged_text(|_| "8".into()), 1).unwrap();
        assert_eq!(rec.averaged, 8);
        assert_eq!(rec.as_record(true).averaged, 8);
        // Without the column the readings are at the instants.
        let plain = read(
            "t,v,omega\n0,1,1\n1,1,2\n2,1,3\n3,1,4\n4,1,5\n5,1,6\n6,1,7\n7,1,8\n",
            1,
        );
        assert_eq!(plain.unwrap().averaged, 1);
    }

    #[test]
    fn an_averaged_column_that_changes_or_is_not_a_count_is_refused_with_its_line() {
        let err = format!(
            "{:#}",
            read(&averaged_text(|k| (4 + k / 5).to_string()), 1).unwrap_err()
        );
        assert!(err.ends_with("line 7: averaged = 5 where the rows before say 4: every sample is the mean of the same number of readings"), "{err}");
        for bad in ["0", "2.5", "-3"] {
            let err = format!("{:#}", read(&averaged_text(|_| bad.into()), 1).unwrap_err());
            assert!(err.contains("line 2: averaged = "), "{bad}: {err}");
            assert!(
                err.contains("a whole number of drive readings"),
                "{bad}: {err}"
            );
        }
    }

    #[test]
    fn means_over_each_step_are_not_decimated() {
        let err = format!("{:#}", read(&averaged_text(|_| "8".into()), 2).unwrap_err());
        assert!(
            err.contains("--decimate would take their means as readings at instants"),
            "{err}"
        );
        // A count of 1 is readings at the instants: decimated as any other.
        assert!(read(&averaged_text(|_| "1".into()), 2).is_ok());
    }
}
