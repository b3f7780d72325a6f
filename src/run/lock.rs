//! One writer per run directory: `RUN/lock`, an advisory lock (`flock`) held for as long
//! as a process trains the run, so that two processes (two SLURM tasks of a resubmitted
//! sweep, a sweep and a `train --resume`) never write one run at once.
//!
//! The lock file names its holder (process, host, SLURM job) for the error the second
//! process gets. The operating system releases the lock when the holder exits, however
//! it exits, so a killed run never leaves a stale lock. On a cluster the run directories
//! must sit on a file system whose locks work across nodes (NFSv4, Lustre, GPFS).

use crate::files::RunFileError;
use std::fs::{File, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

/// The lock file inside a run directory.
pub const LOCK_FILE: &str = "lock";

/// Why a run directory could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another process holds the lock.
    #[error(
        "{dir}: another process is training this run ({holder}); wait for it to end or stop it"
    )]
    Held {
        /// The run directory.
        dir: PathBuf,
        /// Who holds it, as the lock file says.
        holder: String,
    },
    /// The lock file could not be opened or written.
    #[error(transparent)]
    File(#[from] RunFileError),
}

/// The held lock of a run directory; dropping it releases the lock.
#[derive(Debug)]
pub struct RunLock {
    _file: File,
}

fn open(path: &Path) -> Result<File, RunFileError> {
    std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(path)
        .map_err(RunFileError::at(path))
}

fn holder_of(file: &mut File) -> String {
    let mut text = String::new();
    let _ = file.read_to_string(&mut text);
    match text.trim() {
        "" => "holder unknown".into(),
        t => t.to_string(),
    }
}

/// Who this process is: pid, host and, under SLURM, the job (and array task).
pub fn this_process() -> String {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_else(|_| "unknown host".into());
    let mut who = format!("pid {} on {host}", std::process::id());
    let var = |name| std::env::var(name).ok();
    match (var("SLURM_ARRAY_JOB_ID"), var("SLURM_ARRAY_TASK_ID")) {
        (Some(job), Some(task)) => who.push_str(&format!(", SLURM job {job}_{task}")),
        _ => {
            if let Some(job) = var("SLURM_JOB_ID") {
                who.push_str(&format!(", SLURM job {job}"));
            }
        }
    }
    who
}

impl RunLock {
    /// Takes the lock of `run_dir` (which must exist) without waiting.
    pub fn acquire(run_dir: &Path) -> Result<Self, LockError> {
        let path = run_dir.join(LOCK_FILE);
        let mut file = open(&path)?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                return Err(LockError::Held {
                    dir: run_dir.to_path_buf(),
                    holder: holder_of(&mut file),
                });
            }
            Err(TryLockError::Error(e)) => return Err(RunFileError::at(&path)(e).into()),
        }
        let err = RunFileError::at(&path);
        file.set_len(0).map_err(err)?;
        file.rewind().map_err(err)?;
        writeln!(file, "{}", this_process()).map_err(err)?;
        Ok(Self { _file: file })
    }

    /// Who holds the lock of `run_dir` now, or `None` when nobody does (or there is no
    /// run there).
    pub fn holder(run_dir: &Path) -> Option<String> {
        let path = run_dir.join(LOCK_FILE);
        let mut file = std::fs::File::open(&path).ok()?;
        match file.try_lock_shared() {
            Ok(()) => None,
            Err(TryLockError::WouldBlock) => Some(holder_of(&mut file)),
            Err(TryLockError::Error(_)) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_writer_is_refused_with_the_holder_named_until_the_first_lets_go() {
        let dir = std::env::temp_dir().join(format!("foosball-lock-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        assert_eq!(RunLock::holder(&dir), None);
        let first = RunLock::acquire(&dir).unwrap();
        let holder = RunLock::holder(&dir).unwrap();
        assert!(
            holder.starts_with(&format!("pid {}", std::process::id())),
            "{holder}"
        );
        let e = RunLock::acquire(&dir).unwrap_err().to_string();
        assert!(
            e.contains(&dir.display().to_string())
                && e.contains("another process")
                && e.contains(&holder),
            "{e}"
        );
        drop(first);
        assert_eq!(RunLock::holder(&dir), None);
        drop(RunLock::acquire(&dir).unwrap());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
