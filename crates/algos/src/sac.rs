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
//!
//! The step below computes each loss's gradient with respect to the networks' outputs
//! (`dL/dQk = (Qk - y) / n` in 3; in 4 `dL/d log pi = s alpha / n` and `dL/d min Q = -s / n`
//! with `s` the cloning scale or 1, `min` routed to the smaller critic; the temperature's
//! `dL/d log alpha = -(mean log pi + H_target)`) and lets the networks walk it back: Burn's
//! autodiff, or the host MLP path's hand-written backward passes (`backend = "host"`,
//! [`crate::sac_networks`]); one step, either path.

use crate::agent::{ActMode, AgentError, Metrics};
use crate::config::{ConfigError, DEFAULT_GAMMA, NetConfig, OffPolicyConfig, check_gamma, ensure};
use crate::off_policy::{OffPolicy, OffPolicyLearner};
use crate::replay::ReplayBatch;
use crate::rows::{Rows, bellman};
use crate::sac_networks::{
    BurnNetworks, HostNetworks, Modules, Optimisers, SacNetworks, Temperature, Walk,
};
use crate::tensors::{host, matrix, standard_normal};
use burn::module::Module;
use foosball_nets::{Device, ObsShape, Snapshot, SnapshotError, SquashedGaussianActor, TwinQ};
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

/// Where SAC's networks compute.
enum Networks {
    /// Burn modules, gradients by autodiff.
    Burn(Box<BurnNetworks>),
    /// The host MLP path ([`Sac::on_host_path`]).
    Host(Box<HostNetworks>),
}

/// SAC's networks, optimisers and counters.
pub struct Sac {
    config: SacConfig,
    obs_dim: usize,
    action_dim: usize,
    device: Device,
    networks: Networks,
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
        let modules = Modules {
            critic_target: critic.clone().no_grad(),
            actor_average: config.actor_average_tau.map(|_| actor.clone().no_grad()),
            temperature: Temperature::new(config.init_alpha, device),
            actor,
            critic,
        };
        let optim = Optimisers::new(&n.adam);
        let learner = Sac {
            obs_dim,
            action_dim,
            device: device.clone(),
            networks: Networks::Burn(Box::new(BurnNetworks::new(modules, optim, device))),
            gradient_steps: 0,
            config,
        };
        let (schedule, lr) = (learner.config.off_policy.clone(), learner.config.net.lr);
        let gamma = learner.config.gamma;
        OffPolicy::new(learner, (obs, action_dim), (schedule, gamma), lr, rng)
    }

    /// The same learner computing on the host MLP path (`backend = "host"`), from the
    /// same networks; an error names what that path does not compute (an image
    /// observation, layer normalisation). Call before the first step: the optimisers
    /// start fresh.
    pub fn on_host_path(&mut self) -> Result<(), String> {
        if let Networks::Burn(burn) = &self.networks {
            let optim = Optimisers::new(&self.config.net.adam);
            let host = HostNetworks::from_modules(burn.modules.clone(), optim)?;
            self.networks = Networks::Host(Box::new(host));
        }
        Ok(())
    }

    /// The networks as Burn modules (the host path's copied out).
    pub fn modules(&self) -> Modules {
        match &self.networks {
            Networks::Burn(burn) => burn.modules.clone(),
            Networks::Host(host) => host.modules(),
        }
    }

    /// Replaces the networks with `modules`' (the optimisers kept).
    fn set_modules(&mut self, modules: Modules) -> Result<(), String> {
        match &mut self.networks {
            Networks::Burn(burn) => burn.modules = modules,
            Networks::Host(host) => host.set_modules(modules)?,
        }
        Ok(())
    }

    fn optimisers(&self) -> &Optimisers {
        match &self.networks {
            Networks::Burn(burn) => &burn.optim,
            Networks::Host(host) => &host.optim,
        }
    }

    /// The actor.
    pub fn actor(&self) -> SquashedGaussianActor {
        self.modules().actor
    }

    /// The twin critics.
    pub fn critic(&self) -> TwinQ {
        self.modules().critic
    }

    /// The current temperature `alpha`.
    pub fn alpha(&self) -> f32 {
        match &self.networks {
            Networks::Burn(burn) => burn.modules.temperature.alpha(),
            Networks::Host(host) => host.log_alpha[0].exp(),
        }
    }
}

/// What a gradient step reads besides its networks and minibatch.
struct StepContext<'a> {
    config: &'a SacConfig,
    obs_dim: usize,
    action_dim: usize,
    /// Gradient steps taken before this one.
    gradient_steps: u64,
}

impl StepContext<'_> {
    /// One gradient step (steps 1-5 of the module docs) on either path.
    fn step<N: SacNetworks>(
        &self,
        nets: &mut N,
        batch: &ReplayBatch,
        lr: f64,
        rng: &mut ChaCha8Rng,
    ) -> Metrics {
        let r = nets.rows();
        let (o, a) = (self.obs_dim, self.action_dim);
        let n = batch.rewards.len();
        let per_row = 1.0 / n as f32;
        let gamma = self.config.off_policy.bootstrap_discount(self.config.gamma);
        let target_entropy = self.config.target_entropy.unwrap_or(-(a as f32));

        // 1. Current policy on s (kept for the actor's step).
        let obs = r.matrix(&batch.obs, o);
        let noise = r.matrix(&standard_normal(n, a, rng), a);
        let (actions_pi, log_prob) = nets.sample(&obs, &noise);

        // 2. Temperature: dL/d log_alpha = -(mean(log pi) + H_target).
        let log_alpha = nets.log_alpha();
        let alpha = r.exp(&log_alpha);
        let alpha_grad = r.affine(&r.mean(&log_prob), -1.0, -target_entropy);
        let alpha_loss = r.mul(&log_alpha, &alpha_grad);
        if self.config.tune_alpha {
            nets.temperature_step(&alpha_grad, lr);
        }

        // 3. Critics: dL/dQk = (Qk - y) / n.
        let next_obs = r.matrix(&batch.next_obs, o);
        let next_noise = r.matrix(&standard_normal(n, a, rng), a);
        let (next_actions, next_log_prob) = nets.sample_detached(&next_obs, &next_noise);
        let min_q_next = nets.target_min(&next_obs, &next_actions);
        let soft_value = r.sub(&min_q_next, &r.mul(&next_log_prob, &alpha));
        let (rewards, dones) = (r.vector(&batch.rewards), r.vector(&batch.dones));
        let y = bellman(&r, &rewards, &dones, &soft_value, gamma);
        let batch_actions = r.matrix(&batch.actions, a);
        let (q1, q2) = nets.q_values(&obs, &batch_actions, Walk::Params);
        let (e1, e2) = (r.sub(&q1, &y), r.sub(&q2, &y));
        let mse = r.add(&r.mean(&r.square(&e1)), &r.mean(&r.square(&e2)));
        let critic_loss = r.affine(&mse, 0.5, 0.0);
        let dq = [r.affine(&e1, per_row, 0.0), r.affine(&e2, per_row, 0.0)];
        let critic_report = nets.critic_step([&dq[0], &dq[1]], lr);

        // 4. Actor, against the updated critics: L = s mean(alpha log pi - min Q)
        //    (+ w mean((tanh(mean_d) - a_d)^2)), s = 1, or 1 / mean|min Q| when cloning.
        let (q1_pi, q2_pi) = nets.q_values(&obs, &actions_pi, Walk::Actions);
        let min_q_pi = r.min(&q1_pi, &q2_pi);
        let cloning = self.config.bc_weight.filter(|_| batch.demos > 0);
        let scale = match cloning {
            Some(_) => r.div(
                &r.vector(&[1.0]),
                &r.max_scalar(&r.mean(&r.abs(&min_q_pi)), 1e-6),
            ),
            None => r.vector(&[1.0]),
        };
        let soft_q = r.sub(&r.mul(&log_prob, &alpha), &min_q_pi);
        let mut actor_loss = r.mul(&scale, &r.mean(&soft_q));
        // dL/d min Q = -s / n, routed to the smaller critic (the first on a tie).
        let d_min = r.affine(&scale, -per_row, 0.0);
        let first = r.le(&q1_pi, &q2_pi);
        let d_q_pi = [
            r.mul(&first, &d_min),
            r.mul(&r.affine(&first, -1.0, 1.0), &d_min),
        ];
        let d_actions = nets.action_gradient([&d_q_pi[0], &d_q_pi[1]]);
        let d_log_prob = r.mul(&alpha, &r.affine(&scale, per_row, 0.0));
        let d_means = cloning.map(|weight| {
            let d = batch.demos;
            let gap = r.sub_matrix(&nets.sampled_means(d), &r.rows(&batch_actions, 0, d));
            actor_loss = r.add(&actor_loss, &r.affine(&r.mean_square(&gap), weight, 0.0));
            r.scale_matrix(&gap, 2.0 * weight / (d * a) as f32)
        });
        let actor_report = nets.actor_step(&d_actions, &d_log_prob, d_means.as_ref(), lr);
        if let Some(tau) = self.config.actor_average_tau {
            nets.update_actor_average(tau);
        }

        // 5. Targets.
        if (self.gradient_steps + 1).is_multiple_of(self.config.target_update_interval) {
            nets.update_target(self.config.off_policy.tau);
        }

        Metrics(vec![
            ("critic_loss", r.scalar(&critic_loss)),
            ("actor_loss", r.scalar(&actor_loss)),
            ("alpha", r.scalar(&alpha)),
            ("alpha_loss", r.scalar(&alpha_loss)),
            (
                "entropy",
                r.scalar(&r.affine(&r.mean(&log_prob), -1.0, 0.0)),
            ),
            ("q_mean", r.scalar(&r.mean(&q1))),
            ("critic_grad_norm", critic_report.grad_norm),
            ("actor_grad_norm", actor_report.grad_norm),
        ])
    }
}

impl OffPolicyLearner for Sac {
    fn policy_act(&mut self, obs: &[f32], mode: ActMode, rng: &mut ChaCha8Rng) -> Vec<f32> {
        let n = obs.len() / self.obs_dim;
        let noise = |rng: &mut ChaCha8Rng| standard_normal(n, self.action_dim, rng);
        match &mut self.networks {
            Networks::Burn(burn) => {
                let m = &burn.modules;
                let device = self.device.clone().without_autodiff();
                let obs = matrix(obs, self.obs_dim, &device);
                host(match mode {
                    ActMode::Deterministic => m
                        .actor_average
                        .as_ref()
                        .unwrap_or(&m.actor)
                        .valid()
                        .deterministic(obs),
                    ActMode::Explore | ActMode::Sample => {
                        let noise = matrix(&noise(rng), self.action_dim, &device);
                        m.actor.valid().sample(obs, noise).0
                    }
                })
            }
            Networks::Host(host) => match mode {
                ActMode::Deterministic => match &mut host.actor_average {
                    Some(average) => average.deterministic(obs),
                    None => host.actor.deterministic(obs),
                },
                ActMode::Explore | ActMode::Sample => {
                    host.actor.sample_detached(obs, &noise(rng)).0
                }
            },
        }
    }

    fn train_step(&mut self, batch: &ReplayBatch, lr: f64, rng: &mut ChaCha8Rng) -> Metrics {
        let context = StepContext {
            config: &self.config,
            obs_dim: self.obs_dim,
            action_dim: self.action_dim,
            gradient_steps: self.gradient_steps,
        };
        let metrics = match &mut self.networks {
            Networks::Burn(burn) => context.step(burn.as_mut(), batch, lr, rng),
            Networks::Host(host) => context.step(host.as_mut(), batch, lr, rng),
        };
        self.gradient_steps += 1;
        metrics
    }

    fn gradient_steps(&self) -> u64 {
        self.gradient_steps
    }

    fn save(&self, dir: &Path) -> Result<(), AgentError> {
        self.modules().save(dir)
    }

    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        let mut modules = self.modules();
        modules.zero_obs_inputs(inputs)?;
        self.set_modules(modules)
    }

    fn load(&mut self, dir: &Path) -> Result<(), AgentError> {
        let modules = self.modules().load(dir, self.config.tune_alpha)?;
        self.set_modules(modules)
            .map_err(|message| AgentError::File {
                path: dir.to_path_buf(),
                message,
            })
    }

    fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>) {
        self.optimisers().save_state(snap);
        snap.put_u64("sac.gradient_steps", self.gradient_steps);
    }

    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError> {
        let device = self.device.clone();
        match &mut self.networks {
            Networks::Burn(burn) => burn.optim.load_state(snap, &device)?,
            Networks::Host(host) => host.optim.load_state(snap, &device)?,
        }
        self.gradient_steps = snap.u64("sac.gradient_steps")?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use foosball_nets::Adam;
    use foosball_nets::Backend;

    fn device() -> Device {
        Backend::default_cpu().unwrap().device().unwrap()
    }

    /// A minibatch of `n` rows of `o`-wide observations and `a`-wide actions, the first
    /// `demos` rows demonstrations, every fourth row terminal.
    fn batch(n: usize, o: usize, a: usize, demos: usize, seed: u64) -> ReplayBatch {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut uniform = |k: usize, scale: f32| -> Vec<f32> {
            standard_normal(k, 1, &mut rng)
                .iter()
                .map(|x| (x * scale).tanh())
                .collect()
        };
        ReplayBatch {
            obs: uniform(n * o, 1.0),
            actions: uniform(n * a, 1.0),
            rewards: uniform(n, 1.0).iter().map(|r| 3.0 * r).collect(),
            next_obs: uniform(n * o, 1.0),
            dones: (0..n).map(|i| f32::from(u8::from(i % 4 == 3))).collect(),
            demos,
        }
    }

    /// An Adam whose first step is close to a plain gradient step, `lr g / (|g| + eps)`
    /// with `eps` large: parameters after one step show the gradient's size, not only
    /// its sign.
    fn gradient_revealing(mut c: SacConfig) -> SacConfig {
        c.net.adam.eps = 10.0;
        c.net.lr = crate::LrSchedule::Constant(10.0);
        c
    }

    /// Every parameter of the networks, the temperature last.
    fn flat(m: &Modules) -> Vec<f32> {
        let mut all = foosball_nets::params::host_params(&m.actor).concat();
        all.extend(foosball_nets::params::host_params(&m.critic).concat());
        all.extend(foosball_nets::params::host_params(&m.critic_target).concat());
        if let Some(average) = &m.actor_average {
            all.extend(foosball_nets::params::host_params(average).concat());
        }
        all.push(m.temperature.alpha().ln());
        all
    }

    /// The largest gap between `a` and `b`'s changes from `start`, over the largest change.
    fn change_gap(start: &[f32], a: &[f32], b: &[f32]) -> f32 {
        let (mut gap, mut size) = (0.0f32, 0.0f32);
        for ((s, a), b) in start.iter().zip(a).zip(b) {
            gap = gap.max(((a - s) - (b - s)).abs());
            size = size.max((a - s).abs()).max((b - s).abs());
        }
        assert!(size > 0.0, "the step changed nothing");
        gap / size
    }

    /// One step of SAC's losses written as Stable-Baselines3 writes them, gradients by
    /// Burn's autodiff through the whole loss (the way this file computed its update
    /// before the update was written over [`SacNetworks`]), on `m` with `config`'s Adam.
    fn reference_step(
        mut m: Modules,
        config: &SacConfig,
        (o, a): (usize, usize),
        batch: &ReplayBatch,
        rng: &mut ChaCha8Rng,
    ) -> Modules {
        use crate::tensors::vector;
        let dev = device();
        let plain = dev.clone().without_autodiff();
        let lr = 10.0;
        let adam = || Adam::new(config.net.adam.clone());
        let n = batch.rewards.len();
        let obs = matrix(&batch.obs, o, &dev);
        let noise = matrix(&standard_normal(n, a, rng), a, &dev);
        let (actions_pi, log_prob) = m.actor.sample(obs.clone(), noise);
        let alpha = m.temperature.alpha();
        // Temperature.
        let entropy_gap = log_prob.clone().detach().add_scalar(-(a as f32));
        let loss = (m.temperature.log_alpha_param() * entropy_gap).mean().neg();
        adam().step_in_place(&mut m.temperature, &mut loss.backward(), lr);
        // Critics.
        let next_obs = matrix(&batch.next_obs, o, &plain);
        let next_noise = matrix(&standard_normal(n, a, rng), a, &plain);
        let (next_actions, next_log_prob) = m.actor.valid().sample(next_obs.clone(), next_noise);
        let min_q_next = m.critic_target.valid().min(next_obs, next_actions);
        let soft = min_q_next - next_log_prob.mul_scalar(alpha);
        let not_done = vector(&batch.dones, &plain).neg().add_scalar(1.0);
        let y =
            (vector(&batch.rewards, &plain) + not_done.mul_scalar(config.gamma) * soft).autodiff();
        let (q1, q2) = m
            .critic
            .forward(obs.clone(), matrix(&batch.actions, a, &dev));
        let loss = ((q1 - y.clone()).square().mean() + (q2 - y).square().mean()).mul_scalar(0.5);
        adam().step_in_place(&mut m.critic, &mut loss.backward(), lr);
        // Actor.
        let min_q = m.critic.clone().no_grad().min(obs.clone(), actions_pi);
        let mut loss = (log_prob.mul_scalar(alpha) - min_q.clone()).mean();
        if let (Some(w), d) = (config.bc_weight, batch.demos) {
            let q_scale = min_q.detach().abs().mean().clamp_min(1e-6);
            let cloned = m.actor.deterministic(obs.narrow(0, 0, d));
            let bc = (cloned - matrix(&batch.actions[..d * a], a, &dev))
                .square()
                .mean();
            loss = loss / q_scale + bc.mul_scalar(w);
        }
        adam().step_in_place(&mut m.actor, &mut loss.backward(), lr);
        if let (Some(average), Some(tau)) = (&mut m.actor_average, config.actor_average_tau) {
            foosball_nets::polyak_update(average, &m.actor, tau);
        }
        foosball_nets::polyak_update(&mut m.critic_target, &m.critic, config.off_policy.tau);
        m
    }

    /// SAC's update on `(o, a, hidden)` networks, on either path, against
    /// [`reference_step`]: one step from the same networks, minibatch and noise.
    fn check_against_autodiff(config: SacConfig, (o, a): (usize, usize), hidden: Vec<usize>) {
        let mut config = gradient_revealing(config);
        config.net.hidden = hidden;
        let demos = if config.bc_weight.is_some() { 5 } else { 0 };
        let batch = batch(32, o, a, demos, 9);
        let make = || Sac::agent(o, a, config.clone(), 3, &device());
        let start = make().learner().modules();
        let expected = flat(&reference_step(
            start.clone(),
            &config,
            (o, a),
            &batch,
            &mut ChaCha8Rng::seed_from_u64(4),
        ));
        for host_path in [false, true] {
            let mut agent = make();
            let sac = agent.learner_mut();
            if host_path {
                sac.on_host_path().unwrap();
            }
            sac.train_step(&batch, 10.0, &mut ChaCha8Rng::seed_from_u64(4));
            let gap = change_gap(&flat(&start), &flat(&sac.modules()), &expected);
            assert!(
                gap < 1e-4,
                "host path {host_path}: {gap} of the step's size"
            );
        }
    }

    #[test]
    fn the_update_is_the_gradient_of_sacs_losses_on_both_paths() {
        check_against_autodiff(SacConfig::default(), (38, 8), vec![64, 64]);
        check_against_autodiff(SacConfig::default(), (38, 8), vec![256, 256]);
        let options = SacConfig {
            init_alpha: 0.2,
            actor_average_tau: Some(0.3),
            bc_weight: Some(0.4),
            off_policy: OffPolicyConfig {
                demo_share: Some(0.25),
                tau: 0.1,
                ..OffPolicyConfig::default()
            },
            ..SacConfig::default()
        };
        check_against_autodiff(options, (5, 3), vec![16]);
        let tanh = SacConfig {
            net: NetConfig {
                activation: foosball_nets::Activation::Tanh,
                ..NetConfig::default()
            },
            ..SacConfig::default()
        };
        check_against_autodiff(tanh, (7, 2), vec![32, 32]);
    }

    #[test]
    fn the_host_path_follows_the_burn_path_over_many_steps_and_through_files() {
        let mut config = SacConfig::default();
        config.net.hidden = vec![64, 64];
        let (o, a) = (38, 8);
        let make = |host_path: bool| {
            let mut agent = Sac::agent(o, a, config.clone(), 11, &device());
            if host_path {
                agent.learner_mut().on_host_path().unwrap();
            }
            agent
        };
        let (mut burn, mut host) = (make(false), make(true));
        let mut rng = (ChaCha8Rng::seed_from_u64(1), ChaCha8Rng::seed_from_u64(1));
        for k in 0..50 {
            let batch = batch(64, o, a, 0, 100 + k);
            let mb = burn.learner_mut().train_step(&batch, 3e-4, &mut rng.0);
            let mh = host.learner_mut().train_step(&batch, 3e-4, &mut rng.1);
            for ((name, b), (_, h)) in mb.0.into_iter().zip(mh.0) {
                let (b, h) = (b.read(), h.read());
                assert!(
                    (b - h).abs() <= 1e-3 * b.abs().max(1.0),
                    "step {k}: {name} {b} vs {h}"
                );
            }
        }
        let (pb, ph) = (
            flat(&burn.learner().modules()),
            flat(&host.learner().modules()),
        );
        let start = flat(&make(false).learner().modules());
        assert!(change_gap(&start, &pb, &ph) < 1e-3);
        // Acting: the same actions from the same networks.
        let obs = batch(4, o, a, 0, 7).obs;
        let acts = |agent: &mut SacAgent| {
            use crate::agent::Agent;
            agent.act(&obs, ActMode::Deterministic)
        };
        let (ab, ah) = (acts(&mut burn), acts(&mut host));
        assert!(
            ab.iter().zip(&ah).all(|(x, y)| (x - y).abs() < 1e-3),
            "{ab:?} {ah:?}"
        );
        // Files: a host agent's networks load into a Burn agent and back.
        let dir = std::env::temp_dir().join(format!("sac-host-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        crate::agent::Agent::save(&host, &dir).unwrap();
        let (mut loaded_burn, mut loaded_host) = (make(false), make(true));
        crate::agent::Agent::load(&mut loaded_burn, &dir).unwrap();
        crate::agent::Agent::load(&mut loaded_host, &dir).unwrap();
        assert_eq!(flat(&loaded_burn.learner().modules()), ph);
        assert_eq!(flat(&loaded_host.learner().modules()), ph);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_host_path_refuses_what_it_does_not_compute() {
        let mut config = SacConfig::default();
        config.net.critic_layer_norm = true;
        let mut agent = Sac::agent(5, 2, config, 1, &device());
        let err = agent.learner_mut().on_host_path().unwrap_err();
        assert!(err.contains("layer normalisation"), "{err}");
        let image = ObsShape::Image {
            channels: 3,
            height: 36,
            width: 36,
        };
        let mut agent = Sac::agent(image, 2, SacConfig::default(), 1, &device());
        let err = agent.learner_mut().on_host_path().unwrap_err();
        assert!(err.contains("image"), "{err}");
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
        let live = host(agent.learner().actor().deterministic(matrix(
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
