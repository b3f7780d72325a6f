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
use crate::critics::{Critics, Walk};
use crate::network_path::OnPath;
use crate::off_policy::{OffPolicy, OffPolicyLearner};
use crate::policy_chain::Step;
use crate::replay::ReplayBatch;
use crate::rows::{Rows, bellman};
use crate::sac_networks::{
    BurnNetworks, HostNetworks, Modules, Optimisers, SacNetworks, Temperature,
};
use crate::tensors::{host, matrix, standard_normal};
use burn::module::Module;
use foosball_nets::{
    Adam, Device, ObsShape, Snapshot, SnapshotError, SquashedGaussianActor, TwinQ,
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

/// SAC's networks, optimisers and counters.
pub struct Sac {
    config: SacConfig,
    obs_dim: usize,
    action_dim: usize,
    device: Device,
    networks: OnPath<BurnNetworks, HostNetworks>,
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
        let (optim, critic_optim) = (Optimisers::new(&n.adam), Adam::new(n.adam.clone()));
        let networks = BurnNetworks::new(modules, optim, critic_optim, device);
        let learner = Sac {
            obs_dim,
            action_dim,
            device: device.clone(),
            networks: OnPath::Burn(Box::new(networks)),
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
        let adam = &self.config.net.adam;
        (self.networks).to_host(|modules| {
            HostNetworks::from_modules(modules, Optimisers::new(adam), Adam::new(adam.clone()))
        })
    }

    /// The networks as Burn modules (the host path's copied out).
    pub fn modules(&self) -> Modules {
        self.networks.modules()
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
            OnPath::Burn(burn) => burn.temperature.alpha(),
            OnPath::Host(host) => host.log_alpha[0].exp(),
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
        let r = nets.critics().rows();
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
        let min_q_next = nets.critics().target_min(&next_obs, &next_actions);
        let soft_value = r.sub(&min_q_next, &r.mul(&next_log_prob, &alpha));
        let (rewards, dones) = (r.vector(&batch.rewards), r.vector(&batch.dones));
        let y = bellman(&r, &rewards, &dones, &soft_value, gamma);
        let batch_actions = r.matrix(&batch.actions, a);
        let (q1, q2) = nets.critics().q_values(&obs, &batch_actions, Walk::Params);
        let (e1, e2) = (r.sub(&q1, &y), r.sub(&q2, &y));
        let mse = r.add(&r.mean(&r.square(&e1)), &r.mean(&r.square(&e2)));
        let critic_loss = r.affine(&mse, 0.5, 0.0);
        let dq = [r.affine(&e1, per_row, 0.0), r.affine(&e2, per_row, 0.0)];
        let critic_report = nets.critics().critic_step([&dq[0], &dq[1]], lr);

        // 4. Actor, against the updated critics: L = s mean(alpha log pi - min Q)
        //    (+ w mean((tanh(mean_d) - a_d)^2)), s = 1, or 1 / mean|min Q| when cloning.
        let (q1_pi, q2_pi) = nets.critics().q_values(&obs, &actions_pi, Walk::Actions);
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
        let d_actions = nets.critics().action_gradient(&[&d_q_pi[0], &d_q_pi[1]]);
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
            nets.critics().update_target(self.config.off_policy.tau);
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
            OnPath::Burn(burn) => {
                let m = burn.as_ref();
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
            OnPath::Host(host) => match mode {
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
            OnPath::Burn(burn) => context.step(burn.as_mut(), batch, lr, rng),
            OnPath::Host(host) => context.step(host.as_mut(), batch, lr, rng),
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

    /// `tanh` of the mean half of the actor's output (the averaged actor where kept:
    /// what acts deterministically).
    fn policy_chain(&self) -> Result<Vec<Step>, String> {
        let modules = self.modules();
        let actor = modules.actor_average.as_ref().unwrap_or(&modules.actor);
        let mlp = actor.to_host()?.mlp;
        Ok(vec![
            Step::Mlp(mlp),
            Step::First(self.action_dim),
            Step::Tanh,
        ])
    }

    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        let mut modules = self.modules();
        modules.zero_obs_inputs(inputs)?;
        self.networks.set_modules(modules)
    }

    fn load(&mut self, dir: &Path) -> Result<(), AgentError> {
        let modules = self.modules().load(dir, self.config.tune_alpha)?;
        self.networks
            .set_modules(modules)
            .map_err(|message| AgentError::File {
                path: dir.to_path_buf(),
                message,
            })
    }

    fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>) {
        match &self.networks {
            OnPath::Burn(burn) => {
                burn.optim.save_state(snap);
                burn.critics.save_state(snap, "sac");
            }
            OnPath::Host(host) => {
                host.optim.save_state(snap);
                host.critics.save_state(snap, "sac");
            }
        }
        snap.put_u64("sac.gradient_steps", self.gradient_steps);
    }

    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError> {
        let device = self.device.clone();
        match &mut self.networks {
            OnPath::Burn(burn) => {
                burn.optim.load_state(snap, &device)?;
                burn.critics.load_state(snap, "sac")?;
            }
            OnPath::Host(host) => {
                host.optim.load_state(snap, &device)?;
                host.critics.load_state(snap, "sac", &device)?;
            }
        }
        self.gradient_steps = snap.u64("sac.gradient_steps")?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{
        batch, device, gradient_revealing, host_follows_burn, host_path_refusals, steps_as_expected,
    };

    /// An `(o, a)` agent from `config` and `seed`, on the host path when `host_path`.
    fn on_path((o, a): (usize, usize), config: &SacConfig, seed: u64, host_path: bool) -> SacAgent {
        let mut agent = Sac::agent(o, a, config.clone(), seed, &device());
        if host_path {
            agent.learner_mut().on_host_path().unwrap();
        }
        agent
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
        let mut config = config;
        gradient_revealing(&mut config.net);
        config.net.hidden = hidden;
        let demos = if config.bc_weight.is_some() { 5 } else { 0 };
        let batch = batch(32, o, a, demos, 9);
        let make = |host_path| on_path((o, a), &config, 3, host_path);
        let start = make(false).learner().modules();
        let expected = flat(&reference_step(
            start.clone(),
            &config,
            (o, a),
            &batch,
            &mut ChaCha8Rng::seed_from_u64(4),
        ));
        steps_as_expected(make, |l| flat(&l.modules()), &batch, &expected);
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
        let make = |host_path| on_path((38, 8), &config, 11, host_path);
        host_follows_burn(make, |l| flat(&l.modules()), (38, 8));
    }

    #[test]
    fn the_host_path_refuses_what_it_does_not_compute() {
        host_path_refusals(|obs, critic_layer_norm| {
            let mut config = SacConfig::default();
            config.net.critic_layer_norm = critic_layer_norm;
            Sac::agent(obs, 2, config, 1, &device())
                .learner_mut()
                .on_host_path()
        });
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
                teacher: None,
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
