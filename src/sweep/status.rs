//! `sweep --status`: where each run and baseline of a sweep stands, read from its run
//! directory (test metrics, the lock of a process training it, the checkpoint, why it
//! last stopped) and, for a sweep submitted to SLURM, from the scheduler.

use super::slurm::queued;
use super::{STOPPED_FILE, SweepError, SweepSpec, Task};
use crate::play::metrics::TestMetrics;
use crate::run::checkpoint;
use crate::run::lock::RunLock;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// Where one task of a sweep stands.
#[derive(Clone, Debug, PartialEq)]
pub enum State {
    /// Finished; its test score rate (share of test episodes that scored).
    Done(f64),
    /// A process holds the run's lock: who, and the env steps logged so far.
    Running {
        /// The lock holder.
        holder: String,
        /// Env steps of the last logged training episode.
        env_steps: u64,
    },
    /// Stopped before the end: completed epochs checkpointed, and why it stopped when
    /// the stopping process said so.
    Stopped {
        /// Epochs of the checkpoint it resumes from.
        epochs: Option<u64>,
        /// The stopping process's message.
        reason: Option<String>,
    },
    /// Nothing done yet.
    NotStarted,
}

/// One line of the status.
#[derive(Clone, Debug, PartialEq)]
pub struct TaskStatus {
    /// Task index (the SLURM array index).
    pub index: usize,
    /// Run or baseline directory name.
    pub name: String,
    /// Epochs of the whole run (0 for a baseline).
    pub epochs: u64,
    /// Env steps per epoch (0 for a baseline).
    pub steps_per_epoch: u64,
    /// From the directory.
    pub state: State,
    /// From the scheduler: `JOB_TASK STATE (reason)`, when it still knows the task.
    pub scheduler: Option<String>,
}

impl TaskStatus {
    /// The line `sweep --status` prints.
    pub fn line(&self) -> String {
        let state = match &self.state {
            State::Done(score) => format!("done: test score rate {:.1} %", 100.0 * score),
            State::Running { holder, env_steps } => {
                let epoch = (env_steps / self.steps_per_epoch.max(1) + 1).min(self.epochs);
                format!(
                    "running: epoch {epoch} of {} ({env_steps} env steps; {holder})",
                    self.epochs
                )
            }
            State::Stopped { epochs, reason } => {
                let at = match epochs {
                    Some(0) | None => "no epoch checkpointed".to_string(),
                    Some(k) => format!("resumes after epoch {k} of {}", self.epochs),
                };
                match reason {
                    Some(r) => format!("stopped ({at}): {r}"),
                    None => format!("stopped ({at})"),
                }
            }
            State::NotStarted => "not started".into(),
        };
        match &self.scheduler {
            Some(s) => format!("{:>3} {:<22} {state} | SLURM {s}", self.index, self.name),
            None => format!("{:>3} {:<22} {state}", self.index, self.name),
        }
    }
}

/// The training env steps logged in `run_dir/episodes.csv` (its last row's first field).
fn logged_env_steps(run_dir: &Path) -> u64 {
    let Ok(mut file) = std::fs::File::open(run_dir.join("episodes.csv")) else {
        return 0;
    };
    let len = file.seek(SeekFrom::End(0)).unwrap_or(0);
    let _ = file.seek(SeekFrom::Start(len.saturating_sub(4096)));
    let mut tail = String::new();
    let _ = file.read_to_string(&mut tail);
    tail.lines()
        .rev()
        .find_map(|l| l.split(',').next()?.parse().ok())
        .unwrap_or(0)
}

/// The state of `task`'s directory.
fn state(spec: &SweepSpec, out: &Path, task: &Task) -> State {
    let dir = task.dir(spec, out);
    match task {
        Task::Baseline(_) => match TestMetrics::read(&dir.join("metrics.json")) {
            Ok(m) if task.finished(spec, out) => State::Done(m.score_rate.mean),
            _ => State::NotStarted,
        },
        Task::Run(run) => {
            if run.start.is_none()
                && let Ok(m) = TestMetrics::read(&dir.join("test/metrics.json"))
            {
                return State::Done(m.score_rate.mean);
            }
            if let Some(holder) = RunLock::holder(&dir) {
                return State::Running {
                    holder,
                    env_steps: logged_env_steps(&dir),
                };
            }
            let reason = std::fs::read_to_string(dir.join(STOPPED_FILE))
                .ok()
                .map(|r| r.trim().to_string());
            let epochs = checkpoint::find(&dir).and_then(|c| checkpoint::epochs(&c));
            if reason.is_none() && epochs.is_none() && !dir.join("config.toml").is_file() {
                State::NotStarted
            } else {
                State::Stopped { epochs, reason }
            }
        }
    }
}

/// Every task of the sweep in `out` with its state and, for a submitted sweep, what SLURM
/// says of the tasks of its recorded submissions.
pub fn status(out: &Path) -> Result<Vec<TaskStatus>, SweepError> {
    let spec = SweepSpec::load(out)?;
    let tasks = spec.tasks(out)?;
    let queue = queued(out).map_err(SweepError::Slurm)?;
    Ok(tasks
        .iter()
        .enumerate()
        .map(|(index, task)| {
            let (epochs, steps_per_epoch) = match task {
                Task::Run(r) => (
                    u64::from(r.config.protocol.epochs),
                    r.config.protocol.steps_per_epoch,
                ),
                Task::Baseline(_) => (0, 0),
            };
            TaskStatus {
                index,
                name: task.name(&spec),
                epochs,
                steps_per_epoch,
                state: state(&spec, out, task),
                scheduler: queue
                    .get(&index)
                    .map(|(id, state, reason)| match reason.as_str() {
                        "None" | "" => format!("{id} {state}"),
                        r => format!("{id} {state} ({r})"),
                    }),
            }
        })
        .collect())
}
