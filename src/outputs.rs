//! Files lincal writes (`--write-spec`, `--write-urdf`, `--report`, `--truth-out`): never one
//! of its inputs or another output, and never half-written.
//!
//! [`check_distinct`] runs before any work: an output that is the same file as an input or as
//! another output (the same path after resolving links and `..`, or the same file by device
//! and inode, hard links included) is exit 2 naming both. [`write_atomic`] writes to a
//! temporary file beside the target and renames it into place once complete and synced, so an
//! interrupted or failed write leaves the previous file as it was.

use std::io::Write;
use std::path::{Path, PathBuf};

use lincal::error::{Error, ErrorClass, Location, Result};

/// A path resolved as far as it exists: the file itself when it exists, else its resolved
/// directory joined with its name (an output not yet written).
fn resolved(path: &Path) -> Option<PathBuf> {
    if let Ok(p) = std::fs::canonicalize(path) {
        return Some(p);
    }
    let name = path.file_name()?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => std::fs::canonicalize(d).ok()?,
        _ => std::env::current_dir().ok()?,
    };
    Some(dir.join(name))
}

/// Whether `a` and `b` name the same file.
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            if ma.dev() == mb.dev() && ma.ino() == mb.ino() {
                return true;
            }
        }
    }
    match (resolved(a), resolved(b)) {
        (Some(ra), Some(rb)) => ra == rb,
        _ => false,
    }
}

/// Exit 2 when an output is an input or another output; each entry is `(role, path)`, the
/// role as the user wrote it (`--report`, `data file`).
///
/// # Errors
/// [`ErrorClass::Input`] naming both roles and paths.
pub fn check_distinct(inputs: &[(&str, &Path)], outputs: &[(&str, &Path)]) -> Result<()> {
    for (i, (role, out)) in outputs.iter().enumerate() {
        let clash = inputs
            .iter()
            .map(|(r, p)| (*r, *p, "input"))
            .chain(outputs[..i].iter().map(|(r, p)| (*r, *p, "output")))
            .find(|(_, p, _)| same_file(out, p));
        if let Some((other, path, kind)) = clash {
            return Err(Error::input(
                Location {
                    file: Some(out.display().to_string()),
                    field: Some((*role).to_string()),
                    ..Location::default()
                },
                format!(
                    "{role} {} is the same file as the {kind} {other} {}: lincal never \
                     overwrites its inputs or one output with another; give another path",
                    out.display(),
                    path.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Writes `bytes` to `path` through a temporary file in the same directory, synced and then
/// renamed over `path`; on any failure the temporary file is removed and `path` is untouched.
/// `what` names the file in the error (`spec`, `URDF`, `report`).
///
/// # Errors
/// [`ErrorClass::Other`] naming `path` and the system's reason.
pub fn write_atomic(path: &Path, bytes: &[u8], what: &str) -> Result<()> {
    let fail = |e: &dyn std::fmt::Display| {
        Error::new(
            ErrorClass::Other,
            Location {
                file: Some(path.display().to_string()),
                ..Location::default()
            },
            format!("cannot write the {what}: {e}"),
        )
    };
    let name = path
        .file_name()
        .ok_or_else(|| fail(&"the path names no file"))?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let tmp = dir.join(format!(
        ".{}.lincal-{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| -> std::io::Result<()> {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        fail(&e)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("lincal-outputs-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("scratch");
        d
    }

    #[test]
    fn an_output_equal_to_an_input_or_another_output_is_refused() {
        let d = scratch("distinct");
        let data = d.join("data.csv");
        std::fs::write(&data, "q1\n0\n").expect("write");
        let sub = d.join("sub");
        std::fs::create_dir_all(&sub).expect("dir");
        // The same file by another spelling, and a hard link.
        let dotted = sub.join("..").join("data.csv");
        let link = d.join("link.csv");
        std::fs::hard_link(&data, &link).expect("link");
        for out in [&data, &dotted, &link] {
            let e = check_distinct(&[("data file", &data)], &[("--report", out)])
                .expect_err("same file");
            assert_eq!(e.class(), ErrorClass::Input);
            assert!(e.to_string().contains("data file"), "{e}");
        }
        // Two outputs to one new file.
        let new = d.join("new.yaml");
        let e = check_distinct(&[], &[("--write-spec", &new), ("--report", &new)])
            .expect_err("same output");
        assert!(e.to_string().contains("--write-spec"), "{e}");
        check_distinct(&[("data file", &data)], &[("--report", &new)]).expect("distinct");
    }

    #[test]
    fn a_failed_write_leaves_the_old_file() {
        let d = scratch("atomic");
        let out = d.join("out.yaml");
        write_atomic(&out, b"first", "spec").expect("write");
        assert_eq!(std::fs::read(&out).expect("read"), b"first");
        write_atomic(&out, b"second", "spec").expect("write");
        assert_eq!(std::fs::read(&out).expect("read"), b"second");
        // A directory in the way of the rename: the write fails, nothing else changes.
        let blocked = d.join("dir");
        std::fs::create_dir_all(blocked.join("inner")).expect("dir");
        assert!(write_atomic(&blocked, b"x", "report").is_err());
        let left: Vec<_> = std::fs::read_dir(&d)
            .expect("list")
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        assert!(left.iter().all(|n| !n.ends_with(".tmp")), "{left:?}");
    }
}
