//! Writing results to files: the JSON reports.

use anyhow::{Context, Result};
use serde::Serialize;
use std::path::Path;

/// Write `report` as pretty JSON, ending with a newline.
pub fn write_json<T: Serialize + ?Sized>(path: &Path, report: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(report).context("cannot serialise the report")?;
    std::fs::write(path, text + "\n").with_context(|| format!("cannot write {}", path.display()))
}
