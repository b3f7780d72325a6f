//! Checkpoints: everything a run needs to go on exactly where it stopped, written at
//! each epoch end.
//!
//! `RUN/checkpoint/` holds the agent's networks (Burn records) and `state.bin` (a
//! [`Snapshot`]: optimiser moments, replay or rollout buffer, RNG positions, counters and
//! the loop's own state). It is built in `RUN/checkpoint.tmp/` and renamed into place;
//! the previous checkpoint is moved to `RUN/checkpoint.old/` first and removed last, so a
//! crash at any moment leaves one complete checkpoint. The training envs restart at each
//! checkpoint (see [`crate::run::train`]), so no physics state needs saving.

use crate::files::RunFileError;
use foosball_algos::{Agent, AgentError};
use foosball_nets::{Snapshot, SnapshotError};
use std::path::{Path, PathBuf};

/// The file of the non-network state inside a checkpoint directory.
pub const STATE_FILE: &str = "state.bin";

/// A small file inside a checkpoint directory with its completed epochs, for status
/// displays that should not read the whole state (a replay buffer can be gigabytes).
pub const EPOCHS_FILE: &str = "epochs.txt";

/// Where the training loop stands at a checkpoint.
#[derive(Clone, Debug, PartialEq)]
pub struct LoopState {
    /// Epochs completed.
    pub epoch: u64,
    /// Env step of the next evaluation.
    pub next_eval: u64,
    /// Env step of the next row of training scalars.
    pub next_log: u64,
    /// Best evaluation mean return so far (`-inf` before the first).
    pub best: f64,
    /// Bytes of each append-only log file (in [`crate::run::log::CSV_FILES`] order) at the
    /// checkpoint; a resumed run cuts them back to these lengths.
    pub log_bytes: Vec<u64>,
}

impl LoopState {
    fn save(&self, snap: &mut Snapshot<'_>) {
        snap.put_u64("loop.epoch", self.epoch);
        snap.put_u64("loop.next_eval", self.next_eval);
        snap.put_u64("loop.next_log", self.next_log);
        snap.put_f64("loop.best", self.best);
        snap.put_u64s("loop.log_bytes", self.log_bytes.clone());
    }

    fn load(snap: &Snapshot<'_>) -> Result<Self, SnapshotError> {
        Ok(Self {
            epoch: snap.u64("loop.epoch")?,
            next_eval: snap.u64("loop.next_eval")?,
            next_log: snap.u64("loop.next_log")?,
            best: snap.f64("loop.best")?,
            log_bytes: snap.u64s("loop.log_bytes")?.to_vec(),
        })
    }
}

/// A checkpoint that could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// A directory could not be made, renamed or removed.
    #[error(transparent)]
    File(#[from] RunFileError),
    /// The networks could not be written or read.
    #[error(transparent)]
    Agent(#[from] AgentError),
    /// The state file could not be written or read, or lacks an entry.
    #[error("{path}: {source}")]
    State {
        /// The checkpoint directory.
        path: PathBuf,
        /// What went wrong.
        source: SnapshotError,
    },
}

/// Writes `agent`, `state` and what `hooks` add (the run's hooks' states) as `run_dir`'s
/// checkpoint, replacing the previous one.
pub fn write(
    run_dir: &Path,
    agent: &dyn Agent,
    state: &LoopState,
    hooks: impl FnOnce(&mut Snapshot<'_>),
) -> Result<(), CheckpointError> {
    let tmp = run_dir.join("checkpoint.tmp");
    let dst = run_dir.join("checkpoint");
    let old = run_dir.join("checkpoint.old");
    remove_dir(&tmp)?;
    std::fs::create_dir_all(&tmp).map_err(RunFileError::at(&tmp))?;
    agent.save(&tmp)?;
    let mut snap = Snapshot::new();
    agent.save_state(&mut snap);
    state.save(&mut snap);
    hooks(&mut snap);
    snap.write(&tmp.join(STATE_FILE))
        .map_err(|source| CheckpointError::State {
            path: tmp.clone(),
            source,
        })?;
    let epochs = tmp.join(EPOCHS_FILE);
    std::fs::write(&epochs, format!("{}\n", state.epoch)).map_err(RunFileError::at(&epochs))?;
    if dst.exists() {
        remove_dir(&old)?;
        std::fs::rename(&dst, &old).map_err(RunFileError::at(&dst))?;
    }
    std::fs::rename(&tmp, &dst).map_err(RunFileError::at(&tmp))?;
    remove_dir(&old)?;
    Ok(())
}

/// The complete checkpoint of `run_dir`, if any (`checkpoint/`, or `checkpoint.old/`
/// when a crash came between the two renames of [`write`]).
pub fn find(run_dir: &Path) -> Option<PathBuf> {
    ["checkpoint", "checkpoint.old"]
        .iter()
        .map(|name| run_dir.join(name))
        .find(|dir| dir.join(STATE_FILE).is_file())
}

/// The completed epochs of the checkpoint in `dir` (from [`EPOCHS_FILE`]; `None` for a
/// checkpoint written before that file existed).
pub fn epochs(dir: &Path) -> Option<u64> {
    std::fs::read_to_string(dir.join(EPOCHS_FILE))
        .ok()?
        .trim()
        .parse()
        .ok()
}

/// Restores `agent` from the checkpoint in `dir` and returns the loop's state with the
/// whole state file, from which the run's hooks read theirs.
pub fn load(
    dir: &Path,
    agent: &mut dyn Agent,
) -> Result<(LoopState, Snapshot<'static>), CheckpointError> {
    let state_error = |source| CheckpointError::State {
        path: dir.to_path_buf(),
        source,
    };
    agent.load(dir)?;
    let snap = Snapshot::read(&dir.join(STATE_FILE)).map_err(state_error)?;
    agent.load_state(&snap).map_err(state_error)?;
    let state = LoopState::load(&snap).map_err(state_error)?;
    Ok((state, snap))
}

/// Removes `dir` and what it holds, if it exists.
pub fn remove_dir(dir: &Path) -> Result<(), RunFileError> {
    match std::fs::remove_dir_all(dir) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(RunFileError::at(dir)(e)),
        _ => Ok(()),
    }
}
