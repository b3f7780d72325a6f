//! Settings shared by the algorithms: the networks and their optimiser, and the
//! off-policy replay schedule of SAC and TD3. Defaults are Stable-Baselines3's.

use crate::schedule::LrSchedule;
use foosball_nets::{Activation, AdamConfig, CnnConfig, ObsShape};

/// An invalid setting; `key` is its dotted path inside the algorithm's section (the
/// environment's error type, shared by every configuration of the project).
pub use foosball_env::ConfigError;

/// Checks `ok`, else an error for `key`.
pub(crate) fn ensure(ok: bool, key: &str, message: &str) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError::new(key, message))
    }
}

/// The discount factor every algorithm starts from (Stable-Baselines3's).
pub const DEFAULT_GAMMA: f32 = 0.99;

/// Checks a discount factor: `[0, 1]`.
pub(crate) fn check_gamma(gamma: f32) -> Result<(), ConfigError> {
    ensure((0.0..=1.0).contains(&gamma), "gamma", "must be in [0, 1]")
}

/// The networks of an algorithm (every actor and critic shares the hidden sizes) and
/// their Adam optimisers.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NetConfig {
    /// Hidden layer widths.
    pub hidden: Vec<usize>,
    /// Non-linearity between hidden layers.
    pub activation: Activation,
    /// Learning rate of every optimiser.
    pub lr: LrSchedule,
    /// Adam's betas, epsilon and global-norm gradient clipping.
    pub adam: AdamConfig,
    /// The CNN in front of every network when observations are images (SB3's NatureCNN
    /// by default; each network has its own, the twin critics share one).
    pub cnn: CnnConfig,
    /// Layer normalisation after every hidden layer of SAC's and TD3's Q-networks (their
    /// targets too); off by default, as in SB3 and the paper.
    pub critic_layer_norm: bool,
}

impl Default for NetConfig {
    fn default() -> Self {
        Self {
            hidden: vec![256, 256],
            activation: Activation::Relu,
            lr: LrSchedule::Constant(3e-4),
            adam: AdamConfig::default(),
            cnn: CnnConfig::default(),
            critic_layer_norm: false,
        }
    }
}

impl NetConfig {
    /// The initialiser of an agent's networks with these hidden layers.
    pub fn init<'a, R: rand::Rng>(
        &'a self,
        obs: ObsShape,
        action_dim: usize,
        rng: &'a mut R,
        device: &'a foosball_nets::Device,
    ) -> foosball_nets::NetInit<'a, R> {
        foosball_nets::NetInit {
            obs,
            action_dim,
            hidden: &self.hidden,
            activation: self.activation,
            cnn: &self.cnn,
            critic_layer_norm: self.critic_layer_norm,
            rng,
            device,
        }
    }

    /// Rejects empty or zero widths, bad rates, betas outside `[0, 1)`, `eps <= 0` and a
    /// non-positive clipping norm.
    pub fn validate(&self) -> Result<(), ConfigError> {
        ensure(
            !self.hidden.is_empty(),
            "hidden",
            "needs at least one hidden layer",
        )?;
        ensure(
            !self.hidden.contains(&0),
            "hidden",
            "widths must be positive",
        )?;
        ensure(
            self.lr.is_valid(),
            "lr",
            "learning rates must be finite and positive",
        )?;
        let beta = |b: f32| (0.0..1.0).contains(&b);
        ensure(beta(self.adam.beta1), "adam.beta1", "must be in [0, 1)")?;
        ensure(beta(self.adam.beta2), "adam.beta2", "must be in [0, 1)")?;
        ensure(self.adam.eps > 0.0, "adam.eps", "must be positive")?;
        let norm_ok = self
            .adam
            .max_grad_norm
            .is_none_or(|n| n.is_finite() && n > 0.0);
        ensure(norm_ok, "adam.max_grad_norm", "must be finite and positive")?;
        // Whether the layers fit the image is checked against the observation.
        self.cnn.validate().map_err(|e| ConfigError::new("cnn", e))
    }
}

/// SAC's and TD3's replay schedule.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OffPolicyConfig {
    /// Replay capacity in transitions.
    pub buffer_size: usize,
    /// Transitions collected with uniform random actions before training starts.
    pub learning_starts: u64,
    /// Minibatch rows per gradient step.
    pub batch_size: usize,
    /// Polyak coefficient of the target networks.
    pub tau: f32,
    /// Vec-env steps between training rounds.
    pub train_freq: u64,
    /// Gradient steps per training round.
    pub gradient_steps: usize,
    /// Factor on every reward as the replay stores it (1: SB3's; the returns logged and
    /// tested are the env's, unscaled). Under `reference` the shaping pays up to 300 per
    /// step, so Q-values run to 1e4-1e5 against a temperature that starts at 1.
    pub reward_scale: f32,
    /// Steps of the return each stored transition sums (1: SB3's one-step targets): the
    /// replay holds `(s_t, a_t, sum_k gamma^k r_(t+k), s_(t+n))` and the critics
    /// bootstrap with `gamma^n`; windows cut by a termination are stored shorter (they do
    /// not bootstrap), windows cut shorter than `n` by a truncation are dropped.
    pub n_step: usize,
    /// Share of every minibatch drawn from the demonstrations (`protocol.demonstrations`
    /// in a run), the rest from the replay; 0.5 is RLPD's symmetric sampling. Absent
    /// (default): no demonstrations, SB3's sampling. One-step returns only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub demo_share: Option<f32>,
    /// Value a terminated step that reached an absorbing state (the env's
    /// `StepInfo::absorbing`; foosball: the ball lying in a goal, which under the paper's
    /// rules ends the episode some steps after the goal) as that state paying the step's
    /// reward forever: stored as `r / (1 - gamma)` (reward scale included), in the
    /// replay and in the demonstrations. False (default, SB3's): the end pays nothing
    /// more, so under `reference` a goal is worth about 22 steps of 1000 against a
    /// dribble's 300 per step for as long as it lasts. Needs `gamma < 1`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub absorbing_ends: bool,
}

impl Default for OffPolicyConfig {
    fn default() -> Self {
        Self {
            buffer_size: 1_000_000,
            learning_starts: 100,
            batch_size: 256,
            tau: 0.005,
            train_freq: 1,
            gradient_steps: 1,
            reward_scale: 1.0,
            n_step: 1,
            demo_share: None,
            absorbing_ends: false,
        }
    }
}

impl OffPolicyConfig {
    /// Rejects zero sizes and coefficients outside their ranges, and `absorbing_ends` with
    /// the algorithm's `gamma` at 1 (an absorbing end would be worth infinitely much).
    pub fn validate(&self, gamma: f32) -> Result<(), ConfigError> {
        ensure(self.buffer_size > 0, "buffer_size", "must be positive")?;
        ensure(self.batch_size > 0, "batch_size", "must be positive")?;
        ensure(
            self.tau > 0.0 && self.tau <= 1.0,
            "tau",
            "must be in (0, 1]",
        )?;
        ensure(self.train_freq > 0, "train_freq", "must be positive")?;
        ensure(
            self.gradient_steps > 0,
            "gradient_steps",
            "must be positive",
        )?;
        ensure(
            self.reward_scale.is_finite() && self.reward_scale > 0.0,
            "reward_scale",
            "must be finite and positive",
        )?;
        ensure(self.n_step > 0, "n_step", "must be positive")?;
        ensure(
            self.demo_share.is_none_or(|s| s > 0.0 && s < 1.0),
            "demo_share",
            "must be in (0, 1)",
        )?;
        ensure(
            self.demo_share.is_none() || self.n_step == 1,
            "demo_share",
            "takes one-step returns (n_step = 1)",
        )?;
        ensure(
            !self.absorbing_ends || gamma < 1.0,
            "absorbing_ends",
            "needs gamma < 1 (an absorbing end is worth r / (1 - gamma))",
        )
    }

    /// The critics' discount of the bootstrapped value: `gamma^n_step`.
    pub fn bootstrap_discount(&self, gamma: f32) -> f32 {
        gamma.powi(self.n_step as i32)
    }

    /// What the replay stores for reward `r` of a step: `reward_scale * r`, and where the
    /// step `ends_absorbing` under `absorbing_ends`, that over `1 - gamma` (the
    /// discounted sum of the same reward at every later step).
    pub fn stored_reward(&self, r: f32, ends_absorbing: bool, gamma: f32) -> f32 {
        let scaled = r * self.reward_scale;
        if self.absorbing_ends && ends_absorbing {
            scaled / (1.0 - gamma)
        } else {
            scaled
        }
    }
}
