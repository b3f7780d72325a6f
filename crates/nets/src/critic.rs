//! Critics: the state-action value `Q(s, a)`, SAC/TD3's twin pair, and PPO's `V(s)`,
//! each behind an observation encoder (see [`crate::cnn`]).

use crate::cnn::Encoder;
use crate::host_critic::HostTwinQ;
use crate::host_mlp::HostMlp;
use crate::init::NetInit;
use crate::mlp::Mlp;
use burn::module::Module;
use burn::tensor::Tensor;
use rand::Rng;

/// `Q(s, a) = mlp([features(s), a])`: `[batch, features]`, `[batch, action_dim] ->
/// [batch]` (the features are the observation itself, or its encoding by the critic's
/// shared encoder).
#[derive(Module, Debug)]
pub struct QNetwork {
    net: Mlp,
}

impl QNetwork {
    /// Parameters drawn next from `init`'s RNG, for `features`-wide inputs.
    pub fn new(init: &mut NetInit<'_, impl Rng>, features: usize) -> Self {
        let net = init.q_mlp(features + init.action_dim, 1);
        Self { net }
    }

    /// Values `[batch]`.
    pub fn forward(&self, features: Tensor<2>, actions: Tensor<2>) -> Tensor<1> {
        self.value(joined(features, actions))
    }

    /// Values `[batch]` of `[features, actions]` already joined, `[batch, features +
    /// action_dim]`.
    fn value(&self, joined: Tensor<2>) -> Tensor<1> {
        self.net.forward(joined).squeeze_dim(1)
    }
}

/// `[features, actions]` side by side, the Q-networks' input.
fn joined(features: Tensor<2>, actions: Tensor<2>) -> Tensor<2> {
    Tensor::cat(vec![features, actions], 1)
}

/// Two independently initialised Q-networks (clipped double-Q of SAC and TD3) behind one
/// encoder, as SB3's `ContinuousCritic` shares its features extractor.
#[derive(Module, Debug)]
pub struct TwinQ {
    encoder: Encoder,
    /// The first critic; TD3's actor is trained against it alone.
    pub q1: QNetwork,
    /// The second critic.
    pub q2: QNetwork,
}

impl TwinQ {
    /// The encoder is drawn first, then `q1`, then `q2`.
    pub fn new(init: &mut NetInit<'_, impl Rng>) -> Self {
        let (encoder, features) = init.encoder();
        let q1 = QNetwork::new(init, features);
        let q2 = QNetwork::new(init, features);
        Self { encoder, q1, q2 }
    }

    /// Zeroes the input weights from the observation values at `inputs` ([`Mlp::zero_inputs`]);
    /// a vector observation only.
    pub fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        self.encoder.per_value_inputs()?;
        self.q1.net.zero_inputs(inputs)?;
        self.q2.net.zero_inputs(inputs)
    }

    /// Both values, each `[batch]`.
    pub fn forward(&self, obs: Tensor<2>, actions: Tensor<2>) -> (Tensor<1>, Tensor<1>) {
        // One input for both networks: one concatenation, and its gradient reaches
        // `actions` as one sum.
        let input = joined(self.encoder.forward(obs), actions);
        (self.q1.value(input.clone()), self.q2.value(input))
    }

    /// `Q1(s, a)` alone with the critic's parameters frozen (gradients reach `actions`,
    /// not the critic), `[batch]`: TD3's actor loss.
    pub fn q1_frozen(&self, obs: Tensor<2>, actions: Tensor<2>) -> Tensor<1> {
        let features = self.encoder.clone().no_grad().forward(obs);
        self.q1.clone().no_grad().forward(features, actions)
    }

    /// A copy on the host MLP path; an error for an image observation or layer
    /// normalisation, which that path does not compute.
    pub fn to_host(&self) -> Result<HostTwinQ, String> {
        self.encoder.per_value_inputs()?;
        HostTwinQ::new(
            HostMlp::from_mlp(&self.q1.net)?,
            HostMlp::from_mlp(&self.q2.net)?,
        )
    }

    /// These critics with `host`'s parameters (same widths).
    pub fn with_host_params(mut self, host: &HostTwinQ) -> Result<Self, String> {
        self.q1.net = host.q[0].write_to(self.q1.net)?;
        self.q2.net = host.q[1].write_to(self.q2.net)?;
        Ok(self)
    }

    /// `min(Q1, Q2)`, `[batch]`.
    pub fn min(&self, obs: Tensor<2>, actions: Tensor<2>) -> Tensor<1> {
        let (q1, q2) = self.forward(obs, actions);
        q1.min_pair(q2)
    }
}

/// PPO's state value `V(s) = mlp(features(s))`: `[batch, obs_dim] -> [batch]`.
#[derive(Module, Debug)]
pub struct ValueCritic {
    encoder: Encoder,
    net: Mlp,
}

impl ValueCritic {
    /// Parameters drawn next from `init`'s RNG (its encoder first).
    pub fn new(init: &mut NetInit<'_, impl Rng>) -> Self {
        let (encoder, features) = init.encoder();
        let net = init.mlp(features, 1);
        Self { encoder, net }
    }

    /// Zeroes the input weights from the observation values at `inputs` ([`Mlp::zero_inputs`]);
    /// a vector observation only.
    pub fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        self.encoder.per_value_inputs()?;
        self.net.zero_inputs(inputs)
    }

    /// Values `[batch]`.
    pub fn forward(&self, obs: Tensor<2>) -> Tensor<1> {
        self.net.forward(self.encoder.forward(obs)).squeeze_dim(1)
    }

    /// Its MLP on the host path; an error for an image observation or layer
    /// normalisation, which that path does not compute.
    pub fn to_host(&self) -> Result<HostMlp, String> {
        self.encoder.per_value_inputs()?;
        HostMlp::from_mlp(&self.net)
    }

    /// This critic with `host`'s parameters (same widths).
    pub fn with_host_params(mut self, host: &HostMlp) -> Result<Self, String> {
        self.net = host.write_to(self.net)?;
        Ok(self)
    }
}
