//! Adam as PyTorch defines it, with `clip_grad_norm_`'s global-norm gradient clipping.
//!
//! Burn's own Adam defaults to `eps = 1e-5` and its `GradientClipping::Norm` clips each
//! tensor on its own; the paper (SB3 on PyTorch) used `eps = 1e-8` and one norm over all
//! of a network's parameters. Both are written out here.

use crate::params::{flat_grads, map_flat_params};
use burn::module::Module;
use burn::tensor::{Gradients, Tensor};

/// Adam's hyper-parameters (the learning rate is given at each step, so that schedules
/// live with the algorithms).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AdamConfig {
    /// First-moment decay.
    pub beta1: f32,
    /// Second-moment decay.
    pub beta2: f32,
    /// Added to `sqrt(v_hat)`; PyTorch's default 1e-8.
    pub eps: f32,
    /// Rescale the gradient when its global L2 norm over all parameters exceeds this
    /// (PyTorch `clip_grad_norm_`); `None` disables clipping.
    pub max_grad_norm: Option<f32>,
}

impl Default for AdamConfig {
    fn default() -> Self {
        Self {
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
            max_grad_norm: None,
        }
    }
}

/// What one optimiser step did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepReport {
    /// Global L2 norm of the gradient before clipping.
    pub grad_norm: f32,
    /// False when the gradient was not finite: the parameters and moments were left as
    /// they were, so one bad batch cannot poison the run.
    pub applied: bool,
}

/// Adam's state for one module: step count and per-parameter moments (flat, in the
/// module's visiting order; created at the first step).
#[derive(Clone, Debug)]
pub struct Adam {
    config: AdamConfig,
    steps: u64,
    moments: Vec<Option<(Tensor<1>, Tensor<1>)>>,
}

/// PyTorch's `clip_grad_norm_` factor: `min(1, max_norm / (norm + 1e-6))`.
pub fn clip_coefficient(grad_norm: f32, max_norm: Option<f32>) -> f32 {
    max_norm.map_or(1.0, |max| (max / (grad_norm + 1e-6)).min(1.0))
}

impl Adam {
    /// A fresh optimiser (no steps taken).
    pub fn new(config: AdamConfig) -> Self {
        Self {
            config,
            steps: 0,
            moments: Vec::new(),
        }
    }

    /// The hyper-parameters.
    pub fn config(&self) -> &AdamConfig {
        &self.config
    }

    /// Steps applied so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// One update of `module`'s parameters from the gradients of a loss
    /// (`loss.backward()`), with learning rate `lr`. Gradients of parameters of other
    /// modules stay in `grads`.
    pub fn step<M: Module>(&mut self, module: M, grads: &mut Gradients, lr: f64) -> (M, StepReport) {
        let grads = flat_grads(&module, grads);
        if self.moments.is_empty() {
            self.moments = vec![None; grads.len()];
        }
        assert_eq!(self.moments.len(), grads.len(), "Adam used with another module");

        let squares: Vec<Tensor<1>> = grads.iter().flatten().map(|g| g.clone().square().sum()).collect();
        let grad_norm = if squares.is_empty() {
            0.0
        } else {
            Tensor::cat(squares, 0).sum().into_scalar::<f32>().sqrt()
        };
        if !grad_norm.is_finite() {
            return (module, StepReport { grad_norm, applied: false });
        }
        let scale = clip_coefficient(grad_norm, self.config.max_grad_norm);

        self.steps += 1;
        let AdamConfig { beta1, beta2, eps, .. } = self.config;
        let t = self.steps as i32;
        let bias1 = 1.0 - beta1.powi(t);
        let bias2 = 1.0 - beta2.powi(t);
        // p -= lr * (m / bias1) / (sqrt(v / bias2) + eps), folded as in torch.optim.Adam.
        let step_size = lr as f32 / bias1;
        let bias2_sqrt = bias2.sqrt();
        let moments = &mut self.moments;
        let module = map_flat_params(module, |i, p| {
            let Some(g) = grads[i].clone() else { return p };
            let g = if scale < 1.0 { g.mul_scalar(scale) } else { g };
            let (m, v) = match moments[i].take() {
                Some((m, v)) => (
                    m.mul_scalar(beta1) + g.clone().mul_scalar(1.0 - beta1),
                    v.mul_scalar(beta2) + g.square().mul_scalar(1.0 - beta2),
                ),
                None => (g.clone().mul_scalar(1.0 - beta1), g.square().mul_scalar(1.0 - beta2)),
            };
            let denom = v.clone().sqrt().div_scalar(bias2_sqrt).add_scalar(eps);
            let p = p - m.clone().div(denom).mul_scalar(step_size);
            moments[i] = Some((m, v));
            p
        });
        (module, StepReport { grad_norm, applied: true })
    }
}
