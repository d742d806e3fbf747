//! Atomic file writes: readers see the old file or the complete new one, never a partial one,
//! and a crash or kill at any moment leaves at most a stale temporary file next to the target.
//!
//! The content goes to `.NAME.tmp.PID.N` in the target's directory (created with
//! `create_new`; a name that never ends like the target, so a stale one cannot be mistaken for
//! output), is synced, renamed over the target, and the directory is synced. The pid and a
//! per-process counter make the name unique among live writers; a stale temporary file of a
//! dead process with the same pid is skipped, never overwritten. On any error before the
//! rename the temporary file is removed and an existing target is untouched. A failure to sync
//! the directory after the rename is reported, but the new file is then already in place.
//!
//! Used by the light-field file (`format`), images (`image`) and `vlf-bake`'s reports and CSVs;
//! each maps [`AtomicWriteError`] to its own error.

use std::fmt;
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Bytes buffered between the writer and the temporary file.
const BUFFER: usize = 1 << 20;

/// Why an atomic write failed; either way the target is left as it was, except after a failed
/// directory sync (see the module documentation).
#[derive(Debug)]
pub enum AtomicWriteError<E> {
    /// A step of the write failed.
    Io {
        /// What was being done, naming the temporary file: `creating temporary file
        /// .x.vlf.tmp.12.0`, `writing …`, `syncing …`, `renaming … over the target`,
        /// `syncing the directory after the rename`.
        step: String,
        source: io::Error,
    },
    /// The caller's writer failed with its own error.
    Content {
        /// `writing .NAME.tmp.PID.N`.
        step: String,
        error: E,
    },
}

impl AtomicWriteError<io::Error> {
    /// The failed step and its I/O error, for writers whose errors are I/O errors.
    pub fn into_step(self) -> (String, io::Error) {
        match self {
            AtomicWriteError::Io { step, source } => (step, source),
            AtomicWriteError::Content { step, error } => (step, error),
        }
    }
}

impl<E: fmt::Display> fmt::Display for AtomicWriteError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AtomicWriteError::Io { step, source } => write!(f, "{step}: {source}"),
            AtomicWriteError::Content { step, error } => write!(f, "{step}: {error}"),
        }
    }
}

impl<E: std::error::Error + 'static> std::error::Error for AtomicWriteError<E> {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            AtomicWriteError::Io { source, .. } => Some(source),
            AtomicWriteError::Content { error, .. } => Some(error),
        }
    }
}

/// Writes `path` atomically: `content` fills a buffered temporary file next to it (see the
/// module documentation for the guarantees).
pub fn write<E>(
    path: &Path,
    content: impl FnOnce(&mut BufWriter<File>) -> Result<(), E>,
) -> Result<(), AtomicWriteError<E>> {
    let step = |step: String| move |source| AtomicWriteError::Io { step, source };
    let name = path.file_name().ok_or_else(|| {
        step("choosing a temporary name".into())(io::Error::new(
            io::ErrorKind::InvalidInput,
            "the path has no file name",
        ))
    })?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let mut attempts = 0;
    let (tmp_path, tmp_name, tmp) = loop {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        attempts += 1;
        let tmp_name = format!(".{}.tmp.{}.{n}", name.to_string_lossy(), std::process::id());
        let tmp_path = dir.join(&tmp_name);
        match OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp_path)
        {
            Ok(f) => break (tmp_path, tmp_name, f),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists && attempts < 64 => continue,
            Err(e) => return Err(step(format!("creating temporary file {tmp_name}"))(e)),
        }
    };
    let mut guard = TempGuard(Some(tmp_path.clone()));
    let mut out = BufWriter::with_capacity(BUFFER, tmp);
    content(&mut out).map_err(|error| AtomicWriteError::Content {
        step: format!("writing {tmp_name}"),
        error,
    })?;
    out.flush().map_err(step(format!("writing {tmp_name}")))?;
    let tmp = out
        .into_inner()
        .map_err(|e| step(format!("writing {tmp_name}"))(e.into_error()))?;
    tmp.sync_all()
        .map_err(step(format!("syncing {tmp_name}")))?;
    drop(tmp);
    fs::rename(&tmp_path, path).map_err(step(format!("renaming {tmp_name} over the target")))?;
    guard.0 = None;
    sync_dir(dir).map_err(step("syncing the directory after the rename".into()))?;
    Ok(())
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), AtomicWriteError<io::Error>> {
    write(path, |w| w.write_all(bytes))
}

/// Removes the temporary file unless disarmed (after the rename).
struct TempGuard(Option<PathBuf>);

impl Drop for TempGuard {
    fn drop(&mut self) {
        if let Some(p) = self.0.take()
            && let Err(e) = fs::remove_file(&p)
        {
            log::warn!("cannot remove temporary file {}: {e}", p.display());
        }
    }
}

#[cfg(unix)]
fn sync_dir(dir: &Path) -> io::Result<()> {
    File::open(dir)?.sync_all()
}

#[cfg(not(unix))]
fn sync_dir(_dir: &Path) -> io::Result<()> {
    Ok(())
}
