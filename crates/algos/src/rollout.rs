//! Driving an [`Agent`] through environments: the training collector and deterministic
//! evaluation episodes.

use crate::agent::{ActMode, Agent, Experience, Metrics};
use foosball_env::{Env, EnvError, StepInfo, Transition, VecEnv, VecEnvError};
use rayon::prelude::*;

/// One finished episode.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Episode {
    /// Undiscounted sum of rewards.
    pub ret: f64,
    /// Agent steps.
    pub len: u64,
}

/// Training-side state of a vec-env: the observations to act on next, the running
/// returns of the episodes in progress and, where the run has one, the teacher that
/// labels each observation acted on ([`Experience::teacher`]).
pub struct Collector<E: Env> {
    envs: VecEnv<E>,
    obs: Vec<f32>,
    returns: Vec<f64>,
    lengths: Vec<u64>,
    teacher: Option<Box<BatchPolicy<'static>>>,
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
            teacher: None,
        }
    }

    /// The same collector with `teacher` labelling every observation acted on
    /// (`[n_envs, action_dim]` out). It reads what each env's [`Env::teacher_view`] gives
    /// (the state behind an image), else the observation as the env returned it: rows of
    /// `[n_envs, view_dim]` in.
    pub fn with_teacher(self, teacher: Box<BatchPolicy<'static>>) -> Self {
        Self {
            teacher: Some(teacher),
            ..self
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
        let labels = self
            .teacher
            .as_mut()
            .map(|teach| match teacher_views(self.envs.envs()) {
                Some(views) => teach(&views),
                None => teach(&self.obs),
            });
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
            absorbing: step.infos.iter().map(StepInfo::absorbing).collect(),
            teacher: labels.as_deref(),
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

/// The envs' [`Env::teacher_view`]s side by side, `None` where an env has none.
fn teacher_views<E: Env>(envs: &[E]) -> Option<Vec<f32>> {
    let mut views = Vec::new();
    for env in envs {
        views.extend_from_slice(env.teacher_view()?);
    }
    Some(views)
}

/// A policy acting on a batch: observations `[n, obs_dim]` in, actions `[n, action_dim]`
/// out (a trained agent's deterministic action, or a scripted controller).
pub type BatchPolicy<'a> = dyn FnMut(&[f32]) -> Vec<f32> + 'a;

/// An agent's deterministic action as a [`BatchPolicy`].
pub fn deterministic(agent: &mut dyn Agent) -> impl FnMut(&[f32]) -> Vec<f32> + '_ {
    move |obs| agent.act(obs, ActMode::Deterministic)
}

/// An agent's sampled action ([`ActMode::Sample`]) as a [`BatchPolicy`], its noise drawn
/// from `seed` on.
pub fn sampled(agent: &mut dyn Agent, seed: u64) -> impl FnMut(&[f32]) -> Vec<f32> + '_ {
    agent.seed_sampling(seed);
    move |obs| agent.act(obs, ActMode::Sample)
}

/// What an episode of `E` leaves behind, folded from its steps.
pub trait EpisodeLog<E: Env>: Send {
    /// Before each step: the env as the policy acts on it (e.g. to read its state).
    fn before_step(&mut self, _env: &E) {}

    /// One step: the action taken and what followed.
    fn record(&mut self, action: &[f32], transition: &Transition<E::Info>);
}

impl<E: Env> EpisodeLog<E> for Episode {
    fn record(&mut self, _: &[f32], t: &Transition<E::Info>) {
        self.ret += f64::from(t.reward);
        self.len += 1;
    }
}

/// An episode in progress in one env: its seed's index, the observation to act on, room
/// for the next one, and its log.
struct Slot<L> {
    index: usize,
    obs: Vec<f32>,
    next_obs: Vec<f32>,
    log: L,
}

/// Plays one episode per seed with `policy`, `envs.len()` side by side (the policy runs
/// once per step for all of them, the envs step in parallel), and returns their logs
/// (`new_log(seed)` starts each) in seed order. An env takes the next seed as soon as
/// its episode ends. The number of envs is part of an evaluation protocol: a batch of
/// another size may round the networks' outputs differently in the last bit.
pub fn play_episodes<E: Env, L: EpisodeLog<E>>(
    policy: &mut BatchPolicy<'_>,
    envs: &mut [E],
    seeds: &[u64],
    new_log: impl Fn(u64) -> L,
) -> Result<Vec<L>, EnvError> {
    assert!(!envs.is_empty() || seeds.is_empty(), "episodes need an env");
    let action_dim = envs.first().map_or(1, Env::action_dim);
    let start = |env: &mut E, index: usize| {
        let mut obs = vec![0.0; env.obs_dim()];
        env.reset_into(Some(seeds[index]), &mut obs);
        Slot {
            index,
            next_obs: vec![0.0; obs.len()],
            obs,
            log: new_log(seeds[index]),
        }
    };
    let mut next = 0;
    let mut slots: Vec<Option<Slot<L>>> = envs
        .iter_mut()
        .map(|env| {
            (next < seeds.len()).then(|| {
                next += 1;
                start(env, next - 1)
            })
        })
        .collect();
    let mut done: Vec<Option<L>> = (0..seeds.len()).map(|_| None).collect();
    while slots.iter().any(Option::is_some) {
        let batch: Vec<f32> = slots
            .iter()
            .flatten()
            .flat_map(|s| s.obs.iter().copied())
            .collect();
        let actions = policy(&batch);
        let mut rows = actions.chunks(action_dim);
        let work: Vec<(&mut E, &mut Slot<L>, &[f32])> = envs
            .iter_mut()
            .zip(slots.iter_mut())
            .filter_map(|(env, slot)| slot.as_mut().map(|s| (env, s)))
            .map(|(env, s)| (env, s, rows.next().expect("one action row per live slot")))
            .collect();
        let ended: Vec<Result<bool, EnvError>> = work
            .into_par_iter()
            .map(|(env, slot, action)| {
                slot.log.before_step(env);
                let t = env.step_into(action, &mut slot.next_obs)?;
                slot.log.record(action, &t);
                std::mem::swap(&mut slot.obs, &mut slot.next_obs);
                Ok(t.done())
            })
            .collect();
        let mut ended = ended.into_iter();
        for (env, slot) in envs.iter_mut().zip(slots.iter_mut()) {
            if slot.is_none() || !ended.next().expect("one result per live slot")? {
                continue;
            }
            let s = slot.take().expect("live slot");
            done[s.index] = Some(s.log);
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

/// Plays one deterministic episode of `env` from `seed`.
pub fn play_episode<E: Env>(
    agent: &mut dyn Agent,
    env: &mut E,
    seed: u64,
) -> Result<Episode, EnvError> {
    let mut episodes = play_episodes(
        &mut deterministic(agent),
        std::slice::from_mut(env),
        &[seed],
        |_| Episode::default(),
    )?;
    Ok(episodes.pop().expect("one seed, one episode"))
}
