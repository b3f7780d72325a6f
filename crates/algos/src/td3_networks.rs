//! TD3's networks as its update uses them, on either path: [`BurnNetworks`] (Burn
//! modules, gradients by autodiff: any backend, image observations) and
//! [`HostNetworks`] (the host MLP path, issue 51), each its deterministic actor and the
//! actor's target beside the twin critics of [`crate::critics`]. The update
//! ([`crate::td3`]) is written once over [`Td3Networks`], as SAC's is over
//! [`crate::sac_networks::SacNetworks`].
//!
//! [`Modules`] are the networks as files hold them; a host run saves and loads the same
//! files as a Burn run.

use crate::agent::AgentError;
use crate::critics::{BurnCritics, Critics, HostCritics};
use crate::network_path::HoldsModules;
use crate::rows::{DeviceRows, HostRows, Matrix, Rows};
use burn::module::Module;
use foosball_nets::host::lerp_into;
use foosball_nets::store::{load_module, save_module};
use foosball_nets::{
    Adam, DeterministicActor, Device, HostDeterministic, StepReport, Tensor, TwinQ, polyak_update,
};
use std::path::Path;

/// TD3's networks as files hold them (`actor.bpk`, `actor_target.bpk`, `critic.bpk`,
/// `critic_target.bpk`).
#[derive(Clone, Debug)]
pub struct Modules {
    /// The actor.
    pub actor: DeterministicActor,
    /// Its target copy, outside the graph.
    pub actor_target: DeterministicActor,
    /// The twin critics.
    pub critic: TwinQ,
    /// Their target copy, outside the graph.
    pub critic_target: TwinQ,
}

impl Modules {
    /// Writes the networks into `dir`.
    pub fn save(&self, dir: &Path) -> Result<(), AgentError> {
        save_module(&self.actor, &dir.join("actor.bpk"))?;
        save_module(&self.actor_target, &dir.join("actor_target.bpk"))?;
        save_module(&self.critic, &dir.join("critic.bpk"))?;
        save_module(&self.critic_target, &dir.join("critic_target.bpk"))?;
        Ok(())
    }

    /// These modules with the networks in `dir`.
    pub fn load(self, dir: &Path) -> Result<Self, AgentError> {
        Ok(Self {
            actor: load_module(self.actor, &dir.join("actor.bpk"))?,
            actor_target: load_module(self.actor_target, &dir.join("actor_target.bpk"))?,
            critic: load_module(self.critic, &dir.join("critic.bpk"))?,
            critic_target: load_module(self.critic_target, &dir.join("critic_target.bpk"))?,
        })
    }

    /// Zeroes every network's input weights from the observation values at `inputs`.
    pub fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        self.actor.zero_obs_inputs(inputs)?;
        self.actor_target.zero_obs_inputs(inputs)?;
        self.critic.zero_obs_inputs(inputs)?;
        self.critic_target.zero_obs_inputs(inputs)
    }
}

/// What TD3's update asks of its networks besides their [`Critics`]. Values and
/// gradients are [`Rows`] of the critics' arithmetic.
pub trait Td3Networks {
    /// The arithmetic the update's formulas run on.
    type R: Rows + Clone;
    /// The twin critics.
    type C: Critics<R = Self::R>;

    /// The twin critics.
    fn critics(&mut self) -> &mut Self::C;
    /// The actor's actions `[batch, action_dim]` for `obs`, kept for
    /// [`Td3Networks::actor_step`].
    fn actions(&mut self, obs: &<Self::R as Rows>::M) -> <Self::R as Rows>::M;
    /// The target actor's actions `[batch, action_dim]` for `obs` (not kept).
    fn target_actions(&mut self, obs: &<Self::R as Rows>::M) -> <Self::R as Rows>::M;
    /// One Adam step on the actor from `dL/d actions` of the kept pass.
    fn actor_step(&mut self, d_actions: &<Self::R as Rows>::M, lr: f64) -> StepReport;
    /// `actor_target <- (1 - tau) actor_target + tau actor`.
    fn update_actor_target(&mut self, tau: f32);
}

/// Burn modules on an autodiff device, with the graph of the latest kept pass.
pub struct BurnNetworks {
    /// The actor.
    pub actor: DeterministicActor,
    /// Its target copy, outside the graph.
    pub actor_target: DeterministicActor,
    /// The twin critics with their optimiser.
    pub critics: BurnCritics,
    /// The actor's optimiser.
    pub actor_optim: Adam,
    /// The kept actions in the actor's graph.
    kept: Option<Tensor<2>>,
}

impl BurnNetworks {
    /// `modules` on `device` (an autodiff device) stepped by `actor_optim` and
    /// `critic_optim`.
    pub fn new(modules: Modules, actor_optim: Adam, critic_optim: Adam, device: &Device) -> Self {
        Self {
            actor: modules.actor,
            actor_target: modules.actor_target,
            critics: BurnCritics::new(modules.critic, modules.critic_target, critic_optim, device),
            actor_optim,
            kept: None,
        }
    }
}

impl HoldsModules for BurnNetworks {
    type Modules = Modules;

    fn modules(&self) -> Modules {
        Modules {
            actor: self.actor.clone(),
            actor_target: self.actor_target.clone(),
            critic: self.critics.critic.clone(),
            critic_target: self.critics.critic_target.clone(),
        }
    }

    fn set_modules(&mut self, modules: Modules) -> Result<(), String> {
        self.actor = modules.actor;
        self.actor_target = modules.actor_target;
        self.critics.critic = modules.critic;
        self.critics.critic_target = modules.critic_target;
        Ok(())
    }
}

impl Td3Networks for BurnNetworks {
    type R = DeviceRows;
    type C = BurnCritics;

    fn critics(&mut self) -> &mut BurnCritics {
        &mut self.critics
    }

    fn actions(&mut self, obs: &Tensor<2>) -> Tensor<2> {
        let actions = self.actor.forward(obs.clone().autodiff());
        self.kept = Some(actions.clone());
        actions.inner()
    }

    fn target_actions(&mut self, obs: &Tensor<2>) -> Tensor<2> {
        self.actor_target.valid().forward(obs.clone())
    }

    fn actor_step(&mut self, d_actions: &Tensor<2>, lr: f64) -> StepReport {
        let actions = self.kept.take().expect("a kept actor pass");
        let mut grads = (actions * d_actions.clone().autodiff()).sum().backward();
        self.actor_optim
            .step_in_place(&mut self.actor, &mut grads, lr)
    }

    fn update_actor_target(&mut self, tau: f32) {
        polyak_update(&mut self.actor_target, &self.actor, tau);
    }
}

/// The networks on the host MLP path, with the modules they were made from (the file
/// format, the parameters' ids) and the actor's gradient buffer.
pub struct HostNetworks {
    /// The actor.
    pub actor: HostDeterministic,
    /// Its target copy.
    pub actor_target: HostDeterministic,
    /// The twin critics with their optimiser.
    pub critics: HostCritics,
    /// The actor's optimiser (over one flat buffer).
    pub actor_optim: Adam,
    /// What [`HostNetworks::modules`] writes into.
    templates: Modules,
    actor_grads: Vec<f32>,
}

impl HostNetworks {
    /// Copies of `modules` on the host path stepped by `actor_optim` and `critic_optim`
    /// (fresh, or a host run's); an error says which network the path cannot compute.
    pub fn from_modules(
        modules: Modules,
        actor_optim: Adam,
        critic_optim: Adam,
    ) -> Result<Self, String> {
        let actor = modules.actor.to_host()?;
        Ok(Self {
            actor_target: modules.actor_target.to_host()?,
            critics: HostCritics::new(&modules.critic, &modules.critic_target, critic_optim)?,
            actor_optim,
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
        let (critic, critic_target) = self
            .critics
            .modules((t.critic.clone(), t.critic_target.clone()));
        Modules {
            actor: (t.actor.clone().with_host_params(&self.actor.mlp)).expect(written),
            actor_target: (t.actor_target.clone())
                .with_host_params(&self.actor_target.mlp)
                .expect(written),
            critic,
            critic_target,
        }
    }

    fn set_modules(&mut self, modules: Modules) -> Result<(), String> {
        let critic_optim = self.critics.optim.clone();
        *self = Self::from_modules(modules, self.actor_optim.clone(), critic_optim)?;
        Ok(())
    }
}

impl Td3Networks for HostNetworks {
    type R = HostRows;
    type C = HostCritics;

    fn critics(&mut self) -> &mut HostCritics {
        &mut self.critics
    }

    fn actions(&mut self, obs: &Matrix) -> Matrix {
        let data = self.actor.forward(&obs.data);
        Matrix {
            cols: self.actor.mlp.output_dim(),
            data,
        }
    }

    fn target_actions(&mut self, obs: &Matrix) -> Matrix {
        let data = self.actor_target.forward_detached(&obs.data);
        Matrix {
            cols: self.actor_target.mlp.output_dim(),
            data,
        }
    }

    fn actor_step(&mut self, d_actions: &Matrix, lr: f64) -> StepReport {
        self.actor_grads.fill(0.0);
        self.actor.backward(&d_actions.data, &mut self.actor_grads);
        self.actor_optim
            .step_flat(&mut [self.actor.mlp.params_mut()], &self.actor_grads, lr)
    }

    fn update_actor_target(&mut self, tau: f32) {
        lerp_into(
            self.actor_target.mlp.params_mut(),
            self.actor.mlp.params(),
            tau,
        );
    }
}
