//! Deterministic evaluation and test episodes on held-out seeds, several played side by
//! side so the policy runs once per step for all of them.

use crate::metrics::EpisodeSummary;
use foosball_algos::{ActMode, Agent};
use foosball_env::{Env, EnvError, FoosballEnv};
use rayon::prelude::*;

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

/// Plays one deterministic episode per seed, `envs.len()` side by side, and returns them
/// in seed order. The number of envs is part of the protocol: a batch of another size
/// may round the networks' outputs differently in the last bit.
pub fn play_deterministic(
    agent: &mut dyn Agent,
    envs: &mut [FoosballEnv],
    seeds: &[u64],
    record: bool,
) -> Result<Vec<PlayedEpisode>, EnvError> {
    let (obs_dim, action_dim) = (agent.obs_dim(), agent.action_dim());
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
        let actions = agent.act(&batch, ActMode::Deterministic);
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
