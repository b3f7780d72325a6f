//! Twin Delayed DDPG (Fujimoto et al. 2018) as Stable-Baselines3 defines it.
//!
//! Per gradient step, on a minibatch `(s, a, r, s', d)`:
//! 1. target action `a' = clip(pi'(s') + clip(eps, -c, c), -1, 1)`, `eps ~ N(0, sigma^2)`
//!    drawn per element;
//! 2. critics: `y = r + gamma (1 - d) min(Q1', Q2')(s', a')` (`gamma^n` with `n_step`
//!    returns),
//!    `L = MSE(Q1(s, a), y) + MSE(Q2(s, a), y)`;
//! 3. every `policy_delay` steps: actor `L = -mean(Q1(s, pi(s))) + action_l2 mean(pi(s)^2)`
//!    (the penalty 0 by default, as SB3; OpenAI Baselines' HER DDPG uses 1), then polyak
//!    updates of both target networks (targets move only on these delayed steps).
//!
//! Exploration adds `action_noise * x` to the deterministic action, clipped to `[-1, 1]`,
//! `x` standard normal drawn anew each step (SB3) or an AR(1) process over the episode
//! (`action_noise_correlation`, [`crate::correlated_noise`]; DDPG's Ornstein-Uhlenbeck).
//!
//! The step computes the losses' gradients with respect to the networks' outputs
//! (`dL/dQk = 2 (Qk - y) / n`; the actor's `dL/dQ1 = -1 / n`, walked back through the
//! frozen critic to the actions) and lets the networks walk them back, as SAC's does:
//! Burn's autodiff, or the host MLP path (`backend = "host"`, [`crate::td3_networks`]).

use crate::agent::{ActMode, AgentError, Metrics};
use crate::config::{ConfigError, DEFAULT_GAMMA, NetConfig, OffPolicyConfig, check_gamma, ensure};
use crate::correlated_noise::CorrelatedNoise;
use crate::critics::{Critics, Walk};
use crate::network_path::OnPath;
use crate::off_policy::{OffPolicy, OffPolicyLearner};
use crate::policy_chain::Step;
use crate::replay::ReplayBatch;
use crate::rows::{Rows, bellman};
use crate::td3_networks::{BurnNetworks, HostNetworks, Modules, Td3Networks};
use crate::tensors::{host, matrix, standard_normal};
use burn::module::Module;
use foosball_nets::{
    Adam, DeterministicActor, Device, ObsShape, Scalar, Snapshot, SnapshotError, TwinQ,
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
    /// Weight of the actor's penalty on its actions' mean square (the mean over the batch
    /// and the action's elements, in squared action units; 0 disables it): it pulls an
    /// actor off actions the table answers alike, such as a turn past the paper code's
    /// clamp at `|a|` > 0.125, where the critic's slope in the action is zero.
    pub action_l2: f32,
    /// Step correlation `rho` in `[0, 1)` of the exploration noise, an AR(1) process
    /// restarted with every episode; 0 is SB3's white noise.
    pub action_noise_correlation: f32,
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
            action_l2: 0.0,
            action_noise_correlation: 0.0,
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
        )?;
        ensure(
            non_negative(self.action_l2),
            "action_l2",
            "must be finite and >= 0",
        )?;
        ensure(
            (0.0..1.0).contains(&self.action_noise_correlation),
            "action_noise_correlation",
            "must be in [0, 1)",
        )
    }
}

/// Target policy smoothing: `clip(next_actions + clip(noise, -clip, clip), -1, 1)`,
/// element by element, `[batch, action_dim]`.
pub fn smoothed_target_actions<R: Rows>(
    r: &R,
    next_actions: &R::M,
    noise: &R::M,
    noise_clip: f32,
) -> R::M {
    let noise = r.clamp_matrix(noise, -noise_clip, noise_clip);
    r.clamp_matrix(&r.add_matrix(next_actions, &noise), -1.0, 1.0)
}

/// TD3's networks, optimisers and counters.
pub struct Td3 {
    config: Td3Config,
    obs_dim: usize,
    action_dim: usize,
    device: Device,
    networks: OnPath<BurnNetworks, HostNetworks>,
    gradient_steps: u64,
    last_actor_loss: Scalar,
    noise: CorrelatedNoise,
    /// Per env, 1 where the next action begins an episode.
    noise_starts: Vec<f32>,
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
        let modules = Modules {
            actor_target: actor.clone().no_grad(),
            critic_target: critic.clone().no_grad(),
            actor,
            critic,
        };
        let adam = || Adam::new(n.adam.clone());
        let networks = BurnNetworks::new(modules, adam(), adam(), device);
        let learner = Td3 {
            obs_dim,
            action_dim,
            device: device.clone(),
            networks: OnPath::Burn(Box::new(networks)),
            gradient_steps: 0,
            last_actor_loss: Scalar::Host(f64::NAN),
            noise: CorrelatedNoise::new(config.action_noise_correlation),
            noise_starts: Vec::new(),
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
        let adam = || Adam::new(self.config.net.adam.clone());
        (self.networks).to_host(|modules| HostNetworks::from_modules(modules, adam(), adam()))
    }

    /// The networks as Burn modules (the host path's copied out).
    pub fn modules(&self) -> Modules {
        self.networks.modules()
    }

    /// The actor.
    pub fn actor(&self) -> DeterministicActor {
        self.modules().actor
    }

    /// The twin critics.
    pub fn critic(&self) -> TwinQ {
        self.modules().critic
    }
}

/// What a gradient step reads besides its networks and minibatch.
struct StepContext<'a> {
    config: &'a Td3Config,
    obs_dim: usize,
    action_dim: usize,
    /// Gradient steps taken before this one.
    gradient_steps: u64,
}

impl StepContext<'_> {
    /// One gradient step (steps 1-3 of the module docs) on either path: its metrics but
    /// the actor's loss, and the actor's loss when the actor stepped.
    fn step<N: Td3Networks>(
        &self,
        nets: &mut N,
        batch: &ReplayBatch,
        lr: f64,
        rng: &mut ChaCha8Rng,
    ) -> (Metrics, Option<Scalar>) {
        let c = self.config;
        let r = nets.critics().rows();
        let (o, a) = (self.obs_dim, self.action_dim);
        let n = batch.rewards.len();
        let per_row = 1.0 / n as f32;

        // 1-2. Critics against the smoothed target: dL/dQk = 2 (Qk - y) / n.
        let next_obs = r.matrix(&batch.next_obs, o);
        let noise: Vec<f32> = standard_normal(n, a, rng)
            .iter()
            .map(|e| e * c.target_policy_noise)
            .collect();
        let next_actions = smoothed_target_actions(
            &r,
            &nets.target_actions(&next_obs),
            &r.matrix(&noise, a),
            c.target_noise_clip,
        );
        let min_q_next = nets.critics().target_min(&next_obs, &next_actions);
        let (rewards, dones) = (r.vector(&batch.rewards), r.vector(&batch.dones));
        let discount = c.off_policy.bootstrap_discount(c.gamma);
        let y = bellman(&r, &rewards, &dones, &min_q_next, discount);
        let obs = r.matrix(&batch.obs, o);
        let batch_actions = r.matrix(&batch.actions, a);
        let (q1, q2) = nets.critics().q_values(&obs, &batch_actions, Walk::Params);
        let (e1, e2) = (r.sub(&q1, &y), r.sub(&q2, &y));
        let critic_loss = r.add(&r.mean(&r.square(&e1)), &r.mean(&r.square(&e2)));
        let dq = [
            r.affine(&e1, 2.0 * per_row, 0.0),
            r.affine(&e2, 2.0 * per_row, 0.0),
        ];
        let critic_report = nets.critics().critic_step([&dq[0], &dq[1]], lr);

        // 3. Delayed actor and target updates: L = -mean(Q1(s, pi(s))) + l2 mean(pi(s)^2),
        // dL/dQ1 = -1 / n, and the penalty's dL/da = 2 l2 a / (n action_dim).
        let actor_loss = (self.gradient_steps + 1)
            .is_multiple_of(c.policy_delay)
            .then(|| {
                let actions = nets.actions(&obs);
                let q_pi = nets.critics().first_q(&obs, &actions);
                let d_q_pi = r.affine(&q_pi, 0.0, -per_row);
                let mut d_actions = nets.critics().action_gradient(&[&d_q_pi]);
                let mut loss = r.affine(&r.mean(&q_pi), -1.0, 0.0);
                if c.action_l2 > 0.0 {
                    let slope = 2.0 * c.action_l2 / (n * a) as f32;
                    d_actions = r.add_matrix(&d_actions, &r.scale_matrix(&actions, slope));
                    let penalty = r.affine(&r.mean_square(&actions), c.action_l2, 0.0);
                    loss = r.add(&loss, &penalty);
                }
                nets.actor_step(&d_actions, lr);
                let tau = c.off_policy.tau;
                nets.critics().update_target(tau);
                nets.update_actor_target(tau);
                r.scalar(&loss)
            });

        let metrics = Metrics(vec![
            ("critic_loss", r.scalar(&critic_loss)),
            ("q_mean", r.scalar(&r.mean(&q1))),
            ("critic_grad_norm", critic_report.grad_norm),
        ]);
        (metrics, actor_loss)
    }
}

impl OffPolicyLearner for Td3 {
    fn policy_act(&mut self, obs: &[f32], mode: ActMode, rng: &mut ChaCha8Rng) -> Vec<f32> {
        let mut actions = match &mut self.networks {
            OnPath::Burn(burn) => {
                let device = self.device.clone().without_autodiff();
                host(
                    burn.actor
                        .valid()
                        .forward(matrix(obs, self.obs_dim, &device)),
                )
            }
            OnPath::Host(host) => host.actor.forward_detached(obs),
        };
        let sigma = self.config.action_noise;
        if mode == ActMode::Explore && sigma > 0.0 {
            let noise = standard_normal(actions.len(), 1, rng);
            let noise = self.noise.next(noise, &self.noise_starts);
            self.noise_starts.fill(0.0);
            for (x, e) in actions.iter_mut().zip(noise) {
                *x = (*x + sigma * e).clamp(-1.0, 1.0);
            }
        }
        actions
    }

    fn train_step(&mut self, batch: &ReplayBatch, lr: f64, rng: &mut ChaCha8Rng) -> Metrics {
        let context = StepContext {
            config: &self.config,
            obs_dim: self.obs_dim,
            action_dim: self.action_dim,
            gradient_steps: self.gradient_steps,
        };
        let (Metrics(mut metrics), actor_loss) = match &mut self.networks {
            OnPath::Burn(burn) => context.step(burn.as_mut(), batch, lr, rng),
            OnPath::Host(host) => context.step(host.as_mut(), batch, lr, rng),
        };
        self.gradient_steps += 1;
        if let Some(loss) = actor_loss {
            self.last_actor_loss = loss;
        }
        metrics.insert(1, ("actor_loss", self.last_actor_loss.clone()));
        Metrics(metrics)
    }

    fn gradient_steps(&self) -> u64 {
        self.gradient_steps
    }

    fn episodes_ended(&mut self, ended: &[bool]) {
        self.noise_starts = ended.iter().map(|&e| f32::from(u8::from(e))).collect();
    }

    fn save(&self, dir: &Path) -> Result<(), AgentError> {
        self.modules().save(dir)
    }

    /// `tanh` of the actor's output.
    fn policy_chain(&self) -> Result<Vec<Step>, String> {
        let mlp = self.modules().actor.to_host()?.mlp;
        Ok(vec![Step::Mlp(mlp), Step::Tanh])
    }

    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        let mut modules = self.modules();
        modules.zero_obs_inputs(inputs)?;
        self.networks.set_modules(modules)
    }

    fn load(&mut self, dir: &Path) -> Result<(), AgentError> {
        let modules = self.modules().load(dir)?;
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
                burn.actor_optim.save_state(snap, "td3.actor_adam");
                burn.critics.save_state(snap, "td3");
            }
            OnPath::Host(host) => {
                host.actor_optim.save_state(snap, "td3.actor_adam");
                host.critics.save_state(snap, "td3");
            }
        }
        snap.put_u64("td3.gradient_steps", self.gradient_steps);
        snap.put_f64("td3.last_actor_loss", self.last_actor_loss.clone().read());
        self.noise.save_state(snap, "td3.noise");
        if self.config.action_noise_correlation != 0.0 {
            snap.put_f32("td3.noise_starts", &self.noise_starts[..]);
        }
    }

    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError> {
        let d = &self.device;
        match &mut self.networks {
            OnPath::Burn(burn) => {
                burn.actor_optim.load_state(snap, "td3.actor_adam", d)?;
                burn.critics.load_state(snap, "td3")?;
            }
            OnPath::Host(host) => {
                host.actor_optim.load_state(snap, "td3.actor_adam", d)?;
                host.critics.load_state(snap, "td3", d)?;
            }
        }
        self.gradient_steps = snap.u64("td3.gradient_steps")?;
        self.last_actor_loss = Scalar::Host(snap.f64("td3.last_actor_loss")?);
        self.noise.load_state(snap, "td3.noise")?;
        if self.config.action_noise_correlation != 0.0 {
            self.noise_starts = snap.f32s("td3.noise_starts")?.to_vec();
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{
        batch, device, gradient_revealing, host_follows_burn, host_path_refusals, steps_as_expected,
    };

    #[test]
    fn target_smoothing_clips_the_noise_then_the_action_per_element() {
        let r = crate::rows::HostRows;
        let next = r.matrix(&[0.9, -0.2, 0.0, 0.1], 2);
        let noise = r.matrix(&[0.7, -0.1, -0.8, 0.3], 2);
        let got = smoothed_target_actions(&r, &next, &noise, 0.5).data;
        let want = [1.0, -0.3, -0.5, 0.4];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-6, "{got:?}");
        }
    }

    /// An `(o, a)` agent from `config` and `seed`, on the host path when `host_path`.
    fn on_path((o, a): (usize, usize), config: &Td3Config, seed: u64, host_path: bool) -> Td3Agent {
        let mut agent = Td3::agent(o, a, config.clone(), seed, &device());
        if host_path {
            agent.learner_mut().on_host_path().unwrap();
        }
        agent
    }

    /// Every parameter of the networks.
    fn flat(m: &Modules) -> Vec<f32> {
        let mut all = foosball_nets::params::host_params(&m.actor).concat();
        all.extend(foosball_nets::params::host_params(&m.actor_target).concat());
        all.extend(foosball_nets::params::host_params(&m.critic).concat());
        all.extend(foosball_nets::params::host_params(&m.critic_target).concat());
        all
    }

    /// One step of TD3's losses written as Stable-Baselines3 writes them, gradients by
    /// Burn's autodiff through each whole loss (the way this file computed its update
    /// before it was written over [`Td3Networks`]), on `m` with `config`'s Adam; the
    /// actor steps (`policy_delay` = 1).
    fn reference_step(
        mut m: Modules,
        c: &Td3Config,
        (o, a): (usize, usize),
        batch: &ReplayBatch,
        rng: &mut ChaCha8Rng,
    ) -> Modules {
        use crate::tensors::vector;
        let dev = device();
        let plain = dev.clone().without_autodiff();
        let (lr, n) = (10.0, batch.rewards.len());
        let adam = || Adam::new(c.net.adam.clone());
        // Critics.
        let next_obs = matrix(&batch.next_obs, o, &plain);
        let noise = matrix(&standard_normal(n, a, rng), a, &plain)
            .mul_scalar(c.target_policy_noise)
            .clamp(-c.target_noise_clip, c.target_noise_clip);
        let next_actions =
            (m.actor_target.valid().forward(next_obs.clone()) + noise).clamp(-1.0, 1.0);
        let min_q_next = m.critic_target.valid().min(next_obs, next_actions);
        let not_done = vector(&batch.dones, &plain).neg().add_scalar(1.0);
        let y =
            (vector(&batch.rewards, &plain) + not_done.mul_scalar(c.gamma) * min_q_next).autodiff();
        let obs = matrix(&batch.obs, o, &dev);
        let (q1, q2) = m
            .critic
            .forward(obs.clone(), matrix(&batch.actions, a, &dev));
        let loss = (q1 - y.clone()).square().mean() + (q2 - y).square().mean();
        adam().step_in_place(&mut m.critic, &mut loss.backward(), lr);
        // Actor against the updated first critic (with the action penalty), then both
        // targets.
        let actions = m.actor.forward(obs.clone());
        let loss = m.critic.q1_frozen(obs, actions.clone()).mean().neg()
            + actions.square().mean().mul_scalar(c.action_l2);
        adam().step_in_place(&mut m.actor, &mut loss.backward(), lr);
        let tau = c.off_policy.tau;
        foosball_nets::polyak_update(&mut m.critic_target, &m.critic, tau);
        foosball_nets::polyak_update(&mut m.actor_target, &m.actor, tau);
        m
    }

    /// TD3's update on `(o, a, hidden)` networks, on either path, against
    /// [`reference_step`]: one step from the same networks, minibatch and noise.
    fn check_against_autodiff(mut config: Td3Config, (o, a): (usize, usize), hidden: Vec<usize>) {
        gradient_revealing(&mut config.net);
        config.net.hidden = hidden;
        config.policy_delay = 1;
        let batch = batch(32, o, a, 0, 9);
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
    fn the_update_is_the_gradient_of_td3s_losses_on_both_paths() {
        check_against_autodiff(Td3Config::default(), (38, 8), vec![64, 64]);
        check_against_autodiff(Td3Config::default(), (38, 8), vec![256, 256]);
        let options = Td3Config {
            target_policy_noise: 0.6,
            target_noise_clip: 0.3,
            off_policy: OffPolicyConfig {
                tau: 0.1,
                ..OffPolicyConfig::default()
            },
            net: NetConfig {
                activation: foosball_nets::Activation::Tanh,
                ..NetConfig::default()
            },
            action_l2: 0.7,
            ..Td3Config::default()
        };
        check_against_autodiff(options, (5, 3), vec![16]);
        let penalised = Td3Config {
            action_l2: 1.0,
            ..Td3Config::default()
        };
        check_against_autodiff(penalised, (38, 8), vec![64, 64]);
    }

    #[test]
    fn the_host_path_follows_the_burn_path_over_many_steps_and_through_files() {
        let mut config = Td3Config::default();
        config.net.hidden = vec![64, 64];
        let make = |host_path| on_path((38, 8), &config, 11, host_path);
        host_follows_burn(make, |l| flat(&l.modules()), (38, 8));
    }

    #[test]
    fn the_host_path_refuses_what_it_does_not_compute() {
        host_path_refusals(|obs, critic_layer_norm| {
            let mut config = Td3Config::default();
            config.net.critic_layer_norm = critic_layer_norm;
            Td3::agent(obs, 2, config, 1, &device())
                .learner_mut()
                .on_host_path()
        });
    }

    /// A TD3 agent on 2 envs (3 -> 2) that acts from its first step, exploration noise 0.2
    /// of step correlation `rho`, gradient steps far away.
    fn exploring(rho: f32) -> Td3Agent {
        let mut c = Td3Config {
            action_noise: 0.2,
            action_noise_correlation: rho,
            ..Td3Config::default()
        };
        c.off_policy.learning_starts = 0;
        c.off_policy.train_freq = 1_000_000;
        Td3::agent(3, 2, c, 4, &device())
    }

    #[test]
    fn correlated_action_noise_holds_deviations_restarts_with_episodes_and_resumes() {
        crate::test_support::correlated_exploration_holds_restarts_and_resumes(exploring);
        let bad = Td3Config {
            action_noise_correlation: -0.1,
            ..Td3Config::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("action_noise_correlation"), "{e}");
    }
}
