//! SAC's and TD3's twin critics as their updates use them, on either path:
//! [`BurnCritics`] (Burn modules, gradients by autodiff: any backend, image observations)
//! and [`HostCritics`] (the host MLP path, issue 51). Each holds the online pair, its
//! target copy and the pair's Adam; an update computes `dL/dQk` with [`Rows`] arithmetic
//! and hands it back ([`Critics::critic_step`], [`Critics::action_gradient`]), the
//! critics walking it back (Burn as `sum(Qk * dL/dQk).backward()`, the host path by hand).

use crate::rows::{DeviceRows, HostRows, Matrix, Rows};
use burn::module::Module;
use foosball_nets::{
    Adam, Device, HostTwinQ, Snapshot, SnapshotError, StepReport, Tensor, TwinQ, polyak_update,
};

/// Which gradient a Q-value pass is walked back for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Walk {
    /// The critics' own parameters (their regression).
    Params,
    /// The actions fed in, the critics frozen (the actor's loss).
    Actions,
}

/// What an actor-critic update asks of its twin critics. Values and gradients are
/// [`Rows`] of [`Critics::rows`]; the critics keep what a backward pass needs between the
/// forward call and the matching step.
pub trait Critics {
    /// The arithmetic the update's formulas run on.
    type R: Rows + Clone;

    /// The arithmetic, on the critics' device.
    fn rows(&self) -> Self::R;
    /// `(Q1, Q2)` `[batch]` each of the online critics, kept for `walk`.
    fn q_values(
        &mut self,
        obs: &<Self::R as Rows>::M,
        actions: &<Self::R as Rows>::M,
        walk: Walk,
    ) -> (<Self::R as Rows>::V, <Self::R as Rows>::V);
    /// `Q1` `[batch]` alone, the critics frozen, kept for
    /// [`Critics::action_gradient`] (TD3's actor loss).
    fn first_q(
        &mut self,
        obs: &<Self::R as Rows>::M,
        actions: &<Self::R as Rows>::M,
    ) -> <Self::R as Rows>::V;
    /// One Adam step on the online pair from `dL/dQ1`, `dL/dQ2` of the kept
    /// [`Walk::Params`] pass.
    fn critic_step(&mut self, dq: [&<Self::R as Rows>::V; 2], lr: f64) -> StepReport;
    /// `dL/d actions` `[batch, action_dim]` of the kept [`Walk::Actions`] pass given
    /// `dL/dQ1` and `dL/dQ2` (`dL/dQ1` alone after [`Critics::first_q`]).
    fn action_gradient(&mut self, dq: &[&<Self::R as Rows>::V]) -> <Self::R as Rows>::M;
    /// `min(Q1', Q2')` `[batch]` of the target critics.
    fn target_min(
        &mut self,
        obs: &<Self::R as Rows>::M,
        actions: &<Self::R as Rows>::M,
    ) -> <Self::R as Rows>::V;
    /// `target <- (1 - tau) target + tau online`.
    fn update_target(&mut self, tau: f32);
}

/// The optimiser state of a pair under `{prefix}.critic_adam` (`sac`, `td3`).
fn adam_key(prefix: &str) -> String {
    format!("{prefix}.critic_adam")
}

/// Burn twin critics on an autodiff device, with the graph of the latest pass.
pub struct BurnCritics {
    /// The online pair.
    pub critic: TwinQ,
    /// Its target copy, outside the graph.
    pub critic_target: TwinQ,
    /// The pair's optimiser.
    pub optim: Adam,
    device: Device,
    /// The kept `Q1`, `Q2` (absent after [`Critics::first_q`]) and, for a pass walked
    /// back to its actions, those actions.
    kept: Option<(Tensor<1>, Option<Tensor<1>>, Option<Tensor<2>>)>,
}

impl BurnCritics {
    /// `critic` and `critic_target` on `device` (an autodiff device) stepped by `optim`.
    pub fn new(critic: TwinQ, critic_target: TwinQ, optim: Adam, device: &Device) -> Self {
        Self {
            critic,
            critic_target,
            optim,
            device: device.clone(),
            kept: None,
        }
    }

    /// Writes the optimiser's state under `{prefix}.critic_adam`.
    pub fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>, prefix: &str) {
        self.optim.save_state(snap, &adam_key(prefix));
    }

    /// Restores what [`BurnCritics::save_state`] wrote.
    pub fn load_state(&mut self, snap: &Snapshot<'_>, prefix: &str) -> Result<(), SnapshotError> {
        self.optim.load_state(snap, &adam_key(prefix), &self.device)
    }

    /// `sum_k Qk * dL/dQk` of the kept pass, walked back.
    fn walk_back(&mut self, dq: &[&Tensor<1>]) -> (burn::tensor::Gradients, Option<Tensor<2>>) {
        let (q1, q2, actions) = self.kept.take().expect("a kept Q pass");
        let d1 = dq[0].clone().autodiff();
        let walked = match (q2, dq.get(1)) {
            (Some(q2), Some(&d2)) => (q1 * d1 + q2 * d2.clone().autodiff()).sum(),
            _ => (q1 * d1).sum(),
        };
        (walked.backward(), actions)
    }

    /// `actions` as a leaf of the graph whose gradient is asked for.
    fn action_leaf(actions: &Tensor<2>) -> Tensor<2> {
        actions.clone().autodiff().require_grad()
    }
}

impl Critics for BurnCritics {
    type R = DeviceRows;

    fn rows(&self) -> DeviceRows {
        DeviceRows {
            device: self.device.clone().without_autodiff(),
        }
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
                let (q1, q2) = self.critic.forward(obs, actions.clone().autodiff());
                (q1, q2, None)
            }
            Walk::Actions => {
                let actions = Self::action_leaf(actions);
                let frozen = self.critic.clone().no_grad();
                let (q1, q2) = frozen.forward(obs, actions.clone());
                (q1, q2, Some(actions))
            }
        };
        let values = (q1.clone().inner(), q2.clone().inner());
        self.kept = Some((q1, Some(q2), walked));
        values
    }

    fn first_q(&mut self, obs: &Tensor<2>, actions: &Tensor<2>) -> Tensor<1> {
        let actions = Self::action_leaf(actions);
        let q1 = self
            .critic
            .q1_frozen(obs.clone().autodiff(), actions.clone());
        let value = q1.clone().inner();
        self.kept = Some((q1, None, Some(actions)));
        value
    }

    fn critic_step(&mut self, dq: [&Tensor<1>; 2], lr: f64) -> StepReport {
        let (mut grads, _) = self.walk_back(&dq);
        self.optim.step_in_place(&mut self.critic, &mut grads, lr)
    }

    fn action_gradient(&mut self, dq: &[&Tensor<1>]) -> Tensor<2> {
        let (grads, actions) = self.walk_back(dq);
        let actions = actions.expect("a pass walked back to its actions");
        actions.grad(&grads).expect("the actions' gradient")
    }

    fn target_min(&mut self, obs: &Tensor<2>, actions: &Tensor<2>) -> Tensor<1> {
        self.critic_target.valid().min(obs.clone(), actions.clone())
    }

    fn update_target(&mut self, tau: f32) {
        polyak_update(&mut self.critic_target, &self.critic, tau);
    }
}

/// Twin critics on the host MLP path with one gradient buffer for the pair.
pub struct HostCritics {
    /// The online pair.
    pub critic: HostTwinQ,
    /// Its target copy.
    pub critic_target: HostTwinQ,
    /// The pair's optimiser (over one flat buffer).
    pub optim: Adam,
    grads: Vec<f32>,
}

impl HostCritics {
    /// Copies of `critic` and `critic_target` on the host path stepped by `optim` (fresh,
    /// or a host run's); an error says what the path cannot compute.
    pub fn new(critic: &TwinQ, critic_target: &TwinQ, optim: Adam) -> Result<Self, String> {
        let critic = critic.to_host()?;
        Ok(Self {
            grads: vec![0.0; critic.param_count()],
            critic_target: critic_target.to_host()?,
            critic,
            optim,
        })
    }

    /// `(critic, critic_target)` as Burn modules: `templates` with these parameters.
    pub fn modules(&self, templates: (TwinQ, TwinQ)) -> (TwinQ, TwinQ) {
        let written = "a host copy has its modules' widths";
        (
            templates.0.with_host_params(&self.critic).expect(written),
            templates
                .1
                .with_host_params(&self.critic_target)
                .expect(written),
        )
    }

    /// Writes the optimiser's state under `{prefix}.critic_adam`.
    pub fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>, prefix: &str) {
        self.optim.save_state(snap, &adam_key(prefix));
    }

    /// Restores what [`HostCritics::save_state`] wrote (`device`: where the state is
    /// read, the default CPU backend's).
    pub fn load_state(
        &mut self,
        snap: &Snapshot<'_>,
        prefix: &str,
        device: &Device,
    ) -> Result<(), SnapshotError> {
        self.optim.load_state(snap, &adam_key(prefix), device)
    }
}

impl Critics for HostCritics {
    type R = HostRows;

    fn rows(&self) -> HostRows {
        HostRows
    }

    fn q_values(&mut self, obs: &Matrix, actions: &Matrix, _: Walk) -> (Vec<f32>, Vec<f32>) {
        self.critic.forward(&obs.data, &actions.data)
    }

    fn first_q(&mut self, obs: &Matrix, actions: &Matrix) -> Vec<f32> {
        self.critic.first(&obs.data, &actions.data)
    }

    fn critic_step(&mut self, dq: [&Vec<f32>; 2], lr: f64) -> StepReport {
        self.grads.fill(0.0);
        self.critic.backward([dq[0], dq[1]], &mut self.grads);
        self.optim
            .step_flat(&mut self.critic.params_mut(), &self.grads, lr)
    }

    fn action_gradient(&mut self, dq: &[&Vec<f32>]) -> Matrix {
        let dq: Vec<&[f32]> = dq.iter().map(|d| d.as_slice()).collect();
        let data = self.critic.action_gradient(&dq);
        Matrix {
            cols: data.len() / dq[0].len(),
            data,
        }
    }

    fn target_min(&mut self, obs: &Matrix, actions: &Matrix) -> Vec<f32> {
        self.critic_target.min(&obs.data, &actions.data)
    }

    fn update_target(&mut self, tau: f32) {
        self.critic_target.polyak_from(&self.critic, tau);
    }
}
