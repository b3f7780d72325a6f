//! The actors on the host MLP path ([`crate::host_mlp`]), with their output's backward
//! pass written out: SAC's squashed Gaussian ([`HostSquashedGaussian`], the network and
//! distribution of [`crate::SquashedGaussianActor`]), TD3's deterministic tanh actor
//! ([`HostDeterministic`], [`crate::DeterministicActor`]'s: `a = tanh(mlp(obs))`,
//! backward `dz = da (1 - a^2)`) and PPO's Gaussian ([`HostGaussianPolicy`],
//! [`crate::GaussianPolicy`]'s).
//!
//! The squashed Gaussian's forward, per row (`A` actions): `z = mlp(obs) [2A]`, `mean = z[..A]`,
//! `log_std = clamp(z[A..], LOG_STD_MIN, LOG_STD_MAX)`, `u = mean + exp(log_std) * noise`,
//! `a = tanh(u)`,
//! `log pi = sum_j (-0.5 ((u_j - mean_j) / std_j)^2 - log_std_j - 0.5 ln 2 pi - ln(1 - tanh(u_j)^2 + eps))`.
//!
//! Backward, given `da = dL/da [batch, A]`, `dlp = dL/dlog pi [batch]` and optionally
//! `dd = dL/d tanh(mean)` on the first rows (behaviour cloning):
//! `du = da (1 - a^2) + dlp * 2 t (1 - t^2) / (1 - t^2 + eps)` (`t = tanh(u)`, the
//! squashing term taken on its own path, as the Burn actor keeps it),
//! `dmean = du (+ dd (1 - tanh(mean)^2))`, `dlog_std = du * std * noise - dlp` (the
//! Gaussian term's `(u - mean) / std` is `noise` whatever `mean` and `log_std`: only its
//! `- log_std` has a gradient), through the clamp where it is not clamped.

use crate::distributions::{HALF_LN_2PI, LOG_STD_MAX, LOG_STD_MIN, TANH_EPSILON};
use crate::host_mlp::{HostMlp, MlpTape};

/// The squashed Gaussian actor with its latest sample kept for the backward pass.
#[derive(Clone, Debug)]
pub struct HostSquashedGaussian {
    /// `obs [batch, obs_dim] -> [batch, 2 * action_dim]` (mean, then log std).
    pub mlp: HostMlp,
    /// The latest [`HostSquashedGaussian::sample`]'s forward pass.
    tape: MlpTape,
    /// What the latest sample's backward pass needs.
    kept: Kept,
    /// The forward pass and sample of what is not walked back.
    scratch: MlpTape,
    scratch_kept: Kept,
}

/// Of a sample, `[batch, action_dim]` each: the noise, `exp(log_std)`, `tanh(u)` and
/// whether each log std lay inside the clamp.
#[derive(Clone, Debug, Default)]
struct Kept {
    noise: Vec<f32>,
    std: Vec<f32>,
    squashed: Vec<f32>,
    unclamped: Vec<bool>,
}

/// Actions and log-densities `([batch, a], [batch])` of the network outputs `z
/// [batch, 2a]` under `noise [batch, a]`, what the backward needs written to `kept`.
fn squashed_sample(z: &[f32], noise: &[f32], a: usize, kept: &mut Kept) -> (Vec<f32>, Vec<f32>) {
    let batch = z.len() / (2 * a);
    assert_eq!(noise.len(), batch * a, "noise [batch, action_dim]");
    let Kept {
        std,
        unclamped,
        squashed,
        noise: kept_noise,
    } = kept;
    std.clear();
    unclamped.clear();
    squashed.clear();
    kept_noise.clear();
    kept_noise.extend_from_slice(noise);
    let mut log_prob = Vec::with_capacity(batch);
    for (row, eps) in z.chunks_exact(2 * a).zip(noise.chunks_exact(a)) {
        let (mean, raw) = row.split_at(a);
        let mut lp = 0.0;
        for j in 0..a {
            let log_std = raw[j].clamp(LOG_STD_MIN, LOG_STD_MAX);
            let s = log_std.exp();
            let u = mean[j] + s * eps[j];
            let t = u.tanh();
            let gauss = (u - mean[j]) / s;
            lp += gaussian_term(gauss, log_std);
            lp -= (1.0 + TANH_EPSILON - t * t).ln();
            std.push(s);
            unclamped.push((LOG_STD_MIN..=LOG_STD_MAX).contains(&raw[j]));
            squashed.push(t);
        }
        log_prob.push(lp);
    }
    (squashed.clone(), log_prob)
}

/// One action's term of a diagonal Gaussian's log-density, `-0.5 z^2 - log_std - 0.5 ln 2 pi`
/// with `z = (x - mean) / std`.
fn gaussian_term(z: f32, log_std: f32) -> f32 {
    (-0.5 * z * z - log_std) - HALF_LN_2PI
}

/// `tanh(mean)` of the first `rows` rows of network outputs `z [batch, 2a]`.
fn squashed_means(z: &[f32], a: usize, rows: usize) -> Vec<f32> {
    z.chunks_exact(2 * a)
        .take(rows)
        .flat_map(|row| row[..a].iter().map(|m| m.tanh()))
        .collect()
}

impl HostSquashedGaussian {
    /// The actor computing with `mlp`.
    pub fn new(mlp: HostMlp) -> Self {
        Self {
            mlp,
            tape: MlpTape::default(),
            kept: Kept::default(),
            scratch: MlpTape::default(),
            scratch_kept: Kept::default(),
        }
    }

    /// Actions per row.
    pub fn action_dim(&self) -> usize {
        self.mlp.output_dim() / 2
    }

    /// Reparameterised actions `tanh(mean + std * noise)` `[batch, action_dim]` and their
    /// log-densities `[batch]` for `obs [batch, obs_dim]` and `noise [batch, action_dim]`
    /// (standard normal), kept for [`HostSquashedGaussian::backward`].
    pub fn sample(&mut self, obs: &[f32], noise: &[f32]) -> (Vec<f32>, Vec<f32>) {
        let a = self.action_dim();
        let z = self.mlp.forward(obs, &mut self.tape);
        squashed_sample(z, noise, a, &mut self.kept)
    }

    /// As [`HostSquashedGaussian::sample`], not kept: the latest sample stays the one
    /// [`HostSquashedGaussian::backward`] walks back (target values, exploration).
    pub fn sample_detached(&mut self, obs: &[f32], noise: &[f32]) -> (Vec<f32>, Vec<f32>) {
        let a = self.action_dim();
        let z = self.mlp.forward(obs, &mut self.scratch);
        squashed_sample(z, noise, a, &mut self.scratch_kept)
    }

    /// `tanh(mean)` of the latest sample's first `rows` rows, `[rows, action_dim]`.
    pub fn sampled_means(&self, rows: usize) -> Vec<f32> {
        squashed_means(self.tape.output(), self.action_dim(), rows)
    }

    /// The deterministic actions `tanh(mean)` `[batch, action_dim]` (not kept).
    pub fn deterministic(&mut self, obs: &[f32]) -> Vec<f32> {
        let a = self.action_dim();
        let z = self.mlp.forward(obs, &mut self.scratch);
        squashed_means(z, a, usize::MAX)
    }

    /// Adds `dL/dparams` of the latest sample to `grads` (the MLP's layout), given
    /// `d_actions [batch, action_dim]`, `d_log_prob [batch]` and, for the first rows,
    /// `d_means`: the gradient with respect to `tanh(mean)` `[rows, action_dim]`.
    pub fn backward(
        &mut self,
        d_actions: &[f32],
        d_log_prob: &[f32],
        d_means: Option<&[f32]>,
        grads: &mut [f32],
    ) {
        let a = self.action_dim();
        let batch = self.tape.batch();
        assert_eq!(d_actions.len(), batch * a, "d_actions [batch, action_dim]");
        assert_eq!(d_log_prob.len(), batch, "d_log_prob [batch]");
        let z = self.tape.output();
        let Kept {
            noise,
            std,
            squashed,
            unclamped,
        } = &self.kept;
        let mut dz = vec![0.0; batch * 2 * a];
        for i in 0..batch {
            let dlp = d_log_prob[i];
            for j in 0..a {
                let k = i * a + j;
                let t = squashed[k];
                let one_minus = 1.0 - t * t;
                let du = d_actions[k] * one_minus
                    + dlp * 2.0 * t * one_minus / (one_minus + TANH_EPSILON);
                let mut d_mean = du;
                if let Some(dd) = d_means.filter(|dd| k < dd.len()) {
                    let m = z[i * 2 * a + j].tanh();
                    d_mean += dd[k] * (1.0 - m * m);
                }
                let d_log_std = du * std[k] * noise[k] - dlp;
                dz[i * 2 * a + j] = d_mean;
                dz[i * 2 * a + a + j] = if unclamped[k] { d_log_std } else { 0.0 };
            }
        }
        self.mlp.backward(&mut self.tape, &dz, Some(grads), None);
    }
}

/// TD3's actor `a = tanh(mlp(obs))` with its latest kept pass.
#[derive(Clone, Debug)]
pub struct HostDeterministic {
    /// `obs [batch, obs_dim] -> [batch, action_dim]`, before the tanh.
    pub mlp: HostMlp,
    /// The latest [`HostDeterministic::forward`] and its actions.
    tape: MlpTape,
    actions: Vec<f32>,
    /// The passes of [`HostDeterministic::forward_detached`].
    scratch: MlpTape,
}

impl HostDeterministic {
    /// The actor computing with `mlp`.
    pub fn new(mlp: HostMlp) -> Self {
        Self {
            mlp,
            tape: MlpTape::default(),
            actions: Vec::new(),
            scratch: MlpTape::default(),
        }
    }

    /// Actions `[batch, action_dim]` in `[-1, 1]` for `obs [batch, obs_dim]`, kept for
    /// [`HostDeterministic::backward`].
    pub fn forward(&mut self, obs: &[f32]) -> Vec<f32> {
        let z = self.mlp.forward(obs, &mut self.tape);
        self.actions.clear();
        self.actions.extend(z.iter().map(|z| z.tanh()));
        self.actions.clone()
    }

    /// As [`HostDeterministic::forward`], not kept (target actions, acting).
    pub fn forward_detached(&mut self, obs: &[f32]) -> Vec<f32> {
        let z = self.mlp.forward(obs, &mut self.scratch);
        z.iter().map(|z| z.tanh()).collect()
    }

    /// Adds `dL/dparams` of the latest kept pass to `grads` (the MLP's layout), given
    /// `d_actions [batch, action_dim]`.
    pub fn backward(&mut self, d_actions: &[f32], grads: &mut [f32]) {
        assert_eq!(
            d_actions.len(),
            self.actions.len(),
            "d_actions [batch, action_dim]"
        );
        let dz: Vec<f32> = d_actions
            .iter()
            .zip(&self.actions)
            .map(|(d, a)| d * (1.0 - a * a))
            .collect();
        self.mlp.backward(&mut self.tape, &dz, Some(grads), None);
    }
}

/// PPO's Gaussian policy: `mean = mlp(obs)` `[batch, action_dim]` and a state-independent
/// `log_std` `[action_dim]` ([`crate::GaussianPolicy`]'s), with its latest evaluation kept.
///
/// Per row, with `z_j = (a_j - mean_j) / std_j`: `log pi = sum_j (-0.5 z_j^2 - log_std_j -
/// 0.5 ln 2 pi)`, `entropy = sum_j (0.5 + 0.5 ln 2 pi + log_std_j)`. Backward, given
/// `dlp = dL/d log pi` and `dent = dL/d entropy` `[batch]`: `dmean_j = dlp z_j / std_j`,
/// `dlog_std_j = sum over rows of (dlp (z_j^2 - 1) + dent)`.
#[derive(Clone, Debug)]
pub struct HostGaussianPolicy {
    /// `obs [batch, obs_dim] -> mean [batch, action_dim]`.
    pub mlp: HostMlp,
    /// `[action_dim]`.
    pub log_std: Vec<f32>,
    /// The latest [`HostGaussianPolicy::evaluate`]'s forward pass and its `z`.
    tape: MlpTape,
    z: Vec<f32>,
    /// The passes of what is not walked back (acting).
    scratch: MlpTape,
}

impl HostGaussianPolicy {
    /// The policy computing with `mlp` and `log_std` (one per action).
    pub fn new(mlp: HostMlp, log_std: Vec<f32>) -> Result<Self, String> {
        if log_std.len() != mlp.output_dim() {
            return Err(format!(
                "a log std per action: {} for {} actions",
                log_std.len(),
                mlp.output_dim()
            ));
        }
        Ok(Self {
            mlp,
            log_std,
            tape: MlpTape::default(),
            z: Vec::new(),
            scratch: MlpTape::default(),
        })
    }

    /// `(log pi(actions | obs), entropy)`, `[batch]` each, for `obs [batch, obs_dim]` and
    /// `actions [batch, action_dim]`, kept for [`HostGaussianPolicy::backward`].
    pub fn evaluate(&mut self, obs: &[f32], actions: &[f32]) -> (Vec<f32>, Vec<f32>) {
        let a = self.log_std.len();
        let mean = self.mlp.forward(obs, &mut self.tape);
        assert_eq!(actions.len(), mean.len(), "actions [batch, action_dim]");
        let std: Vec<f32> = self.log_std.iter().map(|l| l.exp()).collect();
        let entropy_row: f32 = self.log_std.iter().map(|l| l + 0.5 + HALF_LN_2PI).sum();
        self.z.clear();
        let mut log_prob = Vec::with_capacity(mean.len() / a);
        for (m, x) in mean.chunks_exact(a).zip(actions.chunks_exact(a)) {
            let mut lp = 0.0;
            for j in 0..a {
                let z = (x[j] - m[j]) / std[j];
                lp += gaussian_term(z, self.log_std[j]);
                self.z.push(z);
            }
            log_prob.push(lp);
        }
        let entropy = vec![entropy_row; log_prob.len()];
        (log_prob, entropy)
    }

    /// The means `[batch, action_dim]` for `obs` (not kept).
    pub fn mean(&mut self, obs: &[f32]) -> Vec<f32> {
        self.mlp.forward(obs, &mut self.scratch).to_vec()
    }

    /// Raw actions `mean + std * noise` `[batch, action_dim]` for `obs` and standard-normal
    /// `noise`, and their log-densities `[batch]` (not kept; `(raw - mean) / std` is the
    /// noise itself).
    pub fn sample(&mut self, obs: &[f32], noise: &[f32]) -> (Vec<f32>, Vec<f32>) {
        let a = self.log_std.len();
        let mean = self.mlp.forward(obs, &mut self.scratch);
        assert_eq!(noise.len(), mean.len(), "noise [batch, action_dim]");
        let mut raw = Vec::with_capacity(mean.len());
        let mut log_probs = Vec::with_capacity(mean.len() / a);
        for (m, e) in mean.chunks_exact(a).zip(noise.chunks_exact(a)) {
            let mut lp = 0.0;
            for j in 0..a {
                raw.push(m[j] + self.log_std[j].exp() * e[j]);
                lp += gaussian_term(e[j], self.log_std[j]);
            }
            log_probs.push(lp);
        }
        (raw, log_probs)
    }

    /// The means `[batch, action_dim]` of the latest [`HostGaussianPolicy::evaluate`].
    pub fn kept_means(&self) -> &[f32] {
        self.tape.output()
    }

    /// Adds `dL/dparams` of the latest evaluation to `grads` (the MLP's layout) and
    /// `dL/dlog_std` to `log_std_grads`, given `d_log_prob` and `d_entropy` `[batch]` and,
    /// where a loss reads the means themselves, `d_means` `[batch, action_dim]`.
    pub fn backward(
        &mut self,
        (d_log_prob, d_entropy): (&[f32], &[f32]),
        d_means: Option<&[f32]>,
        grads: &mut [f32],
        log_std_grads: &mut [f32],
    ) {
        let a = self.log_std.len();
        let batch = self.tape.batch();
        assert_eq!(d_log_prob.len(), batch, "d_log_prob [batch]");
        assert_eq!(d_entropy.len(), batch, "d_entropy [batch]");
        let std: Vec<f32> = self.log_std.iter().map(|l| l.exp()).collect();
        let mut d_mean = vec![0.0; batch * a];
        for i in 0..batch {
            for j in 0..a {
                let z = self.z[i * a + j];
                d_mean[i * a + j] = d_log_prob[i] * z / std[j];
                log_std_grads[j] += d_log_prob[i] * (z * z - 1.0) + d_entropy[i];
            }
        }
        if let Some(extra) = d_means {
            for (d, e) in d_mean.iter_mut().zip(extra) {
                *d += e;
            }
        }
        self.mlp
            .backward(&mut self.tape, &d_mean, Some(grads), None);
    }
}
