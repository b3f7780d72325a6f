//! Critics: the state-action value `Q(s, a)`, SAC/TD3's twin pair, and PPO's `V(s)`.

use crate::init::NetInit;
use crate::mlp::Mlp;
use burn::module::Module;
use burn::tensor::Tensor;
use rand::Rng;

/// `Q(s, a) = mlp([s, a])`: `[batch, obs_dim]`, `[batch, action_dim] -> [batch]`.
#[derive(Module, Debug)]
pub struct QNetwork {
    net: Mlp,
}

impl QNetwork {
    /// Parameters drawn next from `init`'s RNG.
    pub fn new(init: &mut NetInit<'_, impl Rng>) -> Self {
        let net = init.mlp(init.obs_dim + init.action_dim, 1);
        Self { net }
    }

    /// Values `[batch]`.
    pub fn forward(&self, obs: Tensor<2>, actions: Tensor<2>) -> Tensor<1> {
        self.net
            .forward(Tensor::cat(vec![obs, actions], 1))
            .squeeze_dim(1)
    }
}

/// Two independently initialised Q-networks (clipped double-Q of SAC and TD3).
#[derive(Module, Debug)]
pub struct TwinQ {
    /// The first critic; TD3's actor is trained against it alone.
    pub q1: QNetwork,
    /// The second critic.
    pub q2: QNetwork,
}

impl TwinQ {
    /// `q1` is drawn before `q2`.
    pub fn new(init: &mut NetInit<'_, impl Rng>) -> Self {
        let q1 = QNetwork::new(init);
        let q2 = QNetwork::new(init);
        Self { q1, q2 }
    }

    /// Both values, each `[batch]`.
    pub fn forward(&self, obs: Tensor<2>, actions: Tensor<2>) -> (Tensor<1>, Tensor<1>) {
        let q1 = self.q1.forward(obs.clone(), actions.clone());
        (q1, self.q2.forward(obs, actions))
    }

    /// `min(Q1, Q2)`, `[batch]`.
    pub fn min(&self, obs: Tensor<2>, actions: Tensor<2>) -> Tensor<1> {
        let (q1, q2) = self.forward(obs, actions);
        q1.min_pair(q2)
    }
}

/// PPO's state value `V(s) = mlp(s)`: `[batch, obs_dim] -> [batch]`.
#[derive(Module, Debug)]
pub struct ValueCritic {
    net: Mlp,
}

impl ValueCritic {
    /// Parameters drawn next from `init`'s RNG.
    pub fn new(init: &mut NetInit<'_, impl Rng>) -> Self {
        let net = init.mlp(init.obs_dim, 1);
        Self { net }
    }

    /// Values `[batch]`.
    pub fn forward(&self, obs: Tensor<2>) -> Tensor<1> {
        self.net.forward(obs).squeeze_dim(1)
    }
}
