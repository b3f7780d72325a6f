//! The evaluation API: foosball episodes of a policy (a trained agent's deterministic or
//! sampled action, or a scripted controller) on held-out seeds, [`EVAL_BATCH`] played side
//! by side by `foosball_algos::play_episodes`, what each leaves ([`PlayedEpisode`]) and
//! the test files they make.

use crate::metrics::{EpisodeSummary, TestMetrics};
use crate::run_dir::{trajectories_bytes, write_atomic};
use crate::train::TrainError;
use foosball_algos::{Agent, EpisodeLog, play_episodes, sampled};
pub use foosball_algos::{BatchPolicy, deterministic};
use foosball_env::seeding::{ACTION_SAMPLING, derive_seed};
use foosball_env::{FoosballConfig, FoosballEnv, FoosballInfo, Transition, layout};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Deterministic episodes played side by side in evaluations and tests (part of the
/// protocol: it fixes the policy's batch shape).
pub const EVAL_BATCH: usize = 10;

/// How a trained agent acts in a test: the paper's text tests deterministically, its code
/// (`model.predict(obs)`, SB3's default `deterministic=False`) samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum TestActions {
    /// The policy's deterministic action (the text's test).
    #[default]
    Deterministic,
    /// A draw from the policy's action distribution (the code's test); TD3's policy has
    /// no distribution, so its draw is its deterministic action, as in SB3.
    Stochastic,
}

impl TestActions {
    /// Lower-case name, as in TOML.
    pub fn name(self) -> &'static str {
        match self {
            TestActions::Deterministic => "deterministic",
            TestActions::Stochastic => "stochastic",
        }
    }
}

/// One episode's steps: the table's states acted on `[T, 38]` (noise-free, whatever the
/// agent observes), actions `[T, action_dim]`, rewards `[T]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory {
    /// States, row-major (foosball's 38-dim layout).
    pub obs: Vec<f32>,
    /// Actions, row-major, in `[-1, 1]`.
    pub actions: Vec<f32>,
    /// Rewards.
    pub rewards: Vec<f32>,
}

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
        let s = &mut self.summary;
        s.steps += 1;
        s.ret += f64::from(t.reward);
        s.distance_sum += f64::from(t.info.goal_distance);
        s.speed_sum += f64::from(t.info.ball_speed);
        s.final_distance = f64::from(t.info.goal_distance);
        s.scored |= t.info.scored();
        s.end = t.info.end;
        if let Some(tr) = self.trajectory.as_mut() {
            tr.actions.extend_from_slice(action);
            tr.rewards.push(t.reward);
        }
    }
}

/// `n` tables of `env`.
pub fn foosball_envs(env: &FoosballConfig, n: usize) -> Result<Vec<FoosballEnv>, TrainError> {
    (0..n)
        .map(|_| FoosballEnv::new(env.clone()).map_err(|e| TrainError::Env(format!("env.{e}"))))
        .collect()
}

/// Episodes played by `policy` on the `stream`'s seeds `0..n` (derived from the run
/// seed `seed`), [`EVAL_BATCH`] side by side.
pub fn play(
    policy: &mut BatchPolicy<'_>,
    env: &FoosballConfig,
    seed: u64,
    stream: u64,
    n: u32,
    record: bool,
) -> Result<Vec<PlayedEpisode>, TrainError> {
    let seeds: Vec<u64> = (0..u64::from(n))
        .map(|k| derive_seed(seed, stream, k))
        .collect();
    let mut envs = foosball_envs(env, EVAL_BATCH.min(seeds.len()))?;
    Ok(play_episodes(policy, &mut envs, &seeds, |seed| {
        PlayedEpisode::new(seed, record)
    })?)
}

/// Episodes played by a trained `agent` acting as `actions` says on the `stream`'s seeds
/// `0..n` (derived from the run seed `seed`); sampled actions draw their noise from
/// `derive_seed(seed, ACTION_SAMPLING, stream)`, so the same call gives the same episodes.
pub fn play_agent(
    agent: &mut dyn Agent,
    actions: TestActions,
    env: &FoosballConfig,
    seed: u64,
    stream: u64,
    n: u32,
    record: bool,
) -> Result<Vec<PlayedEpisode>, TrainError> {
    match actions {
        TestActions::Deterministic => play(&mut deterministic(agent), env, seed, stream, n, record),
        TestActions::Stochastic => {
            let noise = derive_seed(seed, ACTION_SAMPLING, stream);
            play(&mut sampled(agent, noise), env, seed, stream, n, record)
        }
    }
}

/// Writes `metrics.json`, `metrics.md` and `trajectories.bin` into `dir`.
pub fn write_test(dir: &Path, episodes: &[PlayedEpisode]) -> Result<TestMetrics, TrainError> {
    let summaries: Vec<EpisodeSummary> = episodes.iter().map(|e| e.summary).collect();
    let metrics = TestMetrics::from_episodes(&summaries);
    let json = serde_json::to_string_pretty(&metrics).expect("metrics serialise");
    write_atomic(&dir.join("metrics.json"), json.as_bytes())?;
    write_atomic(&dir.join("metrics.md"), metrics.to_markdown().as_bytes())?;
    let bytes = trajectories_bytes(episodes, layout::OBS_DIM, layout::ACTION_DIM);
    write_atomic(&dir.join("trajectories.bin"), &bytes)?;
    Ok(metrics)
}
