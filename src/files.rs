//! Run files written atomically ([`foosball_nets::atomic_file`]) and append-only CSV logs,
//! with the one error every file of a run reports: the path and why.

use std::io::Write;
use std::path::{Path, PathBuf};

/// A file of the run that could not be written or read.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {source}")]
pub struct RunFileError {
    /// The file.
    pub path: PathBuf,
    /// Why.
    pub source: std::io::Error,
}

impl RunFileError {
    /// The error constructor for `path`, for `map_err`.
    pub fn at(path: &Path) -> impl Fn(std::io::Error) -> Self + Copy + '_ {
        move |source| Self {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Writes `bytes` to `path` atomically (creating its directory), so a crash leaves either
/// the old file or the new one ([`foosball_nets::atomic_file`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), RunFileError> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(RunFileError::at(path))?;
    }
    foosball_nets::atomic_file::write_atomic(path, bytes).map_err(RunFileError::at(path))
}

/// Removes the file at `path`, if there is one.
pub fn remove_file(path: &Path) -> Result<(), RunFileError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(RunFileError::at(path)(e)),
        _ => Ok(()),
    }
}

/// Appends lines to a CSV file, writing the header first when the file is new or empty;
/// no lines, no I/O.
pub fn append_csv(path: &Path, header: &str, lines: &[String]) -> Result<(), RunFileError> {
    if lines.is_empty() {
        return Ok(());
    }
    let err = RunFileError::at(path);
    let new = std::fs::metadata(path).map_or(true, |m| m.len() == 0);
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(err)?;
    let mut text = String::new();
    if new {
        text.push_str(header);
        text.push('\n');
    }
    for line in lines {
        text.push_str(line);
        text.push('\n');
    }
    file.write_all(text.as_bytes()).map_err(err)
}
