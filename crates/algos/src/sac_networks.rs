//! SAC's networks as its update uses them, on either path: [`BurnNetworks`] (Burn
//! modules, gradients by autodiff: any backend, image observations) and
//! [`HostNetworks`] (the host MLP path: vector observations, the backward passes
//! written out, issue 51), each its actor and temperature beside the twin critics of
//! [`crate::critics`]. The update itself ([`crate::sac`]) is written once over
//! [`SacNetworks`]: it computes each loss's gradient with respect to the networks'
//! outputs with [`Rows`] arithmetic and hands it to the networks, which walk it back
//! (Burn as `sum(output * gradient).backward()`, the host path by hand) and step Adam.
//!
//! [`Modules`] are the networks as files hold them; a host run saves and loads the same
//! files as a Burn run.

use crate::agent::AgentError;
use crate::critics::{BurnCritics, Critics, HostCritics};
use crate::network_path::HoldsModules;
use crate::rows::{HostRows, Matrix, Rows};
use crate::tensors::vector;
use burn::module::{Module, Param};
use foosball_nets::host::{is_host, lerp_into};
use foosball_nets::store::{load_module, save_module};
use foosball_nets::{
    Adam, AdamConfig, Device, HostSquashedGaussian, Scalar, Snapshot, SnapshotError,
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

/// What SAC's update asks of its networks besides their [`Critics`]. Values and
/// gradients are [`Rows`] of the critics' arithmetic; the networks keep what their
/// backward passes need between the forward call and the matching step.
pub trait SacNetworks {
    /// The arithmetic the update's formulas run on.
    type R: Rows + Clone;
    /// The twin critics.
    type C: Critics<R = Self::R>;

    /// The twin critics.
    fn critics(&mut self) -> &mut Self::C;
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
}

/// The optimisers of the actor and the temperature (the critics' is theirs).
#[derive(Clone, Debug)]
pub struct Optimisers {
    /// The actor's.
    pub actor: Adam,
    /// The temperature's.
    pub temperature: Adam,
}

impl Optimisers {
    /// Fresh optimisers with `adam`'s settings.
    pub fn new(adam: &AdamConfig) -> Self {
        Self {
            actor: Adam::new(adam.clone()),
            temperature: Adam::new(adam.clone()),
        }
    }

    /// Writes both states under `sac.*_adam`.
    pub fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>) {
        self.actor.save_state(snap, "sac.actor_adam");
        self.temperature.save_state(snap, "sac.temperature_adam");
    }

    /// Restores what [`Optimisers::save_state`] wrote.
    pub fn load_state(
        &mut self,
        snap: &Snapshot<'_>,
        device: &Device,
    ) -> Result<(), SnapshotError> {
        self.actor.load_state(snap, "sac.actor_adam", device)?;
        self.temperature
            .load_state(snap, "sac.temperature_adam", device)
    }
}

/// Burn modules on an autodiff device, with the graphs of the latest passes.
pub struct BurnNetworks {
    /// The actor.
    pub actor: SquashedGaussianActor,
    /// Its Polyak average, outside the graph.
    pub actor_average: Option<SquashedGaussianActor>,
    /// `log alpha`.
    pub temperature: Temperature,
    /// The twin critics with their optimiser.
    pub critics: BurnCritics,
    /// The actor's and the temperature's optimisers.
    pub optim: Optimisers,
    device: Device,
    /// The kept sample: observations, actions and `log pi` in the actor's graph.
    sample: Option<(Tensor<2>, Tensor<2>, Tensor<1>)>,
    /// The kept `tanh(mean)` rows.
    means: Option<Tensor<2>>,
}

impl BurnNetworks {
    /// `modules` on `device` (an autodiff device) with `optim` and the critics' `critic_optim`.
    pub fn new(modules: Modules, optim: Optimisers, critic_optim: Adam, device: &Device) -> Self {
        Self {
            actor: modules.actor,
            actor_average: modules.actor_average,
            temperature: modules.temperature,
            critics: BurnCritics::new(modules.critic, modules.critic_target, critic_optim, device),
            optim,
            device: device.clone(),
            sample: None,
            means: None,
        }
    }

    /// The device without autodiff, where the update's values live.
    fn plain(&self) -> Device {
        self.device.clone().without_autodiff()
    }
}

impl HoldsModules for BurnNetworks {
    type Modules = Modules;

    fn modules(&self) -> Modules {
        Modules {
            actor: self.actor.clone(),
            actor_average: self.actor_average.clone(),
            critic: self.critics.critic.clone(),
            critic_target: self.critics.critic_target.clone(),
            temperature: self.temperature.clone(),
        }
    }

    fn set_modules(&mut self, modules: Modules) -> Result<(), String> {
        self.actor = modules.actor;
        self.actor_average = modules.actor_average;
        self.temperature = modules.temperature;
        self.critics.critic = modules.critic;
        self.critics.critic_target = modules.critic_target;
        Ok(())
    }
}

impl SacNetworks for BurnNetworks {
    type R = crate::rows::DeviceRows;
    type C = BurnCritics;

    fn critics(&mut self) -> &mut BurnCritics {
        &mut self.critics
    }

    fn sample(&mut self, obs: &Tensor<2>, noise: &Tensor<2>) -> (Tensor<2>, Tensor<1>) {
        let obs = obs.clone().autodiff();
        let (actions, log_prob) = self.actor.sample(obs.clone(), noise.clone().autodiff());
        let values = (actions.clone().inner(), log_prob.clone().inner());
        self.sample = Some((obs, actions, log_prob));
        self.means = None;
        values
    }

    fn sample_detached(&mut self, obs: &Tensor<2>, noise: &Tensor<2>) -> (Tensor<2>, Tensor<1>) {
        self.actor.valid().sample(obs.clone(), noise.clone())
    }

    fn sampled_means(&mut self, rows: usize) -> Tensor<2> {
        let (obs, ..) = self.sample.as_ref().expect("a kept sample");
        let means = self.actor.deterministic(obs.clone().narrow(0, 0, rows));
        self.means = Some(means.clone());
        means.inner()
    }

    fn log_alpha(&self) -> Tensor<1> {
        if is_host(&self.device) {
            // One read instead of a device op per use (a CPU backend).
            vector(&[self.temperature.log_alpha_value()], &self.plain())
        } else {
            self.temperature.log_alpha.val().inner()
        }
    }

    fn temperature_step(&mut self, grad: &Tensor<1>, lr: f64) {
        let t = &mut self.temperature;
        let mut grads = (t.log_alpha.val() * grad.clone().autodiff())
            .sum()
            .backward();
        self.optim.temperature.step_in_place(t, &mut grads, lr);
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
            .step_in_place(&mut self.actor, &mut grads, lr)
    }

    fn update_actor_average(&mut self, tau: f32) {
        if let Some(average) = &mut self.actor_average {
            polyak_update(average, &self.actor, tau);
        }
    }
}

/// The networks on the host MLP path, with the modules they were made from (the file
/// format, the parameters' ids) and the actor's gradient buffer.
pub struct HostNetworks {
    /// The actor.
    pub actor: HostSquashedGaussian,
    /// Its Polyak average.
    pub actor_average: Option<HostSquashedGaussian>,
    /// The twin critics with their optimiser.
    pub critics: HostCritics,
    /// `[log alpha]`.
    pub log_alpha: Vec<f32>,
    /// The actor's and the temperature's optimisers (each over one flat buffer).
    pub optim: Optimisers,
    /// What [`HostNetworks::modules`] writes into.
    templates: Modules,
    actor_grads: Vec<f32>,
}

impl HostNetworks {
    /// Copies of `modules` on the host path, stepped by `optim` and the critics'
    /// `critic_optim` (whose states are those of flat buffers: fresh ones, or a host
    /// run's); an error says which network the path cannot compute (an image observation,
    /// layer normalisation).
    pub fn from_modules(
        modules: Modules,
        optim: Optimisers,
        critic_optim: Adam,
    ) -> Result<Self, String> {
        let actor = modules.actor.to_host()?;
        Ok(Self {
            actor_average: match &modules.actor_average {
                Some(average) => Some(average.to_host()?),
                None => None,
            },
            critics: HostCritics::new(&modules.critic, &modules.critic_target, critic_optim)?,
            log_alpha: vec![modules.temperature.log_alpha_value()],
            optim,
            actor_grads: vec![0.0; actor.mlp.params().len()],
            actor,
            templates: modules,
        })
    }
}

impl HoldsModules for HostNetworks {
    type Modules = Modules;

    fn modules(&self) -> Modules {
        let t = &self.templates;
        let written = "a host copy has its modules' widths";
        let temperature = Temperature {
            log_alpha: (t.temperature.log_alpha.clone())
                .map(|p| vector(&self.log_alpha, &p.device())),
        };
        let (critic, critic_target) = self
            .critics
            .modules((t.critic.clone(), t.critic_target.clone()));
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
            critic,
            critic_target,
            temperature,
        }
    }

    fn set_modules(&mut self, modules: Modules) -> Result<(), String> {
        let critic_optim = self.critics.optim.clone();
        *self = Self::from_modules(modules, self.optim.clone(), critic_optim)?;
        Ok(())
    }
}

impl SacNetworks for HostNetworks {
    type R = HostRows;
    type C = HostCritics;

    fn critics(&mut self) -> &mut HostCritics {
        &mut self.critics
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
}

/// `data` as a matrix of `cols` columns.
fn matrix_of(data: Vec<f32>, cols: usize) -> Matrix {
    Matrix { data, cols }
}
