//! Adam as PyTorch defines it, with `clip_grad_norm_`'s global-norm gradient clipping.
//!
//! Burn's own Adam defaults to `eps = 1e-5` and its `GradientClipping::Norm` clips each
//! tensor on its own; the paper (SB3 on PyTorch) used `eps = 1e-8` and one norm over all
//! of a network's parameters. Both are written out here.

use crate::host::{CHUNK, host_data, is_host, sum_squares, to_vec, update_in_place};
use crate::params::{flat_grads, map_flat_params, take_module};
use crate::snapshot::{Snapshot, SnapshotError};
use burn::module::Module;
use burn::tensor::TensorData;
use burn::tensor::{Device, Gradients, Tensor};
use rayon::prelude::*;
use std::borrow::Cow;

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

/// A parameter's first and second moments, where its backend keeps them.
#[derive(Clone, Debug)]
enum Moments {
    /// Host vectors (CPU backends: fused update loop).
    Host(Vec<f32>, Vec<f32>),
    /// Device tensors (GPU backends: tensor ops).
    Device(Box<[Tensor<1>; 2]>),
}

/// A parameter's gradient, on the host or on the device.
enum Grad {
    Host(TensorData),
    Device(Tensor<1>),
}

/// The scalars of one Adam step: `p -= step_size * m / (sqrt(v) / bias2_sqrt + eps)`
/// after `m <- b1 m + (1 - b1) g`, `v <- b2 v + (1 - b2) g^2`, `g = scale * grad`;
/// `step_size = lr / (1 - b1^t)`, `bias2_sqrt = sqrt(1 - b2^t)` (torch.optim.Adam).
#[derive(Clone, Copy)]
struct Update {
    beta1: f32,
    beta2: f32,
    eps: f32,
    step_size: f32,
    bias2_sqrt: f32,
    scale: f32,
}

impl Update {
    fn host(self, p: &mut [f32], g: &[f32], m: &mut [f32], v: &mut [f32]) {
        let Update {
            beta1,
            beta2,
            eps,
            step_size,
            bias2_sqrt,
            scale,
        } = self;
        p.par_chunks_mut(CHUNK)
            .zip(g.par_chunks(CHUNK))
            .zip(m.par_chunks_mut(CHUNK))
            .zip(v.par_chunks_mut(CHUNK))
            .for_each(|(((p, g), m), v)| {
                for k in 0..p.len() {
                    let g = g[k] * scale;
                    m[k] = beta1 * m[k] + (1.0 - beta1) * g;
                    v[k] = beta2 * v[k] + (1.0 - beta2) * g * g;
                    p[k] -= step_size * m[k] / (v[k].sqrt() / bias2_sqrt + eps);
                }
            });
    }

    fn device(self, p: Tensor<1>, g: Tensor<1>, m: Tensor<1>, v: Tensor<1>) -> [Tensor<1>; 3] {
        let Update {
            beta1,
            beta2,
            eps,
            step_size,
            bias2_sqrt,
            scale,
        } = self;
        let g = if scale < 1.0 { g.mul_scalar(scale) } else { g };
        let m = m.mul_scalar(beta1) + g.clone().mul_scalar(1.0 - beta1);
        let v = v.mul_scalar(beta2) + g.square().mul_scalar(1.0 - beta2);
        let denom = v.clone().sqrt().div_scalar(bias2_sqrt).add_scalar(eps);
        let p = p - m.clone().div(denom).mul_scalar(step_size);
        [p, m, v]
    }
}

/// Adam's state for one module: step count and per-parameter moments (flat, in the
/// module's visiting order; created at the first step). On CPU backends the update is
/// one fused host loop per parameter, elsewhere tensor ops; the math is the same.
#[derive(Clone, Debug)]
pub struct Adam {
    config: AdamConfig,
    steps: u64,
    moments: Vec<Option<Moments>>,
    host_fast_path: bool,
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
            host_fast_path: true,
        }
    }

    /// The same optimiser doing its update with tensor ops even on a CPU backend (the GPU
    /// path; slower on CPU, kept to check both paths agree).
    pub fn without_host_fast_path(mut self) -> Self {
        self.host_fast_path = false;
        self
    }

    /// The hyper-parameters.
    pub fn config(&self) -> &AdamConfig {
        &self.config
    }

    /// Steps applied so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Stores the step count and moments under `prefix`: `{prefix}.steps`,
    /// `{prefix}.stepped` (one flag per parameter) and `{prefix}.m{i}` / `{prefix}.v{i}`
    /// for each stepped parameter `i` (host moments are borrowed, not copied).
    pub fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>, prefix: &str) {
        snap.put_u64(format!("{prefix}.steps"), self.steps);
        let stepped: Vec<bool> = self.moments.iter().map(Option::is_some).collect();
        snap.put_bools(format!("{prefix}.stepped"), &stepped);
        for (i, moments) in self.moments.iter().enumerate() {
            let (m, v): (Cow<'a, [f32]>, Cow<'a, [f32]>) = match moments {
                None => continue,
                Some(Moments::Host(m, v)) => (m.into(), v.into()),
                Some(Moments::Device(mv)) => {
                    let [m, v] = mv.as_ref().clone();
                    (to_vec(m).into(), to_vec(v).into())
                }
            };
            snap.put_f32(format!("{prefix}.m{i}"), m);
            snap.put_f32(format!("{prefix}.v{i}"), v);
        }
    }

    /// Restores what [`Adam::save_state`] stored under `prefix`, the moments kept where
    /// this optimiser keeps them for `device`'s backend.
    pub fn load_state(
        &mut self,
        snap: &Snapshot<'_>,
        prefix: &str,
        device: &Device,
    ) -> Result<(), SnapshotError> {
        let host = self.host_fast_path && is_host(device);
        let plain = device.clone().without_autodiff();
        let steps = snap.u64(&format!("{prefix}.steps"))?;
        let stepped = snap.bools(&format!("{prefix}.stepped"))?;
        let mut moments = Vec::with_capacity(stepped.len());
        for (i, stepped) in stepped.into_iter().enumerate() {
            if !stepped {
                moments.push(None);
                continue;
            }
            let m = snap.f32s(&format!("{prefix}.m{i}"))?;
            let v = snap.f32s_of_len(&format!("{prefix}.v{i}"), m.len())?;
            moments.push(Some(if host {
                Moments::Host(m.to_vec(), v.to_vec())
            } else {
                let tensor = |x: &[f32]| {
                    Tensor::<1>::from_data(TensorData::new(x.to_vec(), [x.len()]), &plain)
                };
                Moments::Device(Box::new([tensor(m), tensor(v)]))
            }));
        }
        self.steps = steps;
        self.moments = moments;
        Ok(())
    }

    /// One update of `module`'s parameters from the gradients of a loss
    /// (`loss.backward()`), with learning rate `lr`. Gradients of parameters of other
    /// modules stay in `grads`.
    pub fn step<M: Module>(
        &mut self,
        module: M,
        grads: &mut Gradients,
        lr: f64,
    ) -> (M, StepReport) {
        let grads = flat_grads(&module, grads);
        if self.moments.is_empty() {
            self.moments = vec![None; grads.len()];
        }
        assert_eq!(
            self.moments.len(),
            grads.len(),
            "Adam used with another module"
        );
        let host = self.host_fast_path
            && grads
                .iter()
                .flatten()
                .next()
                .is_some_and(|g| is_host(&g.device()));
        let mut grads: Vec<Option<Grad>> = grads
            .into_iter()
            .map(|g| {
                g.map(|g| {
                    if host {
                        Grad::Host(host_data(g))
                    } else {
                        Grad::Device(g)
                    }
                })
            })
            .collect();

        let grad_norm = global_norm(&grads);
        if !grad_norm.is_finite() {
            return (
                module,
                StepReport {
                    grad_norm,
                    applied: false,
                },
            );
        }
        self.steps += 1;
        let AdamConfig {
            beta1,
            beta2,
            eps,
            max_grad_norm,
        } = self.config;
        let t = self.steps as i32;
        let update = Update {
            beta1,
            beta2,
            eps,
            step_size: lr as f32 / (1.0 - beta1.powi(t)),
            bias2_sqrt: (1.0 - beta2.powi(t)).sqrt(),
            scale: clip_coefficient(grad_norm, max_grad_norm),
        };
        let moments = &mut self.moments;
        let module = map_flat_params(module, |i, p| match grads[i].take() {
            None => p,
            Some(Grad::Host(g)) => {
                let g = g.as_slice::<f32>().expect("float gradients are f32");
                let (mut m, mut v) = match moments[i].take() {
                    Some(Moments::Host(m, v)) => (m, v),
                    _ => (vec![0.0; g.len()], vec![0.0; g.len()]),
                };
                let p = update_in_place(p, |p| update.host(p, g, &mut m, &mut v));
                moments[i] = Some(Moments::Host(m, v));
                p
            }
            Some(Grad::Device(g)) => {
                let [m, v] = match moments[i].take() {
                    Some(Moments::Device(mv)) => *mv,
                    _ => [g.zeros_like(), g.zeros_like()],
                };
                let [p, m, v] = update.device(p, g, m, v);
                moments[i] = Some(Moments::Device(Box::new([m, v])));
                p
            }
        });
        (
            module,
            StepReport {
                grad_norm,
                applied: true,
            },
        )
    }

    /// [`Adam::step`] on the module in `slot`, moved out first (see
    /// [`take_module`]) so a CPU backend updates its parameters without copying them.
    pub fn step_in_place<M: Module>(
        &mut self,
        slot: &mut M,
        grads: &mut Gradients,
        lr: f64,
    ) -> StepReport {
        let (module, report) = self.step(take_module(slot), grads, lr);
        *slot = module;
        report
    }
}

/// The L2 norm of all gradients together.
fn global_norm(grads: &[Option<Grad>]) -> f32 {
    let mut host = 0.0f64;
    let mut device = Vec::new();
    for g in grads.iter().flatten() {
        match g {
            Grad::Host(g) => {
                host += sum_squares(g.as_slice::<f32>().expect("float gradients are f32"))
            }
            Grad::Device(g) => device.push(g.clone().square().sum()),
        }
    }
    if !device.is_empty() {
        host += f64::from(Tensor::cat(device, 0).sum().into_scalar::<f32>());
    }
    host.sqrt() as f32
}
