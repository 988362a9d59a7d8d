//! Writing a record CSV (docs/CONTRACTS.md): atomically, with the columns the record holds,
//! and only what the reader ([`super::rows`]) takes back.

use super::{rows, OwnedRecord};
use crate::output::write_atomically;
use anyhow::{bail, Context, Result};
use std::path::Path;

impl OwnedRecord {
    /// Write as record CSV.
    pub fn write(&self, path: &Path) -> Result<()> {
        self.write_showing(path, true)
    }

    /// Write as record CSV, its rows' progress on stderr unless `quiet` (a record of
    /// [`crate::progress::WRITE_PROGRESS_SAMPLES`] samples or more; the bar appears once the
    /// temporary file exists).
    pub fn write_showing(&self, path: &Path, quiet: bool) -> Result<()> {
        write_atomically(path, |tmp| {
            let bar = crate::progress::writing(&path.display().to_string(), self.len(), quiet);
            let written = self.write_to(tmp, path, &bar);
            bar.finish_and_clear();
            written
        })
    }

    /// Whether the reader would take every value back: finite and within
    /// [`rows::MAX_MAGNITUDE`] (a writer must not write what its reader refuses).
    fn check_readable(&self) -> Result<()> {
        if self.averaged == 0 || f64::from(self.averaged) > rows::MAX_AVERAGED {
            bail!(
                "averaged = {}: not a count of drive readings the record reader takes (1 to {})",
                self.averaged,
                rows::MAX_AVERAGED
            );
        }
        let columns = [
            ("v", Some(&self.v)),
            ("omega", Some(&self.omega)),
            ("i", self.current.as_ref()),
            ("tl", self.load.as_ref()),
        ];
        for (name, values) in columns {
            let Some(values) = values else { continue };
            if let Some(k) = values
                .iter()
                .position(|x| !x.is_finite() || f64::from(x.abs()) > rows::MAX_MAGNITUDE)
            {
                bail!(
                    "sample {k}: {name} = {} is beyond {:e}, which the record reader refuses (a unit or scale error?)",
                    values[k],
                    rows::MAX_MAGNITUDE
                );
            }
        }
        Ok(())
    }

    /// Write as record CSV to `tmp` (`path` names it in errors), counting the rows on `bar`.
    fn write_to(&self, tmp: &Path, path: &Path, bar: &indicatif::ProgressBar) -> Result<()> {
        self.check_readable()
            .with_context(|| format!("cannot write {}", path.display()))?;
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
        if self.averaged > 1 {
            header.push("averaged");
        }
        let averaged = self.averaged.to_string();
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
            if self.averaged > 1 {
                row.push(averaged.clone());
            }
            w.write_record(&row)?;
            if k % 4096 == 0 {
                bar.set_position(k as u64);
            }
        }
        w.flush()
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(())
    }
}
