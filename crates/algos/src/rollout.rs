//! Driving an [`Agent`] through environments: the training collector and deterministic
//! evaluation episodes.

use crate::agent::{ActMode, Agent, Experience, Metrics};
use foosball_env::{Env, EnvError, VecEnv, VecEnvError};

/// One finished episode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Episode {
    /// Undiscounted sum of rewards.
    pub ret: f64,
    /// Agent steps.
    pub len: u64,
}

/// Training-side state of a vec-env: the observations to act on next and the running
/// returns of the episodes in progress.
pub struct Collector<E: Env> {
    envs: VecEnv<E>,
    obs: Vec<f32>,
    returns: Vec<f64>,
    lengths: Vec<u64>,
}

impl<E: Env> Collector<E> {
    /// Resets every env from `seed` (see `VecEnv::reset`).
    pub fn new(mut envs: VecEnv<E>, seed: u64) -> Self {
        let obs = envs.reset(seed).to_vec();
        Self::started(envs, obs)
    }

    /// Resets env `i` with `seeds[i]`.
    pub fn with_seeds(mut envs: VecEnv<E>, seeds: &[u64]) -> Self {
        let obs = envs.reset_with_seeds(seeds).to_vec();
        Self::started(envs, obs)
    }

    fn started(envs: VecEnv<E>, obs: Vec<f32>) -> Self {
        let n = envs.num_envs();
        Self {
            envs,
            obs,
            returns: vec![0.0; n],
            lengths: vec![0; n],
        }
    }

    /// One vec-env step: act, step, observe, update. Calls `on_episode` for each episode
    /// that ended (in env order) and returns the training metrics if the agent trained.
    pub fn step(
        &mut self,
        agent: &mut dyn Agent,
        progress_remaining: f64,
        on_episode: impl FnMut(usize, Episode, &E::Info),
    ) -> Result<Option<Metrics>, VecEnvError> {
        self.step_inner(agent, progress_remaining, None, on_episode)
    }

    /// [`Collector::step`] through [`VecEnv::step_then_restart`]: episodes still running
    /// are cut as truncations and env `i` starts anew from `seeds[i]`.
    pub fn step_then_restart(
        &mut self,
        agent: &mut dyn Agent,
        progress_remaining: f64,
        seeds: &[u64],
        on_episode: impl FnMut(usize, Episode, &E::Info),
    ) -> Result<Option<Metrics>, VecEnvError> {
        self.step_inner(agent, progress_remaining, Some(seeds), on_episode)
    }

    fn step_inner(
        &mut self,
        agent: &mut dyn Agent,
        progress_remaining: f64,
        restart: Option<&[u64]>,
        mut on_episode: impl FnMut(usize, Episode, &E::Info),
    ) -> Result<Option<Metrics>, VecEnvError> {
        let actions = agent.act(&self.obs, ActMode::Explore);
        let step = match restart {
            None => self.envs.step(&actions)?,
            Some(seeds) => self.envs.step_then_restart(&actions, seeds)?,
        };
        let n = step.rewards.len();
        let experience = Experience {
            obs: &self.obs,
            actions: &actions,
            rewards: step.rewards,
            next_obs: step.obs,
            final_obs: (0..n).map(|i| step.final_observation(i)).collect(),
            terminated: step.terminated,
            truncated: step.truncated,
        };
        agent.observe(&experience);
        for i in 0..n {
            self.returns[i] += f64::from(step.rewards[i]);
            self.lengths[i] += 1;
            if step.terminated[i] || step.truncated[i] {
                let episode = Episode {
                    ret: self.returns[i],
                    len: self.lengths[i],
                };
                on_episode(i, episode, &step.infos[i]);
                self.returns[i] = 0.0;
                self.lengths[i] = 0;
            }
        }
        self.obs.copy_from_slice(step.obs);
        Ok(agent.update(progress_remaining))
    }
}

/// Plays one deterministic episode of `env` from `seed` and returns it with the last
/// step's info.
pub fn play_episode<E: Env>(
    agent: &mut dyn Agent,
    env: &mut E,
    seed: u64,
) -> Result<(Episode, E::Info), EnvError> {
    let mut obs = vec![0.0; env.obs_dim()];
    env.reset_into(Some(seed), &mut obs);
    let mut episode = Episode { ret: 0.0, len: 0 };
    loop {
        let action = agent.act(&obs, ActMode::Deterministic);
        let t = env.step_into(&action, &mut obs)?;
        episode.ret += f64::from(t.reward);
        episode.len += 1;
        if t.done() {
            return Ok((episode, t.info));
        }
    }
}
