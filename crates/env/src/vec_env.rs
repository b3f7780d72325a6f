//! [`VecEnv`]: N environments stepped in parallel on a rayon pool, with auto-reset.
//!
//! Each environment owns its RNG and physics world, and every batch is laid out in
//! environment-index order, so results are identical whatever the thread count. With
//! one thread the envs are stepped on the calling thread: no pool, no hand-over to a
//! worker and back each step (a tenth of a one-core training's time went to that).

use rayon::prelude::*;

use crate::env::{Env, EnvError, Transition, check_action};
use crate::seeding::{TRAIN_ENVS, derive_seed};

/// A failure of one environment in a batch (none of the batch was stepped).
#[derive(Debug, thiserror::Error)]
pub enum VecEnvError {
    /// Environment `index` refused its action.
    #[error("env {index}: {source}")]
    Env {
        index: usize,
        #[source]
        source: EnvError,
    },
    /// The batch of actions has the wrong length.
    #[error("actions have {got} values, expected {expected} ({num_envs} envs x {action_dim})")]
    BatchSize {
        expected: usize,
        got: usize,
        num_envs: usize,
        action_dim: usize,
    },
    /// A VecEnv needs at least one environment, all of the same dimensions.
    #[error("{0}")]
    Setup(String),
    /// `step` before `reset`.
    #[error("call reset before step")]
    NotReset,
}

/// The result of one batched step; every slice is in environment order.
#[derive(Debug)]
pub struct VecStep<'a, I> {
    /// `[num_envs, obs_dim]` observations to act on next (after auto-reset where an
    /// episode ended).
    pub obs: &'a [f32],
    /// Rewards, `[num_envs]`.
    pub rewards: &'a [f32],
    /// Terminal flags, `[num_envs]`.
    pub terminated: &'a [bool],
    /// Truncation flags, `[num_envs]`.
    pub truncated: &'a [bool],
    /// Per-environment details of the step just taken.
    pub infos: &'a [I],
    final_obs: &'a [f32],
    obs_dim: usize,
}

impl<I> VecStep<'_, I> {
    /// The last observation of env `i`'s episode if it ended on this step (use it to
    /// bootstrap truncated episodes); `obs` then already holds the next episode's first.
    pub fn final_observation(&self, i: usize) -> Option<&[f32]> {
        (self.terminated[i] || self.truncated[i])
            .then(|| &self.final_obs[i * self.obs_dim..(i + 1) * self.obs_dim])
    }
}

/// Environments stepped together (see the module docs).
pub struct VecEnv<E: Env> {
    envs: Vec<E>,
    /// The workers; none with one thread (the caller steps).
    pool: Option<rayon::ThreadPool>,
    obs_dim: usize,
    action_dim: usize,
    obs: Vec<f32>,
    final_obs: Vec<f32>,
    rewards: Vec<f32>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
    infos: Vec<E::Info>,
    started: bool,
}

impl<E: Env> VecEnv<E> {
    /// Wraps `envs`, stepping them on a pool of `threads` worker threads (on the calling
    /// thread for one).
    pub fn new(envs: Vec<E>, threads: usize) -> Result<Self, VecEnvError> {
        let first = envs
            .first()
            .ok_or_else(|| VecEnvError::Setup("a VecEnv needs at least one env".into()))?;
        let (obs_dim, action_dim) = (first.obs_dim(), first.action_dim());
        if let Some(i) = envs
            .iter()
            .position(|e| e.obs_dim() != obs_dim || e.action_dim() != action_dim)
        {
            return Err(VecEnvError::Setup(format!(
                "env {i} has other dimensions than env 0"
            )));
        }
        if threads == 0 {
            return Err(VecEnvError::Setup("threads must be at least 1".into()));
        }
        let pool = (threads > 1)
            .then(|| rayon::ThreadPoolBuilder::new().num_threads(threads).build())
            .transpose()
            .map_err(|e| VecEnvError::Setup(format!("cannot start {threads} threads: {e}")))?;
        let n = envs.len();
        Ok(Self {
            envs,
            pool,
            obs_dim,
            action_dim,
            obs: vec![0.0; n * obs_dim],
            final_obs: vec![0.0; n * obs_dim],
            rewards: vec![0.0; n],
            terminated: vec![false; n],
            truncated: vec![false; n],
            infos: vec![E::Info::default(); n],
            started: false,
        })
    }

    /// Number of environments.
    pub fn num_envs(&self) -> usize {
        self.envs.len()
    }

    /// Observation length of each environment.
    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Action length of each environment.
    pub fn action_dim(&self) -> usize {
        self.action_dim
    }

    /// The environments, in order.
    pub fn envs(&self) -> &[E] {
        &self.envs
    }

    /// Resets env `i` with seed `derive_seed(seed, TRAIN_ENVS, i)`; returns the
    /// `[num_envs, obs_dim]` first observations.
    pub fn reset(&mut self, seed: u64) -> &[f32] {
        let seeds: Vec<u64> = (0..self.envs.len() as u64)
            .map(|i| derive_seed(seed, TRAIN_ENVS, i))
            .collect();
        self.reset_with_seeds(&seeds)
    }

    /// Resets env `i` with `seeds[i]` (one seed per env).
    pub fn reset_with_seeds(&mut self, seeds: &[u64]) -> &[f32] {
        assert_eq!(seeds.len(), self.envs.len(), "one seed per env");
        let seeds: Vec<Option<u64>> = seeds.iter().copied().map(Some).collect();
        self.reset_each(&seeds)
    }

    /// Resets every env from its own random stream, without re-seeding (Gymnasium's
    /// `reset()` without a seed): the next episodes of each env's sequence.
    pub fn reset_unseeded(&mut self) -> &[f32] {
        self.reset_each(&vec![None; self.envs.len()])
    }

    fn reset_each(&mut self, seeds: &[Option<u64>]) -> &[f32] {
        let od = self.obs_dim;
        let reset =
            |((env, obs), &seed): ((&mut E, &mut [f32]), &Option<u64>)| env.reset_into(seed, obs);
        match &self.pool {
            Some(pool) => pool.install(|| {
                self.envs
                    .par_iter_mut()
                    .zip(self.obs.par_chunks_mut(od))
                    .zip(seeds.par_iter())
                    .for_each(reset)
            }),
            None => self
                .envs
                .iter_mut()
                .zip(self.obs.chunks_mut(od))
                .zip(seeds)
                .for_each(reset),
        }
        self.started = true;
        &self.obs
    }

    /// Steps every env with its row of `actions` (`[num_envs, action_dim]`, row-major).
    /// An env whose episode ends is reset from its own RNG stream. A refused action
    /// refuses the whole batch before any env moves.
    pub fn step(&mut self, actions: &[f32]) -> Result<VecStep<'_, E::Info>, VecEnvError> {
        if !self.started {
            return Err(VecEnvError::NotReset);
        }
        let (n, od, ad) = (self.envs.len(), self.obs_dim, self.action_dim);
        if actions.len() != n * ad {
            return Err(VecEnvError::BatchSize {
                expected: n * ad,
                got: actions.len(),
                num_envs: n,
                action_dim: ad,
            });
        }
        for (index, a) in actions.chunks(ad).enumerate() {
            check_action(a, ad).map_err(|source| VecEnvError::Env { index, source })?;
        }
        type Row<'a, E> = (((&'a mut E, &'a mut [f32]), &'a mut [f32]), &'a [f32]);
        let step = |(((env, obs), final_obs), action): Row<'_, E>| {
            let t = env.step_into(action, obs)?;
            if t.done() {
                final_obs.copy_from_slice(obs);
                env.reset_into(None, obs);
            }
            Ok(t)
        };
        let results: Vec<Result<Transition<E::Info>, EnvError>> = match &self.pool {
            Some(pool) => pool.install(|| {
                self.envs
                    .par_iter_mut()
                    .zip(self.obs.par_chunks_mut(od))
                    .zip(self.final_obs.par_chunks_mut(od))
                    .zip(actions.par_chunks(ad))
                    .map(step)
                    .collect()
            }),
            None => self
                .envs
                .iter_mut()
                .zip(self.obs.chunks_mut(od))
                .zip(self.final_obs.chunks_mut(od))
                .zip(actions.chunks(ad))
                .map(step)
                .collect(),
        };
        for (i, r) in results.into_iter().enumerate() {
            let t = r.map_err(|source| VecEnvError::Env { index: i, source })?;
            self.rewards[i] = t.reward;
            self.terminated[i] = t.terminated;
            self.truncated[i] = t.truncated;
            self.infos[i] = t.info;
        }
        Ok(self.last_step())
    }

    /// [`VecEnv::step`], then every episode still running is cut: reported as truncated,
    /// its observation kept as the final one (to bootstrap from), and env `i` restarts
    /// from `seeds[i]` (all envs, ended or not). Training runs do this at checkpoints, so
    /// a resumed run needs no physics state.
    pub fn step_then_restart(
        &mut self,
        actions: &[f32],
        seeds: &[u64],
    ) -> Result<VecStep<'_, E::Info>, VecEnvError> {
        self.step(actions)?;
        let od = self.obs_dim;
        for i in 0..self.envs.len() {
            if !(self.terminated[i] || self.truncated[i]) {
                self.truncated[i] = true;
                self.final_obs[i * od..(i + 1) * od]
                    .copy_from_slice(&self.obs[i * od..(i + 1) * od]);
            }
        }
        self.reset_with_seeds(seeds);
        Ok(self.last_step())
    }

    fn last_step(&self) -> VecStep<'_, E::Info> {
        VecStep {
            obs: &self.obs,
            rewards: &self.rewards,
            terminated: &self.terminated,
            truncated: &self.truncated,
            infos: &self.infos,
            final_obs: &self.final_obs,
            obs_dim: self.obs_dim,
        }
    }
}
