//! Soft Actor-Critic (Haarnoja et al. 2018) as Stable-Baselines3 defines it.
//!
//! Per gradient step, on a minibatch `(s, a, r, s', d)`:
//! 1. `a~, log pi(a~|s)` from the current actor (reparameterised);
//! 2. temperature: `L(log alpha) = -mean(log alpha * (log pi(a~|s) + H_target))`,
//!    `H_target = -dim(A)`; `alpha` used below is the value *before* this step; with
//!    `tune_alpha = false` no step: `alpha` stays `init_alpha` (SB3's `ent_coef = float`);
//! 3. critics: `y = r + gamma (1 - d) (min(Q1', Q2')(s', a') - alpha log pi(a'|s'))`
//!    (`gamma^n` with `n_step` returns),
//!    `a' ~ pi(.|s')`; `L = 0.5 * (MSE(Q1(s, a), y) + MSE(Q2(s, a), y))`;
//! 4. actor, against the *updated* critics: `L = mean(alpha log pi(a~|s) - min(Q1, Q2)(s, a~))`;
//!    with `bc_weight` (demonstrations only) TD3+BC's form instead (Fujimoto & Gu 2021):
//!    `L / mean|min(Q1, Q2)| + bc_weight * mean((tanh(mu(s_d)) - a_d)^2)` over the
//!    minibatch's demonstrated rows `(s_d, a_d)`, the scale a constant of the step;
//! 5. targets: `theta' <- tau theta + (1 - tau) theta'` every `target_update_interval` steps.

use crate::agent::{ActMode, AgentError, Metrics};
use crate::config::{ConfigError, DEFAULT_GAMMA, NetConfig, OffPolicyConfig, check_gamma, ensure};
use crate::off_policy::{OffPolicy, OffPolicyLearner, bellman_target, twin_mse};
use crate::replay::ReplayBatch;
use crate::tensors::{host, matrix, mean, standard_normal, vector};
use burn::module::{Module, Param};
use foosball_nets::host::is_host;
use foosball_nets::store::{load_module, save_module};
use foosball_nets::{
    Adam, Device, ObsShape, Scalar, Snapshot, SnapshotError, SquashedGaussianActor, Tensor, TwinQ,
    polyak_update,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// SAC's settings (SB3 defaults).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SacConfig {
    /// Actor and critics.
    pub net: NetConfig,
    /// Discount factor.
    pub gamma: f32,
    /// Replay schedule.
    pub off_policy: OffPolicyConfig,
    /// Initial temperature `alpha` (SB3's `"auto_1.0"`).
    pub init_alpha: f32,
    /// Whether `alpha` is learned towards `target_entropy` (default true, SB3's `"auto"`);
    /// false holds it at `init_alpha` (SB3's `ent_coef = init_alpha`), also over networks
    /// loaded from a run that learned its own.
    pub tune_alpha: bool,
    /// Target entropy; `None` means `-dim(A)`.
    pub target_entropy: Option<f32>,
    /// Gradient steps between target updates.
    pub target_update_interval: u64,
    /// Polyak coefficient of an averaged copy of the actor, `avg <- (1 - tau) avg +
    /// tau actor` after every actor step: deterministic actions (evaluations and a
    /// deterministic test) come from it, exploration and sampled actions from the actor
    /// itself. Absent (default): no average, SB3's SAC.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub actor_average_tau: Option<f32>,
    /// Weight of behaviour cloning on the demonstrated rows of each minibatch (needs
    /// `off_policy.demo_share`): the actor's loss becomes TD3+BC's (step 4 above; their
    /// `alpha = 2.5` is `bc_weight = 0.4`). Absent (default): SB3's actor loss.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bc_weight: Option<f32>,
}

impl Default for SacConfig {
    fn default() -> Self {
        Self {
            net: NetConfig::default(),
            gamma: DEFAULT_GAMMA,
            off_policy: OffPolicyConfig::default(),
            init_alpha: 1.0,
            tune_alpha: true,
            target_entropy: None,
            target_update_interval: 1,
            actor_average_tau: None,
            bc_weight: None,
        }
    }
}

impl SacConfig {
    /// Rejects invalid settings, naming the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.net.validate().map_err(|e| e.under("net"))?;
        check_gamma(self.gamma)?;
        self.off_policy
            .validate(self.gamma)
            .map_err(|e| e.under("off_policy"))?;
        ensure(
            self.init_alpha > 0.0 && self.init_alpha.is_finite(),
            "init_alpha",
            "must be finite and positive",
        )?;
        ensure(
            self.target_entropy.is_none_or(f32::is_finite),
            "target_entropy",
            "must be finite",
        )?;
        ensure(
            self.target_update_interval > 0,
            "target_update_interval",
            "must be positive",
        )?;
        ensure(
            self.actor_average_tau.is_none_or(|t| t > 0.0 && t <= 1.0),
            "actor_average_tau",
            "must be in (0, 1]",
        )?;
        ensure(
            self.bc_weight.is_none_or(|w| w.is_finite() && w >= 0.0),
            "bc_weight",
            "must be finite and not negative",
        )?;
        ensure(
            self.bc_weight.is_none() || self.off_policy.demo_share.is_some(),
            "bc_weight",
            "clones demonstrations: set off_policy.demo_share",
        )
    }
}

/// `log alpha`, a one-element trainable parameter.
#[derive(Module, Debug)]
pub struct Temperature {
    log_alpha: Param<Tensor<1>>,
}

impl Temperature {
    fn new(alpha: f32, device: &Device) -> Self {
        let log_alpha = Tensor::from_data(
            foosball_nets::TensorData::new(vec![alpha.ln()], [1]),
            device,
        );
        Self {
            log_alpha: Param::from_tensor(log_alpha),
        }
    }

    /// `alpha = exp(log alpha)` on the host.
    pub fn alpha(&self) -> f32 {
        (Scalar::of(self.log_alpha.val().inner()).read() as f32).exp()
    }

    /// `alpha`, `[1]` on `device` (a device without autodiff): exponentiated on the host
    /// on a CPU backend, on the device elsewhere, so a GPU step never waits to read it.
    fn alpha_on(&self, device: &Device) -> Tensor<1> {
        if is_host(device) {
            vector(&[self.alpha()], device)
        } else {
            self.log_alpha.val().inner().exp()
        }
    }
}

/// `-mean(log_alpha * (log_prob + target_entropy))` with `log_prob` `[batch]` treated as a
/// constant: its gradient raises `alpha` when the policy's entropy `-log pi` is below
/// the target and lowers it otherwise.
pub fn temperature_loss(
    log_alpha: Tensor<1>,
    log_prob: Tensor<1>,
    target_entropy: f32,
) -> Tensor<1> {
    (log_alpha * log_prob.detach().add_scalar(target_entropy))
        .mean()
        .neg()
}

/// The soft target `r + gamma (1 - d) (min_q_next - alpha * log_prob_next)`, `[batch]`
/// (`alpha` `[1]`).
pub fn soft_target(
    rewards: Tensor<1>,
    dones: Tensor<1>,
    min_q_next: Tensor<1>,
    log_prob_next: Tensor<1>,
    alpha: Tensor<1>,
    gamma: f32,
) -> Tensor<1> {
    bellman_target(rewards, dones, min_q_next - log_prob_next * alpha, gamma)
}

/// SAC's networks, optimisers and counters.
pub struct Sac {
    config: SacConfig,
    obs_dim: usize,
    action_dim: usize,
    device: Device,
    actor: SquashedGaussianActor,
    /// The Polyak-averaged actor (`actor_average_tau`), outside the graph.
    actor_average: Option<SquashedGaussianActor>,
    critic: TwinQ,
    critic_target: TwinQ,
    temperature: Temperature,
    actor_optim: Adam,
    critic_optim: Adam,
    temperature_optim: Adam,
    gradient_steps: u64,
}

/// SAC with its replay buffer: the [`crate::Agent`] to train.
pub type SacAgent = OffPolicy<Sac>;

impl Sac {
    /// Networks drawn from `seed` in a fixed order (actor, critic; the target is a copy)
    /// on `device` (an autodiff device).
    pub fn agent(
        obs: impl Into<ObsShape>,
        action_dim: usize,
        config: SacConfig,
        seed: u64,
        device: &Device,
    ) -> SacAgent {
        let obs = obs.into();
        let obs_dim = obs.dim();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = &config.net;
        let mut init = n.init(obs, action_dim, &mut rng, device);
        let actor = SquashedGaussianActor::new(&mut init);
        let critic = TwinQ::new(&mut init);
        let critic_target = critic.clone().no_grad();
        let actor_average = config.actor_average_tau.map(|_| actor.clone().no_grad());
        let adam = || Adam::new(n.adam.clone());
        let learner = Sac {
            obs_dim,
            action_dim,
            device: device.clone(),
            temperature: Temperature::new(config.init_alpha, device),
            actor_optim: adam(),
            critic_optim: adam(),
            temperature_optim: adam(),
            actor,
            actor_average,
            critic,
            critic_target,
            gradient_steps: 0,
            config,
        };
        let (schedule, lr) = (learner.config.off_policy.clone(), learner.config.net.lr);
        let gamma = learner.config.gamma;
        OffPolicy::new(learner, (obs, action_dim), (schedule, gamma), lr, rng)
    }

    fn target_entropy(&self) -> f32 {
        self.config
            .target_entropy
            .unwrap_or(-(self.action_dim as f32))
    }

    /// The actor.
    pub fn actor(&self) -> &SquashedGaussianActor {
        &self.actor
    }

    /// The twin critics.
    pub fn critic(&self) -> &TwinQ {
        &self.critic
    }

    /// The current temperature `alpha`.
    pub fn alpha(&self) -> f32 {
        self.temperature.alpha()
    }
}

impl OffPolicyLearner for Sac {
    fn policy_act(&mut self, obs: &[f32], mode: ActMode, rng: &mut ChaCha8Rng) -> Vec<f32> {
        let actor = self.actor.valid();
        let device = self.device.clone().without_autodiff();
        let obs = matrix(obs, self.obs_dim, &device);
        let actions = match mode {
            ActMode::Deterministic => match &self.actor_average {
                Some(average) => average.valid().deterministic(obs),
                None => actor.deterministic(obs),
            },
            ActMode::Explore | ActMode::Sample => {
                let n = obs.dims()[0];
                let noise = matrix(
                    &standard_normal(n, self.action_dim, rng),
                    self.action_dim,
                    &device,
                );
                actor.sample(obs, noise).0
            }
        };
        host(actions)
    }

    fn train_step(&mut self, batch: &ReplayBatch, lr: f64, rng: &mut ChaCha8Rng) -> Metrics {
        let (o, a) = (self.obs_dim, self.action_dim);
        let n = batch.rewards.len();
        let dev = self.device.clone();
        let plain = dev.clone().without_autodiff();
        let gamma = self.config.off_policy.bootstrap_discount(self.config.gamma);

        // 1. Current policy on s (kept in the graph for the actor loss).
        let obs = matrix(&batch.obs, o, &dev);
        let noise = matrix(&standard_normal(n, a, rng), a, &dev);
        let (actions_pi, log_prob) = self.actor.sample(obs.clone(), noise);

        // 2. Temperature.
        let alpha = self.temperature.alpha_on(&plain);
        // A held temperature builds no graph (one never walked back would pile up in
        // the autodiff graph, step after step): its loss is only reported.
        let log_alpha = match self.config.tune_alpha {
            true => self.temperature.log_alpha.val(),
            false => self.temperature.log_alpha.val().detach(),
        };
        let alpha_loss = temperature_loss(log_alpha, log_prob.clone(), self.target_entropy());
        let alpha_loss_value = mean(alpha_loss.clone().inner());
        if self.config.tune_alpha {
            let mut grads = alpha_loss.backward();
            self.temperature_optim
                .step_in_place(&mut self.temperature, &mut grads, lr);
        }

        // 3. Critics.
        let next_obs = matrix(&batch.next_obs, o, &plain);
        let next_noise = matrix(&standard_normal(n, a, rng), a, &plain);
        let (next_actions, next_log_prob) = self.actor.valid().sample(next_obs.clone(), next_noise);
        let min_q_next = self.critic_target.valid().min(next_obs, next_actions);
        let rewards = vector(&batch.rewards, &plain);
        let dones = vector(&batch.dones, &plain);
        let target = soft_target(
            rewards,
            dones,
            min_q_next,
            next_log_prob,
            alpha.clone(),
            gamma,
        )
        .autodiff();
        let (q1, q2) = self
            .critic
            .forward(obs.clone(), matrix(&batch.actions, a, &dev));
        let critic_loss = twin_mse(q1.clone(), q2, target).mul_scalar(0.5);
        let critic_loss_value = mean(critic_loss.clone().inner());
        let mut grads = critic_loss.backward();
        let critic_report = self
            .critic_optim
            .step_in_place(&mut self.critic, &mut grads, lr);

        // 4. Actor, against the updated critics (their parameters frozen).
        let min_q_pi = self.critic.clone().no_grad().min(obs.clone(), actions_pi);
        let cloning = self.config.bc_weight.filter(|_| batch.demos > 0);
        let q_scale = cloning.map(|_| min_q_pi.clone().detach().abs().mean().clamp_min(1e-6));
        let mut actor_loss = (log_prob.clone() * alpha.clone().autodiff() - min_q_pi).mean();
        if let (Some(weight), Some(q_scale)) = (cloning, q_scale) {
            let d = batch.demos;
            let cloned = self.actor.deterministic(obs.narrow(0, 0, d));
            let played = matrix(&batch.actions[..d * a], a, &dev);
            let bc = (cloned - played).square().mean();
            actor_loss = actor_loss / q_scale + bc.mul_scalar(weight);
        }
        let actor_loss_value = mean(actor_loss.clone().inner());
        let mut grads = actor_loss.backward();
        let actor_report = self
            .actor_optim
            .step_in_place(&mut self.actor, &mut grads, lr);
        if let (Some(average), Some(tau)) = (&mut self.actor_average, self.config.actor_average_tau)
        {
            polyak_update(average, &self.actor, tau);
        }

        // 5. Targets.
        self.gradient_steps += 1;
        if self
            .gradient_steps
            .is_multiple_of(self.config.target_update_interval)
        {
            polyak_update(
                &mut self.critic_target,
                &self.critic,
                self.config.off_policy.tau,
            );
        }

        Metrics(vec![
            ("critic_loss", critic_loss_value),
            ("actor_loss", actor_loss_value),
            ("alpha", Scalar::of(alpha)),
            ("alpha_loss", alpha_loss_value),
            ("entropy", mean(log_prob.inner().neg())),
            ("q_mean", mean(q1.inner())),
            ("critic_grad_norm", critic_report.grad_norm),
            ("actor_grad_norm", actor_report.grad_norm),
        ])
    }

    fn gradient_steps(&self) -> u64 {
        self.gradient_steps
    }

    fn save(&self, dir: &Path) -> Result<(), AgentError> {
        save_module(&self.actor, &dir.join("actor.bpk"))?;
        save_module(&self.critic, &dir.join("critic.bpk"))?;
        save_module(&self.critic_target, &dir.join("critic_target.bpk"))?;
        save_module(&self.temperature, &dir.join("temperature.bpk"))?;
        if let Some(average) = &self.actor_average {
            save_module(average, &dir.join("actor_average.bpk"))?;
        }
        Ok(())
    }

    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        self.actor.zero_obs_inputs(inputs)?;
        if let Some(average) = &mut self.actor_average {
            average.zero_obs_inputs(inputs)?;
        }
        self.critic.zero_obs_inputs(inputs)?;
        self.critic_target.zero_obs_inputs(inputs)
    }

    fn load(&mut self, dir: &Path) -> Result<(), AgentError> {
        self.actor = load_module(self.actor.clone(), &dir.join("actor.bpk"))?;
        self.critic = load_module(self.critic.clone(), &dir.join("critic.bpk"))?;
        self.critic_target =
            load_module(self.critic_target.clone(), &dir.join("critic_target.bpk"))?;
        // A held temperature is the config's, whatever the saved networks learned.
        if self.config.tune_alpha {
            self.temperature = load_module(self.temperature.clone(), &dir.join("temperature.bpk"))?;
        }
        if let Some(average) = self.actor_average.take() {
            self.actor_average = Some(load_module(average, &dir.join("actor_average.bpk"))?);
        }
        Ok(())
    }

    fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>) {
        self.actor_optim.save_state(snap, "sac.actor_adam");
        self.critic_optim.save_state(snap, "sac.critic_adam");
        self.temperature_optim
            .save_state(snap, "sac.temperature_adam");
        snap.put_u64("sac.gradient_steps", self.gradient_steps);
    }

    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError> {
        let d = &self.device;
        self.actor_optim.load_state(snap, "sac.actor_adam", d)?;
        self.critic_optim.load_state(snap, "sac.critic_adam", d)?;
        self.temperature_optim
            .load_state(snap, "sac.temperature_adam", d)?;
        self.gradient_steps = snap.u64("sac.gradient_steps")?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use foosball_nets::Backend;

    fn device() -> Device {
        Backend::default_cpu().unwrap().device().unwrap()
    }

    #[test]
    fn the_soft_target_bootstraps_only_non_terminal_rows() {
        let d = device();
        let y = soft_target(
            vector(&[1.0, 2.0], &d),
            vector(&[0.0, 1.0], &d),
            vector(&[10.0, 20.0], &d),
            vector(&[-1.0, 3.0], &d),
            vector(&[0.5], &d),
            0.9,
        );
        let y = host(y);
        assert!((y[0] - (1.0 + 0.9 * (10.0 + 0.5))).abs() < 1e-5, "{y:?}");
        assert_eq!(y[1], 2.0);
    }

    /// d loss / d log_alpha = -mean(log_prob + target_entropy).
    fn temperature_gradient(log_prob: &[f32], target_entropy: f32) -> f32 {
        let d = device();
        let log_alpha = vector(&[0.3], &d).require_grad();
        let loss = temperature_loss(log_alpha.clone(), vector(log_prob, &d), target_entropy);
        host(log_alpha.grad(&loss.backward()).unwrap())[0]
    }

    #[test]
    fn the_temperature_falls_when_entropy_exceeds_the_target_and_rises_otherwise() {
        // Entropy estimate -mean(log_prob) = 3 > target -1: gradient +4, descent lowers alpha.
        assert!((temperature_gradient(&[-2.0, -4.0], -1.0) - 4.0).abs() < 1e-6);
        // Entropy -2 < target -1: gradient -1, descent raises alpha.
        assert!((temperature_gradient(&[2.0, 2.0], -1.0) + 1.0).abs() < 1e-6);
    }

    /// A 3 -> 2 SAC agent with 8-wide networks (`config` otherwise) after `steps` env
    /// steps of replay and updates.
    fn trained(mut c: SacConfig, steps: usize) -> SacAgent {
        use crate::agent::{Agent, Experience};
        c.net.hidden = vec![8];
        c.off_policy.learning_starts = 0;
        c.off_policy.batch_size = 4;
        let mut agent = Sac::agent(3, 2, c, 5, &device());
        for k in 0..steps {
            let obs = [k as f32 * 0.1, 0.5, -0.2];
            agent.observe(&Experience {
                obs: &obs,
                actions: &[0.3, -0.6],
                rewards: &[1.0 + k as f32],
                next_obs: &obs,
                final_obs: vec![None],
                terminated: &[false],
                truncated: &[false],
                absorbing: vec![false],
            });
            agent.update(1.0);
        }
        agent
    }

    #[test]
    fn a_fixed_temperature_stays_at_init_alpha_and_a_tuned_one_moves() {
        let alpha = |tune_alpha| {
            let c = SacConfig {
                init_alpha: 0.3,
                tune_alpha,
                ..SacConfig::default()
            };
            trained(c, 6).learner().alpha()
        };
        assert!((alpha(false) - 0.3).abs() < 1e-6, "{}", alpha(false));
        assert!((alpha(true) - 0.3).abs() > 1e-4, "{}", alpha(true));
        // Networks saved by a tuned run: a held temperature stays the config's.
        let dir = std::env::temp_dir().join(format!("sac-held-alpha-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let tuned = trained(SacConfig::default(), 6);
        crate::agent::Agent::save(&tuned, &dir).unwrap();
        for (tune_alpha, expected) in [(false, 0.3), (true, tuned.learner().alpha())] {
            let c = SacConfig {
                init_alpha: 0.3,
                tune_alpha,
                ..SacConfig::default()
            };
            let mut loaded = trained(c, 0);
            crate::agent::Agent::load(&mut loaded, &dir).unwrap();
            assert!(
                (loaded.learner().alpha() - expected).abs() < 1e-6,
                "{tune_alpha}"
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The deterministic actions of [`trained`] with `actor_average_tau = tau` on a fixed
    /// batch: the agent's and the live actor's.
    fn averaged(tau: Option<f32>, steps: usize) -> (Vec<f32>, Vec<f32>) {
        use crate::agent::Agent;
        let c = SacConfig {
            actor_average_tau: tau,
            ..SacConfig::default()
        };
        let mut agent = trained(c, steps);
        let device = device();
        let batch = [0.2, -0.1, 0.4, 0.0, 0.3, -0.5];
        let live = host(agent.learner().actor().valid().deterministic(matrix(
            &batch,
            3,
            &device.clone().without_autodiff(),
        )));
        (agent.act(&batch, ActMode::Deterministic), live)
    }

    #[test]
    fn the_averaged_actor_acts_deterministically_and_follows_the_actor_by_tau() {
        let (plain, live) = averaged(None, 6);
        assert_eq!(plain, live, "no average: the actor itself");
        let (full, live) = averaged(Some(1.0), 6);
        assert_eq!(full, live, "tau 1: the average is the actor");
        let (slow, live) = averaged(Some(1e-4), 6);
        let (start, _) = averaged(Some(1e-4), 0);
        let gap = |a: &[f32], b: &[f32]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f32::max)
        };
        assert!(
            gap(&slow, &live) > 1e-4,
            "the actor moved away from its slow average"
        );
        assert!(gap(&slow, &start) < 1e-3 * gap(&live, &start).max(1e-3));
        let bad = SacConfig {
            actor_average_tau: Some(0.0),
            ..SacConfig::default()
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("actor_average_tau")
        );
    }
}
