//! The evaluation API: foosball episodes of a policy (a trained agent's deterministic or
//! sampled action, or a scripted controller) on held-out seeds, [`EVAL_BATCH`] played side
//! by side by `foosball_algos::play_episodes`, what each leaves ([`PlayedEpisode`]) and
//! the test files they make.

use super::metrics::{EpisodeSummary, TestMetrics};
use super::trajectories::{Trajectory, trajectories_bytes};
use crate::config::TestActions;
use crate::files::{RunFileError, write_atomic};
use foosball_algos::{Agent, EpisodeLog, play_episodes, sampled};
pub use foosball_algos::{BatchPolicy, deterministic};

/// A policy over batches of agent-view observations that owns what it needs (its
/// networks, controller, ONNX file or program) and can move to another thread: one side
/// of a match. An error (an outside policy's: a process that died, a non-finite action)
/// ends what it plays.
pub type OwnedPolicy = Box<dyn FnMut(&[f32]) -> Result<Vec<f32>, String> + Send>;
use foosball_env::seeding::{ACTION_SAMPLING, derive_seed};
use foosball_env::{EnvError, FoosballConfig, FoosballEnv, FoosballInfo, Transition, layout};
use std::path::Path;

/// Why episodes could not be played or their files written.
#[derive(Debug, thiserror::Error)]
pub enum PlayError {
    /// A table refused its settings or an action, or cannot serve the policy.
    #[error("environment: {0}")]
    Env(String),
    /// The policy failed (an outside policy: its file or program).
    #[error("policy: {0}")]
    Policy(String),
    /// A test file could not be written.
    #[error(transparent)]
    File(#[from] RunFileError),
}

impl From<EnvError> for PlayError {
    fn from(e: EnvError) -> Self {
        PlayError::Env(e.to_string())
    }
}

pub use foosball_env::test_metrics::EVAL_BATCH;

/// One episode played to its end.
#[derive(Clone, Debug, PartialEq)]
pub struct PlayedEpisode {
    /// The seed it was reset with.
    pub seed: u64,
    /// What the test metrics need of it.
    pub summary: EpisodeSummary,
    /// Its steps, when recorded.
    pub trajectory: Option<Trajectory>,
}

impl PlayedEpisode {
    /// An episode about to start from `seed`; `record` keeps its steps.
    pub fn new(seed: u64, record: bool) -> Self {
        Self {
            seed,
            summary: EpisodeSummary::default(),
            trajectory: record.then(Trajectory::default),
        }
    }
}

impl EpisodeLog<FoosballEnv> for PlayedEpisode {
    /// The trajectory keeps the table's 38-dim state (whatever the agent observes), so
    /// that episodes of image agents stay small and can be drawn.
    fn before_step(&mut self, env: &FoosballEnv) {
        if let (Some(tr), Some(state)) = (self.trajectory.as_mut(), env.state()) {
            tr.obs.extend_from_slice(state);
        }
    }

    fn record(&mut self, action: &[f32], t: &Transition<FoosballInfo>) {
        self.summary.add(t.reward, &t.info);
        if let Some(tr) = self.trajectory.as_mut() {
            tr.actions.extend_from_slice(action);
            tr.rewards.push(t.reward);
        }
    }
}

/// `n` tables of `env`.
pub fn foosball_envs(env: &FoosballConfig, n: usize) -> Result<Vec<FoosballEnv>, PlayError> {
    (0..n)
        .map(|_| FoosballEnv::new(env.clone()).map_err(|e| PlayError::Env(format!("env.{e}"))))
        .collect()
}

/// Which episodes to play: `n` on a table, reset from the seeds `0..n` of one stream
/// derived from a run seed.
#[derive(Clone, Copy, Debug)]
pub struct Episodes<'a> {
    /// The table.
    pub env: &'a FoosballConfig,
    /// The run seed the episode seeds derive from.
    pub seed: u64,
    /// The seed stream ([`foosball_env::seeding::EVAL_ENVS`] or `TEST_ENVS`).
    pub stream: u64,
    /// How many.
    pub n: u32,
    /// Whether to keep their steps.
    pub record: bool,
}

/// The `episodes` played by `policy`, [`EVAL_BATCH`] side by side, in seed order.
pub fn play(
    policy: &mut BatchPolicy<'_>,
    episodes: &Episodes<'_>,
) -> Result<Vec<PlayedEpisode>, PlayError> {
    let seeds: Vec<u64> = (0..u64::from(episodes.n))
        .map(|k| derive_seed(episodes.seed, episodes.stream, k))
        .collect();
    let mut envs = foosball_envs(episodes.env, EVAL_BATCH.min(seeds.len()))?;
    Ok(play_episodes(policy, &mut envs, &seeds, |seed| {
        PlayedEpisode::new(seed, episodes.record)
    })?)
}

/// The `episodes` played by an [`OwnedPolicy`] of the table's state observation; its
/// first error ends the play and is returned.
pub fn play_owned(
    policy: &mut OwnedPolicy,
    episodes: &Episodes<'_>,
) -> Result<Vec<PlayedEpisode>, PlayError> {
    let mut fault = None;
    let played = play(
        &mut |obs: &[f32]| match policy(obs) {
            Ok(actions) => actions,
            Err(e) => {
                fault.get_or_insert(e);
                // The table refuses a non-finite action: the play ends at this step.
                vec![f32::NAN; obs.len() / layout::OBS_DIM * layout::ACTION_DIM]
            }
        },
        episodes,
    );
    match fault {
        Some(e) => Err(PlayError::Policy(e)),
        None => played,
    }
}

/// The `episodes` played by a trained `agent` acting as `actions` says; sampled actions
/// draw their noise from `derive_seed(seed, ACTION_SAMPLING, stream)`, so the same call
/// gives the same episodes.
pub fn play_agent(
    agent: &mut dyn Agent,
    actions: TestActions,
    episodes: &Episodes<'_>,
) -> Result<Vec<PlayedEpisode>, PlayError> {
    match actions {
        TestActions::Deterministic => play(&mut deterministic(agent), episodes),
        TestActions::Stochastic => {
            let noise = derive_seed(episodes.seed, ACTION_SAMPLING, episodes.stream);
            play(&mut sampled(agent, noise), episodes)
        }
    }
}

/// Writes `metrics.json`, `metrics.md` and `trajectories.bin` into `dir`.
pub fn write_test(dir: &Path, episodes: &[PlayedEpisode]) -> Result<TestMetrics, PlayError> {
    let summaries: Vec<EpisodeSummary> = episodes.iter().map(|e| e.summary).collect();
    let metrics = TestMetrics::from_episodes(&summaries);
    let json = serde_json::to_string_pretty(&metrics).expect("metrics serialise");
    write_atomic(&dir.join("metrics.json"), json.as_bytes())?;
    write_atomic(&dir.join("metrics.md"), metrics.to_markdown().as_bytes())?;
    let recorded: Vec<(u64, &Trajectory)> = episodes
        .iter()
        .filter_map(|e| Some((e.seed, e.trajectory.as_ref()?)))
        .collect();
    let bytes = trajectories_bytes(&recorded, layout::OBS_DIM, layout::ACTION_DIM);
    write_atomic(&dir.join("trajectories.bin"), &bytes)?;
    Ok(metrics)
}
