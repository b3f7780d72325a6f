//! Proximal Policy Optimization (Schulman et al. 2017) as Stable-Baselines3 defines it.
//!
//! Collect `n_steps` vec-env steps with the stochastic policy (truncated episodes
//! bootstrapped: `r += gamma V(s_final)`), compute GAE, then `n_epochs` passes of
//! shuffled minibatches minimising
//! `L = pg_coef * L_clip + ent_coef * (-mean(entropy)) + vf_coef * MSE(returns, V(s))`,
//! `L_clip = -mean(min(A ratio, A clip(ratio, 1 - eps, 1 + eps)))`,
//! `ratio = exp(log pi(a|s) - log pi_old(a|s))`, advantages normalised per minibatch,
//! plus, under `bounds_loss_coef` > 0, rl_games' bound loss on the policy's means
//! `bounds_loss_coef * mean over rows of sum_j (max(mu_j - b, 0)^2 + min(mu_j + b, 0)^2)`,
//! `b = bounds_soft_bound`: the env clips actions to `[-1, 1]`, so a mean far past a
//! bound explores nothing on that action. `pg_coef` is 1 in PPO; at 0 the return trains
//! only the value network and the policy learns from its cloning terms alone (below):
//! DAgger's supervised learner with a critic beside it.
//! Exploring actions are `mean + exp(log_std) x` with `x` standard normal, drawn anew
//! each step (SB3) or an AR(1) process over the episode (`noise_correlation`).
//! Under `[ppo.self_imitation]` each rollout's update is followed by self-imitation steps
//! on the learner's own past episodes ([`crate::self_imitation`]). Under
//! `[ppo.kickstart]` each minibatch's loss adds a cloning term pulling the policy's means
//! towards a teacher's actions on the same states ([`crate::kickstart`]). Under
//! `[ppo.demonstrations]` each rollout's update is followed by cloning steps on the
//! demonstrations the agent holds ([`crate::demo_cloning`]).
//!
//! The minibatch step computes the loss's gradients with respect to the networks'
//! outputs (`dL/d log pi = ratio dL/d ratio` with `dL/d ratio = -pg_coef A / n` where the
//! unclipped term is the smaller or the ratio lies inside the clip range, else 0;
//! `dL/d entropy = -ent_coef / n`; `dL/dV = 2 vf_coef (V - returns) / n`) and lets the
//! networks walk them back: Burn's autodiff, or the host MLP path (`backend = "host"`,
//! [`crate::ppo_networks`]).

use crate::agent::{ActMode, Agent, AgentError, Experience, Metrics};
use crate::config::{ConfigError, DEFAULT_GAMMA, NetConfig, check_gamma, ensure};
use crate::correlated_noise::CorrelatedNoise;
use crate::demo_cloning::{DemoBatch, DemoCloningConfig, DemoRows};
use crate::demonstrations::Demonstration;
use crate::kickstart::{KickstartConfig, cloning_loss};
use crate::network_path::OnPath;
use crate::policy_chain::Step;
pub use crate::ppo_networks::ActorCritic;
use crate::ppo_networks::{BurnNetworks, Evaluation, HostNetworks, PpoNetworks};
use crate::rollout_buffer::{RolloutBuffer, gae};
use crate::rows::Rows;
use crate::schedule::LrSchedule;
use crate::self_imitation::{self, SelfImitation, SelfImitationConfig};
use crate::tensors::{gather_rows, standard_normal};
use foosball_nets::store::{load_module, save_module};
use foosball_nets::{
    Activation, Adam, AdamConfig, CnnConfig, Device, GaussianPolicy, ObsShape, Snapshot,
    SnapshotError, ValueCritic,
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
    /// Weight of the clipped surrogate `L_clip` (1: PPO; 0: the policy learns only from
    /// `kickstart` and `demonstrations`, the return only the value network).
    pub pg_coef: f32,
    /// Entropy bonus coefficient.
    pub ent_coef: f32,
    /// Value loss coefficient.
    pub vf_coef: f32,
    /// Normalise advantages per minibatch.
    pub normalize_advantage: bool,
    /// Stop a rollout's epochs once approx-KL exceeds `1.5 * target_kl`.
    pub target_kl: Option<f32>,
    /// Starting log standard deviation of every action dimension (SB3's `log_std_init`;
    /// RL Zoo's PyBullet settings use -2): the policy's exploration before it learns.
    pub log_std_init: f32,
    /// Step correlation `rho` in `[0, 1)` of the exploration noise, an AR(1) process
    /// restarted with every episode ([`crate::correlated_noise`]); 0 is SB3's white noise.
    pub noise_correlation: f32,
    /// Weight of the bound loss on the policy's means (rl_games' `bounds_loss_coef`; 0:
    /// off, as in SB3).
    pub bounds_loss_coef: f32,
    /// Where the bound loss starts, `|mean|` past it (rl_games' 1.1).
    pub bounds_soft_bound: f32,
    /// Self-imitation of past episodes after each update (Oh et al. 2018; off by default).
    pub self_imitation: SelfImitationConfig,
    /// A teacher's actions cloned beside the return (Schmitt et al. 2018; off by default).
    pub kickstart: KickstartConfig,
    /// Demonstrations cloned after each update (`None`, the default: PPO takes none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub demonstrations: Option<DemoCloningConfig>,
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
            pg_coef: 1.0,
            ent_coef: 0.0,
            vf_coef: 0.5,
            normalize_advantage: true,
            target_kl: None,
            log_std_init: 0.0,
            noise_correlation: 0.0,
            bounds_loss_coef: 0.0,
            bounds_soft_bound: 1.1,
            self_imitation: SelfImitationConfig::default(),
            kickstart: KickstartConfig::default(),
            demonstrations: None,
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
        ensure(
            self.pg_coef.is_finite() && self.pg_coef >= 0.0,
            "pg_coef",
            "must be finite and >= 0",
        )?;
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
        )?;
        ensure(
            (-20.0..=2.0).contains(&self.log_std_init),
            "log_std_init",
            "must be in [-20, 2] (a standard deviation of 2e-9 to 7.4)",
        )?;
        ensure(
            (0.0..1.0).contains(&self.noise_correlation),
            "noise_correlation",
            "must be in [0, 1)",
        )?;
        ensure(
            self.bounds_loss_coef.is_finite() && self.bounds_loss_coef >= 0.0,
            "bounds_loss_coef",
            "must be finite and >= 0",
        )?;
        ensure(
            self.bounds_soft_bound.is_finite() && self.bounds_soft_bound >= 0.0,
            "bounds_soft_bound",
            "must be finite and >= 0",
        )?;
        self.self_imitation
            .validate()
            .map_err(|e| e.under("self_imitation"))?;
        self.kickstart
            .validate()
            .map_err(|e| e.under("kickstart"))?;
        match &self.demonstrations {
            Some(d) => d.validate().map_err(|e| e.under("demonstrations")),
            None => Ok(()),
        }
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

/// The clipped surrogate, its gradient and its diagnostics for one minibatch, `[1]`
/// values but the gradient.
pub struct Surrogate<R: Rows> {
    /// `-mean(min(A ratio, A clip(ratio, 1 - eps, 1 + eps)))`.
    pub loss: R::V,
    /// `dL/d log pi`, `[batch]`.
    pub d_log_prob: R::V,
    /// Share of rows with `|ratio - 1| > eps`.
    pub clip_fraction: R::V,
    /// `mean((ratio - 1) - log ratio)`, the low-variance KL estimate SB3 logs.
    pub approx_kl: R::V,
}

/// PPO's clipped objective of `log_prob` given `old_log_prob` and `advantages` (all
/// `[batch]`, `batch` rows), with its gradient with respect to `log_prob`.
pub fn clipped_surrogate<R: Rows>(
    r: &R,
    (log_prob, old_log_prob): (&R::V, &R::V),
    advantages: &R::V,
    clip: f32,
    batch: usize,
) -> Surrogate<R> {
    let per_row = 1.0 / batch as f32;
    let log_ratio = r.sub(log_prob, old_log_prob);
    let ratio = r.exp(&log_ratio);
    let excess = r.affine(&ratio, 1.0, -1.0);
    let unclipped = r.mul(advantages, &ratio);
    let clipped = r.mul(advantages, &r.clamp(&ratio, 1.0 - clip, 1.0 + clip));
    let loss = r.affine(&r.mean(&r.min(&unclipped, &clipped)), -1.0, 0.0);
    // The gradient passes where the unclipped term is taken, or the clip is not active.
    let inside = r.le(&r.abs(&excess), &r.vector(&[clip]));
    let first = r.le(&unclipped, &clipped);
    let passes = r.sub(&r.add(&first, &inside), &r.mul(&first, &inside));
    let d_ratio = r.mul(&passes, &r.affine(advantages, -per_row, 0.0));
    Surrogate {
        loss,
        d_log_prob: r.mul(&d_ratio, &ratio),
        clip_fraction: r.mean(&r.affine(&inside, -1.0, 1.0)),
        approx_kl: r.mean(&r.sub(&excess, &log_ratio)),
    }
}

/// The bound loss of `means` (`[batch, action_dim]`, `batch` rows) past `bound`, weight
/// `coef`, and its gradient with respect to the means:
/// `L = coef / batch * sum (max(mu - b, 0)^2 + min(mu + b, 0)^2)`,
/// `dL/dmu = 2 coef / batch * (max(mu - b, 0) + min(mu + b, 0))`.
pub fn bound_loss(means: &[f32], batch: usize, coef: f32, bound: f32) -> (f32, Vec<f32>) {
    let per_row = coef / batch as f32;
    let past: Vec<f32> = means
        .iter()
        .map(|&m| (m - bound).max(0.0) + (m + bound).min(0.0))
        .collect();
    let loss = per_row * past.iter().map(|p| p * p).sum::<f32>();
    (loss, past.iter().map(|p| 2.0 * per_row * p).collect())
}

/// What `act(.., Explore)` computed, kept for `observe`.
struct Pending {
    actions: Vec<f32>,
    values: Vec<f32>,
    log_probs: Vec<f32>,
}

/// PPO: networks and their optimiser, the rollout being collected and counters.
pub struct Ppo {
    config: PpoConfig,
    obs_dim: usize,
    action_dim: usize,
    device: Device,
    networks: OnPath<BurnNetworks, HostNetworks>,
    rng: ChaCha8Rng,
    sample_rng: ChaCha8Rng,
    rollout: RolloutBuffer,
    pending: Option<Pending>,
    episode_starts: Vec<f32>,
    noise: CorrelatedNoise,
    self_imitation: Option<SelfImitation>,
    /// The demonstrations handed in (`[ppo.demonstrations]`), none at first.
    demos: DemoRows,
    /// DAgger's aggregate of labelled rows (`[ppo.kickstart] keep`), none at first.
    aggregate: DemoRows,
    last_obs: Vec<f32>,
    last_dones: Vec<f32>,
    env_steps: u64,
}

/// One minibatch of a rollout, host values: observations `[batch, obs_dim]`, actions
/// `[batch, action_dim]`, advantages (normalised when asked), old `log pi` and returns
/// `[batch]`, and where a teacher labels the rollout its actions `[batch, action_dim]`
/// with the cloning term's weight.
struct Minibatch {
    obs: Vec<f32>,
    actions: Vec<f32>,
    advantages: Vec<f32>,
    old_log_probs: Vec<f32>,
    returns: Vec<f32>,
    teacher: Option<(Vec<f32>, f32)>,
}

/// One gradient step on `mb` (the module docs' loss) on either path; `None` when the KL
/// estimate stops the rollout's epochs first (`target_kl`).
fn minibatch_step<N: PpoNetworks>(
    nets: &mut N,
    c: &PpoConfig,
    (o, a): (usize, usize),
    mb: &Minibatch,
    lr: f64,
) -> Option<Metrics> {
    let r = nets.rows();
    let n = mb.returns.len();
    let per_row = 1.0 / n as f32;
    let (obs, actions) = (r.matrix(&mb.obs, o), r.matrix(&mb.actions, a));
    let Evaluation {
        log_prob,
        entropy,
        values,
    } = nets.evaluate(&obs, &actions);
    let old_log_prob = r.vector(&mb.old_log_probs);
    let advantages = r.vector(&mb.advantages);
    let s = clipped_surrogate(&r, (&log_prob, &old_log_prob), &advantages, c.clip_range, n);
    // SB3's early stop needs the KL estimate on the host: one read per minibatch on a
    // GPU, and only with `target_kl` set.
    let approx_kl = r.scalar(&s.approx_kl);
    if c.target_kl
        .is_some_and(|kl| approx_kl.clone().read() > 1.5 * f64::from(kl))
    {
        return None;
    }
    let error = r.sub(&values, &r.vector(&mb.returns));
    let value_loss = r.mean(&r.square(&error));
    let d_values = r.affine(&error, 2.0 * c.vf_coef * per_row, 0.0);
    let d_entropy = r.affine(&entropy, 0.0, -c.ent_coef * per_row);
    let means = (c.bounds_loss_coef > 0.0 || mb.teacher.is_some()).then(|| nets.kept_means());
    let bounds = means
        .as_ref()
        .filter(|_| c.bounds_loss_coef > 0.0)
        .map(|m| bound_loss(m, n, c.bounds_loss_coef, c.bounds_soft_bound));
    let cloning = (means.as_ref().zip(mb.teacher.as_ref())).map(|(m, (labels, coef))| {
        let cloned = c.kickstart.cloned_actions(labels.len() / n);
        cloning_loss(m, labels, &cloned, n, *coef)
    });
    let d_means = match (&bounds, &cloning) {
        (Some((_, b)), Some((_, k))) => Some(b.iter().zip(k).map(|(b, k)| b + k).collect()),
        (Some((_, d)), None) | (None, Some((_, d))) => Some(d.clone()),
        (None, None) => None,
    };
    let d_log_prob = r.affine(&s.d_log_prob, c.pg_coef, 0.0);
    let report = nets.step(&d_log_prob, &d_entropy, &d_values, d_means.as_deref(), lr);
    let mut metrics = vec![
        ("policy_loss", r.scalar(&s.loss)),
        ("value_loss", r.scalar(&value_loss)),
        ("entropy", r.scalar(&r.mean(&entropy))),
        ("approx_kl", approx_kl),
        ("clip_fraction", r.scalar(&s.clip_fraction)),
        ("grad_norm", report.grad_norm),
    ];
    if let Some((loss, _)) = bounds {
        metrics.push(("bounds_loss", f64::from(loss).into()));
    }
    if let (Some((loss, _)), Some((_, coef))) = (cloning, &mb.teacher) {
        metrics.push(("kickstart_loss", f64::from(loss).into()));
        metrics.push(("kickstart_coef", f64::from(*coef).into()));
    }
    Some(Metrics(metrics))
}

/// One self-imitation step on kept rows ([`crate::self_imitation`]'s loss) on either
/// path: `dL/d log pi = -coef (R - V)_+ / n`, `dL/dV = -value_coef (R - V)_+ / n`. No step
/// where no row's return beats its value (Adam's momentum alone would still move the
/// networks).
fn self_imitation_step<N: PpoNetworks>(
    nets: &mut N,
    c: &SelfImitationConfig,
    (o, a): (usize, usize),
    rows: &self_imitation::Batch,
    lr: f64,
) -> Metrics {
    let r = nets.rows();
    let per_row = 1.0 / rows.returns.len() as f32;
    let (obs, actions) = (r.matrix(&rows.obs, o), r.matrix(&rows.actions, a));
    let Evaluation {
        entropy, values, ..
    } = nets.evaluate(&obs, &actions);
    let gap = r.max_scalar(&r.sub(&r.vector(&rows.returns), &values), 0.0);
    let mean_gap = r.scalar(&r.mean(&gap));
    let below = r.mean(&r.le(&gap, &r.vector(&[0.0])));
    let mut metrics = vec![
        ("self_imitation_gap", mean_gap.clone()),
        (
            "self_imitation_positive",
            r.scalar(&r.affine(&below, -1.0, 1.0)),
        ),
    ];
    if mean_gap.read() > 0.0 {
        let d_log_prob = r.affine(&gap, -c.coef * per_row, 0.0);
        let d_values = r.affine(&gap, -c.value_coef * per_row, 0.0);
        let no_entropy = r.affine(&entropy, 0.0, 0.0);
        let report = nets.step(&d_log_prob, &no_entropy, &d_values, None, lr);
        metrics.push(("self_imitation_grad_norm", report.grad_norm));
    }
    Metrics(metrics)
}

/// The names of a demonstrations cloning step's loss and gradient norm.
const DEMO_METRICS: [&str; 2] = ["demo_cloning_loss", "demo_cloning_grad_norm"];
/// The names of an aggregate cloning step's ([`KickstartConfig::keep`]).
const AGGREGATE_METRICS: [&str; 2] = ["kickstart_aggregate_loss", "kickstart_aggregate_grad_norm"];
/// Where the checkpoint holds DAgger's aggregate.
const AGGREGATE_STATE: &str = "ppo.kickstart_aggregate";

/// One cloning step on demonstrated rows ([`crate::demo_cloning`]'s loss) on either
/// path: only the means of the `cloned` action values feel a gradient,
/// `dL/dmu = 2 coef (mu - a) / n`.
fn demonstration_step<N: PpoNetworks>(
    nets: &mut N,
    (coef, cloned): (f32, &[bool]),
    (o, a): (usize, usize),
    rows: &DemoBatch,
    lr: f64,
    [loss_name, norm_name]: [&'static str; 2],
) -> Metrics {
    let r = nets.rows();
    let n = rows.obs.len() / o;
    let (obs, actions) = (r.matrix(&rows.obs, o), r.matrix(&rows.actions, a));
    let Evaluation {
        log_prob,
        entropy,
        values,
    } = nets.evaluate(&obs, &actions);
    let (loss, d_means) = cloning_loss(&nets.kept_means(), &rows.actions, cloned, n, coef);
    let zero = |v| r.affine(v, 0.0, 0.0);
    let report = nets.step(
        &zero(&log_prob),
        &zero(&entropy),
        &zero(&values),
        Some(&d_means),
        lr,
    );
    Metrics(vec![
        (loss_name, f64::from(loss).into()),
        (norm_name, report.grad_norm),
    ])
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
        let policy = GaussianPolicy::new(&mut init, config.log_std_init);
        let value = ValueCritic::new(&mut init);
        let model = ActorCritic { policy, value };
        let networks = BurnNetworks::new(model, Adam::new(n.adam.clone()), device, obs_dim);
        Self {
            obs_dim,
            action_dim,
            device: device.clone(),
            networks: OnPath::Burn(Box::new(networks)),
            rng,
            sample_rng: ChaCha8Rng::seed_from_u64(seed),
            rollout: RolloutBuffer::default(),
            pending: None,
            episode_starts: Vec::new(),
            noise: CorrelatedNoise::new(config.noise_correlation),
            self_imitation: config.self_imitation.enabled().then(|| {
                let sil = config.self_imitation.clone();
                SelfImitation::new(sil, config.gamma, (obs_dim, action_dim), seed)
            }),
            demos: DemoRows::default(),
            aggregate: DemoRows::empty(obs_dim, action_dim),
            last_obs: Vec::new(),
            last_dones: Vec::new(),
            env_steps: 0,
            config,
        }
    }

    /// The same learner computing on the host MLP path (`backend = "host"`), from the
    /// same networks; an error names what that path does not compute (an image
    /// observation). Call before the first step: the optimiser starts fresh.
    pub fn on_host_path(&mut self) -> Result<(), String> {
        let adam = Adam::new(self.config.net.adam.clone());
        (self.networks).to_host(|model| HostNetworks::from_modules(model, adam))
    }

    /// The policy and value networks (the host path's copied out).
    pub fn model(&self) -> ActorCritic {
        self.networks.modules()
    }

    fn values(&mut self, obs: &[f32]) -> Vec<f32> {
        match &mut self.networks {
            OnPath::Burn(burn) => burn.values(obs),
            OnPath::Host(host) => host.values(obs),
        }
    }

    fn optimiser(&self) -> &Adam {
        match &self.networks {
            OnPath::Burn(burn) => burn.optimiser(),
            OnPath::Host(host) => host.optimiser(),
        }
    }

    /// PPO's epochs on the rollout at learning rate `lr`, the cloning term (where a teacher
    /// labels the rollout) weighted `kickstart`.
    fn train(&mut self, lr: f64, kickstart: f32) -> Metrics {
        let c = self.config.clone();
        let (o, a) = (self.obs_dim, self.action_dim);
        let last_obs = self.last_obs.clone();
        let last_values = self.values(&last_obs);
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
        let mut indices: Vec<usize> = (0..rows).collect();
        let mut rounds = Vec::new();
        'epochs: for _ in 0..c.n_epochs {
            indices.shuffle(&mut self.rng);
            for chunk in indices.chunks(c.batch_size) {
                let gather = |src: &[f32], w: usize| gather_rows(src, w, chunk);
                let r = &self.rollout;
                let mut mb = Minibatch {
                    obs: gather(&r.obs, o),
                    actions: gather(&r.actions, a),
                    advantages: gather(&advantages, 1),
                    old_log_probs: gather(&r.log_probs, 1),
                    returns: gather(&returns, 1),
                    teacher: (!r.teacher.is_empty()).then(|| (gather(&r.teacher, a), kickstart)),
                };
                if c.normalize_advantage && mb.advantages.len() > 1 {
                    mb.advantages = normalize_advantages(&mb.advantages);
                }
                let metrics = match &mut self.networks {
                    OnPath::Burn(burn) => minibatch_step(burn.as_mut(), &c, (o, a), &mb, lr),
                    OnPath::Host(host) => minibatch_step(host.as_mut(), &c, (o, a), &mb, lr),
                };
                match metrics {
                    Some(m) => rounds.push(m),
                    None => break 'epochs,
                }
            }
        }
        let mut metrics = Metrics::mean(rounds);
        metrics.0.push((
            "explained_variance",
            explained_variance(&self.rollout.values, &returns).into(),
        ));
        if let Some(sil) = &mut self.self_imitation {
            let sc = &c.self_imitation;
            let mut steps = Vec::new();
            for rows in sil.sample(sc.updates) {
                steps.push(match &mut self.networks {
                    OnPath::Burn(burn) => self_imitation_step(burn.as_mut(), sc, (o, a), &rows, lr),
                    OnPath::Host(host) => self_imitation_step(host.as_mut(), sc, (o, a), &rows, lr),
                });
            }
            metrics.0.extend(Metrics::mean(steps).0);
            metrics
                .0
                .push(("self_imitation_rows", (sil.len() as f64).into()));
        }
        if let Some(d) = c.demonstrations.as_ref().filter(|_| !self.demos.is_empty()) {
            let mut steps = Vec::new();
            let term = (d.coef, &d.cloned_actions(a)[..]);
            for _ in 0..d.updates {
                let rows = self.demos.sample(d.batch_size, &mut self.rng);
                steps.push(self.cloning_step(term, &rows, lr, DEMO_METRICS));
            }
            metrics.0.extend(Metrics::mean(steps).0);
            metrics
                .0
                .push(("demo_cloning_rows", (self.demos.len() as f64).into()));
        }
        let k = &c.kickstart;
        if k.keep > 0 && !self.rollout.teacher.is_empty() {
            let r = &self.rollout;
            self.aggregate.keep_newest(&r.obs, &r.teacher, k.keep);
            let term = (kickstart, &k.cloned_actions(a)[..]);
            let steps: Vec<Metrics> = (0..k.updates)
                .map(|_| {
                    let rows = self.aggregate.sample(c.batch_size, &mut self.rng);
                    self.cloning_step(term, &rows, lr, AGGREGATE_METRICS)
                })
                .collect();
            metrics.0.extend(Metrics::mean(steps).0);
            metrics.0.push((
                "kickstart_aggregate_rows",
                (self.aggregate.len() as f64).into(),
            ));
        }
        self.rollout.clear();
        metrics
    }

    /// One [`demonstration_step`] on `rows` on the networks' path.
    fn cloning_step(
        &mut self,
        term: (f32, &[bool]),
        rows: &DemoBatch,
        lr: f64,
        names: [&'static str; 2],
    ) -> Metrics {
        let dims = (self.obs_dim, self.action_dim);
        match &mut self.networks {
            OnPath::Burn(burn) => demonstration_step(burn.as_mut(), term, dims, rows, lr, names),
            OnPath::Host(host) => demonstration_step(host.as_mut(), term, dims, rows, lr, names),
        }
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
        let clip = |x: &[f32]| x.iter().map(|x| x.clamp(-1.0, 1.0)).collect();
        let n = obs.len() / self.obs_dim;
        let rng = match mode {
            ActMode::Deterministic => {
                return clip(&match &mut self.networks {
                    OnPath::Burn(burn) => burn.means(obs),
                    OnPath::Host(host) => host.means(obs),
                });
            }
            ActMode::Sample => &mut self.sample_rng,
            ActMode::Explore => &mut self.rng,
        };
        let noise = standard_normal(n, self.action_dim, rng);
        let noise = match mode {
            ActMode::Explore => self.noise.next(noise, &self.episode_starts),
            _ => noise,
        };
        let (actions, log_probs) = match &mut self.networks {
            OnPath::Burn(burn) => burn.sample(obs, &noise),
            OnPath::Host(host) => host.sample(obs, &noise),
        };
        let clipped = clip(&actions);
        if mode == ActMode::Explore {
            self.pending = Some(Pending {
                actions,
                values: self.values(obs),
                log_probs,
            });
        }
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
        if self.config.kickstart.enabled() {
            let labels = step
                .teacher
                .expect("a run with [ppo.kickstart] hands its teacher's labels");
            r.teacher.extend_from_slice(labels);
        }
        let dones: Vec<f32> = (0..n)
            .map(|i| {
                if step.terminated[i] || step.truncated[i] {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        if let Some(sil) = &mut self.self_imitation {
            sil.record(
                step.obs,
                &pending.actions,
                (&rewards, &pending.values),
                &dones,
            );
        }
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
        let kickstart = self.config.kickstart.coef_at(progress_remaining);
        Some(self.train(lr, kickstart))
    }

    fn env_steps(&self) -> u64 {
        self.env_steps
    }

    fn gradient_steps(&self) -> u64 {
        self.optimiser().steps()
    }

    fn save(&self, dir: &Path) -> Result<(), AgentError> {
        save_module(&self.model(), &dir.join("actor_critic.bpk"))?;
        Ok(())
    }

    fn load(&mut self, dir: &Path) -> Result<(), AgentError> {
        let model = load_module(self.model(), &dir.join("actor_critic.bpk"))?;
        self.networks
            .set_modules(model)
            .map_err(|message| AgentError::File {
                path: dir.to_path_buf(),
                message,
            })
    }

    /// The Gaussian's mean, clamped to `[-1, 1]`.
    fn policy_chain(&self) -> Result<Vec<Step>, String> {
        let mlp = self.model().policy.to_host()?.mlp;
        Ok(vec![
            Step::Mlp(mlp),
            Step::Clamp {
                min: -1.0,
                max: 1.0,
            },
        ])
    }

    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        let mut model = self.model();
        model.policy.zero_obs_inputs(inputs)?;
        model.value.zero_obs_inputs(inputs)?;
        self.networks.set_modules(model)
    }

    fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>) {
        self.optimiser().save_state(snap, "ppo.adam");
        snap.put_rng("agent.rng", &self.rng);
        snap.put_u64("agent.env_steps", self.env_steps);
        self.rollout.save_state(snap, "rollout");
        snap.put_f32("ppo.episode_starts", &self.episode_starts[..]);
        snap.put_f32("ppo.last_obs", &self.last_obs[..]);
        snap.put_f32("ppo.last_dones", &self.last_dones[..]);
        self.noise.save_state(snap, "ppo.noise");
        if let Some(sil) = &self.self_imitation {
            sil.save_state(snap, "ppo.self_imitation");
        }
        if self.config.kickstart.keep > 0 {
            self.aggregate.save_state(snap, AGGREGATE_STATE);
        }
    }

    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError> {
        let device = self.device.clone();
        match &mut self.networks {
            OnPath::Burn(burn) => burn.optimiser_mut(),
            OnPath::Host(host) => host.optimiser_mut(),
        }
        .load_state(snap, "ppo.adam", &device)?;
        self.rng = snap.rng("agent.rng")?;
        self.env_steps = snap.u64("agent.env_steps")?;
        self.rollout.load_state(snap, "rollout")?;
        self.episode_starts = snap.f32s("ppo.episode_starts")?.to_vec();
        self.last_obs = snap.f32s("ppo.last_obs")?.to_vec();
        self.last_dones = snap.f32s("ppo.last_dones")?.to_vec();
        self.noise.load_state(snap, "ppo.noise")?;
        if let Some(sil) = &mut self.self_imitation {
            sil.load_state(snap, "ppo.self_imitation")?;
        }
        if self.config.kickstart.keep > 0 {
            self.aggregate.load_state(snap, AGGREGATE_STATE)?;
        }
        self.pending = None;
        Ok(())
    }

    /// Holds every state-action row of `episodes` for the cloning steps, in place of any
    /// held before; refused without `[ppo.demonstrations]`.
    fn set_demonstrations(&mut self, episodes: &[Demonstration<'_>]) -> Result<usize, String> {
        if self.config.demonstrations.is_none() {
            return Err("ppo.demonstrations is not set: no update would clone them".into());
        }
        self.demos = DemoRows::new(episodes, self.obs_dim, self.action_dim)?;
        Ok(self.demos.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network_path::HoldsModules;
    use crate::tensors::{host, matrix, vector};
    use crate::test_support::{change_gap, device, gradient_revealing};
    use burn::module::Module;
    use foosball_nets::distributions::diag_gaussian_log_prob;
    use foosball_nets::params::host_params;

    /// Every parameter of both networks.
    fn flat(m: &ActorCritic) -> Vec<f32> {
        host_params(m).concat()
    }

    /// A minibatch of `n` rows for `(o, a)` networks: old log-probabilities that put
    /// ratios on both sides of the clip range, advantages of both signs; teacher's labels
    /// in `[-1, 1]` weighted `kickstart` where given.
    fn minibatch(n: usize, (o, a): (usize, usize), seed: u64, kickstart: Option<f32>) -> Minibatch {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut normal = |k: usize| standard_normal(k, 1, &mut rng);
        Minibatch {
            obs: normal(n * o).iter().map(|x| x.tanh()).collect(),
            actions: normal(n * a).iter().map(|x| 0.5 * x).collect(),
            advantages: normalize_advantages(&normal(n)),
            old_log_probs: normal(n).iter().map(|x| 0.3 * x - 1.0 * a as f32).collect(),
            returns: normal(n).iter().map(|x| 2.0 * x).collect(),
            teacher: kickstart.map(|coef| (normal(n * a).iter().map(|x| x.tanh()).collect(), coef)),
        }
    }

    /// One minibatch step of PPO's loss written as Stable-Baselines3 writes it, gradients
    /// by Burn's autodiff through the whole loss (the way this file computed its update
    /// before it was written over [`PpoNetworks`]), on `m` with `c`'s Adam.
    fn reference_step(
        mut m: ActorCritic,
        c: &PpoConfig,
        (o, a): (usize, usize),
        mb: &Minibatch,
    ) -> ActorCritic {
        let dev = device();
        let obs = matrix(&mb.obs, o, &dev);
        let (log_prob, entropy, mean) =
            m.policy.evaluate(obs.clone(), matrix(&mb.actions, a, &dev));
        let values = m.value.forward(obs);
        let ratio = (log_prob - vector(&mb.old_log_probs, &dev)).exp();
        let adv = vector(&mb.advantages, &dev);
        let clipped = adv.clone() * ratio.clone().clamp(1.0 - c.clip_range, 1.0 + c.clip_range);
        let policy_loss = (adv * ratio).min_pair(clipped).mean().neg();
        let value_loss = (vector(&mb.returns, &dev) - values).square().mean();
        let b = c.bounds_soft_bound;
        let past =
            mean.clone().sub_scalar(b).clamp_min(0.0) + mean.clone().add_scalar(b).clamp_max(0.0);
        let bounds = past
            .square()
            .sum_dim(1)
            .mean()
            .mul_scalar(c.bounds_loss_coef);
        let mut loss = policy_loss.mul_scalar(c.pg_coef)
            + entropy.mean().neg().mul_scalar(c.ent_coef)
            + value_loss.mul_scalar(c.vf_coef)
            + bounds;
        if let Some((labels, coef)) = &mb.teacher {
            let rows = mb.returns.len();
            let cloned: Vec<f32> = (0..rows)
                .flat_map(|_| c.kickstart.cloned_actions(a))
                .map(|c| if c { 1.0 } else { 0.0 })
                .collect();
            let error = (mean - matrix(labels, a, &dev)) * matrix(&cloned, a, &dev);
            loss = loss + error.square().sum_dim(1).mean().mul_scalar(*coef);
        }
        let mut adam = Adam::new(c.net.adam.clone());
        adam.step_in_place(&mut m, &mut loss.backward(), 10.0);
        m
    }

    /// Both paths took the step `expected` from `start` (within 1e-4 of its size) and
    /// report the same metrics.
    fn assert_paths_agree(
        start: &ActorCritic,
        expected: &[f32],
        (burn, host): (ActorCritic, ActorCritic),
        (mb, mh): (Metrics, Metrics),
    ) {
        for (label, after) in [("burn", burn), ("host", host)] {
            let gap = change_gap(&flat(start), &flat(&after), expected);
            assert!(gap < 1e-4, "{label}: {gap} of the step's size");
        }
        for ((name, b), (_, h)) in mb.read().into_iter().zip(mh.read()) {
            assert!(
                (b - h).abs() <= 1e-4 * b.abs().max(1.0),
                "{name} {b} vs {h}"
            );
        }
    }

    fn check_against_autodiff(mut c: PpoConfig, (o, a): (usize, usize), hidden: Vec<usize>) {
        gradient_revealing(&mut c.net);
        c.net.hidden = hidden;
        c.ent_coef = 0.01;
        let kickstart = c.kickstart.enabled().then_some(c.kickstart.coef_start);
        let mb = minibatch(64, (o, a), 9, kickstart);
        let start = Ppo::new(o, a, c.clone(), 3, &device()).model();
        let expected = flat(&reference_step(start.clone(), &c, (o, a), &mb));
        let adam = || Adam::new(c.net.adam.clone());
        let mut burn = BurnNetworks::new(start.clone(), adam(), &device(), o);
        let mut host = HostNetworks::from_modules(start.clone(), adam()).unwrap();
        let mb_burn = minibatch_step(&mut burn, &c, (o, a), &mb, 10.0).unwrap();
        let mb_host = minibatch_step(&mut host, &c, (o, a), &mb, 10.0).unwrap();
        let after = (burn.modules(), host.modules());
        assert_paths_agree(&start, &expected, after, (mb_burn, mb_host));
    }

    #[test]
    fn the_minibatch_step_is_the_gradient_of_ppos_loss_on_both_paths() {
        check_against_autodiff(PpoConfig::default(), (38, 8), vec![64, 64]);
        check_against_autodiff(PpoConfig::default(), (38, 8), vec![256, 256]);
        let mut relu = PpoConfig::default();
        relu.net.activation = Activation::Relu;
        relu.net.adam.max_grad_norm = None;
        relu.clip_range = 0.1;
        check_against_autodiff(relu, (5, 3), vec![16]);
        // The bound loss, reaching every mean (bound 0.05) and only some (0.2).
        for bound in [0.05, 0.2] {
            let bounded = PpoConfig {
                bounds_loss_coef: 5.0,
                bounds_soft_bound: bound,
                ..PpoConfig::default()
            };
            check_against_autodiff(bounded.clone(), (38, 8), vec![64, 64]);
            // ... and beside a teacher's cloning term.
            let kickstarted = PpoConfig {
                kickstart: KickstartConfig {
                    teacher: Some("shooter".into()),
                    coef_start: 2.0,
                    rods: vec![1, 3],
                    ..KickstartConfig::default()
                },
                ..bounded
            };
            check_against_autodiff(kickstarted, (38, 8), vec![64, 64]);
        }
        // The cloning term alone, and with the surrogate weighted down or off.
        let mut kickstarted = PpoConfig::default();
        kickstarted.kickstart.teacher = Some("dribbler".into());
        check_against_autodiff(kickstarted.clone(), (38, 8), vec![64, 64]);
        for pg_coef in [0.3, 0.0] {
            let weighted = PpoConfig {
                pg_coef,
                ..kickstarted.clone()
            };
            check_against_autodiff(weighted, (38, 8), vec![64, 64]);
        }
    }

    #[test]
    fn with_the_surrogate_off_the_return_moves_only_the_value_network() {
        let c = PpoConfig {
            pg_coef: 0.0,
            ..PpoConfig::default()
        };
        let (o, a) = (38, 8);
        let mb = minibatch(64, (o, a), 9, None);
        let start = Ppo::new(o, a, c.clone(), 3, &device()).model();
        let adam = || Adam::new(c.net.adam.clone());
        let mut host = HostNetworks::from_modules(start.clone(), adam()).unwrap();
        minibatch_step(&mut host, &c, (o, a), &mb, 1e-2).unwrap();
        let after = host.modules();
        let params = |m: &ActorCritic| {
            (
                host_params(&m.policy).concat(),
                host_params(&m.value).concat(),
            )
        };
        let ((policy0, value0), (policy1, value1)) = (params(&start), params(&after));
        assert_eq!(policy0, policy1);
        assert_ne!(value0, value1);
    }

    /// One self-imitation step as the paper writes its loss, gradients by Burn's autodiff
    /// through the whole loss, on `m` with `c`'s Adam.
    fn reference_self_imitation_step(
        mut m: ActorCritic,
        c: &PpoConfig,
        (o, a): (usize, usize),
        rows: &self_imitation::Batch,
    ) -> ActorCritic {
        let dev = device();
        let obs = matrix(&rows.obs, o, &dev);
        let (log_prob, _, _) = m
            .policy
            .evaluate(obs.clone(), matrix(&rows.actions, a, &dev));
        let gap = (vector(&rows.returns, &dev) - m.value.forward(obs)).clamp_min(0.0);
        let s = &c.self_imitation;
        let loss = (gap.clone().detach() * log_prob)
            .mean()
            .neg()
            .mul_scalar(s.coef)
            + gap.square().mean().mul_scalar(0.5 * s.value_coef);
        let mut adam = Adam::new(c.net.adam.clone());
        adam.step_in_place(&mut m, &mut loss.backward(), 10.0);
        m
    }

    #[test]
    fn the_self_imitation_step_is_the_gradient_of_its_loss_on_both_paths() {
        let mut c = PpoConfig::default();
        gradient_revealing(&mut c.net);
        c.self_imitation = SelfImitationConfig {
            coef: 0.7,
            value_coef: 0.3,
            ..SelfImitationConfig::default()
        };
        let (o, a) = (38, 8);
        let mb = minibatch(64, (o, a), 9, None);
        let rows = self_imitation::Batch {
            obs: mb.obs,
            actions: mb.actions,
            returns: mb.returns,
        };
        let start = Ppo::new(o, a, c.clone(), 3, &device()).model();
        let expected = flat(&reference_self_imitation_step(
            start.clone(),
            &c,
            (o, a),
            &rows,
        ));
        let adam = || Adam::new(c.net.adam.clone());
        let mut burn = BurnNetworks::new(start.clone(), adam(), &device(), o);
        let mut host = HostNetworks::from_modules(start.clone(), adam()).unwrap();
        let sc = &c.self_imitation;
        let (mb, mh) = (
            self_imitation_step(&mut burn, sc, (o, a), &rows, 10.0),
            self_imitation_step(&mut host, sc, (o, a), &rows, 10.0),
        );
        let positive = mh.clone().read();
        let share = positive
            .iter()
            .find(|(n, _)| *n == "self_imitation_positive")
            .unwrap()
            .1;
        assert!(share > 0.2 && share < 0.8, "{share}");
        let after = (burn.modules(), host.modules());
        assert_paths_agree(&start, &expected, after, (mb, mh));
        // Rows that all earned less than their value: no step at all.
        let low = self_imitation::Batch {
            returns: vec![-1e6; 64],
            ..rows
        };
        let before = flat(&host.modules());
        let m = self_imitation_step(&mut host, sc, (o, a), &low, 10.0).read();
        assert!(m.iter().all(|(n, _)| *n != "self_imitation_grad_norm"));
        assert_eq!(flat(&host.modules()), before);
    }

    #[test]
    fn the_bound_loss_reaches_only_means_past_the_bound() {
        // Two rows of two means, bound 1, weight 0.5: (1.5, -0.2) and (-3, 1).
        let (loss, d) = bound_loss(&[1.5, -0.2, -3.0, 1.0], 2, 0.5, 1.0);
        assert!((loss - 0.25 * (0.25 + 4.0)).abs() < 1e-6, "{loss}");
        assert_eq!(d, vec![0.5 * 0.5, 0.0, 0.5 * -2.0, 0.0]);
        let bad = PpoConfig {
            bounds_loss_coef: -1.0,
            ..PpoConfig::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("bounds_loss_coef"), "{e}");
    }

    #[test]
    fn the_surrogates_gradient_passes_where_the_clip_is_not_taken() {
        let r = crate::rows::HostRows;
        // Ratios 0.5, 1.1, 1.5, 1.5 with advantages 1, 1, 1, -1 (clip 0.2): the first row
        // takes its unclipped term, the second is inside the range, the third is clipped
        // (no gradient), the fourth takes its unclipped term.
        let log_prob: Vec<f32> = [0.5f32, 1.1, 1.5, 1.5].iter().map(|x| x.ln()).collect();
        let s = clipped_surrogate(
            &r,
            (&log_prob, &vec![0.0; 4]),
            &vec![1.0, 1.0, 1.0, -1.0],
            0.2,
            4,
        );
        let want = [-0.5 / 4.0, -1.1 / 4.0, 0.0, 1.5 / 4.0];
        for (g, w) in s.d_log_prob.iter().zip(want) {
            assert!((g - w).abs() < 1e-6, "{:?}", s.d_log_prob);
        }
        assert_eq!(s.clip_fraction, vec![0.75]);
        // Burn's autodiff of the same loss.
        let dev = device();
        let lp = vector(&log_prob, &dev).require_grad();
        let ratio = lp.clone().exp();
        let adv = vector(&[1.0, 1.0, 1.0, -1.0], &dev);
        let loss = (adv.clone() * ratio.clone())
            .min_pair(adv * ratio.clamp(0.8, 1.2))
            .mean()
            .neg();
        let grads = loss.backward();
        let got = host(lp.grad(&grads).unwrap());
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-6, "{got:?}");
        }
    }

    /// [`drive`] with the [`small`] settings: the learner only.
    fn driven(host_path: bool, rounds: usize) -> Ppo {
        drive(small(), host_path, rounds).0
    }

    /// 16-step rollouts on 2 envs, minibatches of 8, 2 epochs.
    fn small() -> PpoConfig {
        PpoConfig {
            n_steps: 16,
            batch_size: 8,
            n_epochs: 2,
            ..PpoConfig::default()
        }
    }

    /// A 3 -> 2 learner of settings `c` driven through `rounds` rollouts on made-up
    /// observations and rewards (env 0's episodes 11 steps long; [`teacher`] labels every
    /// row), and each update's metrics.
    fn drive(c: PpoConfig, host_path: bool, rounds: usize) -> (Ppo, Vec<Vec<(&'static str, f64)>>) {
        let mut ppo = Ppo::new(3, 2, c, 7, &device());
        if host_path {
            ppo.on_host_path().unwrap();
        }
        let updates = drive_on(&mut ppo, rounds);
        (ppo, updates)
    }

    /// [`drive`]'s rollouts with a learner already built.
    fn drive_on(ppo: &mut Ppo, rounds: usize) -> Vec<Vec<(&'static str, f64)>> {
        let mut k = 0;
        let mut updates = Vec::new();
        for _ in 0..rounds {
            loop {
                let obs: Vec<f32> = (0..6).map(|i| ((k * 6 + i) as f32 * 0.37).sin()).collect();
                let next: Vec<f32> = obs.iter().map(|x| x * 0.9).collect();
                let actions = ppo.act(&obs, ActMode::Explore);
                let rewards: Vec<f32> = actions.chunks(2).map(|a| -a[0] * a[0] + a[1]).collect();
                let done = k % 11 == 10;
                let labels = teacher(&obs);
                ppo.observe(&Experience {
                    obs: &obs,
                    actions: &actions,
                    rewards: &rewards,
                    next_obs: &next,
                    final_obs: vec![None, None],
                    terminated: &[done, false],
                    truncated: &[false, false],
                    absorbing: vec![false, false],
                    teacher: Some(&labels),
                });
                k += 1;
                if let Some(m) = ppo.update(1.0) {
                    updates.push(m.read());
                    break;
                }
            }
        }
        updates
    }

    /// The made-up teacher of [`drive`]'s 3 -> 2 rows: `(0.6 o_0, 0.3 o_1 - 0.5)`, against
    /// the rewards' pull towards `(0, 1)`.
    fn teacher(obs: &[f32]) -> Vec<f32> {
        obs.chunks(3)
            .flat_map(|o| [0.6 * o[0], 0.3 * o[1] - 0.5])
            .collect()
    }

    /// The metric `name` of one update's metrics, if logged.
    fn value(m: &[(&str, f64)], name: &str) -> Option<f64> {
        m.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
    }

    /// The squared error of the policy's means from [`teacher`]'s actions on 100 states
    /// none of the tests trains on, per state.
    fn error(ppo: &mut Ppo) -> f32 {
        let obs: Vec<f32> = (0..300).map(|i| (i as f32 * 0.731 + 0.2).sin()).collect();
        let means = ppo.act(&obs, ActMode::Deterministic);
        (means.iter().zip(&teacher(&obs)))
            .map(|(m, a)| (m - a).powi(2))
            .sum::<f32>()
            / 100.0
    }

    /// Kickstarted, the policy's means come to the teacher's actions on states it never
    /// saw (a tenth of the squared error of PPO alone, which follows the rewards), the
    /// logged cloning loss falls and its weight follows the schedule; off, nothing of it
    /// runs.
    #[test]
    fn a_kickstarted_policy_clones_its_teacher() {
        let mut c = small();
        c.kickstart = KickstartConfig {
            teacher: Some("shooter".into()),
            coef_start: 20.0,
            coef_end: 20.0,
            ..KickstartConfig::default()
        };
        let (mut cloned, updates) = drive(c, true, 40);
        let (mut plain, plain_updates) = drive(small(), true, 40);
        let (e_cloned, e_plain) = (error(&mut cloned), error(&mut plain));
        assert!(
            e_cloned < 0.02 && e_cloned < 0.1 * e_plain,
            "kickstarted {e_cloned}, alone {e_plain}"
        );
        let loss: Vec<f64> = updates
            .iter()
            .map(|m| value(m, "kickstart_loss").unwrap())
            .collect();
        assert!(loss[loss.len() - 1] < 0.1 * loss[0], "{loss:?}");
        assert_eq!(value(&updates[0], "kickstart_coef"), Some(20.0));
        assert!(
            plain_updates
                .iter()
                .all(|m| value(m, "kickstart_loss").is_none())
        );
        assert!(
            updates
                .iter()
                .all(|m| value(m, "kickstart_aggregate_rows").is_none())
        );
    }

    /// With `keep`, each rollout's labelled rows join the aggregate (the newest 150 kept)
    /// and its cloning steps bring the means to the teacher's on unseen states, on both
    /// paths, with the rollout's own epochs cut to one.
    #[test]
    fn a_kickstarted_policy_clones_its_teacher_from_the_aggregate() {
        for host_path in [true, false] {
            let mut c = small();
            c.n_epochs = 1;
            c.kickstart = KickstartConfig {
                teacher: Some("shooter".into()),
                coef_start: 20.0,
                coef_end: 20.0,
                keep: 150,
                updates: 8,
                ..KickstartConfig::default()
            };
            let (mut cloned, updates) = drive(c, host_path, 40);
            let rows: Vec<f64> = (updates.iter())
                .map(|m| value(m, "kickstart_aggregate_rows").unwrap())
                .collect();
            let per_rollout = rows[0];
            assert!(per_rollout > 0.0 && per_rollout < 150.0, "{rows:?}");
            assert_eq!(rows[1], (2.0 * per_rollout).min(150.0));
            assert_eq!(rows[rows.len() - 1], 150.0);
            let loss: Vec<f64> = (updates.iter())
                .map(|m| value(m, "kickstart_aggregate_loss").unwrap())
                .collect();
            assert!(loss[loss.len() - 1] < 0.1 * loss[0], "{loss:?}");
            let e = error(&mut cloned);
            assert!(e < 0.02, "host path {host_path}: {e}");
        }
    }

    /// With demonstrations of [`teacher`] (on states of their own) handed in, the cloning
    /// steps bring the policy's means to the teacher's actions on states it never saw (a
    /// twentieth of the squared error of PPO alone), their logged loss falls; without
    /// `[ppo.demonstrations]` the agent refuses them and nothing of it runs.
    #[test]
    fn handed_demonstrations_are_cloned_after_each_update() {
        let obs: Vec<f32> = (0..600).map(|i| (i as f32 * 1.37 + 0.5).cos()).collect();
        let actions = teacher(&obs);
        let rewards = vec![0.0; 200];
        let demo = Demonstration {
            obs: &obs,
            actions: &actions,
            rewards: &rewards,
            terminated: false,
            absorbing: false,
        };
        let mut c = small();
        c.demonstrations = Some(DemoCloningConfig {
            coef: 20.0,
            batch_size: 32,
            updates: 8,
            ..DemoCloningConfig::default()
        });
        let mut cloned = Ppo::new(3, 2, c, 7, &device());
        cloned.on_host_path().unwrap();
        assert_eq!(cloned.set_demonstrations(&[demo]), Ok(200));
        let updates = drive_on(&mut cloned, 40);
        let (mut plain, plain_updates) = drive(small(), true, 40);
        let (e_cloned, e_plain) = (error(&mut cloned), error(&mut plain));
        assert!(
            e_cloned < 0.1 && e_cloned < 0.05 * e_plain,
            "cloned {e_cloned}, alone {e_plain}"
        );
        let loss: Vec<f64> = (updates.iter())
            .map(|m| value(m, "demo_cloning_loss").unwrap())
            .collect();
        assert!(loss[loss.len() - 1] < 0.1 * loss[0], "{loss:?}");
        assert_eq!(value(&updates[0], "demo_cloning_rows"), Some(200.0));
        let refused = plain.set_demonstrations(&[demo]).unwrap_err();
        assert!(refused.contains("ppo.demonstrations"), "{refused}");
        assert!((plain_updates.iter()).all(|m| value(m, "demo_cloning_loss").is_none()));
    }

    /// With self-imitation on, env 0's finished episodes fill the buffer and, once it
    /// holds a minibatch, every update takes its steps on it (the policy then differs
    /// from PPO's alone); off, nothing of it runs.
    #[test]
    fn self_imitation_steps_follow_each_update_once_episodes_are_kept() {
        let mut c = small();
        c.self_imitation = SelfImitationConfig {
            coef: 1.0,
            updates: 3,
            batch_size: 2,
            capacity: 40,
            ..SelfImitationConfig::default()
        };
        let (with, updates) = drive(c, true, 4);
        let rows: Vec<f64> = updates
            .iter()
            .map(|m| value(m, "self_imitation_rows").unwrap())
            .collect();
        assert!(
            rows[rows.len() - 1] >= 2.0 && rows.iter().all(|&r| r <= 40.0),
            "{rows:?}"
        );
        assert!(rows.windows(2).all(|w| w[0] <= w[1]), "{rows:?}");
        let last = updates.last().unwrap();
        assert!(
            value(last, "self_imitation_grad_norm").is_some(),
            "{last:?}"
        );
        let (without, plain) = drive(small(), true, 4);
        assert!(
            plain
                .iter()
                .all(|m| value(m, "self_imitation_rows").is_none())
        );
        assert_ne!(flat(&with.model()), flat(&without.model()));
    }

    #[test]
    fn the_host_path_follows_the_burn_path_over_rollouts_and_through_files() {
        let (burn, host) = (driven(false, 4), driven(true, 4));
        let start = flat(&driven(false, 0).model());
        let (pb, ph) = (flat(&burn.model()), flat(&host.model()));
        assert!(change_gap(&start, &pb, &ph) < 1e-3);
        assert_eq!(burn.gradient_steps(), host.gradient_steps());
        // Files: the host learner's networks load into either path.
        let dir = std::env::temp_dir().join(format!("ppo-host-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        host.save(&dir).unwrap();
        for host_path in [false, true] {
            let mut loaded = driven(host_path, 0);
            loaded.load(&dir).unwrap();
            assert_eq!(flat(&loaded.model()), ph);
        }
        std::fs::remove_dir_all(&dir).unwrap();
        // Acting: the same means from the same networks.
        let obs = [0.1, -0.4, 0.7];
        let (mut burn, mut host) = (burn, host);
        let (ab, ah) = (
            burn.act(&obs, ActMode::Deterministic),
            host.act(&obs, ActMode::Deterministic),
        );
        assert!(
            ab.iter().zip(&ah).all(|(x, y)| (x - y).abs() < 1e-4),
            "{ab:?} {ah:?}"
        );
        // The log-density of a sample as the Burn distribution computes it.
        let noise = [0.3, -1.2];
        let (raw, lp) = HostNetworks::from_modules(host.model(), Adam::new(AdamConfig::default()))
            .unwrap()
            .sample(&obs, &noise);
        let dev = device().without_autodiff();
        let (mean, log_std) = host
            .model()
            .policy
            .valid()
            .distribution(matrix(&obs, 3, &dev));
        let want =
            crate::tensors::host(diag_gaussian_log_prob(mean, log_std, matrix(&raw, 2, &dev)));
        assert!((lp[0] - want[0]).abs() < 1e-4, "{lp:?} {want:?}");
    }

    #[test]
    fn the_policy_explores_from_log_std_init_and_the_setting_is_checked() {
        let c = PpoConfig {
            log_std_init: -2.0,
            ..PpoConfig::default()
        };
        let obs = [0.1, -0.4, 0.7];
        let mut ppo = Ppo::new(3, 2, c.clone(), 5, &device());
        let dev = device().without_autodiff();
        let (_, log_std) = ppo
            .model()
            .policy
            .valid()
            .distribution(matrix(&obs, 3, &dev));
        assert_eq!(host(log_std.flatten::<1>(0, 1)), vec![-2.0, -2.0]);
        // Samples spread around the mean by e^-2 (0.135), 400 draws.
        let mean = ppo.act(&obs, ActMode::Deterministic);
        let draws: Vec<f32> = (0..400)
            .flat_map(|_| ppo.act(&obs, ActMode::Sample))
            .collect();
        for (d, m) in mean.iter().enumerate() {
            let sd = (draws
                .iter()
                .skip(d)
                .step_by(2)
                .map(|x| (x - m).powi(2))
                .sum::<f32>()
                / 400.0)
                .sqrt();
            assert!((sd - (-2.0f32).exp()).abs() < 0.02, "dim {d}: sd {sd}");
        }
        // The default is SB3's 0, and the same networks otherwise.
        let plain = Ppo::new(3, 2, PpoConfig::default(), 5, &device()).model();
        let (_, log_std) = plain.policy.valid().distribution(matrix(&obs, 3, &dev));
        assert_eq!(host(log_std.flatten::<1>(0, 1)), vec![0.0, 0.0]);
        let bad = PpoConfig {
            log_std_init: f32::NAN,
            ..PpoConfig::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("log_std_init"), "{e}");
    }

    #[test]
    fn correlated_noise_holds_deviations_restarts_with_episodes_and_resumes() {
        crate::test_support::correlated_exploration_holds_restarts_and_resumes(|rho| {
            let c = PpoConfig {
                noise_correlation: rho,
                log_std_init: -3.0,
                ..PpoConfig::default()
            };
            Ppo::new(3, 2, c, 5, &device())
        });
        let bad = PpoConfig {
            noise_correlation: 1.0,
            ..PpoConfig::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("noise_correlation"), "{e}");
    }

    #[test]
    fn the_host_path_refuses_images() {
        let image = ObsShape::Image {
            channels: 3,
            height: 36,
            width: 36,
        };
        let mut ppo = Ppo::new(image, 2, PpoConfig::default(), 1, &device());
        let err = ppo.on_host_path().unwrap_err();
        assert!(err.contains("image"), "{err}");
    }
}
