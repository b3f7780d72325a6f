//! SAC's networks as its update uses them, on either path: [`BurnNetworks`] (Burn
//! modules, gradients by autodiff: any backend, image observations) and
//! [`HostNetworks`] (the host MLP path: vector observations, the backward passes
//! written out, issue 51). The update itself ([`crate::sac`]) is written once over
//! [`SacNetworks`]: it computes each loss's gradient with respect to the networks'
//! outputs with [`Rows`] arithmetic and hands it to the networks, which walk it back
//! (Burn as `sum(output * gradient).backward()`, the host path by hand) and step Adam.
//!
//! [`Modules`] are the networks as files hold them; a host run saves and loads the same
//! files as a Burn run.

use crate::agent::AgentError;
use crate::rows::{DeviceRows, HostRows, Matrix, Rows};
use crate::tensors::vector;
use burn::module::{Module, Param};
use foosball_nets::host::{is_host, lerp_into};
use foosball_nets::store::{load_module, save_module};
use foosball_nets::{
    Adam, AdamConfig, Device, HostSquashedGaussian, HostTwinQ, Scalar, Snapshot, SnapshotError,
    SquashedGaussianActor, StepReport, Tensor, TwinQ, polyak_update,
};
use std::path::Path;

/// `log alpha`, a one-element trainable parameter.
#[derive(Module, Debug)]
pub struct Temperature {
    log_alpha: Param<Tensor<1>>,
}

impl Temperature {
    /// `log alpha = ln(alpha)` on `device`.
    pub fn new(alpha: f32, device: &Device) -> Self {
        Self {
            log_alpha: Param::from_tensor(vector(&[alpha.ln()], device)),
        }
    }

    /// `alpha = exp(log alpha)` on the host.
    pub fn alpha(&self) -> f32 {
        self.log_alpha_value().exp()
    }

    /// `log alpha`, `[1]`, in the graph.
    pub fn log_alpha_param(&self) -> Tensor<1> {
        self.log_alpha.val()
    }

    /// `log alpha` on the host.
    fn log_alpha_value(&self) -> f32 {
        Scalar::of(self.log_alpha.val().inner()).read() as f32
    }
}

/// SAC's networks as files hold them (`actor.bpk`, `critic.bpk`, `critic_target.bpk`,
/// `temperature.bpk`, `actor_average.bpk` when averaged).
#[derive(Clone, Debug)]
pub struct Modules {
    /// The actor.
    pub actor: SquashedGaussianActor,
    /// Its Polyak average (`actor_average_tau`), outside the graph.
    pub actor_average: Option<SquashedGaussianActor>,
    /// The twin critics.
    pub critic: TwinQ,
    /// Their target copy, outside the graph.
    pub critic_target: TwinQ,
    /// `log alpha`.
    pub temperature: Temperature,
}

impl Modules {
    /// Writes the networks into `dir`.
    pub fn save(&self, dir: &Path) -> Result<(), AgentError> {
        save_module(&self.actor, &dir.join("actor.bpk"))?;
        save_module(&self.critic, &dir.join("critic.bpk"))?;
        save_module(&self.critic_target, &dir.join("critic_target.bpk"))?;
        save_module(&self.temperature, &dir.join("temperature.bpk"))?;
        if let Some(average) = &self.actor_average {
            save_module(average, &dir.join("actor_average.bpk"))?;
        }
        Ok(())
    }

    /// These modules with the networks in `dir`; the temperature only when `temperature`
    /// (a held one stays the config's, whatever the saved networks learned).
    pub fn load(self, dir: &Path, temperature: bool) -> Result<Self, AgentError> {
        Ok(Self {
            actor: load_module(self.actor, &dir.join("actor.bpk"))?,
            critic: load_module(self.critic, &dir.join("critic.bpk"))?,
            critic_target: load_module(self.critic_target, &dir.join("critic_target.bpk"))?,
            temperature: match temperature {
                true => load_module(self.temperature, &dir.join("temperature.bpk"))?,
                false => self.temperature,
            },
            actor_average: match self.actor_average {
                Some(average) => Some(load_module(average, &dir.join("actor_average.bpk"))?),
                None => None,
            },
        })
    }

    /// Zeroes every network's input weights from the observation values at `inputs`.
    pub fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        self.actor.zero_obs_inputs(inputs)?;
        if let Some(average) = &mut self.actor_average {
            average.zero_obs_inputs(inputs)?;
        }
        self.critic.zero_obs_inputs(inputs)?;
        self.critic_target.zero_obs_inputs(inputs)
    }
}

/// Which gradient a Q-value pass is walked back for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Walk {
    /// The critics' own parameters (their regression).
    Params,
    /// The actions fed in, the critics frozen (the actor's loss).
    Actions,
}

/// What SAC's update asks of its networks. Values and gradients are [`Rows`] of
/// [`SacNetworks::rows`]; the networks keep what their backward passes need between the
/// forward call and the matching step.
pub trait SacNetworks {
    /// The arithmetic the update's formulas run on.
    type R: Rows + Clone;

    /// The arithmetic, on the networks' device.
    fn rows(&self) -> Self::R;
    /// Reparameterised actions `[batch, action_dim]` and `log pi` `[batch]` for `obs`
    /// and standard-normal `noise`, kept for [`SacNetworks::actor_step`].
    fn sample(
        &mut self,
        obs: &<Self::R as Rows>::M,
        noise: &<Self::R as Rows>::M,
    ) -> (<Self::R as Rows>::M, <Self::R as Rows>::V);
    /// The same, not kept (no gradient flows back).
    fn sample_detached(
        &mut self,
        obs: &<Self::R as Rows>::M,
        noise: &<Self::R as Rows>::M,
    ) -> (<Self::R as Rows>::M, <Self::R as Rows>::V);
    /// `tanh(mean)` of the kept sample's first `rows` rows, kept for the step.
    fn sampled_means(&mut self, rows: usize) -> <Self::R as Rows>::M;
    /// `log alpha`, `[1]`.
    fn log_alpha(&self) -> <Self::R as Rows>::V;
    /// One Adam step on `log alpha` with gradient `grad` (`[1]`).
    fn temperature_step(&mut self, grad: &<Self::R as Rows>::V, lr: f64);
    /// `(Q1, Q2)` `[batch]` each of the online critics, kept for `walk`.
    fn q_values(
        &mut self,
        obs: &<Self::R as Rows>::M,
        actions: &<Self::R as Rows>::M,
        walk: Walk,
    ) -> (<Self::R as Rows>::V, <Self::R as Rows>::V);
    /// One Adam step on the critics from `dL/dQ1`, `dL/dQ2` of the kept
    /// [`Walk::Params`] pass.
    fn critic_step(&mut self, dq: [&<Self::R as Rows>::V; 2], lr: f64) -> StepReport;
    /// `dL/d actions` `[batch, action_dim]` of the kept [`Walk::Actions`] pass.
    fn action_gradient(&mut self, dq: [&<Self::R as Rows>::V; 2]) -> <Self::R as Rows>::M;
    /// `min(Q1', Q2')` `[batch]` of the target critics.
    fn target_min(
        &mut self,
        obs: &<Self::R as Rows>::M,
        actions: &<Self::R as Rows>::M,
    ) -> <Self::R as Rows>::V;
    /// One Adam step on the actor from the gradients with respect to the kept sample's
    /// actions and `log pi` (`[batch]` or `[1]`) and, when given, its
    /// [`SacNetworks::sampled_means`].
    fn actor_step(
        &mut self,
        d_actions: &<Self::R as Rows>::M,
        d_log_prob: &<Self::R as Rows>::V,
        d_means: Option<&<Self::R as Rows>::M>,
        lr: f64,
    ) -> StepReport;
    /// `average <- (1 - tau) average + tau actor`, when there is an average.
    fn update_actor_average(&mut self, tau: f32);
    /// `target <- (1 - tau) target + tau critic`.
    fn update_target(&mut self, tau: f32);
}

/// The three optimisers.
#[derive(Clone, Debug)]
pub struct Optimisers {
    /// The actor's.
    pub actor: Adam,
    /// The twin critics'.
    pub critic: Adam,
    /// The temperature's.
    pub temperature: Adam,
}

impl Optimisers {
    /// Three fresh optimisers with `adam`'s settings.
    pub fn new(adam: &AdamConfig) -> Self {
        Self {
            actor: Adam::new(adam.clone()),
            critic: Adam::new(adam.clone()),
            temperature: Adam::new(adam.clone()),
        }
    }

    /// Writes the three states under `sac.*_adam`.
    pub fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>) {
        self.actor.save_state(snap, "sac.actor_adam");
        self.critic.save_state(snap, "sac.critic_adam");
        self.temperature.save_state(snap, "sac.temperature_adam");
    }

    /// Restores what [`Optimisers::save_state`] wrote.
    pub fn load_state(
        &mut self,
        snap: &Snapshot<'_>,
        device: &Device,
    ) -> Result<(), SnapshotError> {
        self.actor.load_state(snap, "sac.actor_adam", device)?;
        self.critic.load_state(snap, "sac.critic_adam", device)?;
        self.temperature
            .load_state(snap, "sac.temperature_adam", device)
    }
}

/// Burn modules on an autodiff device, with the graphs of the latest passes.
pub struct BurnNetworks {
    /// The networks.
    pub modules: Modules,
    /// Their optimisers.
    pub optim: Optimisers,
    device: Device,
    /// The kept sample: observations, actions and `log pi` in the actor's graph.
    sample: Option<(Tensor<2>, Tensor<2>, Tensor<1>)>,
    /// The kept `tanh(mean)` rows.
    means: Option<Tensor<2>>,
    /// The kept Q-values and, for [`Walk::Actions`], the actions they were walked from.
    q: Option<(Tensor<1>, Tensor<1>, Option<Tensor<2>>)>,
}

impl BurnNetworks {
    /// `modules` on `device` (an autodiff device) with `optim`.
    pub fn new(modules: Modules, optim: Optimisers, device: &Device) -> Self {
        Self {
            modules,
            optim,
            device: device.clone(),
            sample: None,
            means: None,
            q: None,
        }
    }

    /// The device without autodiff, where the update's values live.
    fn plain(&self) -> Device {
        self.device.clone().without_autodiff()
    }
}

impl SacNetworks for BurnNetworks {
    type R = DeviceRows;

    fn rows(&self) -> DeviceRows {
        DeviceRows {
            device: self.plain(),
        }
    }

    fn sample(&mut self, obs: &Tensor<2>, noise: &Tensor<2>) -> (Tensor<2>, Tensor<1>) {
        let obs = obs.clone().autodiff();
        let (actions, log_prob) = self
            .modules
            .actor
            .sample(obs.clone(), noise.clone().autodiff());
        let values = (actions.clone().inner(), log_prob.clone().inner());
        self.sample = Some((obs, actions, log_prob));
        self.means = None;
        values
    }

    fn sample_detached(&mut self, obs: &Tensor<2>, noise: &Tensor<2>) -> (Tensor<2>, Tensor<1>) {
        self.modules
            .actor
            .valid()
            .sample(obs.clone(), noise.clone())
    }

    fn sampled_means(&mut self, rows: usize) -> Tensor<2> {
        let (obs, ..) = self.sample.as_ref().expect("a kept sample");
        let means = self
            .modules
            .actor
            .deterministic(obs.clone().narrow(0, 0, rows));
        self.means = Some(means.clone());
        means.inner()
    }

    fn log_alpha(&self) -> Tensor<1> {
        let log_alpha = &self.modules.temperature;
        if is_host(&self.device) {
            // One read instead of a device op per use (a CPU backend).
            vector(&[log_alpha.log_alpha_value()], &self.plain())
        } else {
            log_alpha.log_alpha.val().inner()
        }
    }

    fn temperature_step(&mut self, grad: &Tensor<1>, lr: f64) {
        let t = &mut self.modules.temperature;
        let mut grads = (t.log_alpha.val() * grad.clone().autodiff())
            .sum()
            .backward();
        self.optim.temperature.step_in_place(t, &mut grads, lr);
    }

    fn q_values(
        &mut self,
        obs: &Tensor<2>,
        actions: &Tensor<2>,
        walk: Walk,
    ) -> (Tensor<1>, Tensor<1>) {
        let obs = obs.clone().autodiff();
        let (q1, q2, walked) = match walk {
            Walk::Params => {
                let (q1, q2) = self.modules.critic.forward(obs, actions.clone().autodiff());
                (q1, q2, None)
            }
            Walk::Actions => {
                let actions = actions.clone().autodiff().require_grad();
                let frozen = self.modules.critic.clone().no_grad();
                let (q1, q2) = frozen.forward(obs, actions.clone());
                (q1, q2, Some(actions))
            }
        };
        let values = (q1.clone().inner(), q2.clone().inner());
        self.q = Some((q1, q2, walked));
        values
    }

    fn critic_step(&mut self, dq: [&Tensor<1>; 2], lr: f64) -> StepReport {
        let (q1, q2, _) = self.q.take().expect("a kept Q pass");
        let mut grads = (q1 * dq[0].clone().autodiff() + q2 * dq[1].clone().autodiff())
            .sum()
            .backward();
        self.optim
            .critic
            .step_in_place(&mut self.modules.critic, &mut grads, lr)
    }

    fn action_gradient(&mut self, dq: [&Tensor<1>; 2]) -> Tensor<2> {
        let (q1, q2, actions) = self.q.take().expect("a kept Q pass");
        let actions = actions.expect("a pass walked back to its actions");
        let grads = (q1 * dq[0].clone().autodiff() + q2 * dq[1].clone().autodiff())
            .sum()
            .backward();
        actions.grad(&grads).expect("the actions' gradient")
    }

    fn target_min(&mut self, obs: &Tensor<2>, actions: &Tensor<2>) -> Tensor<1> {
        self.modules
            .critic_target
            .valid()
            .min(obs.clone(), actions.clone())
    }

    fn actor_step(
        &mut self,
        d_actions: &Tensor<2>,
        d_log_prob: &Tensor<1>,
        d_means: Option<&Tensor<2>>,
        lr: f64,
    ) -> StepReport {
        let (_, actions, log_prob) = self.sample.take().expect("a kept sample");
        let mut walked = (actions * d_actions.clone().autodiff()).sum()
            + (log_prob * d_log_prob.clone().autodiff()).sum();
        if let (Some(means), Some(d)) = (self.means.take(), d_means) {
            walked = walked + (means * d.clone().autodiff()).sum();
        }
        let mut grads = walked.backward();
        self.optim
            .actor
            .step_in_place(&mut self.modules.actor, &mut grads, lr)
    }

    fn update_actor_average(&mut self, tau: f32) {
        if let Some(average) = &mut self.modules.actor_average {
            polyak_update(average, &self.modules.actor, tau);
        }
    }

    fn update_target(&mut self, tau: f32) {
        polyak_update(&mut self.modules.critic_target, &self.modules.critic, tau);
    }
}

/// The networks on the host MLP path, with the modules they were made from (the file
/// format, the parameters' ids) and one gradient buffer per network.
pub struct HostNetworks {
    /// The actor.
    pub actor: HostSquashedGaussian,
    /// Its Polyak average.
    pub actor_average: Option<HostSquashedGaussian>,
    /// The twin critics.
    pub critic: HostTwinQ,
    /// Their target copy.
    pub critic_target: HostTwinQ,
    /// `[log alpha]`.
    pub log_alpha: Vec<f32>,
    /// Their optimisers (each over one flat buffer).
    pub optim: Optimisers,
    /// What [`HostNetworks::modules`] writes into.
    templates: Modules,
    actor_grads: Vec<f32>,
    critic_grads: Vec<f32>,
}

impl HostNetworks {
    /// Copies of `modules` on the host path, stepped by `optim` (whose states are those of
    /// flat buffers: fresh ones, or a host run's); an error says which network the path
    /// cannot compute (an image observation, layer normalisation).
    pub fn from_modules(modules: Modules, optim: Optimisers) -> Result<Self, String> {
        let actor = modules.actor.to_host()?;
        let critic = modules.critic.to_host()?;
        Ok(Self {
            actor_average: match &modules.actor_average {
                Some(average) => Some(average.to_host()?),
                None => None,
            },
            critic_target: modules.critic_target.to_host()?,
            log_alpha: vec![modules.temperature.log_alpha_value()],
            optim,
            actor_grads: vec![0.0; actor.mlp.params().len()],
            critic_grads: vec![0.0; critic.param_count()],
            actor,
            critic,
            templates: modules,
        })
    }

    /// The networks as Burn modules (for files and for reading them).
    pub fn modules(&self) -> Modules {
        let t = &self.templates;
        let written = "a host copy has its modules' widths";
        let temperature = Temperature {
            log_alpha: (t.temperature.log_alpha.clone())
                .map(|p| vector(&self.log_alpha, &p.device())),
        };
        Modules {
            actor: t
                .actor
                .clone()
                .with_host_params(&self.actor.mlp)
                .expect(written),
            actor_average: t
                .actor_average
                .clone()
                .zip(self.actor_average.as_ref())
                .map(|(module, host)| module.with_host_params(&host.mlp).expect(written)),
            critic: t
                .critic
                .clone()
                .with_host_params(&self.critic)
                .expect(written),
            critic_target: t
                .critic_target
                .clone()
                .with_host_params(&self.critic_target)
                .expect(written),
            temperature,
        }
    }

    /// The networks replaced by `modules`' (the optimisers kept).
    pub fn set_modules(&mut self, modules: Modules) -> Result<(), String> {
        *self = Self::from_modules(modules, self.optim.clone())?;
        Ok(())
    }
}

impl SacNetworks for HostNetworks {
    type R = HostRows;

    fn rows(&self) -> HostRows {
        HostRows
    }

    fn sample(&mut self, obs: &Matrix, noise: &Matrix) -> (Matrix, Vec<f32>) {
        let (actions, log_prob) = self.actor.sample(&obs.data, &noise.data);
        (matrix_of(actions, noise.cols), log_prob)
    }

    fn sample_detached(&mut self, obs: &Matrix, noise: &Matrix) -> (Matrix, Vec<f32>) {
        let (actions, log_prob) = self.actor.sample_detached(&obs.data, &noise.data);
        (matrix_of(actions, noise.cols), log_prob)
    }

    fn sampled_means(&mut self, rows: usize) -> Matrix {
        matrix_of(self.actor.sampled_means(rows), self.actor.action_dim())
    }

    fn log_alpha(&self) -> Vec<f32> {
        self.log_alpha.clone()
    }

    fn temperature_step(&mut self, grad: &Vec<f32>, lr: f64) {
        self.optim
            .temperature
            .step_flat(&mut [&mut self.log_alpha], grad, lr);
    }

    fn q_values(&mut self, obs: &Matrix, actions: &Matrix, _: Walk) -> (Vec<f32>, Vec<f32>) {
        self.critic.forward(&obs.data, &actions.data)
    }

    fn critic_step(&mut self, dq: [&Vec<f32>; 2], lr: f64) -> StepReport {
        self.critic_grads.fill(0.0);
        self.critic.backward([dq[0], dq[1]], &mut self.critic_grads);
        self.optim
            .critic
            .step_flat(&mut self.critic.params_mut(), &self.critic_grads, lr)
    }

    fn action_gradient(&mut self, dq: [&Vec<f32>; 2]) -> Matrix {
        let a = self.actor.action_dim();
        matrix_of(self.critic.action_gradient([dq[0], dq[1]], a), a)
    }

    fn target_min(&mut self, obs: &Matrix, actions: &Matrix) -> Vec<f32> {
        self.critic_target.min(&obs.data, &actions.data)
    }

    fn actor_step(
        &mut self,
        d_actions: &Matrix,
        d_log_prob: &Vec<f32>,
        d_means: Option<&Matrix>,
        lr: f64,
    ) -> StepReport {
        let batch = d_actions.data.len() / d_actions.cols;
        let d_log_prob = match d_log_prob.len() {
            1 => vec![d_log_prob[0]; batch],
            _ => d_log_prob.clone(),
        };
        self.actor_grads.fill(0.0);
        self.actor.backward(
            &d_actions.data,
            &d_log_prob,
            d_means.map(|m| m.data.as_slice()),
            &mut self.actor_grads,
        );
        self.optim
            .actor
            .step_flat(&mut [self.actor.mlp.params_mut()], &self.actor_grads, lr)
    }

    fn update_actor_average(&mut self, tau: f32) {
        if let Some(average) = &mut self.actor_average {
            lerp_into(average.mlp.params_mut(), self.actor.mlp.params(), tau);
        }
    }

    fn update_target(&mut self, tau: f32) {
        self.critic_target.polyak_from(&self.critic, tau);
    }
}

/// `data` as a matrix of `cols` columns.
fn matrix_of(data: Vec<f32>, cols: usize) -> Matrix {
    Matrix { data, cols }
}
