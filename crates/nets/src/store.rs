//! Saving and loading networks as Burn records (burnpack files), written atomically.

use burn::module::Module;
use std::path::{Path, PathBuf};

/// A record that could not be written or read; names the file.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct StoreError {
    /// The file at fault.
    pub path: PathBuf,
    /// What went wrong.
    pub message: String,
}

/// Writes `module`'s parameters to `path` atomically ([`crate::atomic_file`]), so an
/// interrupted write leaves the previous file intact.
pub fn save_module<M: Module>(module: &M, path: &Path) -> Result<(), StoreError> {
    crate::atomic_file::replace_file(path, |tmp| {
        module.clone().save_file(tmp).map_err(std::io::Error::other)
    })
    .map_err(|e| StoreError {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// `module` with its parameters read from `path` (written by [`save_module`] for a
/// module of the same shape).
pub fn load_module<M: Module>(module: M, path: &Path) -> Result<M, StoreError> {
    module.try_load_file(path).map_err(|e| StoreError {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}
