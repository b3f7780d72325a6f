//! An agent's deterministic policy written out as a chain of fixed steps from its
//! observation to its action ([`Agent::policy_chain`](crate::Agent::policy_chain)): what
//! an exporter needs to rebuild the policy in another runtime (the root package's `onnx`
//! module writes it as an ONNX graph), with nothing left that only a training loop holds
//! (no running moments still moving, no noise, no optimiser).
//!
//! Each step maps rows `[n, width_in]` to rows `[n, width_out]`; the chain's first step
//! reads the agent's observation and its last writes the action the agent's
//! `act(.., ActMode::Deterministic)` returns.

use foosball_nets::HostMlp;

/// One step of a policy chain (module docs).
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Per value `j`: `z = (x - mean[j]) / scale[j]` computed in f64 (the f32 value widened
    /// exactly), rounded to f32, then clamped to `[-clip, clip]`: [`crate::Normalized`]'s
    /// observation. Widths unchanged.
    Standardize {
        /// The running mean of each value, `[width]`.
        mean: Vec<f64>,
        /// `sqrt(var + epsilon)` of each value, `[width]`.
        scale: Vec<f64>,
        /// The clamp bound (observation units of one standard deviation).
        clip: f32,
    },
    /// [`crate::FourierFeatures`]: each value `x` passed on, followed where `encoded` by
    /// `sin(f x), cos(f x)` for each `f` of `frequencies` (radians per unit of the value,
    /// f32, in order). Width `width` in, [`crate::FourierConfig::width`] out.
    Fourier {
        /// Whether each input value is encoded, `[width]`.
        encoded: Vec<bool>,
        /// The angular frequencies `pi s 2^k`, `[K]`.
        frequencies: Vec<f32>,
    },
    /// A multilayer perceptron: per layer `x W + b`, its activation after every hidden
    /// layer, none after the output layer.
    Mlp(HostMlp),
    /// The first `n` values of each row (SAC's mean, ahead of its log standard deviation).
    First(usize),
    /// `tanh` of each value.
    Tanh,
    /// Each value clamped to `[min, max]`.
    Clamp {
        /// Lower bound.
        min: f32,
        /// Upper bound.
        max: f32,
    },
}

impl Step {
    /// Width of this step's output for an input of `width` values.
    pub fn width_out(&self, width: usize) -> usize {
        match self {
            Step::Fourier {
                encoded,
                frequencies,
            } => width + 2 * frequencies.len() * encoded.iter().filter(|&&e| e).count(),
            Step::Mlp(mlp) => mlp.output_dim(),
            Step::First(n) => *n,
            Step::Standardize { .. } | Step::Tanh | Step::Clamp { .. } => width,
        }
    }
}
