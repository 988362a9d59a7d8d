//! Writing results to files, atomically: a file is written under a temporary name beside
//! it and renamed over the target only when complete, so an interrupted run leaves the old
//! file or none, never half a file (which another command could then read as a record).

use anyhow::{anyhow, Context, Result};
use serde::Serialize;
use std::path::Path;

/// Write `path` through `write`, which writes a file at the path it is given (a temporary
/// one beside `path`, with the same extension: plot backends choose the format by it).
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let suffix = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let tmp = tempfile::Builder::new()
        .prefix(".motor-id-")
        .suffix(&suffix)
        .tempfile_in(dir)
        .map_err(|e| anyhow!("cannot write {}: {e}", path.display()))?;
    write(tmp.path())?;
    tmp.persist(path)
        .map_err(|e| anyhow!("cannot write {}: {}", path.display(), e.error))?;
    Ok(())
}

/// Write `report` as pretty JSON, ending with a newline.
pub fn write_json<T: Serialize + ?Sized>(path: &Path, report: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(report).context("cannot serialise the report")?;
    write_atomically(path, |tmp| {
        std::fs::write(tmp, text + "\n").with_context(|| format!("cannot write {}", path.display()))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_leaves_the_old_file_and_no_temporary_one() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.csv");
        std::fs::write(&path, "old").unwrap();
        let err = write_atomically(&path, |tmp| {
            std::fs::write(tmp, "half a fi")?;
            Err(anyhow!("interrupted"))
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "a temporary file was left: {names:?}");
        write_atomically(&path, |tmp| Ok(std::fs::write(tmp, "new")?)).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
    }

    #[test]
    fn a_missing_directory_is_one_clear_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("missing").join("plot.png");
        let err = write_atomically(&path, |_| Ok(())).unwrap_err().to_string();
        assert!(
            err.starts_with(&format!("cannot write {}:", path.display())),
            "{err}"
        );
        assert_eq!(err.lines().count(), 1);
    }
}
