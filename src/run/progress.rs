//! What the training loop tells a progress display: [`Progress`] events (a window of
//! training scalars, a tick of wall time, an evaluation, a checkpoint, the test).

use super::log::Speed;

/// Wall time between [`Event::Tick`]s.
pub const TICK: std::time::Duration = std::time::Duration::from_secs(2);

/// What the loop has just done, for progress displays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// The loop starts (after a resume, at the checkpoint's env steps).
    Started,
    /// A logging window ended ([`super::protocol::LOG_EVERY`] env steps or an epoch end).
    Window(Speed),
    /// At most every [`TICK`] of wall time: the speed since this process started training,
    /// for progress displays only (nothing is logged), so that an estimate shows before the
    /// first window ends even where one update takes seconds.
    Tick(Speed),
    /// An evaluation ended; its mean return and score rate.
    Evaluation {
        /// Mean return of the evaluation episodes.
        mean_return: f64,
        /// Share of evaluation episodes that scored.
        score_rate: f64,
    },
    /// Epoch `n` ended and was checkpointed.
    Checkpoint(u64),
    /// The final test started.
    Test,
}

/// Where the run stands when the loop reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Env steps done.
    pub env_steps: u64,
    /// Env steps of the whole run.
    pub total_steps: u64,
    /// What just happened.
    pub event: Event,
}
