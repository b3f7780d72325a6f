//! Proximal Policy Optimization (Schulman et al. 2017) as Stable-Baselines3 defines it.
//!
//! Collect `n_steps` vec-env steps with the stochastic policy (truncated episodes
//! bootstrapped: `r += gamma V(s_final)`), compute GAE, then `n_epochs` passes of
//! shuffled minibatches minimising
//! `L = L_clip + ent_coef * (-mean(entropy)) + vf_coef * MSE(returns, V(s))`,
//! `L_clip = -mean(min(A ratio, A clip(ratio, 1 - eps, 1 + eps)))`,
//! `ratio = exp(log pi(a|s) - log pi_old(a|s))`, advantages normalised per minibatch.

use crate::agent::{ActMode, Agent, AgentError, Experience, Metrics};
use crate::config::{ConfigError, DEFAULT_GAMMA, NetConfig, check_gamma, ensure};
use crate::rollout_buffer::{RolloutBuffer, gae};
use crate::schedule::LrSchedule;
use crate::tensors::{host, matrix, mean, standard_normal, vector};
use burn::module::Module;
use foosball_nets::distributions::diag_gaussian_log_prob;
use foosball_nets::host::{is_host, read_all};
use foosball_nets::store::{load_module, save_module};
use foosball_nets::{
    Activation, Adam, AdamConfig, CnnConfig, Device, GaussianPolicy, ObsShape, Scalar, Snapshot,
    SnapshotError, Tensor, ValueCritic,
};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// PPO's settings (SB3 defaults).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PpoConfig {
    /// Policy and value networks (separate, same widths) and their one optimiser.
    pub net: NetConfig,
    /// Vec-env steps per rollout (rows = `n_steps * n_envs`).
    pub n_steps: usize,
    /// Minibatch rows.
    pub batch_size: usize,
    /// Passes over each rollout.
    pub n_epochs: usize,
    /// Discount factor.
    pub gamma: f32,
    /// GAE's lambda.
    pub gae_lambda: f32,
    /// Clip range `eps` of the probability ratio.
    pub clip_range: f32,
    /// Entropy bonus coefficient.
    pub ent_coef: f32,
    /// Value loss coefficient.
    pub vf_coef: f32,
    /// Normalise advantages per minibatch.
    pub normalize_advantage: bool,
    /// Stop a rollout's epochs once approx-KL exceeds `1.5 * target_kl`.
    pub target_kl: Option<f32>,
}

impl Default for PpoConfig {
    fn default() -> Self {
        Self {
            net: NetConfig {
                hidden: vec![64, 64],
                activation: Activation::Tanh,
                lr: LrSchedule::Constant(3e-4),
                adam: AdamConfig {
                    max_grad_norm: Some(0.5),
                    ..AdamConfig::default()
                },
                cnn: CnnConfig::default(),
                critic_layer_norm: false,
            },
            n_steps: 2048,
            batch_size: 64,
            n_epochs: 10,
            gamma: DEFAULT_GAMMA,
            gae_lambda: 0.95,
            clip_range: 0.2,
            ent_coef: 0.0,
            vf_coef: 0.5,
            normalize_advantage: true,
            target_kl: None,
        }
    }
}

impl PpoConfig {
    /// Rejects invalid settings, naming the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.net.validate().map_err(|e| e.under("net"))?;
        ensure(
            !self.net.critic_layer_norm,
            "net.critic_layer_norm",
            "applies to SAC's and TD3's Q-networks; PPO's value network has none",
        )?;
        ensure(self.n_steps > 0, "n_steps", "must be positive")?;
        ensure(self.batch_size > 1, "batch_size", "must be at least 2")?;
        ensure(self.n_epochs > 0, "n_epochs", "must be positive")?;
        check_gamma(self.gamma)?;
        ensure(
            (0.0..=1.0).contains(&self.gae_lambda),
            "gae_lambda",
            "must be in [0, 1]",
        )?;
        ensure(self.clip_range > 0.0, "clip_range", "must be positive")?;
        ensure(self.ent_coef.is_finite(), "ent_coef", "must be finite")?;
        ensure(
            self.vf_coef.is_finite() && self.vf_coef >= 0.0,
            "vf_coef",
            "must be >= 0",
        )?;
        ensure(
            self.target_kl.is_none_or(|k| k > 0.0),
            "target_kl",
            "must be positive",
        )
    }
}

/// `(a - mean(a)) / (std(a) + 1e-8)` with the unbiased std, as SB3 (torch) computes it.
pub fn normalize_advantages(advantages: &[f32]) -> Vec<f32> {
    let n = advantages.len() as f64;
    let m = advantages.iter().map(|&a| f64::from(a)).sum::<f64>() / n;
    let var = advantages
        .iter()
        .map(|&a| (f64::from(a) - m).powi(2))
        .sum::<f64>()
        / (n - 1.0);
    let scale = var.sqrt() + 1e-8;
    advantages
        .iter()
        .map(|&a| ((f64::from(a) - m) / scale) as f32)
        .collect()
}

/// The clipped surrogate and its diagnostics for one minibatch.
pub struct Surrogate {
    /// `-mean(min(A ratio, A clip(ratio, 1 - eps, 1 + eps)))`, one element.
    pub loss: Tensor<1>,
    /// Share of rows with `|ratio - 1| > eps`.
    pub clip_fraction: Scalar,
    /// `mean((ratio - 1) - log ratio)`, the low-variance KL estimate SB3 logs.
    pub approx_kl: Scalar,
}

/// PPO's clipped objective; `log_prob` `[batch]` carries the gradient, `old_log_prob`
/// and `advantages` `[batch]` are constants. The diagnostics are summed on the host in
/// f64 on a CPU backend (a read is free there) and stay on the device on a GPU, where
/// only `target_kl` reads the KL estimate back.
pub fn clipped_surrogate(
    log_prob: Tensor<1>,
    old_log_prob: Tensor<1>,
    advantages: Tensor<1>,
    clip: f32,
) -> Surrogate {
    let log_ratio = log_prob - old_log_prob;
    let ratio = log_ratio.clone().exp();
    let unclipped = advantages.clone() * ratio.clone();
    let clipped = advantages * ratio.clone().clamp(1.0 - clip, 1.0 + clip);
    let loss = unclipped.min_pair(clipped).mean().neg();
    let (ratio, log_ratio) = (ratio.inner(), log_ratio.inner());
    if !is_host(&ratio.device()) {
        let excess = ratio.sub_scalar(1.0);
        return Surrogate {
            loss,
            clip_fraction: Scalar::of(excess.clone().abs().greater_elem(clip).float().mean()),
            approx_kl: Scalar::of((excess - log_ratio).mean()),
        };
    }
    // One read for both.
    let [ratio, log_ratio]: [Vec<f32>; 2] = read_all(vec![ratio, log_ratio])
        .into_iter()
        .map(|d| d.try_into_vec::<f32>().expect("float tensors are f32"))
        .collect::<Vec<_>>()
        .try_into()
        .expect("two tensors read");
    let n = ratio.len() as f64;
    let clip_fraction = ratio.iter().filter(|r| (*r - 1.0).abs() > clip).count() as f64 / n;
    let approx_kl = ratio
        .iter()
        .zip(&log_ratio)
        .map(|(r, l)| f64::from(r - 1.0 - l))
        .sum::<f64>()
        / n;
    Surrogate {
        loss,
        clip_fraction: clip_fraction.into(),
        approx_kl: approx_kl.into(),
    }
}

/// PPO's policy and value networks, trained by one optimiser.
#[derive(Module, Debug)]
pub struct ActorCritic {
    /// Gaussian policy with state-independent log-std.
    pub policy: GaussianPolicy,
    /// State-value critic.
    pub value: ValueCritic,
}

/// What `act(.., Explore)` computed, kept for `observe`.
struct Pending {
    actions: Vec<f32>,
    values: Vec<f32>,
    log_probs: Vec<f32>,
}

/// PPO: networks, optimiser, the rollout being collected and counters.
pub struct Ppo {
    config: PpoConfig,
    obs_dim: usize,
    action_dim: usize,
    device: Device,
    model: ActorCritic,
    optim: Adam,
    rng: ChaCha8Rng,
    sample_rng: ChaCha8Rng,
    rollout: RolloutBuffer,
    pending: Option<Pending>,
    episode_starts: Vec<f32>,
    last_obs: Vec<f32>,
    last_dones: Vec<f32>,
    env_steps: u64,
}

impl Ppo {
    /// Networks drawn from `seed` in a fixed order (policy, value) on `device` (an
    /// autodiff device).
    pub fn new(
        obs: impl Into<ObsShape>,
        action_dim: usize,
        config: PpoConfig,
        seed: u64,
        device: &Device,
    ) -> Self {
        let obs = obs.into();
        let obs_dim = obs.dim();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = &config.net;
        let mut init = n.init(obs, action_dim, &mut rng, device);
        let policy = GaussianPolicy::new(&mut init);
        let value = ValueCritic::new(&mut init);
        Self {
            obs_dim,
            action_dim,
            device: device.clone(),
            model: ActorCritic { policy, value },
            optim: Adam::new(n.adam.clone()),
            rng,
            sample_rng: ChaCha8Rng::seed_from_u64(seed),
            rollout: RolloutBuffer::default(),
            pending: None,
            episode_starts: Vec::new(),
            last_obs: Vec::new(),
            last_dones: Vec::new(),
            env_steps: 0,
            config,
        }
    }

    /// The policy and value networks.
    pub fn model(&self) -> &ActorCritic {
        &self.model
    }

    fn values(&self, obs: &[f32]) -> Vec<f32> {
        let plain = self.device.clone().without_autodiff();
        host(
            self.model
                .value
                .valid()
                .forward(matrix(obs, self.obs_dim, &plain)),
        )
    }

    fn train(&mut self, lr: f64) -> Metrics {
        let c = self.config.clone();
        let (o, a) = (self.obs_dim, self.action_dim);
        let last_values = self.values(&self.last_obs);
        let r = &self.rollout;
        let (advantages, returns) = gae(
            &r.rewards,
            &r.values,
            &r.episode_starts,
            &last_values,
            &self.last_dones,
            c.gamma,
            c.gae_lambda,
        );
        let rows = r.len();
        let dev = self.device.clone();
        let mut indices: Vec<usize> = (0..rows).collect();
        let mut rounds = Vec::new();
        'epochs: for _ in 0..c.n_epochs {
            indices.shuffle(&mut self.rng);
            for chunk in indices.chunks(c.batch_size) {
                let gather = |src: &[f32], w: usize| -> Vec<f32> {
                    chunk
                        .iter()
                        .flat_map(|&i| src[i * w..(i + 1) * w].iter().copied())
                        .collect()
                };
                let r = &self.rollout;
                let obs = matrix(&gather(&r.obs, o), o, &dev);
                let actions = matrix(&gather(&r.actions, a), a, &dev);
                let mut adv = gather(&advantages, 1);
                if c.normalize_advantage && adv.len() > 1 {
                    adv = normalize_advantages(&adv);
                }
                let old_log_prob = vector(&gather(&r.log_probs, 1), &dev);
                let batch_returns = vector(&gather(&returns, 1), &dev);

                let (log_prob, entropy) = self.model.policy.evaluate(obs.clone(), actions);
                let values = self.model.value.forward(obs);
                let surrogate =
                    clipped_surrogate(log_prob, old_log_prob, vector(&adv, &dev), c.clip_range);
                // SB3's early stop needs the KL estimate on the host: one read per
                // minibatch on a GPU, and only with `target_kl` set.
                if c.target_kl
                    .is_some_and(|kl| surrogate.approx_kl.clone().read() > 1.5 * f64::from(kl))
                {
                    break 'epochs;
                }
                let value_loss = (batch_returns - values).square().mean();
                let entropy_loss = entropy.clone().mean().neg();
                let loss = surrogate.loss.clone()
                    + entropy_loss.mul_scalar(c.ent_coef)
                    + value_loss.clone().mul_scalar(c.vf_coef);
                let mut grads = loss.backward();
                let report = self.optim.step_in_place(&mut self.model, &mut grads, lr);
                rounds.push(Metrics(vec![
                    ("policy_loss", mean(surrogate.loss.inner())),
                    ("value_loss", mean(value_loss.inner())),
                    ("entropy", mean(entropy.inner())),
                    ("approx_kl", surrogate.approx_kl),
                    ("clip_fraction", surrogate.clip_fraction),
                    ("grad_norm", report.grad_norm),
                ]));
            }
        }
        let mut metrics = Metrics::mean(rounds);
        metrics.0.push((
            "explained_variance",
            explained_variance(&self.rollout.values, &returns).into(),
        ));
        self.rollout.clear();
        metrics
    }
}

/// `1 - Var(returns - values) / Var(returns)` (NaN when the returns are constant).
pub fn explained_variance(values: &[f32], returns: &[f32]) -> f64 {
    let residual = variance(values.iter().zip(returns).map(|(v, r)| f64::from(r - v)));
    let total = variance(returns.iter().map(|&r| f64::from(r)));
    if total == 0.0 {
        f64::NAN
    } else {
        1.0 - residual / total
    }
}

/// Population variance of `x`.
fn variance(x: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = x.collect();
    let m = v.iter().sum::<f64>() / v.len() as f64;
    v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64
}

impl Agent for Ppo {
    fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    fn action_dim(&self) -> usize {
        self.action_dim
    }

    fn act(&mut self, obs: &[f32], mode: ActMode) -> Vec<f32> {
        let plain = self.device.clone().without_autodiff();
        let policy = self.model.policy.valid();
        let obs_t = matrix(obs, self.obs_dim, &plain);
        let (mean_t, log_std) = policy.distribution(obs_t);
        let n = obs.len() / self.obs_dim;
        let rng = match mode {
            ActMode::Deterministic => return host(mean_t.clamp(-1.0, 1.0)),
            ActMode::Sample => &mut self.sample_rng,
            ActMode::Explore => &mut self.rng,
        };
        let noise = matrix(
            &standard_normal(n, self.action_dim, rng),
            self.action_dim,
            &plain,
        );
        let raw = mean_t.clone() + log_std.clone().exp() * noise;
        if mode == ActMode::Sample {
            return host(raw.clamp(-1.0, 1.0));
        }
        let log_probs = host(diag_gaussian_log_prob(mean_t, log_std, raw.clone()));
        let actions = host(raw);
        let clipped = actions.iter().map(|x| x.clamp(-1.0, 1.0)).collect();
        self.pending = Some(Pending {
            actions,
            values: self.values(obs),
            log_probs,
        });
        clipped
    }

    fn seed_sampling(&mut self, seed: u64) {
        self.sample_rng = ChaCha8Rng::seed_from_u64(seed);
    }

    fn observe(&mut self, step: &Experience<'_>) {
        let pending = self
            .pending
            .take()
            .expect("observe follows act(.., Explore)");
        let (n, o) = (step.len(), self.obs_dim);
        if self.episode_starts.len() != n {
            self.episode_starts = vec![1.0; n];
        }
        let mut rewards = step.rewards.to_vec();
        let cut: Vec<usize> = (0..n)
            .filter(|&i| step.truncated[i] && !step.terminated[i])
            .collect();
        if !cut.is_empty() {
            let finals: Vec<f32> = cut
                .iter()
                .flat_map(|&i| step.reached(i, o).iter().copied())
                .collect();
            for (&i, v) in cut.iter().zip(self.values(&finals)) {
                rewards[i] += self.config.gamma * v;
            }
        }
        let r = &mut self.rollout;
        r.obs.extend_from_slice(step.obs);
        r.actions.extend_from_slice(&pending.actions);
        r.rewards.extend_from_slice(&rewards);
        r.episode_starts.extend_from_slice(&self.episode_starts);
        r.values.extend_from_slice(&pending.values);
        r.log_probs.extend_from_slice(&pending.log_probs);
        let dones: Vec<f32> = (0..n)
            .map(|i| {
                if step.terminated[i] || step.truncated[i] {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        self.episode_starts = dones.clone();
        self.last_dones = dones;
        self.last_obs = step.next_obs.to_vec();
        self.env_steps += n as u64;
    }

    fn update(&mut self, progress_remaining: f64) -> Option<Metrics> {
        let n_envs = self.last_dones.len();
        if n_envs == 0 || self.rollout.len() < self.config.n_steps * n_envs {
            return None;
        }
        let lr = self.config.net.lr.at(progress_remaining);
        Some(self.train(lr))
    }

    fn env_steps(&self) -> u64 {
        self.env_steps
    }

    fn gradient_steps(&self) -> u64 {
        self.optim.steps()
    }

    fn save(&self, dir: &Path) -> Result<(), AgentError> {
        save_module(&self.model, &dir.join("actor_critic.bpk"))?;
        Ok(())
    }

    fn load(&mut self, dir: &Path) -> Result<(), AgentError> {
        self.model = load_module(self.model.clone(), &dir.join("actor_critic.bpk"))?;
        Ok(())
    }

    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        self.model.policy.zero_obs_inputs(inputs)?;
        self.model.value.zero_obs_inputs(inputs)
    }

    fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>) {
        self.optim.save_state(snap, "ppo.adam");
        snap.put_rng("agent.rng", &self.rng);
        snap.put_u64("agent.env_steps", self.env_steps);
        self.rollout.save_state(snap, "rollout");
        snap.put_f32("ppo.episode_starts", &self.episode_starts[..]);
        snap.put_f32("ppo.last_obs", &self.last_obs[..]);
        snap.put_f32("ppo.last_dones", &self.last_dones[..]);
    }

    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError> {
        self.optim.load_state(snap, "ppo.adam", &self.device)?;
        self.rng = snap.rng("agent.rng")?;
        self.env_steps = snap.u64("agent.env_steps")?;
        self.rollout.load_state(snap, "rollout")?;
        self.episode_starts = snap.f32s("ppo.episode_starts")?.to_vec();
        self.last_obs = snap.f32s("ppo.last_obs")?.to_vec();
        self.last_dones = snap.f32s("ppo.last_dones")?.to_vec();
        self.pending = None;
        Ok(())
    }
}
