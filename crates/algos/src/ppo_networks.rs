//! PPO's policy and value networks as its update and its acting use them, on either path:
//! [`BurnNetworks`] (the [`ActorCritic`] module, gradients by autodiff: any backend, image
//! observations) and [`HostNetworks`] (the host MLP path, issue 51). The minibatch step
//! ([`crate::ppo`]) is written once over [`PpoNetworks`]: it computes the loss's
//! gradients with respect to `log pi`, the entropy and `V` with [`Rows`] arithmetic and
//! hands them to the networks, which walk them back (Burn as
//! `sum(output * gradient).backward()`, the host path by hand) and take one Adam step
//! over both networks (one clipping norm, as SB3's one optimiser).

use crate::network_path::HoldsModules;
use crate::rows::{DeviceRows, HostRows, Matrix, Rows};
use crate::tensors::{host, matrix};
use burn::module::Module;
use foosball_nets::distributions::diag_gaussian_log_prob;
use foosball_nets::{
    Adam, Device, GaussianPolicy, HostGaussianPolicy, HostMlp, MlpTape, StepReport, Tensor,
    ValueCritic,
};

/// PPO's policy and value networks, trained by one optimiser (`actor_critic.bpk`).
#[derive(Module, Debug)]
pub struct ActorCritic {
    /// Gaussian policy with state-independent log-std.
    pub policy: GaussianPolicy,
    /// State-value critic.
    pub value: ValueCritic,
}

/// `log pi(actions | obs)`, the entropy and `V(obs)` of a minibatch, `[batch]` each.
pub struct Evaluation<V> {
    /// `log pi(actions | obs)`.
    pub log_prob: V,
    /// The policy's entropy.
    pub entropy: V,
    /// `V(obs)`.
    pub values: V,
}

/// What PPO asks of its networks. Values and gradients of the step are [`Rows`] of
/// [`PpoNetworks::rows`]; acting reads and returns host values.
pub trait PpoNetworks {
    /// The arithmetic the step's formulas run on.
    type R: Rows + Clone;

    /// The arithmetic, on the networks' device.
    fn rows(&self) -> Self::R;
    /// The networks' outputs on `obs` and `actions`, kept for [`PpoNetworks::step`].
    fn evaluate(
        &mut self,
        obs: &<Self::R as Rows>::M,
        actions: &<Self::R as Rows>::M,
    ) -> Evaluation<<Self::R as Rows>::V>;
    /// The policy's means `[batch, action_dim]` in the kept evaluation, on the host (a
    /// read on a GPU).
    fn kept_means(&self) -> Vec<f32>;
    /// One Adam step on both networks from `dL/d log pi`, `dL/d entropy` and `dL/dV`
    /// (`[batch]` each) of the kept evaluation, and `dL/d mean` `[batch, action_dim]`
    /// where a loss term reads the means themselves.
    fn step(
        &mut self,
        d_log_prob: &<Self::R as Rows>::V,
        d_entropy: &<Self::R as Rows>::V,
        d_values: &<Self::R as Rows>::V,
        d_means: Option<&[f32]>,
        lr: f64,
    ) -> StepReport;
    /// The policy's means `[n, action_dim]` for `obs [n, obs_dim]`.
    fn means(&mut self, obs: &[f32]) -> Vec<f32>;
    /// Raw actions `mean + std * noise` `[n, action_dim]` for standard-normal `noise`,
    /// and their log-probabilities `[n]`.
    fn sample(&mut self, obs: &[f32], noise: &[f32]) -> (Vec<f32>, Vec<f32>);
    /// `V(obs)`, `[n]`.
    fn values(&mut self, obs: &[f32]) -> Vec<f32>;
    /// The optimiser (its step count, its state).
    fn optimiser(&self) -> &Adam;
    /// The optimiser, to restore.
    fn optimiser_mut(&mut self) -> &mut Adam;
}

/// The [`ActorCritic`] module on an autodiff device with the graph of the latest
/// evaluation.
pub struct BurnNetworks {
    /// Both networks.
    pub model: ActorCritic,
    /// Their optimiser.
    pub optim: Adam,
    device: Device,
    /// The kept `log pi`, entropy and `V` in the graph, and the means `[batch, action_dim]`.
    kept: Option<([Tensor<1>; 3], Tensor<2>)>,
    obs_dim: usize,
}

impl BurnNetworks {
    /// `model` on `device` (an autodiff device) stepped by `optim`, for `obs_dim`-wide
    /// observations.
    pub fn new(model: ActorCritic, optim: Adam, device: &Device, obs_dim: usize) -> Self {
        Self {
            model,
            optim,
            device: device.clone(),
            kept: None,
            obs_dim,
        }
    }

    fn plain(&self) -> Device {
        self.device.clone().without_autodiff()
    }
}

impl HoldsModules for BurnNetworks {
    type Modules = ActorCritic;

    fn modules(&self) -> ActorCritic {
        self.model.clone()
    }

    fn set_modules(&mut self, modules: ActorCritic) -> Result<(), String> {
        self.model = modules;
        Ok(())
    }
}

impl PpoNetworks for BurnNetworks {
    type R = DeviceRows;

    fn rows(&self) -> DeviceRows {
        DeviceRows {
            device: self.plain(),
        }
    }

    fn evaluate(&mut self, obs: &Tensor<2>, actions: &Tensor<2>) -> Evaluation<Tensor<1>> {
        let obs = obs.clone().autodiff();
        let (log_prob, entropy, mean) = self
            .model
            .policy
            .evaluate(obs.clone(), actions.clone().autodiff());
        let values = self.model.value.forward(obs);
        let out = Evaluation {
            log_prob: log_prob.clone().inner(),
            entropy: entropy.clone().inner(),
            values: values.clone().inner(),
        };
        self.kept = Some(([log_prob, entropy, values], mean));
        out
    }

    fn kept_means(&self) -> Vec<f32> {
        let (_, mean) = self.kept.as_ref().expect("a kept evaluation");
        host(mean.clone().inner())
    }

    fn step(
        &mut self,
        d_log_prob: &Tensor<1>,
        d_entropy: &Tensor<1>,
        d_values: &Tensor<1>,
        d_means: Option<&[f32]>,
        lr: f64,
    ) -> StepReport {
        let ([log_prob, entropy, values], mean) = self.kept.take().expect("a kept evaluation");
        let mut walked = (log_prob * d_log_prob.clone().autodiff()).sum()
            + (entropy * d_entropy.clone().autodiff()).sum()
            + (values * d_values.clone().autodiff()).sum();
        if let Some(d) = d_means {
            let d = matrix(d, mean.dims()[1], &self.plain()).autodiff();
            walked = walked + (mean * d).sum();
        }
        let mut grads = walked.backward();
        self.optim.step_in_place(&mut self.model, &mut grads, lr)
    }

    fn means(&mut self, obs: &[f32]) -> Vec<f32> {
        let obs = matrix(obs, self.obs_dim, &self.plain());
        host(self.model.policy.valid().distribution(obs).0)
    }

    fn sample(&mut self, obs: &[f32], noise: &[f32]) -> (Vec<f32>, Vec<f32>) {
        let plain = self.plain();
        let (mean, log_std) =
            (self.model.policy.valid()).distribution(matrix(obs, self.obs_dim, &plain));
        let noise = matrix(noise, mean.dims()[1], &plain);
        let raw = mean.clone() + log_std.clone().exp() * noise;
        let log_probs = host(diag_gaussian_log_prob(mean, log_std, raw.clone()));
        (host(raw), log_probs)
    }

    fn values(&mut self, obs: &[f32]) -> Vec<f32> {
        let obs = matrix(obs, self.obs_dim, &self.plain());
        host(self.model.value.valid().forward(obs))
    }

    fn optimiser(&self) -> &Adam {
        &self.optim
    }

    fn optimiser_mut(&mut self) -> &mut Adam {
        &mut self.optim
    }
}

/// Both networks on the host MLP path with one gradient buffer (the policy's MLP, its
/// log std, the value MLP: Burn's visiting order of [`ActorCritic`]).
pub struct HostNetworks {
    /// The policy.
    pub policy: HostGaussianPolicy,
    /// `obs -> V [batch, 1]`.
    pub value: HostMlp,
    /// Their optimiser (over the one buffer).
    pub optim: Adam,
    value_tape: MlpTape,
    scratch: MlpTape,
    /// What [`HoldsModules::modules`] writes into.
    template: ActorCritic,
    grads: Vec<f32>,
}

impl HostNetworks {
    /// Copies of `model` on the host path stepped by `optim` (fresh, or a host run's); an
    /// error says what the path cannot compute.
    pub fn from_modules(model: ActorCritic, optim: Adam) -> Result<Self, String> {
        let policy = model.policy.to_host()?;
        let value = model.value.to_host()?;
        let len = policy.mlp.params().len() + policy.log_std.len() + value.params().len();
        Ok(Self {
            policy,
            value,
            optim,
            value_tape: MlpTape::default(),
            scratch: MlpTape::default(),
            template: model,
            grads: vec![0.0; len],
        })
    }
}

impl HoldsModules for HostNetworks {
    type Modules = ActorCritic;

    fn modules(&self) -> ActorCritic {
        let written = "a host copy has its modules' widths";
        let t = self.template.clone();
        ActorCritic {
            policy: t.policy.with_host_params(&self.policy).expect(written),
            value: t.value.with_host_params(&self.value).expect(written),
        }
    }

    fn set_modules(&mut self, modules: ActorCritic) -> Result<(), String> {
        *self = Self::from_modules(modules, self.optim.clone())?;
        Ok(())
    }
}

impl PpoNetworks for HostNetworks {
    type R = HostRows;

    fn rows(&self) -> HostRows {
        HostRows
    }

    fn evaluate(&mut self, obs: &Matrix, actions: &Matrix) -> Evaluation<Vec<f32>> {
        let (log_prob, entropy) = self.policy.evaluate(&obs.data, &actions.data);
        let values = self.value.forward(&obs.data, &mut self.value_tape).to_vec();
        Evaluation {
            log_prob,
            entropy,
            values,
        }
    }

    fn kept_means(&self) -> Vec<f32> {
        self.policy.kept_means().to_vec()
    }

    fn step(
        &mut self,
        d_log_prob: &Vec<f32>,
        d_entropy: &Vec<f32>,
        d_values: &Vec<f32>,
        d_means: Option<&[f32]>,
        lr: f64,
    ) -> StepReport {
        self.grads.fill(0.0);
        let (policy_grads, rest) = self.grads.split_at_mut(self.policy.mlp.params().len());
        let (log_std_grads, value_grads) = rest.split_at_mut(self.policy.log_std.len());
        (self.policy).backward(
            (d_log_prob, d_entropy),
            d_means,
            policy_grads,
            log_std_grads,
        );
        (self.value).backward(&mut self.value_tape, d_values, Some(value_grads), None);
        let mut params = [
            self.policy.mlp.params_mut(),
            &mut self.policy.log_std[..],
            self.value.params_mut(),
        ];
        self.optim.step_flat(&mut params, &self.grads, lr)
    }

    fn means(&mut self, obs: &[f32]) -> Vec<f32> {
        self.policy.mean(obs)
    }

    fn sample(&mut self, obs: &[f32], noise: &[f32]) -> (Vec<f32>, Vec<f32>) {
        self.policy.sample(obs, noise)
    }

    fn values(&mut self, obs: &[f32]) -> Vec<f32> {
        self.value.forward(obs, &mut self.scratch).to_vec()
    }

    fn optimiser(&self) -> &Adam {
        &self.optim
    }

    fn optimiser_mut(&mut self) -> &mut Adam {
        &mut self.optim
    }
}
