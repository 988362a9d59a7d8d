//! Writing results to files without ever losing one. A regular file is written under a
//! temporary name beside it and renamed over it only when complete, so an interrupted or
//! failed run leaves the old file or none, never half a file (which another command could
//! then read as a record), and no temporary file (removed on error and on Ctrl-C,
//! [`crate::interrupt`]). A symbolic link is followed: its target is replaced, in the
//! target's directory. A special file (a device such as `/dev/null`, a FIFO) is written
//! through, never replaced. A new file gets the user's umask (as `touch` would make it); a
//! replaced one keeps its mode. [`check_paths`] checks every output before the work starts.

use crate::interrupt::Registered;
use anyhow::{anyhow, bail, Context, Result};
use serde::Serialize;
use std::fs::{self, Permissions};
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};

/// Most symbolic links followed from one output path (as the kernel's `ELOOP` limit).
const MAX_LINKS: usize = 40;

/// Write `path` through `write`, which writes a file at the path it is given (a temporary
/// one beside the file `path` names, with the same extension: plot backends choose the
/// format by it; the special file itself when `path` names one).
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let target = follow_links(path)?;
    let existing = fs::metadata(&target).ok();
    if let Some(meta) = &existing {
        if meta.is_dir() {
            bail!("cannot write {}: it is a directory", path.display());
        }
        if !meta.is_file() {
            return write(&target);
        }
    }
    let mode = existing.map_or(0o666, |m| m.permissions().mode());
    let suffix = target
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let (tmp, removed_on_ctrl_c) = Registered::create(
        || {
            tempfile::Builder::new()
                .prefix(".motor-id-")
                .suffix(&suffix)
                .permissions(Permissions::from_mode(mode))
                .tempfile_in(directory_of(&target))
        },
        |tmp| tmp.path(),
    )
    .map_err(|e| anyhow!("cannot write {}: {e}", path.display()))?;
    if let Err(e) = write(tmp.path()) {
        // Removed before it is unregistered: Ctrl-C in between still finds it.
        drop(tmp);
        drop(removed_on_ctrl_c);
        return Err(e);
    }
    removed_on_ctrl_c
        .complete(|| tmp.persist(&target))
        .map_err(|e| anyhow!("cannot write {}: {}", path.display(), e.error))?;
    Ok(())
}

/// The directory a file lives in (`.` for a bare name).
fn directory_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// The file `path` names once its symbolic links are followed (itself when it is none, or
/// does not exist yet).
fn follow_links(path: &Path) -> Result<PathBuf> {
    let mut at = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match fs::symlink_metadata(&at) {
            Ok(m) if m.file_type().is_symlink() => {
                let link = fs::read_link(&at)
                    .map_err(|e| anyhow!("cannot write {}: {e}", path.display()))?;
                at = directory_of(&at).join(link);
            }
            _ => return Ok(at),
        }
    }
    bail!("cannot write {}: too many symbolic links", path.display())
}

/// Check, before any work, every output a command will write: not a directory, not the
/// same file as an input or as another output (the report would replace the record it was
/// made from), in a directory that exists and takes new files. One line naming the path.
pub fn check_paths(inputs: &[&Path], outputs: &[&Path]) -> Result<()> {
    let identity = |m: &fs::Metadata| (m.dev(), m.ino());
    let inputs: Vec<_> = inputs
        .iter()
        .map(|p| (*p, fs::metadata(p).ok().map(|m| identity(&m))))
        .collect();
    let mut targets: Vec<PathBuf> = Vec::new();
    for &out in outputs {
        let target = follow_links(out)?;
        if let Ok(meta) = fs::metadata(&target) {
            let id = Some(identity(&meta));
            if let Some((input, _)) = inputs.iter().find(|(_, i)| *i == id) {
                bail!(
                    "refusing to write {}: it is the input {}",
                    out.display(),
                    input.display()
                );
            }
            if meta.is_dir() {
                bail!("cannot write {}: it is a directory", out.display());
            }
            if !meta.is_file() {
                continue;
            }
        }
        if targets.iter().any(|t| same_path(t, &target)) {
            bail!("{} is named as two outputs", out.display());
        }
        let dir = directory_of(&target);
        tempfile::tempfile_in(dir).map_err(|e| {
            anyhow!(
                "cannot write {}: directory {}: {e}",
                out.display(),
                dir.display()
            )
        })?;
        targets.push(target);
    }
    Ok(())
}

/// Whether two paths name the same place (compared once their directories are resolved).
fn same_path(a: &Path, b: &Path) -> bool {
    let resolve = |p: &Path| {
        fs::canonicalize(directory_of(p))
            .ok()
            .map(|d| d.join(p.file_name().unwrap_or_default()))
    };
    a == b || matches!((resolve(a), resolve(b)), (Some(x), Some(y)) if x == y)
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

    #[test]
    fn a_new_file_takes_the_umask_and_a_replaced_one_keeps_its_mode() {
        let dir = tempfile::tempdir().unwrap();
        let umask = {
            // The process umask, read by creating a file with 0o666 asked for.
            let probe = dir.path().join("probe");
            std::fs::write(&probe, "").unwrap();
            0o777 & !std::fs::metadata(&probe).unwrap().permissions().mode()
        };
        let path = dir.path().join("new.json");
        write_json(&path, &1).unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o666 & !umask);
        std::fs::set_permissions(&path, Permissions::from_mode(0o640)).unwrap();
        write_json(&path, &2).unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640);
    }

    #[test]
    fn a_symlink_is_followed_and_a_special_file_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("target.json");
        std::fs::write(&target, "old").unwrap();
        let link = dir.path().join("link.json");
        std::os::unix::fs::symlink("target.json", &link).unwrap();
        write_json(&link, &7).unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "7\n");
        write_json(Path::new("/dev/null"), &7).unwrap();
        let null = std::fs::metadata("/dev/null").unwrap();
        assert!(!null.is_file(), "/dev/null was replaced by a regular file");
    }

    #[test]
    fn an_output_that_is_an_input_or_in_a_missing_directory_is_refused_before_the_work() {
        let dir = tempfile::tempdir().unwrap();
        let record = dir.path().join("r.csv");
        std::fs::write(&record, "t,v,w\n").unwrap();
        let link = dir.path().join("alias.json");
        std::os::unix::fs::symlink(&record, &link).unwrap();
        for out in [&record, &link] {
            let err = check_paths(&[&record], &[out]).unwrap_err().to_string();
            assert!(err.starts_with("refusing to write"), "{err}");
        }
        let missing = dir.path().join("no").join("r.json");
        assert!(check_paths(&[&record], &[&missing]).is_err());
        let twice = dir.path().join("out.json");
        assert!(check_paths(&[&record], &[&twice, &twice]).is_err());
        assert!(check_paths(&[&record], &[&twice, Path::new("/dev/null")]).is_ok());
        assert_eq!(std::fs::read_to_string(&record).unwrap(), "t,v,w\n");
    }
}
