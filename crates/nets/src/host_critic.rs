//! SAC's and TD3's twin Q-networks on the host MLP path ([`crate::host_mlp`]): the same
//! networks as [`crate::TwinQ`] over vector observations, `Q_k(s, a) = mlp_k([s, a])`,
//! with one gradient buffer for both (`q1`'s parameters then `q2`'s, Burn's visiting
//! order), so one Adam step and one clipping norm cover the pair as they cover the module.

use crate::host_mlp::{HostMlp, MlpTape};

/// Two Q-networks on one input, with the latest forward pass kept.
#[derive(Clone, Debug)]
pub struct HostTwinQ {
    /// `[obs, action] [batch, obs_dim + action_dim] -> [batch, 1]`, each.
    pub q: [HostMlp; 2],
    /// Each network's latest [`HostTwinQ::forward`] (its input, `[obs, action]`, included).
    tapes: [MlpTape; 2],
    /// The passes of [`HostTwinQ::min`], not walked back.
    scratch: MlpTape,
    /// The action width of the kept pass.
    action_dim: usize,
}

impl HostTwinQ {
    /// The pair computing with `q1` and `q2` (one input width, one output each); an
    /// error says what does not fit.
    pub fn new(q1: HostMlp, q2: HostMlp) -> Result<Self, String> {
        if q1.input_dim() != q2.input_dim() || q1.output_dim() != 1 || q2.output_dim() != 1 {
            return Err(format!(
                "twin Q-networks need one input width and one output each: {:?} and {:?}",
                q1.widths(),
                q2.widths()
            ));
        }
        Ok(Self {
            q: [q1, q2],
            tapes: Default::default(),
            scratch: MlpTape::default(),
            action_dim: 0,
        })
    }

    /// Parameters of both networks (the length of a gradient buffer).
    pub fn param_count(&self) -> usize {
        self.q.iter().map(|q| q.params().len()).sum()
    }

    /// Both networks' parameters, `q1`'s then `q2`'s (for an optimiser step or Polyak
    /// averaging over the pair).
    pub fn params_mut(&mut self) -> [&mut [f32]; 2] {
        let [q1, q2] = &mut self.q;
        [q1.params_mut(), q2.params_mut()]
    }

    /// `target <- (1 - tau) target + tau online`, parameter by parameter.
    pub fn polyak_from(&mut self, online: &Self, tau: f32) {
        for (t, o) in self.q.iter_mut().zip(&online.q) {
            crate::host::lerp_into(t.params_mut(), o.params(), tau);
        }
    }

    /// `(Q1, Q2)`, `[batch]` each, for `obs [batch, obs_dim]` and `actions [batch,
    /// action_dim]`, kept for the backward passes.
    pub fn forward(&mut self, obs: &[f32], actions: &[f32]) -> (Vec<f32>, Vec<f32>) {
        let joined = self.kept_input(obs, actions);
        let q1 = self.q[0].forward(&joined, &mut self.tapes[0]).to_vec();
        let q2 = self.q[1].forward(&joined, &mut self.tapes[1]).to_vec();
        (q1, q2)
    }

    /// `Q1` alone, `[batch]`, kept for [`HostTwinQ::action_gradient`] (TD3's actor loss).
    pub fn first(&mut self, obs: &[f32], actions: &[f32]) -> Vec<f32> {
        let joined = self.kept_input(obs, actions);
        self.q[0].forward(&joined, &mut self.tapes[0]).to_vec()
    }

    /// `[obs, actions]` for a kept pass, its action width noted.
    fn kept_input(&mut self, obs: &[f32], actions: &[f32]) -> Vec<f32> {
        let (joined, action_dim) = joined(obs, actions, self.q[0].input_dim());
        self.action_dim = action_dim;
        joined
    }

    /// `min(Q1, Q2)`, `[batch]` (nothing kept for a backward pass).
    pub fn min(&mut self, obs: &[f32], actions: &[f32]) -> Vec<f32> {
        let (joined, _) = joined(obs, actions, self.q[0].input_dim());
        let q1 = self.q[0].forward(&joined, &mut self.scratch).to_vec();
        let q2 = self.q[1].forward(&joined, &mut self.scratch);
        q1.iter().zip(q2).map(|(a, b)| a.min(*b)).collect()
    }

    /// Adds `dL/dparams` of the latest forward pass to `grads` (`q1`'s layout then
    /// `q2`'s), given `dq1` and `dq2` `[batch]`.
    pub fn backward(&mut self, dq: [&[f32]; 2], grads: &mut [f32]) {
        let (g1, g2) = grads.split_at_mut(self.q[0].params().len());
        for ((q, tape), (dq, g)) in self
            .q
            .iter()
            .zip(&mut self.tapes)
            .zip(dq.into_iter().zip([g1, g2]))
        {
            q.backward(tape, dq, Some(g), None);
        }
    }

    /// `dL/d actions` `[batch, action_dim]` of the latest forward pass given `dq1` and
    /// `dq2` `[batch]` (`dq1` alone after [`HostTwinQ::first`]), the networks' own
    /// gradients not computed.
    pub fn action_gradient(&mut self, dq: &[&[f32]]) -> Vec<f32> {
        let action_dim = self.action_dim;
        let width = self.q[0].input_dim();
        let batch = self.tapes[0].batch();
        let mut dx = vec![0.0; batch * width];
        let mut sum = vec![0.0; batch * width];
        for ((q, tape), &dq) in self.q.iter().zip(&mut self.tapes).zip(dq) {
            q.backward(tape, dq, None, Some(&mut dx));
            sum.iter_mut().zip(&dx).for_each(|(s, d)| *s += d);
        }
        sum.chunks_exact(width)
            .flat_map(|row| row[width - action_dim..].iter().copied())
            .collect()
    }
}

/// `[obs, actions]` side by side, `[batch, width]`, and the action width.
fn joined(obs: &[f32], actions: &[f32], width: usize) -> (Vec<f32>, usize) {
    let batch = (obs.len() + actions.len()) / width;
    let (o, a) = (obs.len() / batch.max(1), actions.len() / batch.max(1));
    assert_eq!(
        o + a,
        width,
        "observations and actions of the networks' input width"
    );
    let mut joined = Vec::with_capacity(batch * width);
    for (s, a) in obs.chunks_exact(o).zip(actions.chunks_exact(a)) {
        joined.extend_from_slice(s);
        joined.extend_from_slice(a);
    }
    (joined, a)
}
