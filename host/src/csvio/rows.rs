//! The data rows of a record CSV, read one at a time into one reused buffer: the file is
//! never held whole, and a row costs no allocation. Every value is checked here, with its
//! line.

use super::bounded::{quoted, BoundedLines};
use anyhow::{anyhow, bail, Result};
use csv::StringRecord;
use std::fs::File;
use std::path::Path;

/// Largest magnitude of a signal sample (V, rad/s, A, N m): a larger one is a unit or scale
/// error, and its squares would overflow the fit's f32 sums.
pub(super) const MAX_MAGNITUDE: f64 = 1e9;

/// Most drive readings a sample's readings may be the mean of (`averaged` column).
pub(super) const MAX_AVERAGED: f64 = 1e6;

/// Bytes read from the file at a time.
const BUFFER_BYTES: usize = 1 << 20;

/// Where the columns of a record CSV are, found by name in its header.
#[derive(Clone, Copy, Debug)]
pub struct Columns {
    t: usize,
    v: usize,
    omega: usize,
    /// `i`, if the record has current.
    pub current: Option<usize>,
    /// `tl`, if the record has a known load torque.
    pub load: Option<usize>,
    bridge: Option<usize>,
    averaged: Option<usize>,
}

impl Columns {
    /// Find the columns in `header`: names without regard to case or surrounding spaces,
    /// each at most once; `t`, `v` and `omega` required (with a hint when the fields seem
    /// separated by `;` or tabs).
    fn find(header: &StringRecord) -> Result<Columns> {
        if header.is_empty() {
            bail!("empty file");
        }
        let header: Vec<&str> = header.iter().map(str::trim).collect();
        let col = |name: &str| header.iter().position(|h| h.eq_ignore_ascii_case(name));
        for name in ["t", "v", "omega", "i", "tl", "bridge", "averaged"] {
            if header
                .iter()
                .filter(|h| h.eq_ignore_ascii_case(name))
                .count()
                > 1
            {
                bail!("column {name} appears more than once in the header: which one is meant?");
            }
        }
        let (Some(t), Some(v), Some(omega)) = (col("t"), col("v"), col("omega")) else {
            let missing: Vec<&str> = ["t", "v", "omega"]
                .into_iter()
                .filter(|c| col(c).is_none())
                .collect();
            let joined = header.join(",");
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
                "missing column(s) {} (header is '{}'; need t, v, omega, optional i, tl, bridge, averaged){hint}",
                missing.join(", "),
                quoted(&joined)
            );
        };
        Ok(Columns {
            t,
            v,
            omega,
            current: col("i"),
            load: col("tl"),
            bridge: col("bridge"),
            averaged: col("averaged"),
        })
    }
}

/// One data row, checked: every value finite as a 32-bit float, no signal beyond
/// [`MAX_MAGNITUDE`], `bridge` 0 or 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// The file line of the row (for messages).
    pub line: u64,
    /// Time [s], kept in f64: the uniform-step check needs its digits.
    pub t: f64,
    /// Armature voltage [V].
    pub v: f32,
    /// Speed [rad/s].
    pub omega: f32,
    /// Current [A] (0 without an `i` column).
    pub current: f32,
    /// Load torque [N m] (0 without a `tl` column).
    pub load: f32,
    /// The bridge drives the armature (true without a `bridge` column).
    pub driven: bool,
    /// Drive readings the row's readings are the mean of (1 without an `averaged` column).
    pub averaged: u32,
}

/// The data rows of one record CSV, in file order.
pub struct Rows {
    reader: csv::Reader<BoundedLines<File>>,
    record: StringRecord,
    /// The columns found in the header.
    pub columns: Columns,
    /// Data rows read so far.
    count: u64,
}

impl Rows {
    /// Open `path` and read its header.
    pub fn open(path: &Path) -> Result<Rows> {
        // Fields are trimmed where they are used: the reader's own trimming allocates a new
        // record for every row.
        let file = File::open(path).map_err(|e| anyhow!("cannot open: {e}"))?;
        let mut reader = csv::ReaderBuilder::new()
            .buffer_capacity(BUFFER_BYTES)
            .from_reader(BoundedLines::new(file));
        let header = reader
            .headers()
            .map_err(|e| anyhow!("{}", csv_message(&e)))?;
        let columns = Columns::find(header)?;
        Ok(Rows {
            reader,
            record: StringRecord::new(),
            columns,
            count: 0,
        })
    }

    /// Bytes of the file read so far (up to the last row returned).
    pub fn bytes_read(&self) -> u64 {
        self.record.position().map_or(0, |p| p.byte())
    }

    /// The next data row, `None` at the end of the file.
    pub fn next_row(&mut self) -> Result<Option<Row>> {
        // The line of a row the reader does not place: the header is line 1.
        let guess = self.count + 2;
        let more = self.reader.read_record(&mut self.record).map_err(|e| {
            let line = e.position().map_or(guess, |p| p.line());
            anyhow!("line {line}: {}", csv_message(&e))
        })?;
        if !more {
            return Ok(None);
        }
        self.count += 1;
        let line = self.record.position().map_or(guess, |p| p.line());
        let c = self.columns;
        let field = |c: usize, name: &str| field(&self.record, c, name, line);
        let t = field(c.t, "t")?;
        let v = field(c.v, "v")? as f32;
        let omega = field(c.omega, "omega")? as f32;
        let current = c.current.map_or(Ok(0.0), |c| field(c, "i"))? as f32;
        let load = c.load.map_or(Ok(0.0), |c| field(c, "tl"))? as f32;
        let driven = match c.bridge {
            None => true,
            Some(c) => {
                let b = field(c, "bridge")?;
                if b != 0.0 && b != 1.0 {
                    bail!("line {line}: bridge = {b}: 1 (driven) or 0 (open circuit)");
                }
                b == 1.0
            }
        };
        let averaged = match c.averaged {
            None => 1,
            Some(c) => {
                let m = field(c, "averaged")?;
                if m.fract() != 0.0 || !(1.0..=MAX_AVERAGED).contains(&m) {
                    bail!("line {line}: averaged = {m}: a whole number of drive readings from 1 to {MAX_AVERAGED}");
                }
                m as u32
            }
        };
        Ok(Some(Row {
            line,
            t,
            v,
            omega,
            current,
            load,
            driven,
            averaged,
        }))
    }

    /// Count the data rows left without reading their values (for the message of a record
    /// too long to hold): `(rows, complete)`, `complete` false when a malformed row ended
    /// the count early.
    pub fn count_rest(&mut self) -> (u64, bool) {
        let mut bytes = csv::ByteRecord::new();
        let mut rows = 0;
        loop {
            match self.reader.read_byte_record(&mut bytes) {
                Ok(true) => rows += 1,
                Ok(false) => return (rows, true),
                Err(_) => return (rows, false),
            }
        }
    }
}

/// Field `c` (named `name`) of `record`, the row at file line `line`, as a number: every
/// column is stored as f32 (time as f64), so a value beyond f32 is refused here, with its
/// line, rather than later as an anonymous infinity.
fn field(record: &StringRecord, c: usize, name: &str, line: u64) -> Result<f64> {
    let text = record
        .get(c)
        .ok_or_else(|| anyhow!("line {line}: column {name} is missing"))?
        .trim();
    let x: f64 = text.parse().map_err(|_| {
        // Escaped and cut: a quoted field may hold a line break, and the error is one
        // short line.
        let text = quoted(text);
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
}

/// A csv error in words, without the crate's position prefix.
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
