//! Reading input files: every reader checks a file's size against the limit of its kind before
//! reading, and reads at most limit + 1 bytes, so a huge file or a device (`/dev/zero`, whose
//! metadata length is 0) stops early with an error instead of exhausting memory. A failure is
//! a [`DataError`]: the file, the line, what is wrong and the fix.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The kinds of input brdfit reads, each with its own default size limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Input {
    /// A measurement (CSV, ASTM, Cornell, MERL): 64 MiB (a MERL table is 35 MB; the densest
    /// CSV rows, 10 bytes, take about 100 bytes each in memory).
    Data,
    /// A fit JSON (`brdfit fit --json`, a report's `results.json`): 4 MiB (as
    /// `serde_json::Value`, a hostile 4 MB array takes about 300 MB).
    FitJson,
    /// A scene TOML: 1 MiB.
    Scene,
    /// An OBJ mesh a scene names: 64 MiB.
    Mesh,
}

impl Input {
    /// The default limit in bytes.
    pub fn default_limit(self) -> u64 {
        match self {
            Input::Data => 64 << 20,
            Input::FitJson => 4 << 20,
            Input::Scene => 1 << 20,
            Input::Mesh => 64 << 20,
        }
    }

    /// What the input is, for messages.
    pub fn what(self) -> &'static str {
        match self {
            Input::Data => "data file",
            Input::FitJson => "fit JSON",
            Input::Scene => "scene file",
            Input::Mesh => "OBJ mesh",
        }
    }
}

/// 0 = the default limits; otherwise one limit in bytes for every kind.
static LIMIT: AtomicU64 = AtomicU64::new(0);

/// Replace every kind's limit by `bytes` (`None` restores the defaults). The command line's
/// `--max-input-mb` sets this.
pub fn set_max_input_bytes(bytes: Option<u64>) {
    LIMIT.store(bytes.unwrap_or(0), Ordering::Relaxed);
}

/// The limit in bytes that applies to `kind` now.
pub fn limit(kind: Input) -> u64 {
    match LIMIT.load(Ordering::Relaxed) {
        0 => kind.default_limit(),
        n => n,
    }
}

fn too_large(path: &Path, kind: Input, size: Option<u64>) -> DataError {
    let lim = limit(kind);
    let size = match size {
        Some(s) => format!("{s} bytes"),
        None => format!("more than {lim} bytes"),
    };
    DataError::new(
        path,
        None,
        format!(
            "the {} is {size}, above the limit of {lim} bytes ({} MB) for a {}",
            kind.what(),
            lim as f64 / (1u64 << 20) as f64,
            kind.what()
        ),
        "check that this is the intended file; if it is, raise the input size limit",
    )
    .with_setting(crate::support::setting::Setting::MaxInputSize)
}

/// A reader that delivers at most `limit` bytes of a file and fails with an I/O error
/// carrying [`TooLarge`] when the file has more (it reads one byte past the limit to know).
pub struct Limited<R> {
    inner: R,
    left: u64,
    path: std::path::PathBuf,
    kind: Input,
}

/// The payload of the I/O error a [`Limited`] reader returns past the limit;
/// [`io_error`] turns it into the size-limit error.
#[derive(Debug)]
pub struct TooLarge {
    /// The file.
    pub path: std::path::PathBuf,
    /// Its kind.
    pub kind: Input,
}

impl std::fmt::Display for TooLarge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", too_large(&self.path, self.kind, None))
    }
}

impl std::error::Error for TooLarge {}

impl TooLarge {
    /// The error to report.
    pub fn to_error(&self) -> DataError {
        too_large(&self.path, self.kind, None)
    }
}

impl<R: Read> Read for Limited<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        if self.left == 0 {
            let mut probe = [0u8; 1];
            return match self.inner.read(&mut probe)? {
                0 => Ok(0),
                _ => Err(std::io::Error::other(TooLarge {
                    path: self.path.clone(),
                    kind: self.kind,
                })),
            };
        }
        let n = buf
            .len()
            .min(usize::try_from(self.left).unwrap_or(usize::MAX));
        let got = self.inner.read(&mut buf[..n])?;
        self.left -= got as u64;
        Ok(got)
    }
}

impl Limited<std::fs::File> {
    /// The open file (for its metadata).
    pub fn file(&self) -> &std::fs::File {
        &self.inner
    }
}

/// Open `path` as input of `kind`: refuse a directory, a missing or unreadable file, or a
/// file whose size already exceeds the limit; the reader returned fails past the limit
/// (a file that grew, or a device such as `/dev/zero`).
pub fn open_limited(path: &Path, kind: Input) -> Result<Limited<std::fs::File>, DataError> {
    let meta = check_regular(path, kind)?;
    if meta.len() > limit(kind) {
        return Err(too_large(path, kind, Some(meta.len())));
    }
    let f = std::fs::File::open(path).map_err(|e| io_error(path, &e))?;
    Ok(Limited {
        inner: f,
        left: limit(kind),
        path: path.to_path_buf(),
        kind,
    })
}

/// What kind of file `t` is, for a message: "a character device", "a named pipe (FIFO)"...
pub fn kind_of(t: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a named pipe (FIFO)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    let _ = t;
    "a special file"
}

/// Refuse an input that is not a regular file, before it is opened: a folder, a named pipe
/// (FIFO, `<(cat f)`, `/dev/stdin` on a pipe), a device or a socket. Opening a named pipe
/// blocks until someone writes to it, and a pipe can be read only once while the loaders
/// read a file twice (the format from its first bytes, then the whole). A symbolic link to a
/// regular file is followed. Returns the file's metadata.
pub fn check_regular(path: &Path, kind: Input) -> Result<std::fs::Metadata, DataError> {
    let meta = std::fs::metadata(path).map_err(|e| io_error(path, &e))?;
    if meta.is_dir() {
        return Err(DataError::new(
            path,
            None,
            "is a directory",
            "give the path of a file inside it",
        ));
    }
    if !meta.is_file() {
        return Err(DataError::new(
            path,
            None,
            format!(
                "is {}, not a regular file (brdfit reads every {} and other input only from a regular file)",
                kind_of(meta.file_type()),
                kind.what()
            ),
            "save the input to a file first (e.g. `cat … > FILE`) and give that file",
        ));
    }
    Ok(meta)
}

/// Read all of `path`, input of `kind`, within its size limit.
/// The buffer grows to at most limit + 1 bytes (not by doubling past it), so a device
/// such as `/dev/zero` costs about the limit in memory.
pub fn read_limited(path: &Path, kind: Input) -> Result<Vec<u8>, DataError> {
    let mut r = open_limited(path, kind)?;
    let io = |e: std::io::Error| io_error(path, &e);
    let most = usize::try_from(limit(kind)).unwrap_or(usize::MAX - 1) + 1;
    let size = r.file().metadata().map_err(io)?.len() as usize;
    let mut bytes = Vec::with_capacity(size.min(most).max(1 << 12));
    loop {
        let room = (bytes.capacity() - bytes.len()).max(1);
        let before = bytes.len();
        (&mut r)
            .take(room as u64)
            .read_to_end(&mut bytes)
            .map_err(io)?;
        if bytes.len() == before {
            return Ok(bytes);
        }
        if bytes.len() == bytes.capacity() {
            bytes.reserve_exact(
                bytes
                    .capacity()
                    .min(most.saturating_sub(bytes.len()))
                    .max(1),
            );
        }
    }
}

/// [`read_limited`] as UTF-8 text; a UTF-8 BOM is dropped, invalid UTF-8 is an error that
/// gives its offset.
pub fn read_to_string_limited(path: &Path, kind: Input) -> Result<String, DataError> {
    let mut bytes = read_limited(path, kind)?;
    if bytes.starts_with(b"\xEF\xBB\xBF") {
        bytes.drain(..3);
    }
    String::from_utf8(bytes).map_err(|e| {
        let message = format!(
            "not UTF-8 text (invalid byte at offset {})",
            e.utf8_error().valid_up_to()
        );
        if kind == Input::Data {
            DataError::new(
                path,
                None,
                message,
                "save the file as UTF-8 text, or choose the format merl for a MERL binary",
            )
            .with_setting(crate::support::setting::Setting::Format)
        } else {
            DataError::new(
                path,
                None,
                message,
                format!("save the {} as UTF-8 text", kind.what()),
            )
        }
    })
}

/// A loader or writer error: the file, the line where known, what is wrong and how to fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}{}: {message}\n  fix: {fix}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct DataError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line number, where the problem is on one line.
    pub line: Option<u64>,
    /// What is wrong.
    pub message: String,
    /// What the user should do.
    pub fix: String,
    /// The setting that fix changes, if it is one.
    pub setting: Option<crate::support::setting::Setting>,
}

impl DataError {
    /// New error for `path` at optional `line`.
    pub fn new(
        path: &Path,
        line: Option<u64>,
        message: impl Into<String>,
        fix: impl Into<String>,
    ) -> Self {
        DataError {
            path: path.to_path_buf(),
            line,
            message: message.into(),
            fix: fix.into(),
            setting: None,
        }
    }

    /// The same error, naming the setting its fix changes.
    pub fn with_setting(mut self, s: crate::support::setting::Setting) -> Self {
        self.setting = Some(s);
        self
    }
}

/// An I/O error on `path`, with a fix.
pub fn io_error(path: &Path, e: &std::io::Error) -> DataError {
    if let Some(t) = e.get_ref().and_then(|i| i.downcast_ref::<TooLarge>()) {
        return t.to_error();
    }
    let fix = match e.kind() {
        std::io::ErrorKind::NotFound => "check the path; the file does not exist",
        std::io::ErrorKind::PermissionDenied => "check the file's permissions (chmod +r)",
        _ => "check that the file is readable",
    };
    DataError::new(path, None, format!("cannot read: {e}"), fix)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_device_is_refused_before_it_is_read() {
        // /dev/zero has metadata length 0 and never ends: it is refused unopened.
        let e = read_limited(Path::new("/dev/zero"), Input::Scene).unwrap_err();
        assert!(
            e.message.contains("a character device, not a regular file"),
            "{e}"
        );
        assert!(e.fix.contains("save the input to a file"), "{e}");
    }

    #[test]
    fn a_reader_stops_one_byte_past_the_limit() {
        // A file that grows past the limit after the size check (here: /dev/zero read
        // through the reader directly) fails at limit + 1 bytes.
        let mut r = Limited {
            inner: std::fs::File::open("/dev/zero").unwrap(),
            left: 1 << 10,
            path: PathBuf::from("/dev/zero"),
            kind: Input::Scene,
        };
        let mut buf = Vec::new();
        let e = r.read_to_end(&mut buf).unwrap_err();
        assert_eq!(buf.len(), 1 << 10);
        assert!(
            io_error(Path::new("x"), &e).message.contains("more than"),
            "{e}"
        );
    }

    #[test]
    fn a_file_at_the_limit_is_read_and_one_byte_more_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.toml");
        std::fs::write(&p, vec![b'#'; 1 << 20]).unwrap();
        assert_eq!(read_limited(&p, Input::Scene).unwrap().len(), 1 << 20);
        std::fs::write(&p, vec![b'#'; (1 << 20) + 1]).unwrap();
        let e = read_limited(&p, Input::Scene).unwrap_err();
        assert!(
            e.message
                .contains("is 1048577 bytes, above the limit of 1048576 bytes (1 MB)"),
            "{e}"
        );
        let e = read_limited(dir.path(), Input::Scene).unwrap_err();
        assert!(e.message.contains("directory"), "{e}");
    }
}
