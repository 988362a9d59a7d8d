//! Record CSVs (`docs/CONTRACTS.md`: columns `t`, `v`, `omega`, optional `i`, optional
//! `tl`; sample `k` holds the readings at `t_k` and the inputs held from `t_k` to `t_k+1`):
//! the reference plant writes them for `motor-id`, and reads those `motor-id simulate`
//! writes to replay the same input.

use super::{Input, Run};
use std::fmt::Write as _;
use std::path::Path;

/// The columns of a record CSV, by name.
#[derive(Clone, Debug, PartialEq)]
pub struct Columns {
    /// Header names, lower case.
    pub names: Vec<String>,
    /// One vector per column.
    pub values: Vec<Vec<f64>>,
}

impl Columns {
    /// The column `name`, if present.
    pub fn get(&self, name: &str) -> Option<&[f64]> {
        let k = self.names.iter().position(|n| n == name)?;
        Some(&self.values[k])
    }

    /// The column `name`; panics when absent.
    pub fn col(&self, name: &str) -> &[f64] {
        self.get(name)
            .unwrap_or_else(|| panic!("no column {name} in {:?}", self.names))
    }

    /// The record's input (`v`, and `tl` when present), the step from `t`.
    pub fn input(&self) -> Input {
        let t = self.col("t");
        Input {
            dt: (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64,
            v: self.col("v").to_vec(),
            tl: self.get("tl").map(<[f64]>::to_vec),
            open_from: self
                .get("bridge")
                .and_then(|b| b.iter().position(|x| *x == 0.0)),
        }
    }
}

/// Read a record CSV with a header row.
pub fn read(path: &Path) -> Columns {
    let text = std::fs::read_to_string(path).expect("read record CSV");
    let mut lines = text.lines();
    let names: Vec<String> = lines
        .next()
        .expect("header")
        .split(',')
        .map(|n| n.trim().to_lowercase())
        .collect();
    let mut values = vec![Vec::new(); names.len()];
    for line in lines.filter(|l| !l.trim().is_empty()) {
        for (column, field) in values.iter_mut().zip(line.split(',')) {
            column.push(field.trim().parse::<f64>().expect("number in record CSV"));
        }
    }
    Columns { names, values }
}

/// Write `run` as a record CSV: `t,v,omega`, then `i` when `with_current`, then `tl` when
/// the input has a load column, then `bridge` (1 driven, 0 open) when it coasts.
pub fn write(run: &Run, path: &Path, with_current: bool) {
    let input = &run.input;
    let mut text = String::from("t,v,omega");
    text += if with_current { ",i" } else { "" };
    text += if input.tl.is_some() { ",tl" } else { "" };
    text += if input.open_from.is_some() {
        ",bridge\n"
    } else {
        "\n"
    };
    for k in 0..input.len() {
        let t = k as f64 * input.dt;
        write!(text, "{t},{},{}", input.v[k], run.omega[k]).unwrap();
        if with_current {
            write!(text, ",{}", run.current[k]).unwrap();
        }
        if let Some(tl) = &input.tl {
            write!(text, ",{}", tl[k]).unwrap();
        }
        if let Some(from) = input.open_from {
            text += if k < from { ",1" } else { ",0" };
        }
        text.push('\n');
    }
    std::fs::write(path, text).expect("write record CSV");
}
