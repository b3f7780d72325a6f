//! The one shape every algorithm has, so one training loop drives PPO, SAC and TD3.

use crate::demonstrations::Demonstration;
use crate::policy_chain::Step;
use foosball_nets::{Scalar, Snapshot, SnapshotError};
use std::path::Path;

/// How to pick actions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ActMode {
    /// Sample for exploration (training rollouts).
    Explore,
    /// The policy's deterministic action (evaluation and test).
    Deterministic,
    /// A draw from the policy's action distribution, as SB3's `predict(deterministic=False)`
    /// gives it (the paper code's test): no bookkeeping, no warm-up actions, noise from the
    /// sampling stream that [`Agent::seed_sampling`] sets. PPO draws from its Gaussian and
    /// clips, SAC from its squashed Gaussian; TD3's policy is deterministic (SB3 adds its
    /// exploration noise outside `predict`), so its draw is its deterministic action.
    Sample,
}

/// One vec-env step as the learner sees it; every slice is in env order.
#[derive(Clone, Debug)]
pub struct Experience<'a> {
    /// Observations acted on, `[n_envs, obs_dim]`.
    pub obs: &'a [f32],
    /// Actions sent to the envs (what `act` returned), `[n_envs, action_dim]`.
    pub actions: &'a [f32],
    /// Rewards, `[n_envs]`.
    pub rewards: &'a [f32],
    /// Observations to act on next, after auto-reset, `[n_envs, obs_dim]`.
    pub next_obs: &'a [f32],
    /// The last observation of env `i`'s episode where it ended on this step.
    pub final_obs: Vec<Option<&'a [f32]>>,
    /// Episode reached a terminal state, `[n_envs]`.
    pub terminated: &'a [bool],
    /// Episode was cut by a time limit or fault, `[n_envs]`.
    pub truncated: &'a [bool],
    /// The state reached is absorbing (the env's `StepInfo::absorbing`), `[n_envs]`;
    /// read only where `terminated`.
    pub absorbing: Vec<bool>,
    /// A teacher's action on each observation acted on, `[n_envs, action_dim]` in the
    /// env's action space, where the run has a teacher ([`crate::kickstart`]).
    pub teacher: Option<&'a [f32]>,
}

impl Experience<'_> {
    /// Number of envs in the step.
    pub fn len(&self) -> usize {
        self.rewards.len()
    }

    /// Whether the step holds no env.
    pub fn is_empty(&self) -> bool {
        self.rewards.is_empty()
    }

    /// The state env `i`'s transition reached: its final observation where its episode
    /// ended, else the next observation.
    pub fn reached(&self, i: usize, obs_dim: usize) -> &[f32] {
        self.final_obs[i].unwrap_or(&self.next_obs[i * obs_dim..(i + 1) * obs_dim])
    }

    /// The step's observations (acted on, next, final) passed through `f`, held to be
    /// handed on by a wrapper ([`MappedObs::with`]).
    pub fn map_obs(&self, f: impl Fn(&[f32]) -> Vec<f32>) -> MappedObs {
        MappedObs {
            obs: f(self.obs),
            next_obs: f(self.next_obs),
            finals: self.final_obs.iter().map(|o| o.map(&f)).collect(),
        }
    }
}

/// A step's observations as a wrapper hands them to its inner agent
/// ([`Experience::map_obs`]).
#[derive(Clone, Debug)]
pub struct MappedObs {
    obs: Vec<f32>,
    next_obs: Vec<f32>,
    finals: Vec<Option<Vec<f32>>>,
}

impl MappedObs {
    /// `step` with these observations and `rewards` (`[n_envs]`).
    pub fn with<'b>(&'b self, step: &Experience<'b>, rewards: &'b [f32]) -> Experience<'b> {
        Experience {
            obs: &self.obs,
            actions: step.actions,
            rewards,
            next_obs: &self.next_obs,
            final_obs: self.finals.iter().map(Option::as_deref).collect(),
            terminated: step.terminated,
            truncated: step.truncated,
            absorbing: step.absorbing.clone(),
            teacher: step.teacher,
        }
    }
}

/// Named scalars from one training round (losses, entropy, temperature, ...), averaged
/// over its gradient steps. On a GPU the values stay on the device: a log window reads
/// all of its rounds' metrics in one transfer ([`Metrics::read`]).
#[derive(Clone, Debug, Default)]
pub struct Metrics(pub Vec<(&'static str, Scalar)>);

impl Metrics {
    /// Averages each name over several rounds' metrics (names in first-seen order).
    pub fn mean(rounds: Vec<Metrics>) -> Metrics {
        let mut values: Vec<(&'static str, Vec<Scalar>)> = Vec::new();
        for (name, value) in rounds.into_iter().flat_map(|m| m.0) {
            match values.iter_mut().find(|(n, _)| *n == name) {
                Some((_, v)) => v.push(value),
                None => values.push((name, vec![value])),
            }
        }
        Metrics(
            values
                .into_iter()
                .filter_map(|(n, v)| Scalar::mean(v).map(|m| (n, m)))
                .collect(),
        )
    }

    /// The values on the host, those on a device read in one transfer.
    pub fn read(self) -> Vec<(&'static str, f64)> {
        let (names, values): (Vec<_>, Vec<_>) = self.0.into_iter().unzip();
        names.into_iter().zip(Scalar::read_all(values)).collect()
    }
}

/// An error saving or loading an agent; names the file.
#[derive(Debug, thiserror::Error)]
pub enum AgentError {
    /// A network file could not be written or read.
    #[error(transparent)]
    Store(#[from] foosball_nets::store::StoreError),
    /// Another file of the agent could not be written or read.
    #[error("{path}: {message}")]
    File {
        /// The file at fault.
        path: std::path::PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// A learning algorithm driven by a training loop:
/// `act` -> env step -> `observe` -> `update`, repeated.
pub trait Agent {
    /// Observation width.
    fn obs_dim(&self) -> usize;
    /// Action width.
    fn action_dim(&self) -> usize;
    /// Actions in `[-1, 1]`, `[n, action_dim]`, for observations `[n, obs_dim]`.
    fn act(&mut self, obs: &[f32], mode: ActMode) -> Vec<f32>;
    /// Restarts the noise stream of [`ActMode::Sample`] from `seed`, so that sampled
    /// episodes are reproducible whatever the agent did before.
    fn seed_sampling(&mut self, seed: u64);
    /// Records the step that followed the last `act(.., Explore)`.
    fn observe(&mut self, step: &Experience<'_>);
    /// Trains if the algorithm's schedule says so; `progress_remaining` goes from 1 (start
    /// of training) to 0 (end) and drives learning-rate schedules.
    fn update(&mut self, progress_remaining: f64) -> Option<Metrics>;
    /// Transitions observed so far.
    fn env_steps(&self) -> u64;
    /// Gradient steps taken so far (critic steps for SAC and TD3, minibatch steps for
    /// PPO).
    fn gradient_steps(&self) -> u64;
    /// Writes the networks (Burn records) into `dir`.
    fn save(&self, dir: &Path) -> Result<(), AgentError>;
    /// Reads the networks written by `save` from `dir`.
    fn load(&mut self, dir: &Path) -> Result<(), AgentError>;
    /// Zeroes every network's input-layer weights from the observation values at `inputs`
    /// (targets and averages included), so the networks start blind to those values; a
    /// vector observation only.
    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String>;
    /// Adds everything but the networks that training needs to go on exactly where it
    /// stands: optimiser moments, replay or rollout buffer, RNG position, counters.
    fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>);
    /// Restores what [`Agent::save_state`] stored (the networks come from `load`).
    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError>;
    /// Holds `episodes` as demonstrations to learn from beside the agent's own
    /// experience (they are not part of [`Agent::save_state`]: a resumed run is given
    /// them again) and returns the transitions kept; an error says why they cannot be
    /// used. By default an agent takes none.
    fn set_demonstrations(&mut self, episodes: &[Demonstration<'_>]) -> Result<usize, String> {
        let _ = episodes;
        Err("this algorithm learns from its own rollouts only and takes no demonstrations".into())
    }
    /// The deterministic policy (`act(.., ActMode::Deterministic)`) as fixed steps from
    /// the observation to the action, as it stands, for an exporter; an error says what
    /// the agent holds that no chain of [`Step`]s computes. By default none.
    fn policy_chain(&self) -> Result<Vec<Step>, String> {
        Err("this agent does not write its policy as a chain of fixed steps".into())
    }
}
