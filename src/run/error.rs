//! Why a run stopped: [`TrainError`], every failure of the training loop named by what
//! failed (the environment, a file, the networks, a checkpoint, a hook's capability).

use super::checkpoint::CheckpointError;
use super::lock::LockError;
use crate::files::RunFileError;
use crate::play::evaluation::PlayError;
use crate::self_play::SelfPlayError;
use foosball_algos::AgentError;
use foosball_env::{EnvError, VecEnvError};
use foosball_nets::BackendError;
use std::path::PathBuf;

/// Why a run stopped.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// The backend is unknown or not compiled in.
    #[error(transparent)]
    Backend(#[from] BackendError),
    /// An environment refused its settings or an action.
    #[error("environment: {0}")]
    Env(String),
    /// The network backend's device failed to run queued work.
    #[error("device of protocol.backend: {0}")]
    Device(String),
    /// A run file could not be written.
    #[error(transparent)]
    File(#[from] RunFileError),
    /// Networks could not be saved.
    #[error(transparent)]
    Agent(#[from] AgentError),
    /// The rayon pool could not be built.
    #[error("thread pool: {0}")]
    Threads(String),
    /// A checkpoint could not be written or read.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// Evaluation or test episodes could not be played or written.
    #[error(transparent)]
    Play(#[from] PlayError),
    /// `--resume` on a directory without a checkpoint.
    #[error("{0}: no checkpoint to resume from (none is written before the first epoch ends)")]
    NoCheckpoint(PathBuf),
    /// `protocol.init_from` names networks that cannot start this run, or
    /// `protocol.demonstrations` episodes it cannot learn from.
    #[error("{0}")]
    Init(String),
    /// Self-play's pool could not be saved, loaded or written.
    #[error(transparent)]
    SelfPlay(#[from] SelfPlayError),
    /// Another process trains the run, or its lock file could not be written.
    #[error(transparent)]
    Locked(#[from] LockError),
    /// A stop signal came ([`interrupt`]); the run resumes from its last checkpoint.
    #[error(
        "{dir}: stopped by a signal at env step {env_steps}; resumes from {from} (`train --resume` or the same sweep again)"
    )]
    Interrupted {
        /// The run directory.
        dir: PathBuf,
        /// Env steps done when it stopped.
        env_steps: u64,
        /// Where a resume starts.
        from: String,
    },
}

impl From<VecEnvError> for TrainError {
    fn from(e: VecEnvError) -> Self {
        TrainError::Env(e.to_string())
    }
}

impl From<EnvError> for TrainError {
    fn from(e: EnvError) -> Self {
        TrainError::Env(e.to_string())
    }
}
