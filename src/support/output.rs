//! Output files are written to a temporary name in the same directory and renamed, so a crash
//! or a failing writer never leaves a half-written result.

use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// The temporary name used while `path` is being written.
pub fn temp_name(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    path.with_file_name(format!(".{name}.brdfit-tmp-{}", std::process::id()))
}

/// The folders this process created for its outputs, not yet announced.
static CREATED: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Create the folder `dir` with its missing parents, and record the topmost folder created
/// so that the command can say so ([`take_created`]).
pub fn create_dir(dir: &Path) -> io::Result<()> {
    if dir.as_os_str().is_empty() || dir.is_dir() {
        return Ok(());
    }
    let mut top = dir;
    while let Some(p) = top.parent() {
        if p.as_os_str().is_empty() || p.exists() {
            break;
        }
        top = p;
    }
    let top = top.to_path_buf();
    std::fs::create_dir_all(dir).map_err(|e| explain(e, dir))?;
    if let Ok(mut c) = CREATED.lock() {
        c.push(top);
    }
    Ok(())
}

/// The folders created since the last call, in the order they were created.
pub fn take_created() -> Vec<PathBuf> {
    CREATED
        .lock()
        .map(|mut c| std::mem::take(&mut *c))
        .unwrap_or_default()
}

/// Removes the temporary file when dropped unless it was renamed into place: on an error,
/// and also when the writer panics.
struct TempGuard<'a> {
    path: &'a Path,
    renamed: bool,
}

impl Drop for TempGuard<'_> {
    fn drop(&mut self) {
        if !self.renamed {
            let _ = std::fs::remove_file(self.path);
        }
    }
}

/// Remove temporary files of `path` left by processes that are no longer running
/// (`.NAME.brdfit-tmp-PID`, where no process PID exists: a run that was killed while writing).
/// Only where `/proc` lists the running processes; elsewhere nothing is removed.
pub fn remove_stale_temps(path: &Path) {
    let (Some(name), Some(dir)) = (path.file_name(), path.parent()) else {
        return;
    };
    let proc_ = Path::new("/proc");
    if !proc_.join("self").exists() {
        return;
    }
    let prefix = format!(".{}.brdfit-tmp-", name.to_string_lossy());
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let n = e.file_name();
        let Some(pid) = n
            .to_str()
            .and_then(|n| n.strip_prefix(&prefix))
            .and_then(|p| p.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id() && !proc_.join(pid.to_string()).exists() {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Write `path` atomically: `write` fills a temporary file beside it, which is renamed over
/// `path` only when `write` succeeded; otherwise (an error or a panic) the temporary file is
/// removed. Stale temporary files of `path` from killed runs are removed first
/// ([`remove_stale_temps`]). A missing parent folder is created ([`create_dir`]).
pub fn write_atomic<F>(path: &Path, write: F) -> io::Result<()>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    if let Some(dir) = path.parent() {
        create_dir(dir)?;
    }
    if path.is_dir() {
        return Err(io::Error::new(
            io::ErrorKind::IsADirectory,
            format!(
                "`{}` is a folder, not a file\n  fix: give a file name (e.g. `{}`)",
                path.display(),
                path.join("out").display()
            ),
        ));
    }
    remove_stale_temps(path);
    let tmp = temp_name(path);
    let mut guard = TempGuard {
        path: &tmp,
        renamed: false,
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    let file = std::fs::File::create(&tmp).map_err(|e| explain(e, dir))?;
    let mut w = BufWriter::with_capacity(1 << 16, file);
    write(&mut w)?;
    let file = w.into_inner().map_err(|e| e.into_error())?;
    file.sync_all()?;
    drop(file);
    std::fs::rename(&tmp, path)?;
    guard.renamed = true;
    Ok(())
}

/// An error creating the output folder `dir` or a file in it, with what is in the way and the
/// fix: a file where a folder must be, or a folder the user may not write to.
fn explain(e: io::Error, dir: &Path) -> io::Error {
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    // The deepest existing ancestor of `dir`: a file there blocks the folder.
    let mut blocker = Some(dir);
    while let Some(b) = blocker {
        if b.exists() {
            break;
        }
        blocker = b.parent().filter(|p| !p.as_os_str().is_empty());
    }
    let msg = match blocker {
        Some(b) if b == dir && b.exists() && !b.is_dir() => format!(
            "`{}` is a file, not a folder\n  fix: choose another output path, or move `{}` away",
            b.display(),
            b.display()
        ),
        Some(b) if b.exists() && !b.is_dir() => format!(
            "`{}` is a file, so the folder `{}` cannot be made\n  fix: choose another output \
             path, or move `{}` away",
            b.display(),
            dir.display(),
            b.display()
        ),
        _ if e.kind() == io::ErrorKind::PermissionDenied => format!(
            "no permission to write in `{}` ({e})\n  fix: choose an output path in a folder you \
             can write to",
            dir.display()
        ),
        _ => format!("cannot write in `{}`: {e}", dir.display()),
    };
    io::Error::new(e.kind(), msg)
}

/// [`write_atomic`] for a byte buffer.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomic(path, |w| w.write_all(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failing_writer_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.csv");
        let r = write_atomic(&p, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("injected"))
        });
        assert!(r.is_err());
        assert!(!p.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        write_bytes_atomic(&p, b"ok").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"ok");
    }

    #[test]
    fn a_panicking_writer_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.csv");
        let r = std::panic::catch_unwind(|| {
            let _ = write_atomic(&p, |w| {
                w.write_all(b"partial")?;
                panic!("injected");
            });
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn a_file_in_the_way_is_named_with_the_fix() {
        let dir = tempfile::tempdir().unwrap();
        let blocker = dir.path().join("afile");
        std::fs::write(&blocker, b"x").unwrap();
        let e = write_bytes_atomic(&blocker.join("sub/out.json"), b"ok").unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("afile` is a file"), "{msg}");
        assert!(msg.contains("fix:"), "{msg}");
        let e = write_bytes_atomic(dir.path(), b"ok")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("is a folder, not a file") && e.contains("fix:"),
            "{e}"
        );
        assert_eq!(std::fs::read(&blocker).unwrap(), b"x");
    }

    #[test]
    fn stale_temporary_files_of_dead_processes_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.csv");
        // A process id above the kernel's largest (pid_max ≤ 2^22) was never running.
        let dead = dir.path().join(".out.csv.brdfit-tmp-4999999");
        // Process 1 is always running: its file stays; so does another output's.
        let alive = dir.path().join(".out.csv.brdfit-tmp-1");
        let other = dir.path().join(".other.csv.brdfit-tmp-4999999");
        for f in [&dead, &alive, &other] {
            std::fs::write(f, b"left over").unwrap();
        }
        write_bytes_atomic(&p, b"ok").unwrap();
        assert!(!dead.exists());
        assert!(alive.exists() && other.exists());
        assert_eq!(std::fs::read(&p).unwrap(), b"ok");
    }
}
