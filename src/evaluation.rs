//! The evaluation API: episodes of a policy (a trained agent's deterministic action or a
//! scripted controller) on held-out seeds, several played side by side so the policy runs
//! once per step for all of them, and the test files they make.

use crate::metrics::{EpisodeSummary, TestMetrics};
use crate::run_dir::{trajectories_bytes, write_atomic};
use crate::train::TrainError;
use foosball_algos::{ActMode, Agent};
use foosball_env::seeding::derive_seed;
use foosball_env::{Env, EnvError, FoosballConfig, FoosballEnv, layout};
use rayon::prelude::*;
use std::path::Path;

/// Deterministic episodes played side by side in evaluations and tests (part of the
/// protocol: it fixes the policy's batch shape).
pub const EVAL_BATCH: usize = 10;

/// One episode's steps: observations acted on `[T, obs_dim]`, actions `[T, action_dim]`,
/// rewards `[T]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory {
    /// Observations, row-major.
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

/// An episode in progress in one slot.
struct Slot {
    index: usize,
    obs: Vec<f32>,
    summary: EpisodeSummary,
    trajectory: Option<Trajectory>,
}

/// A policy acting on a batch: observations `[n, obs_dim]` in, actions `[n, action_dim]`
/// out (a trained agent's deterministic action, or a scripted controller).
pub type BatchPolicy<'a> = dyn FnMut(&[f32]) -> Vec<f32> + 'a;

/// An agent's deterministic action as a [`BatchPolicy`].
pub fn deterministic(agent: &mut dyn Agent) -> impl FnMut(&[f32]) -> Vec<f32> + '_ {
    move |obs| agent.act(obs, ActMode::Deterministic)
}

/// Plays one episode per seed with `policy`, `envs.len()` side by side, and returns them
/// in seed order. The number of envs is part of the protocol: a batch of another size
/// may round the networks' outputs differently in the last bit.
pub fn play_deterministic(
    policy: &mut BatchPolicy<'_>,
    envs: &mut [FoosballEnv],
    seeds: &[u64],
    record: bool,
) -> Result<Vec<PlayedEpisode>, EnvError> {
    let (obs_dim, action_dim) = (layout::OBS_DIM, layout::ACTION_DIM);
    let start = |env: &mut FoosballEnv, index: usize| {
        let mut obs = vec![0.0; obs_dim];
        env.reset_into(Some(seeds[index]), &mut obs);
        Slot {
            index,
            obs,
            summary: EpisodeSummary::default(),
            trajectory: record.then(Trajectory::default),
        }
    };
    let mut next = 0;
    let mut slots: Vec<Option<Slot>> = envs
        .iter_mut()
        .map(|env| {
            (next < seeds.len()).then(|| {
                next += 1;
                start(env, next - 1)
            })
        })
        .collect();
    let mut done: Vec<Option<PlayedEpisode>> = vec![None; seeds.len()];
    while slots.iter().any(Option::is_some) {
        let batch: Vec<f32> = slots
            .iter()
            .flatten()
            .flat_map(|s| s.obs.iter().copied())
            .collect();
        let actions = policy(&batch);
        let mut rows = actions.chunks(action_dim);
        let work: Vec<(&mut FoosballEnv, &mut Slot, &[f32])> = envs
            .iter_mut()
            .zip(slots.iter_mut())
            .filter_map(|(env, slot)| slot.as_mut().map(|s| (env, s)))
            .map(|(env, s)| (env, s, rows.next().expect("one action row per live slot")))
            .collect();
        let ended: Vec<Result<bool, EnvError>> = work
            .into_par_iter()
            .map(|(env, slot, action)| {
                if let Some(tr) = slot.trajectory.as_mut() {
                    tr.obs.extend_from_slice(&slot.obs);
                    tr.actions.extend_from_slice(action);
                }
                let t = env.step_into(action, &mut slot.obs)?;
                let s = &mut slot.summary;
                s.steps += 1;
                s.ret += f64::from(t.reward);
                s.distance_sum += f64::from(t.info.goal_distance);
                s.speed_sum += f64::from(t.info.ball_speed);
                s.final_distance = f64::from(t.info.goal_distance);
                s.scored |= t.info.scored();
                s.end = t.info.end;
                if let Some(tr) = slot.trajectory.as_mut() {
                    tr.rewards.push(t.reward);
                }
                Ok(t.done())
            })
            .collect();
        let mut ended = ended.into_iter();
        for (env, slot) in envs.iter_mut().zip(slots.iter_mut()) {
            if slot.is_none() || !ended.next().expect("one result per live slot")? {
                continue;
            }
            let s = slot.take().expect("live slot");
            done[s.index] = Some(PlayedEpisode {
                seed: seeds[s.index],
                summary: s.summary,
                trajectory: s.trajectory,
            });
            if next < seeds.len() {
                *slot = Some(start(env, next));
                next += 1;
            }
        }
    }
    Ok(done
        .into_iter()
        .map(|e| e.expect("every seed played"))
        .collect())
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
    Ok(play_deterministic(policy, &mut envs, &seeds, record)?)
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
