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

/// Why an output cannot be written, and the fix: the error inside the [`io::Error`]s that
/// [`write_atomic`] and [`check_target`] return. [`write_error`] turns it into a
/// [`DataError`](crate::support::input::DataError).
#[derive(Debug)]
pub struct Refusal {
    /// The path in the way: the output, or the folder it goes in.
    pub path: PathBuf,
    /// What is wrong.
    pub message: String,
    /// What the user should do.
    pub fix: String,
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {}\n  fix: {}",
            self.path.display(),
            self.message,
            self.fix
        )
    }
}

impl std::error::Error for Refusal {}

fn refusal(
    kind: io::ErrorKind,
    path: &Path,
    message: impl Into<String>,
    fix: impl Into<String>,
) -> io::Error {
    io::Error::new(
        kind,
        Refusal {
            path: path.to_path_buf(),
            message: message.into(),
            fix: fix.into(),
        },
    )
}

/// An error of [`write_atomic`] on `path` as a [`DataError`](crate::support::input::DataError) that
/// says what could not be written and the fix.
pub fn write_error(path: &Path, e: &io::Error) -> crate::support::input::DataError {
    use crate::support::input::DataError;
    match e.get_ref().and_then(|i| i.downcast_ref::<Refusal>()) {
        Some(r) => DataError::new(&r.path, None, r.message.clone(), r.fix.clone()),
        None => DataError::new(path, None, format!("cannot write: {e}"), write_fix(e)),
    }
}

/// The fix for a failure writing a file.
fn write_fix(e: &io::Error) -> &'static str {
    match e.kind() {
        io::ErrorKind::StorageFull => "free space on the disk, or choose another output path",
        io::ErrorKind::PermissionDenied | io::ErrorKind::ReadOnlyFilesystem => {
            "choose an output path you can write to"
        }
        _ => "check the output path and the disk, or choose another output path",
    }
}

/// A failure writing `path` (not creating it), worded as one.
fn cannot_write(path: &Path, e: io::Error) -> io::Error {
    if e.get_ref().is_some_and(|i| i.is::<Refusal>()) {
        return e;
    }
    let fix = write_fix(&e);
    refusal(e.kind(), path, format!("cannot write: {e}"), fix)
}

/// Refuse an output `path` that exists and is not a regular file: a folder, a device
/// (`/dev/null`), a named pipe or a socket would be replaced by a regular file. A symbolic
/// link is replaced itself, never written through, unless it points to a folder. A path that
/// does not exist yet is fine. [`write_atomic`] checks this first; a command calls it before
/// its work, so that nothing is computed for an output that would be refused.
pub fn check_target(path: &Path) -> io::Result<()> {
    let Ok(meta) = std::fs::symlink_metadata(path) else {
        return Ok(());
    };
    let t = meta.file_type();
    if t.is_dir() || (t.is_symlink() && path.is_dir()) {
        return Err(refusal(
            io::ErrorKind::IsADirectory,
            path,
            "is a folder, not a file",
            format!("give a file name (e.g. `{}`)", path.join("out").display()),
        ));
    }
    if t.is_file() {
        return Ok(());
    }
    // A link is replaced itself, so a dangling link or a link to a regular file is fine; a
    // link to a device or a pipe is refused like the device: its name says where output went.
    let t = match std::fs::metadata(path) {
        Ok(m) if t.is_symlink() && !m.is_file() => m.file_type(),
        _ if t.is_symlink() => return Ok(()),
        _ => t,
    };
    Err(refusal(
        io::ErrorKind::InvalidInput,
        path,
        format!(
            "is {}, not a regular file; brdfit replaces only regular files",
            crate::support::input::kind_of(t)
        ),
        "give a path to a regular file or a new name",
    ))
}

/// Write `path` atomically: `write` fills a temporary file beside it, which is renamed over
/// `path` only when `write` succeeded; otherwise (an error or a panic) the temporary file is
/// removed. An existing `path` that is not a regular file (a device, a named pipe, a folder)
/// is refused before anything is written ([`check_target`]). Stale temporary files of `path`
/// from killed runs are removed first ([`remove_stale_temps`]). A missing parent folder is
/// created ([`create_dir`]). Errors carry a [`Refusal`]: what is wrong and the fix.
pub fn write_atomic<F>(path: &Path, write: F) -> io::Result<()>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    check_target(path)?;
    if let Some(dir) = path.parent() {
        create_dir(dir)?;
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
    let fail = |e| cannot_write(path, e);
    write(&mut w).map_err(fail)?;
    let file = w.into_inner().map_err(|e| fail(e.into_error()))?;
    file.sync_all().map_err(fail)?;
    drop(file);
    std::fs::rename(&tmp, path).map_err(fail)?;
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
    let fix = |b: &Path| format!("choose another output path, or move `{}` away", b.display());
    match blocker {
        Some(b) if b == dir && b.exists() && !b.is_dir() => {
            refusal(e.kind(), b, "is a file, not a folder", fix(b))
        }
        Some(b) if b.exists() && !b.is_dir() => refusal(
            e.kind(),
            b,
            format!(
                "is a file, so the folder `{}` cannot be made",
                dir.display()
            ),
            fix(b),
        ),
        _ if e.kind() == io::ErrorKind::PermissionDenied => refusal(
            e.kind(),
            dir,
            format!("no permission to write in this folder ({e})"),
            "choose an output path in a folder you can write to",
        ),
        _ => {
            let fix = write_fix(&e);
            refusal(
                e.kind(),
                dir,
                format!("cannot write in this folder: {e}"),
                fix,
            )
        }
    }
}

/// Write the folder `dir` whole: `fill` writes a run's files into a staging folder beside it
/// (`.NAME.brdfit-tmp-PID`), which then takes `dir`'s place by renaming; files already in
/// `dir` that the run did not write are moved into the new folder. Two runs at once, or a run
/// killed part-way, therefore never leave one run's files beside another's: `dir` holds one
/// whole run (the last to finish), and a killed run leaves only its staging folder, removed
/// by the next run. Returns `fill`'s paths moved to `dir`.
pub fn write_dir_atomic<E>(
    dir: &Path,
    fill: impl FnOnce(&Path) -> Result<Vec<PathBuf>, E>,
) -> Result<Vec<PathBuf>, E>
where
    E: From<io::Error>,
{
    // A folder named `.` or `..` cannot be renamed: written in place.
    let Some(name) = dir.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        create_dir(dir)?;
        return fill(dir);
    };
    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    create_dir(&parent)?;
    remove_stale_dirs(&parent, &name);
    let pid = std::process::id();
    let stage = parent.join(format!(".{name}.brdfit-tmp-{pid}"));
    let old = parent.join(format!(".{name}.brdfit-old-{pid}"));
    let _ = std::fs::remove_dir_all(&stage);
    std::fs::create_dir(&stage).map_err(|e| explain(e, &parent))?;
    let created_before = dir.exists();
    let staged = match fill(&stage) {
        Ok(p) => p,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&stage);
            return Err(e);
        }
    };
    // The folders made inside the staging folder are not announced; `dir` itself is, if new.
    let _ = take_created();
    let mut tries = 0;
    loop {
        let had = match std::fs::rename(dir, &old) {
            Ok(()) => true,
            Err(e) if e.kind() == io::ErrorKind::NotFound => false,
            Err(e) => {
                let _ = std::fs::remove_dir_all(&stage);
                return Err(cannot_write(dir, e).into());
            }
        };
        match std::fs::rename(&stage, dir) {
            Ok(()) => {
                if had {
                    keep_others(&old, dir);
                    let _ = std::fs::remove_dir_all(&old);
                }
                break;
            }
            // Another run put its folder in place between the two renames: try again.
            Err(_) if tries < 8 => {
                if had {
                    let _ = std::fs::rename(&old, dir);
                }
                tries += 1;
            }
            Err(e) => {
                if had {
                    let _ = std::fs::rename(&old, dir);
                }
                let _ = std::fs::remove_dir_all(&stage);
                return Err(cannot_write(dir, e).into());
            }
        }
    }
    if !created_before && let Ok(mut c) = CREATED.lock() {
        c.push(dir.to_path_buf());
    }
    Ok(staged
        .into_iter()
        .map(|p| match p.strip_prefix(&stage) {
            Ok(rel) => dir.join(rel),
            Err(_) => p,
        })
        .collect())
}

/// Move the entries of `old` that `new` lacks into `new` (a user's own files in an output
/// folder stay); a folder the run wrote replaces the old one whole.
fn keep_others(old: &Path, new: &Path) {
    let Ok(entries) = std::fs::read_dir(old) else {
        return;
    };
    for e in entries.flatten() {
        let target = new.join(e.file_name());
        if std::fs::symlink_metadata(&target).is_err() {
            let _ = std::fs::rename(e.path(), &target);
        }
    }
}

/// Remove staging folders of `parent/name` left by runs no longer running.
fn remove_stale_dirs(parent: &Path, name: &str) {
    let proc_ = Path::new("/proc");
    if !proc_.join("self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(parent) else {
        return;
    };
    for e in entries.flatten() {
        let n = e.file_name();
        let Some(pid) = n.to_str().and_then(|n| {
            n.strip_prefix(&format!(".{name}.brdfit-tmp-"))
                .or_else(|| n.strip_prefix(&format!(".{name}.brdfit-old-")))
                .and_then(|p| p.parse::<u32>().ok())
        }) else {
            continue;
        };
        if pid != std::process::id() && !proc_.join(pid.to_string()).exists() {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
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
        assert!(msg.contains("afile: is a file"), "{msg}");
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
    fn a_folder_is_replaced_whole_or_not_at_all() {
        let top = tempfile::tempdir().unwrap();
        let dir = top.path().join("run");
        std::fs::create_dir(&dir).unwrap();
        std::fs::write(dir.join("result.json"), b"old").unwrap();
        std::fs::write(dir.join("notes.txt"), b"mine").unwrap();
        // A run that fails part-way (as a killed one would stop) leaves the old run whole.
        let r: io::Result<Vec<PathBuf>> = write_dir_atomic(&dir, |stage| {
            write_bytes_atomic(&stage.join("image.png"), b"new")?;
            Err(io::Error::other("stopped"))
        });
        assert!(r.is_err());
        assert!(!dir.join("image.png").exists());
        assert_eq!(std::fs::read(dir.join("result.json")).unwrap(), b"old");
        // A run that ends replaces the run's files together; the user's file stays.
        let wrote = write_dir_atomic(&dir, |stage| -> io::Result<Vec<PathBuf>> {
            write_bytes_atomic(&stage.join("image.png"), b"new")?;
            write_bytes_atomic(&stage.join("result.json"), b"new")?;
            Ok(vec![stage.join("image.png"), stage.join("result.json")])
        })
        .unwrap();
        assert_eq!(wrote, vec![dir.join("image.png"), dir.join("result.json")]);
        assert_eq!(std::fs::read(dir.join("result.json")).unwrap(), b"new");
        assert_eq!(std::fs::read(dir.join("notes.txt")).unwrap(), b"mine");
        // Nothing staged is left beside the folder.
        let names: Vec<String> = std::fs::read_dir(top.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, vec!["run".to_string()]);
    }

    #[test]
    fn a_link_to_a_device_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("out.csv");
        std::os::unix::fs::symlink("/dev/null", &link).unwrap();
        let e = write_bytes_atomic(&link, b"x").unwrap_err().to_string();
        assert!(e.contains("a character device, not a regular file"), "{e}");
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
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
