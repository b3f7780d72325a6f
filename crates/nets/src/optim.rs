//! Adam as PyTorch defines it, with `clip_grad_norm_`'s global-norm gradient clipping.
//!
//! Burn's own Adam defaults to `eps = 1e-5` and its `GradientClipping::Norm` clips each
//! tensor on its own; the paper (SB3 on PyTorch) used `eps = 1e-8` and one norm over all
//! of a network's parameters. Both are written out here.

use crate::any_rank::AnyRank;
use crate::host::{CHUNK, host_data, is_host, sum_squares, to_vec, update_in_place};
use crate::params::{
    ParamFn, flat_grads, grads_any_rank, map_flat_params, map_params, on_host, take_module,
};
use crate::scalar::Scalar;
use crate::snapshot::{Snapshot, SnapshotError};
use burn::module::Module;
use burn::tensor::{Bool, Device, Gradients, Tensor, TensorData};
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
#[derive(Clone, Debug)]
pub struct StepReport {
    /// Global L2 norm of the gradient before clipping.
    pub grad_norm: Scalar,
    /// 1 when the step was applied, 0 when the gradient was not finite: the parameters
    /// and moments were left as they were, so one bad batch cannot poison the run (on a
    /// GPU this is decided on the device, without reading the norm back).
    pub applied: Scalar,
}

/// A parameter's first and second moments, where its backend keeps them.
#[derive(Clone, Debug)]
enum Moments {
    /// Host vectors (CPU backends: fused update loop).
    Host(Vec<f32>, Vec<f32>),
    /// Device tensors at the parameter's own rank (GPU backends: tensor ops).
    Device(Box<[AnyRank; 2]>),
}

/// Steps applied so far: counted on the host, or on the device (a `[1]` tensor that a
/// skipped step does not advance; exact up to 2^24 steps, past which Adam's bias
/// corrections are 1 to f32 precision anyway).
#[derive(Clone, Debug)]
enum Steps {
    Host(u64),
    Device(Box<Tensor<1>>),
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
}

/// [`Update`]'s step on a device: the same formulas with the step-dependent scalars as
/// `[1]` tensors computed there (`t`, the clipping scale and whether the gradient is
/// finite are never read back), applied to each parameter at its own rank so that a
/// parameter's update is one fused element-wise kernel.
struct DeviceUpdate {
    beta1: f32,
    beta2: f32,
    eps: f32,
    step_size: Tensor<1>,
    bias2_sqrt: Tensor<1>,
    /// `min(1, max_norm / (norm + 1e-6))`; `None` without clipping.
    scale: Option<Tensor<1>>,
    /// True when the gradient is not finite: everything stays as it was.
    skip: Tensor<1, Bool>,
    grads: Vec<Option<AnyRank>>,
    moments: Vec<Option<Moments>>,
}

impl ParamFn for &mut DeviceUpdate {
    fn apply<const D: usize>(&mut self, index: usize, p: Tensor<D>) -> Tensor<D> {
        let Some(g) = self.grads[index].take() else {
            return p;
        };
        let dims = p.dims();
        let g = g.into_rank(dims);
        let [m, v] = match self.moments[index].take() {
            Some(Moments::Device(mv)) => mv.map(|x| x.into_rank(dims)),
            _ => [g.zeros_like(), g.zeros_like()],
        };
        let [p, m, v] = if dims.iter().product::<usize>() > 1 {
            self.update(p, g, m, v)
        } else {
            // A one-element parameter (SAC's log alpha) has the shape of the step's `[1]`
            // scalars, and burn-fusion 0.22 then writes the fused kernel's outputs into
            // the wrong same-shaped inputs (wrong parameters on wgpu, measured; cf.
            // burn#1656). Updated at width 2 instead, the two lanes equal, and the first
            // lane kept.
            let wide = |x: Tensor<D>| {
                let x = x.reshape([1]);
                Tensor::cat(vec![x.clone(), x], 0)
            };
            self.update(wide(p), wide(g), wide(m), wide(v))
                .map(|x| x.narrow(0, 0, 1).reshape(dims))
        };
        self.moments[index] = Some(Moments::Device(Box::new([
            AnyRank::new(m),
            AnyRank::new(v),
        ])));
        p
    }
}

impl DeviceUpdate {
    /// `[p, m, v]` after the step.
    fn update<const D: usize>(
        &self,
        p: Tensor<D>,
        g: Tensor<D>,
        m: Tensor<D>,
        v: Tensor<D>,
    ) -> [Tensor<D>; 3] {
        let dims = p.dims();
        let scalar = |x: &Tensor<1>| x.clone().reshape([1; D]);
        let g = match &self.scale {
            Some(scale) => g * scalar(scale),
            None => g,
        };
        let (beta1, beta2) = (self.beta1, self.beta2);
        let m_new = m.clone().mul_scalar(beta1) + g.clone().mul_scalar(1.0 - beta1);
        let v_new = v.clone().mul_scalar(beta2) + g.square().mul_scalar(1.0 - beta2);
        let denom = (v_new.clone().sqrt() / scalar(&self.bias2_sqrt)).add_scalar(self.eps);
        let p_new = p.clone() - m_new.clone() / denom * scalar(&self.step_size);
        let skip = self.skip.clone().reshape([1; D]).expand(dims);
        [
            p_new.mask_where(skip.clone(), p),
            m_new.mask_where(skip.clone(), m),
            v_new.mask_where(skip, v),
        ]
    }
}

/// Adam's state for one module: step count and per-parameter moments (in the module's
/// visiting order; created at the first step). On CPU backends the update is one fused
/// host loop per parameter, elsewhere tensor ops that never wait for the device; the
/// math is the same.
#[derive(Clone, Debug)]
pub struct Adam {
    config: AdamConfig,
    steps: Steps,
    moments: Vec<Option<Moments>>,
    host_fast_path: bool,
}

/// The report of a host step: the norm and whether the step was applied.
fn host_report(grad_norm: f32, applied: bool) -> StepReport {
    StepReport {
        grad_norm: Scalar::Host(f64::from(grad_norm)),
        applied: Scalar::Host(f64::from(u8::from(applied))),
    }
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
            steps: Steps::Host(0),
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

    /// Steps applied so far (a read from the device on the GPU path).
    pub fn steps(&self) -> u64 {
        match &self.steps {
            Steps::Host(k) => *k,
            Steps::Device(t) => Scalar::of(t.as_ref().clone()).read() as u64,
        }
    }

    /// Stores the step count and moments under `prefix`: `{prefix}.steps`,
    /// `{prefix}.stepped` (one flag per parameter) and `{prefix}.m{i}` / `{prefix}.v{i}`
    /// for each stepped parameter `i` (host moments are borrowed, not copied).
    pub fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>, prefix: &str) {
        snap.put_u64(format!("{prefix}.steps"), self.steps());
        let stepped: Vec<bool> = self.moments.iter().map(Option::is_some).collect();
        snap.put_bools(format!("{prefix}.stepped"), &stepped);
        for (i, moments) in self.moments.iter().enumerate() {
            let (m, v): (Cow<'a, [f32]>, Cow<'a, [f32]>) = match moments {
                None => continue,
                Some(Moments::Host(m, v)) => (m.into(), v.into()),
                Some(Moments::Device(mv)) => {
                    let [m, v] = mv.as_ref().clone();
                    (to_vec(m.flat()).into(), to_vec(v.flat()).into())
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
                    AnyRank::R1(Tensor::from_data(
                        TensorData::new(x.to_vec(), [x.len()]),
                        &plain,
                    ))
                };
                Moments::Device(Box::new([tensor(m), tensor(v)]))
            }));
        }
        self.steps = Steps::Host(steps);
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
        if self.host_fast_path && on_host(&module) {
            self.host_step(module, grads, lr)
        } else {
            self.device_step(module, grads, lr)
        }
    }

    fn check_module(&mut self, params: usize) {
        if self.moments.is_empty() {
            self.moments = vec![None; params];
        }
        assert_eq!(self.moments.len(), params, "Adam used with another module");
    }

    /// The step as one fused host loop per parameter.
    fn host_step<M: Module>(
        &mut self,
        module: M,
        grads: &mut Gradients,
        lr: f64,
    ) -> (M, StepReport) {
        let mut grads: Vec<Option<TensorData>> = flat_grads(&module, grads)
            .into_iter()
            .map(|g| g.map(host_data))
            .collect();
        self.check_module(grads.len());
        let grad_norm = grads
            .iter()
            .flatten()
            .map(|g| sum_squares(g.as_slice::<f32>().expect("float gradients are f32")))
            .sum::<f64>()
            .sqrt() as f32;
        let Some(update) = self.host_update(grad_norm, lr) else {
            return (module, host_report(grad_norm, false));
        };
        let moments = &mut self.moments;
        let module = map_flat_params(module, |i, p| {
            let Some(g) = grads[i].take() else {
                return p;
            };
            let g = g.as_slice::<f32>().expect("float gradients are f32");
            let (mut m, mut v) = match moments[i].take() {
                Some(Moments::Host(m, v)) => (m, v),
                _ => (vec![0.0; g.len()], vec![0.0; g.len()]),
            };
            let p = update_in_place(p, |p| update.host(p, g, &mut m, &mut v));
            moments[i] = Some(Moments::Host(m, v));
            p
        });
        (module, host_report(grad_norm, true))
    }

    /// The [`Update`] of a host step whose gradient has global norm `grad_norm`, the step
    /// counted; `None`, nothing counted, when the norm is not finite.
    fn host_update(&mut self, grad_norm: f32, lr: f64) -> Option<Update> {
        if !grad_norm.is_finite() {
            return None;
        }
        let steps = match &mut self.steps {
            Steps::Host(k) => k,
            Steps::Device(_) => unreachable!("a host optimiser counts its steps on the host"),
        };
        *steps += 1;
        let AdamConfig {
            beta1,
            beta2,
            eps,
            max_grad_norm,
        } = self.config;
        let t = *steps as i32;
        Some(Update {
            beta1,
            beta2,
            eps,
            step_size: lr as f32 / (1.0 - beta1.powi(t)),
            bias2_sqrt: (1.0 - beta2.powi(t)).sqrt(),
            scale: clip_coefficient(grad_norm, max_grad_norm),
        })
    }

    /// One update of a network kept in flat host buffers ([`crate::HostMlp`]): `params`,
    /// one or more pieces (the twin critics' two networks), and their gradient `grads`,
    /// the pieces' concatenation, taken as a single parameter (its moments and snapshot
    /// entries are those of a one-parameter module; the clipping norm is over all pieces).
    /// The formulas, the clipping and the skipping of a non-finite gradient are
    /// [`Adam::step`]'s.
    pub fn step_flat(&mut self, params: &mut [&mut [f32]], grads: &[f32], lr: f64) -> StepReport {
        let n: usize = params.iter().map(|p| p.len()).sum();
        assert_eq!(n, grads.len(), "a gradient per parameter");
        self.check_module(1);
        let grad_norm = sum_squares(grads).sqrt() as f32;
        let Some(update) = self.host_update(grad_norm, lr) else {
            return host_report(grad_norm, false);
        };
        let moments =
            self.moments[0].get_or_insert_with(|| Moments::Host(vec![0.0; n], vec![0.0; n]));
        if let Moments::Device(mv) = moments {
            let [m, v] = mv.as_ref().clone();
            *moments = Moments::Host(to_vec(m.flat()), to_vec(v.flat()));
        }
        let Moments::Host(m, v) = moments else {
            unreachable!("moved to the host above")
        };
        let mut start = 0;
        for piece in params.iter_mut() {
            let range = start..start + piece.len();
            let (m, v) = (&mut m[range.clone()], &mut v[range.clone()]);
            update.host(piece, &grads[range.clone()], m, v);
            start = range.end;
        }
        host_report(grad_norm, true)
    }

    /// The step as tensor ops, with nothing read back from the device.
    fn device_step<M: Module>(
        &mut self,
        module: M,
        grads: &mut Gradients,
        lr: f64,
    ) -> (M, StepReport) {
        let grads = grads_any_rank(&module, grads);
        self.check_module(grads.len());
        let Some(device) = grads.iter().flatten().next().map(AnyRank::device) else {
            return (
                module,
                StepReport {
                    grad_norm: Scalar::Host(0.0),
                    applied: Scalar::Host(0.0),
                },
            );
        };
        let squares: Vec<Tensor<1>> = grads.iter().flatten().map(AnyRank::sum_squares).collect();
        let grad_norm = Tensor::cat(squares, 0).sum().sqrt();
        let finite = grad_norm.clone().is_finite();
        let steps = match &self.steps {
            Steps::Host(k) => Tensor::from_data(TensorData::new(vec![*k as f32], [1]), &device),
            Steps::Device(t) => t.as_ref().clone(),
        } + finite.clone().float();
        self.steps = Steps::Device(Box::new(steps.clone()));
        let AdamConfig {
            beta1,
            beta2,
            eps,
            max_grad_norm,
        } = self.config;
        // b^t = exp(t ln b); 1 - b^t.
        let one_minus_pow = |b: f32| steps.clone().mul_scalar(b.ln()).exp().neg().add_scalar(1.0);
        let mut update = DeviceUpdate {
            beta1,
            beta2,
            eps,
            step_size: one_minus_pow(beta1).recip().mul_scalar(lr as f32),
            bias2_sqrt: one_minus_pow(beta2).sqrt(),
            scale: max_grad_norm.map(|max| {
                grad_norm
                    .clone()
                    .add_scalar(1e-6)
                    .recip()
                    .mul_scalar(max)
                    .clamp_max(1.0)
            }),
            skip: finite.clone().bool_not(),
            grads,
            moments: std::mem::take(&mut self.moments),
        };
        let module = map_params(module, &mut update);
        self.moments = update.moments;
        (
            module,
            StepReport {
                grad_norm: Scalar::Device(Box::new(grad_norm)),
                applied: Scalar::Device(Box::new(finite.float())),
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
