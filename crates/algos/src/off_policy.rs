//! What SAC and TD3 share: the replay buffer (rewards stored times `reward_scale`, an
//! absorbing end's over `1 - gamma` under `absorbing_ends`, summed over `n_step` steps),
//! demonstrations mixed into each minibatch at `demo_share`,
//! uniform random actions before `learning_starts`, and the
//! train-every-`train_freq`-steps schedule. The algorithm itself is an
//! [`OffPolicyLearner`].

use crate::agent::{ActMode, Agent, AgentError, Experience, Metrics};
use crate::config::OffPolicyConfig;
use crate::demonstrations::{Demonstration, demonstration_buffer};
use crate::policy_chain::Step;
use crate::replay::{ReplayBatch, ReplayBuffer};
use crate::schedule::LrSchedule;
use foosball_nets::{ObsShape, Snapshot, SnapshotError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::VecDeque;
use std::path::Path;

/// The algorithm-specific half of an off-policy agent.
pub trait OffPolicyLearner {
    /// Policy actions in `[-1, 1]` for `[n, obs_dim]` observations (exploration noise
    /// included when `mode` is `Explore`).
    fn policy_act(&mut self, obs: &[f32], mode: ActMode, rng: &mut ChaCha8Rng) -> Vec<f32>;
    /// One gradient step on a sampled minibatch with learning rate `lr`.
    fn train_step(&mut self, batch: &ReplayBatch, lr: f64, rng: &mut ChaCha8Rng) -> Metrics;
    /// Gradient steps taken so far.
    fn gradient_steps(&self) -> u64;
    /// Told after each explored step which envs' episodes `ended` (terminated or
    /// truncated), for exploration that spans an episode; nothing by default.
    fn episodes_ended(&mut self, _ended: &[bool]) {}
    /// Writes the networks into `dir`.
    fn save(&self, dir: &Path) -> Result<(), AgentError>;
    /// Reads the networks from `dir`.
    fn load(&mut self, dir: &Path) -> Result<(), AgentError>;
    /// See [`Agent::zero_obs_inputs`].
    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String>;
    /// Adds the optimiser states and counters (see [`Agent::save_state`]).
    fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>);
    /// Restores what `save_state` stored.
    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError>;
    /// See [`Agent::policy_chain`]; none by default.
    fn policy_chain(&self) -> Result<Vec<Step>, String> {
        Err("this learner does not write its policy as a chain of fixed steps".into())
    }
}

/// An off-policy agent: a learner plus its replay buffer and schedule.
pub struct OffPolicy<L> {
    learner: L,
    obs_dim: usize,
    action_dim: usize,
    schedule: OffPolicyConfig,
    lr: LrSchedule,
    buffer: ReplayBuffer,
    /// Demonstrated transitions, never overwritten (`set_demonstrations`).
    demos: Option<ReplayBuffer>,
    rng: ChaCha8Rng,
    sample_rng: ChaCha8Rng,
    env_steps: u64,
    steps_since_train: u64,
    /// The learner's discount, for `n_step` returns.
    gamma: f32,
    /// Per env, the steps whose `n_step` return is still being summed, oldest first.
    windows: Vec<VecDeque<Pending>>,
}

/// A step waiting for the rewards of its `n_step` window.
#[derive(Clone, Debug, PartialEq)]
struct Pending {
    obs: Vec<f32>,
    action: Vec<f32>,
    /// Already times `reward_scale`.
    reward: f32,
}

impl<L: OffPolicyLearner> OffPolicy<L> {
    /// Wraps `learner` for an env of `obs`/`action_dim`, trained on `schedule` with
    /// discount `gamma` (for `n_step` returns) and learning rate `lr`; `rng` draws random
    /// actions, minibatches and noise.
    pub fn new(
        learner: L,
        (obs, action_dim): (ObsShape, usize),
        (schedule, gamma): (OffPolicyConfig, f32),
        lr: LrSchedule,
        rng: ChaCha8Rng,
    ) -> Self {
        let obs_dim = obs.dim();
        let buffer = ReplayBuffer::for_obs(schedule.buffer_size, obs, action_dim);
        Self {
            learner,
            obs_dim,
            action_dim,
            schedule,
            lr,
            buffer,
            demos: None,
            sample_rng: rng.clone(),
            rng,
            env_steps: 0,
            steps_since_train: 0,
            gamma,
            windows: Vec::new(),
        }
    }

    /// Stores the oldest step of `window` with the discounted sum of the window's rewards,
    /// reaching `reached`, and drops it from the window.
    fn store_oldest(&mut self, env: usize, reached: &[f32], terminated: bool, timeout: bool) {
        let window = &mut self.windows[env];
        let ret = window
            .iter()
            .rev()
            .fold(0.0_f32, |acc, p| p.reward + self.gamma * acc);
        let first = window.pop_front().expect("a window holds a step");
        self.buffer
            .push(&first.obs, &first.action, ret, reached, terminated, timeout);
    }

    /// A minibatch of `batch_size` rows: `round(demo_share * batch_size)` demonstrations
    /// first when there are any, the rest from the replay.
    fn minibatch(&mut self) -> ReplayBatch {
        let size = self.schedule.batch_size;
        let (Some(demos), Some(share)) = (&self.demos, self.schedule.demo_share) else {
            return self.buffer.sample(size, &mut self.rng);
        };
        let k = ((share * size as f32).round() as usize).min(size);
        let mut batch = demos.sample(k, &mut self.rng);
        batch.demos = k;
        batch.extend(self.buffer.sample(size - k, &mut self.rng));
        batch
    }

    /// The algorithm.
    pub fn learner(&self) -> &L {
        &self.learner
    }

    /// The learner, to change (e.g. [`crate::Sac::on_host_path`]).
    pub fn learner_mut(&mut self) -> &mut L {
        &mut self.learner
    }
}

impl<L: OffPolicyLearner> Agent for OffPolicy<L> {
    fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    fn action_dim(&self) -> usize {
        self.action_dim
    }

    fn act(&mut self, obs: &[f32], mode: ActMode) -> Vec<f32> {
        let warming_up = self.env_steps < self.schedule.learning_starts;
        if mode == ActMode::Explore && warming_up {
            let n = obs.len() / self.obs_dim() * self.action_dim();
            return (0..n).map(|_| self.rng.random_range(-1.0..=1.0)).collect();
        }
        let rng = match mode {
            ActMode::Sample => &mut self.sample_rng,
            ActMode::Explore | ActMode::Deterministic => &mut self.rng,
        };
        self.learner.policy_act(obs, mode, rng)
    }

    fn seed_sampling(&mut self, seed: u64) {
        self.sample_rng = ChaCha8Rng::seed_from_u64(seed);
    }

    fn observe(&mut self, step: &Experience<'_>) {
        let (o, a, n) = (self.obs_dim(), self.action_dim(), self.schedule.n_step);
        self.windows.resize(step.len(), VecDeque::new());
        for i in 0..step.len() {
            let (terminated, truncated) = (step.terminated[i], step.truncated[i]);
            let reward = self.schedule.stored_reward(
                step.rewards[i],
                terminated && step.absorbing[i],
                self.gamma,
            );
            if n == 1 {
                // One-step returns need no window (and no copy of the row).
                let (obs, action) = (
                    &step.obs[i * o..(i + 1) * o],
                    &step.actions[i * a..(i + 1) * a],
                );
                let reached = step.reached(i, o);
                self.buffer
                    .push(obs, action, reward, reached, terminated, truncated);
                continue;
            }
            self.windows[i].push_back(Pending {
                obs: step.obs[i * o..(i + 1) * o].to_vec(),
                action: step.actions[i * a..(i + 1) * a].to_vec(),
                reward,
            });
            let reached = step.reached(i, o);
            if terminated {
                // Every window ends here, none bootstraps.
                while !self.windows[i].is_empty() {
                    self.store_oldest(i, reached, true, truncated);
                }
            } else if self.windows[i].len() == n {
                self.store_oldest(i, reached, false, truncated);
            }
            if truncated {
                // Windows shorter than n would bootstrap with the wrong discount.
                self.windows[i].clear();
            }
        }
        let ended: Vec<bool> = (0..step.len())
            .map(|i| step.terminated[i] || step.truncated[i])
            .collect();
        self.learner.episodes_ended(&ended);
        self.env_steps += step.len() as u64;
        self.steps_since_train += 1;
    }

    fn update(&mut self, progress_remaining: f64) -> Option<Metrics> {
        let s = &self.schedule;
        if self.env_steps <= s.learning_starts || self.steps_since_train < s.train_freq {
            return None;
        }
        self.steps_since_train = 0;
        let (lr, steps) = (self.lr.at(progress_remaining), s.gradient_steps);
        let mut rounds = Vec::with_capacity(steps);
        for _ in 0..steps {
            let batch = self.minibatch();
            rounds.push(self.learner.train_step(&batch, lr, &mut self.rng));
        }
        Some(Metrics::mean(rounds))
    }

    fn env_steps(&self) -> u64 {
        self.env_steps
    }

    fn gradient_steps(&self) -> u64 {
        self.learner.gradient_steps()
    }

    fn save(&self, dir: &Path) -> Result<(), AgentError> {
        self.learner.save(dir)
    }

    fn load(&mut self, dir: &Path) -> Result<(), AgentError> {
        self.learner.load(dir)
    }

    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        self.learner.zero_obs_inputs(inputs)
    }

    fn policy_chain(&self) -> Result<Vec<Step>, String> {
        self.learner.policy_chain()
    }

    fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>) {
        snap.put_rng("agent.rng", &self.rng);
        snap.put_u64("agent.env_steps", self.env_steps);
        snap.put_u64("agent.steps_since_train", self.steps_since_train);
        if self.schedule.n_step > 1 {
            let lens: Vec<u64> = self.windows.iter().map(|w| w.len() as u64).collect();
            let values: Vec<f32> = self
                .windows
                .iter()
                .flatten()
                .flat_map(|p| p.obs.iter().chain(&p.action).chain([&p.reward]).copied())
                .collect();
            snap.put_u64s("agent.windows.len", lens);
            snap.put_f32("agent.windows", values);
        }
        self.buffer.save_state(snap, "replay");
        self.learner.save_state(snap);
    }

    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError> {
        self.rng = snap.rng("agent.rng")?;
        self.env_steps = snap.u64("agent.env_steps")?;
        self.steps_since_train = snap.u64("agent.steps_since_train")?;
        self.windows.clear();
        if self.schedule.n_step > 1 {
            let (o, a) = (self.obs_dim, self.action_dim);
            let lens = snap.u64s("agent.windows.len")?;
            let total: u64 = lens.iter().sum();
            let values = snap.f32s_of_len("agent.windows", total as usize * (o + a + 1))?;
            let mut rows = values.chunks_exact(o + a + 1);
            for &len in lens {
                let window = (0..len)
                    .filter_map(|_| rows.next())
                    .map(|r| Pending {
                        obs: r[..o].to_vec(),
                        action: r[o..o + a].to_vec(),
                        reward: r[o + a],
                    })
                    .collect();
                self.windows.push(window);
            }
        }
        self.buffer.load_state(snap, "replay")?;
        self.learner.load_state(snap)
    }

    fn set_demonstrations(&mut self, episodes: &[Demonstration<'_>]) -> Result<usize, String> {
        if self.schedule.demo_share.is_none() {
            return Err(
                "off_policy.demo_share is not set: no share of the minibatches would \
                        draw from them"
                    .into(),
            );
        }
        let (o, a) = (self.obs_dim, self.action_dim);
        let store = |r: f32, absorbing: bool| self.schedule.stored_reward(r, absorbing, self.gamma);
        let buffer = demonstration_buffer(episodes, o, a, store)?;
        let rows = buffer.len();
        self.demos = Some(buffer);
        Ok(rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A learner that keeps the rows of the minibatches it is given.
    #[derive(Default)]
    struct Recorder {
        rewards: Vec<f32>,
        /// `(obs[0], reward, next_obs[0], done)` of each row.
        rows: Vec<(f32, f32, f32, f32)>,
    }

    impl OffPolicyLearner for Recorder {
        fn policy_act(&mut self, obs: &[f32], _: ActMode, _: &mut ChaCha8Rng) -> Vec<f32> {
            vec![0.0; obs.len()]
        }
        fn train_step(&mut self, batch: &ReplayBatch, _: f64, _: &mut ChaCha8Rng) -> Metrics {
            self.rewards.extend_from_slice(&batch.rewards);
            for k in 0..batch.rewards.len() {
                let row = (
                    batch.obs[k],
                    batch.rewards[k],
                    batch.next_obs[k],
                    batch.dones[k],
                );
                self.rows.push(row);
            }
            Metrics::default()
        }
        fn gradient_steps(&self) -> u64 {
            0
        }
        fn save(&self, _: &Path) -> Result<(), AgentError> {
            Ok(())
        }
        fn load(&mut self, _: &Path) -> Result<(), AgentError> {
            Ok(())
        }
        fn zero_obs_inputs(&mut self, _: &[usize]) -> Result<(), String> {
            Ok(())
        }
        fn save_state<'a>(&'a self, _: &mut Snapshot<'a>) {}
        fn load_state(&mut self, _: &Snapshot<'_>) -> Result<(), SnapshotError> {
            Ok(())
        }
    }

    /// A recorder on a 1-dim env with 1-dim actions, discount `gamma`, rng from `seed`.
    fn recorder(schedule: OffPolicyConfig, gamma: f32, seed: u64) -> OffPolicy<Recorder> {
        let lr = LrSchedule::Constant(1e-3);
        let rng = ChaCha8Rng::seed_from_u64(seed);
        OffPolicy::new(
            Recorder::default(),
            (ObsShape::Vector(1), 1),
            (schedule, gamma),
            lr,
            rng,
        )
    }

    #[test]
    fn the_replay_stores_rewards_times_reward_scale() {
        let schedule = OffPolicyConfig {
            learning_starts: 0,
            batch_size: 8,
            reward_scale: 0.25,
            ..OffPolicyConfig::default()
        };
        let mut agent = recorder(schedule, 0.99, 0);
        for k in 0..4 {
            let obs = [k as f32];
            agent.observe(&Experience {
                obs: &obs,
                actions: &[0.0],
                rewards: &[40.0 * (k + 1) as f32],
                next_obs: &obs,
                final_obs: vec![None],
                terminated: &[false],
                truncated: &[false],
                absorbing: vec![false],
                teacher: None,
            });
        }
        agent.update(1.0);
        let seen = &agent.learner().rewards;
        assert_eq!(seen.len(), 8);
        assert!(
            seen.iter().all(|r| [10.0, 20.0, 30.0, 40.0].contains(r)),
            "{seen:?}"
        );
        let bad = OffPolicyConfig {
            reward_scale: 0.0,
            ..OffPolicyConfig::default()
        };
        assert!(
            bad.validate(0.99)
                .unwrap_err()
                .to_string()
                .contains("reward_scale")
        );
    }

    #[test]
    fn an_absorbing_end_is_stored_as_its_reward_forever_only_where_it_terminates() {
        for on in [false, true] {
            let schedule = OffPolicyConfig {
                learning_starts: 0,
                batch_size: 64,
                reward_scale: 0.5,
                absorbing_ends: on,
                ..OffPolicyConfig::default()
            };
            let mut agent = recorder(schedule, 0.9, 1);
            // Reward 10 each: absorbing but going on; terminated absorbing; terminated.
            for (k, terminated, absorbing) in [(0, false, true), (1, true, true), (2, true, false)]
            {
                let obs = [k as f32];
                agent.observe(&Experience {
                    obs: &obs,
                    actions: &[0.0],
                    rewards: &[10.0],
                    next_obs: &obs,
                    final_obs: vec![terminated.then_some(&obs[..])],
                    terminated: &[terminated],
                    truncated: &[false],
                    absorbing: vec![absorbing],
                    teacher: None,
                });
            }
            agent.update(1.0);
            let by_obs = |k: f32| {
                let rows = &agent.learner().rows;
                let r: Vec<f32> = rows.iter().filter(|r| r.0 == k).map(|r| r.1).collect();
                assert!(!r.is_empty(), "row {k} never sampled");
                r[0]
            };
            // 0.5 * 10 = 5; absorbing and terminated: 5 / (1 - 0.9) = 50.
            let expected = if on { 50.0 } else { 5.0 };
            assert_eq!([by_obs(0.0), by_obs(2.0)], [5.0, 5.0]);
            assert!((by_obs(1.0) - expected).abs() < 1e-3, "{}", by_obs(1.0));
        }
        let on = OffPolicyConfig {
            absorbing_ends: true,
            ..OffPolicyConfig::default()
        };
        let refused = on.validate(1.0).unwrap_err().to_string();
        assert!(refused.contains("absorbing_ends"), "{refused}");
        assert!(on.validate(0.99).is_ok());
    }

    #[test]
    fn demo_share_fills_the_leading_rows_of_every_minibatch_with_demonstrations() {
        let schedule = OffPolicyConfig {
            learning_starts: 0,
            batch_size: 8,
            demo_share: Some(0.25),
            ..OffPolicyConfig::default()
        };
        let new = |schedule: OffPolicyConfig| recorder(schedule, 0.9, 2);
        let mut plain = new(OffPolicyConfig {
            demo_share: None,
            ..schedule.clone()
        });
        let demo = Demonstration {
            obs: &[-1.0, -2.0],
            actions: &[0.5, 0.5],
            rewards: &[7.0, 7.0],
            terminated: true,
            absorbing: false,
        };
        let refused = plain.set_demonstrations(&[demo]).unwrap_err();
        assert!(refused.contains("demo_share"), "{refused}");
        let mut agent = new(schedule);
        assert_eq!(agent.set_demonstrations(&[demo]), Ok(2));
        for k in 0..3 {
            step(&mut agent, k, k as f32 + 1.0, (false, false));
            agent.update(1.0);
        }
        let rows = &agent.learner().rows;
        assert_eq!(rows.len(), 24);
        for batch in rows.chunks(8) {
            // Demonstrated rows are the negative observations, reward 7.
            assert!(
                batch[..2].iter().all(|r| r.0 < 0.0 && r.1 == 7.0),
                "{batch:?}"
            );
            assert!(batch[2..].iter().all(|r| r.0 >= 0.0), "{batch:?}");
        }
    }

    /// One env step of a 1-dim env: observation `k`, reward `k + 1`, reaching `next`.
    fn step(agent: &mut OffPolicy<Recorder>, k: usize, next: f32, ended: (bool, bool)) {
        let (obs, next) = ([k as f32], [next]);
        agent.observe(&Experience {
            obs: &obs,
            actions: &[0.0],
            rewards: &[k as f32 + 1.0],
            next_obs: &next,
            final_obs: vec![(ended.0 || ended.1).then_some(&next[..])],
            terminated: &[ended.0],
            truncated: &[ended.1],
            absorbing: vec![false],
            teacher: None,
        });
    }

    #[test]
    fn n_step_windows_sum_discounted_rewards_end_at_terminations_and_survive_a_snapshot() {
        let schedule = OffPolicyConfig {
            learning_starts: 0,
            batch_size: 64,
            n_step: 3,
            ..OffPolicyConfig::default()
        };
        let new = || recorder(schedule.clone(), 0.5, 1);
        let mut agent = new();
        for k in 0..4 {
            step(&mut agent, k, k as f32 + 1.0, (false, false));
        }
        // Two windows are in flight (steps 2 and 3): a snapshot carries them over.
        let mut snap = Snapshot::new();
        agent.save_state(&mut snap);
        let path = std::env::temp_dir().join(format!("n-step-{}.bin", std::process::id()));
        snap.write(&path).unwrap();
        let mut agent = new();
        agent.load_state(&Snapshot::read(&path).unwrap()).unwrap();
        std::fs::remove_file(&path).unwrap();
        step(&mut agent, 4, 100.0, (true, false));
        // A new episode cut by a time limit after 2 steps leaves nothing (window < 3).
        step(&mut agent, 5, 6.0, (false, false));
        step(&mut agent, 6, 200.0, (false, true));
        agent.update(1.0);
        let expected = [
            (0.0, 1.0 + 0.5 * 2.0 + 0.25 * 3.0, 3.0, 0.0),
            (1.0, 2.0 + 0.5 * 3.0 + 0.25 * 4.0, 4.0, 0.0),
            (2.0, 3.0 + 0.5 * 4.0 + 0.25 * 5.0, 100.0, 1.0),
            (3.0, 4.0 + 0.5 * 5.0, 100.0, 1.0),
            (4.0, 5.0, 100.0, 1.0),
        ];
        let rows = &agent.learner().rows;
        assert_eq!(rows.len(), 64);
        for e in expected {
            assert!(rows.contains(&e), "{e:?} never sampled: {rows:?}");
        }
        assert!(rows.iter().all(|r| expected.contains(r)), "{rows:?}");
        assert_eq!(schedule.bootstrap_discount(0.5), 0.125);
    }
}
