//! Twin Delayed DDPG (Fujimoto et al. 2018) as Stable-Baselines3 defines it.
//!
//! Per gradient step, on a minibatch `(s, a, r, s', d)`:
//! 1. target action `a' = clip(pi'(s') + clip(eps, -c, c), -1, 1)`, `eps ~ N(0, sigma^2)`
//!    drawn per element;
//! 2. critics: `y = r + gamma (1 - d) min(Q1', Q2')(s', a')` (`gamma^n` with `n_step`
//!    returns),
//!    `L = MSE(Q1(s, a), y) + MSE(Q2(s, a), y)`;
//! 3. every `policy_delay` steps: actor `L = -mean(Q1(s, pi(s)))`, then polyak updates of
//!    both target networks (targets move only on these delayed steps).
//!
//! Exploration adds `N(0, action_noise^2)` to the deterministic action, clipped to `[-1, 1]`.

use crate::agent::{ActMode, AgentError, Metrics};
use crate::config::{ConfigError, DEFAULT_GAMMA, NetConfig, OffPolicyConfig, check_gamma, ensure};
use crate::off_policy::{OffPolicy, OffPolicyLearner, twin_mse};
use crate::replay::ReplayBatch;
use crate::rows::{DeviceRows, bellman};
use crate::tensors::{host, matrix, mean, standard_normal, vector};
use burn::module::Module;
use foosball_nets::store::{load_module, save_module};
use foosball_nets::{
    Adam, DeterministicActor, Device, ObsShape, Scalar, Snapshot, SnapshotError, Tensor, TwinQ,
    polyak_update,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// TD3's settings (SB3 defaults; exploration noise as in the paper and RL Zoo).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Td3Config {
    /// Actor and critics.
    pub net: NetConfig,
    /// Discount factor.
    pub gamma: f32,
    /// Replay schedule.
    pub off_policy: OffPolicyConfig,
    /// Critic updates per actor and target update.
    pub policy_delay: u64,
    /// Standard deviation of the target policy smoothing noise.
    pub target_policy_noise: f32,
    /// Clip of the target policy smoothing noise.
    pub target_noise_clip: f32,
    /// Standard deviation of the Gaussian exploration noise (0 disables it).
    pub action_noise: f32,
}

impl Default for Td3Config {
    fn default() -> Self {
        Self {
            net: NetConfig::default(),
            gamma: DEFAULT_GAMMA,
            off_policy: OffPolicyConfig::default(),
            policy_delay: 2,
            target_policy_noise: 0.2,
            target_noise_clip: 0.5,
            action_noise: 0.1,
        }
    }
}

impl Td3Config {
    /// Rejects invalid settings, naming the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.net.validate().map_err(|e| e.under("net"))?;
        check_gamma(self.gamma)?;
        self.off_policy
            .validate(self.gamma)
            .map_err(|e| e.under("off_policy"))?;
        ensure(self.policy_delay > 0, "policy_delay", "must be positive")?;
        let non_negative = |x: f32| x.is_finite() && x >= 0.0;
        ensure(
            non_negative(self.target_policy_noise),
            "target_policy_noise",
            "must be finite and >= 0",
        )?;
        ensure(
            non_negative(self.target_noise_clip),
            "target_noise_clip",
            "must be finite and >= 0",
        )?;
        ensure(
            non_negative(self.action_noise),
            "action_noise",
            "must be finite and >= 0",
        )
    }
}

/// Target policy smoothing: `clip(next_actions + clip(noise, -clip, clip), -1, 1)`,
/// element by element, `[batch, action_dim]`.
pub fn smoothed_target_actions(
    next_actions: Tensor<2>,
    noise: Tensor<2>,
    noise_clip: f32,
) -> Tensor<2> {
    (next_actions + noise.clamp(-noise_clip, noise_clip)).clamp(-1.0, 1.0)
}

/// TD3's networks, optimisers and counters.
pub struct Td3 {
    config: Td3Config,
    obs_dim: usize,
    action_dim: usize,
    device: Device,
    actor: DeterministicActor,
    actor_target: DeterministicActor,
    critic: TwinQ,
    critic_target: TwinQ,
    actor_optim: Adam,
    critic_optim: Adam,
    gradient_steps: u64,
    last_actor_loss: Scalar,
}

/// TD3 with its replay buffer: the [`crate::Agent`] to train.
pub type Td3Agent = OffPolicy<Td3>;

impl Td3 {
    /// Networks drawn from `seed` in a fixed order (actor, critic; targets are copies)
    /// on `device` (an autodiff device).
    pub fn agent(
        obs: impl Into<ObsShape>,
        action_dim: usize,
        config: Td3Config,
        seed: u64,
        device: &Device,
    ) -> Td3Agent {
        let obs = obs.into();
        let obs_dim = obs.dim();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = &config.net;
        let mut init = n.init(obs, action_dim, &mut rng, device);
        let actor = DeterministicActor::new(&mut init);
        let critic = TwinQ::new(&mut init);
        let learner = Td3 {
            obs_dim,
            action_dim,
            device: device.clone(),
            actor_target: actor.clone().no_grad(),
            critic_target: critic.clone().no_grad(),
            actor_optim: Adam::new(n.adam.clone()),
            critic_optim: Adam::new(n.adam.clone()),
            actor,
            critic,
            gradient_steps: 0,
            last_actor_loss: Scalar::Host(f64::NAN),
            config,
        };
        let (schedule, lr) = (learner.config.off_policy.clone(), learner.config.net.lr);
        let gamma = learner.config.gamma;
        OffPolicy::new(learner, (obs, action_dim), (schedule, gamma), lr, rng)
    }

    /// The actor.
    pub fn actor(&self) -> &DeterministicActor {
        &self.actor
    }

    /// The twin critics.
    pub fn critic(&self) -> &TwinQ {
        &self.critic
    }
}

impl OffPolicyLearner for Td3 {
    fn policy_act(&mut self, obs: &[f32], mode: ActMode, rng: &mut ChaCha8Rng) -> Vec<f32> {
        let device = self.device.clone().without_autodiff();
        let mut actions = host(
            self.actor
                .valid()
                .forward(matrix(obs, self.obs_dim, &device)),
        );
        let sigma = self.config.action_noise;
        if mode == ActMode::Explore && sigma > 0.0 {
            let noise = standard_normal(actions.len(), 1, rng);
            for (x, e) in actions.iter_mut().zip(noise) {
                *x = (*x + sigma * e).clamp(-1.0, 1.0);
            }
        }
        actions
    }

    fn train_step(&mut self, batch: &ReplayBatch, lr: f64, rng: &mut ChaCha8Rng) -> Metrics {
        let (o, a) = (self.obs_dim, self.action_dim);
        let n = batch.rewards.len();
        let dev = self.device.clone();
        let plain = dev.clone().without_autodiff();
        let c = &self.config;

        // 1-2. Critics against the smoothed target.
        let next_obs = matrix(&batch.next_obs, o, &plain);
        let noise: Vec<f32> = standard_normal(n, a, rng)
            .iter()
            .map(|e| e * c.target_policy_noise)
            .collect();
        let next_actions = smoothed_target_actions(
            self.actor_target.valid().forward(next_obs.clone()),
            matrix(&noise, a, &plain),
            c.target_noise_clip,
        );
        let min_q_next = self.critic_target.valid().min(next_obs, next_actions);
        let rewards = vector(&batch.rewards, &plain);
        let dones = vector(&batch.dones, &plain);
        let discount = c.off_policy.bootstrap_discount(c.gamma);
        let rows = DeviceRows { device: plain };
        let target = bellman(&rows, &rewards, &dones, &min_q_next, discount).autodiff();
        let obs = matrix(&batch.obs, o, &dev);
        let (q1, q2) = self
            .critic
            .forward(obs.clone(), matrix(&batch.actions, a, &dev));
        let critic_loss = twin_mse(q1.clone(), q2, target);
        let critic_loss_value = mean(critic_loss.clone().inner());
        let mut grads = critic_loss.backward();
        let critic_report = self
            .critic_optim
            .step_in_place(&mut self.critic, &mut grads, lr);
        self.gradient_steps += 1;

        // 3. Delayed actor and target updates.
        if self.gradient_steps.is_multiple_of(c.policy_delay) {
            let q_pi = self.critic.q1_frozen(obs.clone(), self.actor.forward(obs));
            let actor_loss = q_pi.mean().neg();
            self.last_actor_loss = mean(actor_loss.clone().inner());
            let mut grads = actor_loss.backward();
            self.actor_optim
                .step_in_place(&mut self.actor, &mut grads, lr);
            let tau = c.off_policy.tau;
            polyak_update(&mut self.critic_target, &self.critic, tau);
            polyak_update(&mut self.actor_target, &self.actor, tau);
        }

        Metrics(vec![
            ("critic_loss", critic_loss_value),
            ("actor_loss", self.last_actor_loss.clone()),
            ("q_mean", mean(q1.inner())),
            ("critic_grad_norm", critic_report.grad_norm),
        ])
    }

    fn gradient_steps(&self) -> u64 {
        self.gradient_steps
    }

    fn save(&self, dir: &Path) -> Result<(), AgentError> {
        save_module(&self.actor, &dir.join("actor.bpk"))?;
        save_module(&self.actor_target, &dir.join("actor_target.bpk"))?;
        save_module(&self.critic, &dir.join("critic.bpk"))?;
        save_module(&self.critic_target, &dir.join("critic_target.bpk"))?;
        Ok(())
    }

    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        self.actor.zero_obs_inputs(inputs)?;
        self.actor_target.zero_obs_inputs(inputs)?;
        self.critic.zero_obs_inputs(inputs)?;
        self.critic_target.zero_obs_inputs(inputs)
    }

    fn load(&mut self, dir: &Path) -> Result<(), AgentError> {
        self.actor = load_module(self.actor.clone(), &dir.join("actor.bpk"))?;
        self.actor_target = load_module(self.actor_target.clone(), &dir.join("actor_target.bpk"))?;
        self.critic = load_module(self.critic.clone(), &dir.join("critic.bpk"))?;
        self.critic_target =
            load_module(self.critic_target.clone(), &dir.join("critic_target.bpk"))?;
        Ok(())
    }

    fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>) {
        self.actor_optim.save_state(snap, "td3.actor_adam");
        self.critic_optim.save_state(snap, "td3.critic_adam");
        snap.put_u64("td3.gradient_steps", self.gradient_steps);
        snap.put_f64("td3.last_actor_loss", self.last_actor_loss.clone().read());
    }

    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError> {
        let d = &self.device;
        self.actor_optim.load_state(snap, "td3.actor_adam", d)?;
        self.critic_optim.load_state(snap, "td3.critic_adam", d)?;
        self.gradient_steps = snap.u64("td3.gradient_steps")?;
        self.last_actor_loss = Scalar::Host(snap.f64("td3.last_actor_loss")?);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use foosball_nets::Backend;

    #[test]
    fn target_smoothing_clips_the_noise_then_the_action_per_element() {
        let d = Backend::default_cpu().unwrap().device().unwrap();
        let next = matrix(&[0.9, -0.2, 0.0, 0.1], 2, &d);
        let noise = matrix(&[0.7, -0.1, -0.8, 0.3], 2, &d);
        let got = host(smoothed_target_actions(next, noise, 0.5));
        let want = [1.0, -0.3, -0.5, 0.4];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-6, "{got:?}");
        }
    }
}
