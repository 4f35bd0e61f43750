//! Files lincal writes (`--write-spec`, `--write-urdf`, `--report`, `--truth-out`): never one
//! of its inputs or another output, and never half-written.
//!
//! [`check_distinct`] runs before any work: an output that cannot be written (a directory, a
//! file in a directory that does not exist) is exit 2 naming it, and so is an output that is
//! the same file as an input or as another output (the same path after resolving links and
//! `..`, or the same file by device and inode, hard links included), naming both.
//! [`write_atomic`] writes a regular file through a temporary file beside it, renamed into
//! place once complete and synced, so an interrupted or failed write leaves the previous file
//! as it was; it follows a symbolic link to the file it names (the link stays), keeps an
//! existing file's permissions, and writes straight into a device or a pipe (`/dev/null`, a
//! FIFO), which a rename would replace with a regular file.

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

/// Exit 2 when an output cannot be written: a directory, or a file in a directory that does
/// not exist (`role` as the user wrote it, `--report`).
///
/// # Errors
/// [`ErrorClass::Input`] naming the role and the path.
pub fn check_writable(role: &str, path: &Path) -> Result<()> {
    let refuse = |why: String| {
        Err(Error::input(
            Location {
                file: Some(path.display().to_string()),
                field: Some(role.to_string()),
                ..Location::default()
            },
            format!(
                "cannot write the {} {}: {why}",
                what_of(role),
                path.display()
            ),
        ))
    };
    if path.is_dir() {
        return refuse("it is a directory".to_string());
    }
    if let Ok(meta) = std::fs::metadata(path) {
        if meta.is_file() && meta.permissions().readonly() {
            return refuse("it is read-only".to_string());
        }
        return Ok(());
    }
    // Not there yet (or a dangling link): the directory it will be made in must exist.
    let target = link_target(path).unwrap_or_else(|_| path.to_path_buf());
    match target.parent() {
        Some(dir) if !dir.as_os_str().is_empty() && !dir.is_dir() => {
            refuse(format!("the directory {} does not exist", dir.display()))
        }
        _ => Ok(()),
    }
}

/// What an output option writes, for messages.
fn what_of(role: &str) -> &str {
    match role {
        "--report" => "report",
        "--write-spec" => "spec",
        "--write-urdf" => "URDF",
        "--truth-out" => "truth file",
        other => other,
    }
}

/// Exit 2 when an output cannot be written ([`check_writable`]), or is an input or another
/// output; each entry is `(role, path)`, the role as the user wrote it (`--report`, `data
/// file`).
///
/// # Errors
/// [`ErrorClass::Input`] naming the roles and paths.
pub fn check_distinct(inputs: &[(&str, &Path)], outputs: &[(&str, &Path)]) -> Result<()> {
    for (role, out) in outputs {
        check_writable(role, out)?;
    }
    for (i, (role, out)) in outputs.iter().enumerate() {
        // A device or a pipe (`/dev/null` for two outputs) is written into, never replaced.
        if std::fs::metadata(out).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
            continue;
        }
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
    // What the path names, as the kernel follows it (`/dev/stdout` → `/proc/self/fd/1` → a
    // pipe is followed only by the kernel, not as text).
    if let Ok(meta) = std::fs::metadata(path) {
        if !meta.is_file() && !meta.is_dir() {
            // A device or a pipe: written into, as a shell's `>` would; a rename would put a
            // regular file in its place.
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(|e| fail(&e))?;
            return f
                .write_all(bytes)
                .and_then(|()| f.flush())
                .map_err(|e| fail(&e));
        }
    }
    // A link to a regular file (or a dangling one) is followed to the file it names, so the
    // link stays a link.
    let target = link_target(path).map_err(|e| fail(&e))?;
    let path = target.as_path();
    let existing = std::fs::metadata(path).ok();
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
        if let Some(meta) = &existing {
            // The replaced file's read and write bits, not its set-id bits.
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                let mode = meta.permissions().mode() & 0o777;
                f.set_permissions(std::fs::Permissions::from_mode(mode))?;
            }
            #[cfg(not(unix))]
            f.set_permissions(meta.permissions())?;
        }
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        fail(&e)
    })
}

/// The file a path names after following symbolic links (a dangling link: the path it points
/// to, which the write creates); the path itself when it is not a link. An error for a chain
/// of more than 40 links (a loop), which the rename would otherwise replace.
fn link_target(path: &Path) -> std::io::Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let next = std::fs::read_link(&p)?;
                p = match p.parent() {
                    Some(dir) if next.is_relative() => dir.join(next),
                    _ => next,
                };
            }
            _ => return Ok(p),
        }
    }
    Err(std::io::Error::other("too many levels of symbolic links"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory, removed when the test ends (pass or fail).
    struct Scratch(PathBuf);

    impl std::ops::Deref for Scratch {
        type Target = PathBuf;
        fn deref(&self) -> &PathBuf {
            &self.0
        }
    }

    impl AsRef<Path> for Scratch {
        fn as_ref(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn scratch(name: &str) -> Scratch {
        let d = std::env::temp_dir().join(format!("lincal-outputs-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("scratch");
        Scratch(d)
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

    #[cfg(unix)]
    #[test]
    fn links_devices_and_permissions_survive_a_write() {
        use std::os::unix::fs::PermissionsExt;
        let d = scratch("special");
        // A link: the file it names gets the bytes, the link stays.
        let target = d.join("target.yaml");
        std::fs::write(&target, "old").expect("write");
        let link = d.join("link.yaml");
        std::os::unix::fs::symlink("target.yaml", &link).expect("symlink");
        write_atomic(&link, b"new", "spec").expect("write");
        assert!(std::fs::symlink_metadata(&link)
            .expect("meta")
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read(&target).expect("read"), b"new");
        // A dangling link creates the file it names.
        let dangling = d.join("dangling.yaml");
        std::os::unix::fs::symlink("made.yaml", &dangling).expect("symlink");
        write_atomic(&dangling, b"made", "spec").expect("write");
        assert_eq!(std::fs::read(d.join("made.yaml")).expect("read"), b"made");
        // Permissions of the file replaced are kept.
        std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o640)).expect("chmod");
        write_atomic(&target, b"again", "spec").expect("write");
        let mode = std::fs::metadata(&target)
            .expect("meta")
            .permissions()
            .mode();
        assert_eq!(mode & 0o777, 0o640);
        // A device is written into, not replaced, also through a link; two outputs may
        // share it.
        write_atomic(Path::new("/dev/null"), b"gone", "report").expect("write");
        assert!(!std::fs::metadata("/dev/null").expect("meta").is_file());
        let dev = d.join("dev");
        std::os::unix::fs::symlink("/dev/null", &dev).expect("symlink");
        write_atomic(&dev, b"gone", "report").expect("write");
        assert!(std::fs::symlink_metadata(&dev)
            .expect("meta")
            .file_type()
            .is_symlink());
        check_distinct(&[], &[("--write-spec", &dev), ("--report", &dev)]).expect("a device");
        // A loop of links is an error, and the links stay.
        let (a, b) = (d.join("a.yaml"), d.join("b.yaml"));
        std::os::unix::fs::symlink("b.yaml", &a).expect("symlink");
        std::os::unix::fs::symlink("a.yaml", &b).expect("symlink");
        assert!(write_atomic(&a, b"x", "spec").is_err());
        assert!(std::fs::symlink_metadata(&a)
            .expect("meta")
            .file_type()
            .is_symlink());
        // A read-only file is refused before any work (as root too, where a write would pass).
        let frozen = d.join("frozen.yaml");
        std::fs::write(&frozen, "keep").expect("write");
        std::fs::set_permissions(&frozen, std::fs::Permissions::from_mode(0o444)).expect("chmod");
        let e = check_distinct(&[], &[("--write-spec", &frozen)]).expect_err("read-only");
        assert!(e.to_string().contains("read-only"), "{e}");
    }

    #[test]
    fn an_output_in_a_missing_directory_or_on_a_directory_is_refused_before_work() {
        let d = scratch("writable");
        let missing = d.join("nodir").join("x.yaml");
        let e = check_distinct(&[], &[("--write-spec", &missing)]).expect_err("missing dir");
        assert_eq!(e.class(), ErrorClass::Input);
        assert!(e.to_string().contains("does not exist"), "{e}");
        let e = check_distinct(&[], &[("--write-urdf", &d)]).expect_err("a directory");
        assert!(e.to_string().contains("is a directory"), "{e}");
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
