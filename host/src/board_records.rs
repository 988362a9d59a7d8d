//! The records a board recorded (the commissioning experiment's slow and fast records, or a
//! record streamed to it) as record CSVs, `bridge` column included: one writer for the
//! virtual board (`commission --sim --out-dir`) and for a board's download
//! (`board record --out-dir`), so that `identify` and `validate` run on exactly what the
//! board fitted (`diagnose` on readings at the instants only: an `averaged` record is
//! refused there).

use crate::csvio::OwnedRecord;
use anyhow::{bail, Result};
use motor_id_shared::device::virtual_board::BoardRecord;
use std::path::{Path, PathBuf};

/// The file names of `count` records: a commissioning's two are `slow.csv` and `fast.csv`,
/// anything else `record-1.csv`, `record-2.csv`, ...
pub fn file_names(count: usize) -> Vec<String> {
    match count {
        2 => vec!["slow.csv".into(), "fast.csv".into()],
        n => (1..=n).map(|k| format!("record-{k}.csv")).collect(),
    }
}

/// Refuse an output directory that does not exist, before any work.
pub fn check_out_dir(dir: &Path) -> Result<()> {
    if !dir.is_dir() {
        bail!("--out-dir {}: no such directory", dir.display());
    }
    Ok(())
}

/// A board record as a record CSV at `path`.
fn record_file(r: &BoardRecord, path: PathBuf) -> OwnedRecord {
    OwnedRecord {
        path,
        t0: 0.0,
        dt: r.dt,
        v: r.v.clone(),
        omega: r.omega.clone(),
        current: (!r.current.is_empty()).then(|| r.current.clone()),
        load: None,
        coast_from: r.coast_from,
        averaged: r.averaged,
    }
}

/// Write `records` into `dir` (each atomically) under [`file_names`]; the paths written.
pub fn write_records(dir: &Path, records: &[BoardRecord]) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for (r, name) in records.iter().zip(file_names(records.len())) {
        let path = dir.join(name);
        record_file(r, path.clone()).write(&path)?;
        written.push(path);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn averaged_records_are_written_with_their_count_and_read_back_as_means() {
        let dir = tempfile::tempdir().unwrap();
        let record = BoardRecord {
            dt: 1e-3,
            v: vec![6.0; 10],
            omega: (0..10).map(|k| k as f32).collect(),
            current: vec![0.5; 10],
            coast_from: Some(7),
            averaged: 4,
        };
        let written = write_records(dir.path(), std::slice::from_ref(&record)).unwrap();
        let back = OwnedRecord::read(&written[0]).unwrap();
        assert_eq!(back.averaged, 4);
        assert_eq!(back.coast_from, Some(7));
        assert_eq!(back.omega, record.omega);
        assert_eq!(back.current.as_ref(), Some(&record.current));
        // Readings at the instants carry no column.
        let instant = BoardRecord {
            averaged: 1,
            ..record
        };
        let written = write_records(dir.path(), std::slice::from_ref(&instant)).unwrap();
        let text = std::fs::read_to_string(&written[0]).unwrap();
        assert_eq!(text.lines().next(), Some("t,v,omega,i,bridge"));
        // A count the reader would refuse (a hostile board's) is not written.
        for averaged in [0, 2_000_000] {
            let bad = BoardRecord {
                averaged,
                ..instant.clone()
            };
            let sub = dir.path().join(format!("bad-{averaged}"));
            std::fs::create_dir(&sub).unwrap();
            let err = write_records(&sub, &[bad]).unwrap_err();
            assert!(
                format!("{err:#}").contains(&format!("averaged = {averaged}")),
                "{err:#}"
            );
            assert!(std::fs::read_dir(&sub).unwrap().next().is_none());
        }
    }
}
