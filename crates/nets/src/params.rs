//! Parameter-wise views of a module: every float parameter flattened to `[numel]`, in
//! the module's visiting order (field order, layers input side first). Optimisers,
//! polyak averaging and checkpoints all walk parameters through these two functions.

use crate::host::{host_data, is_host, lerp_into, to_vec, update_in_place};
use burn::module::{Module, ModuleMapper, ModuleVisitor, Param};
use burn::tensor::{Gradients, Tensor};

struct Collect<'g> {
    grads: Option<&'g mut Gradients>,
    values: Vec<Tensor<1>>,
    gradients: Vec<Option<Tensor<1>>>,
}

impl ModuleVisitor for Collect<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let value = param.val();
        let numel = value.shape().num_elements();
        if let Some(grads) = self.grads.as_deref_mut() {
            let grad = value.grad_remove(grads).map(|g| g.reshape([numel]));
            self.gradients.push(grad);
        } else {
            self.values.push(value.inner().reshape([numel]));
        }
    }
}

/// Every float parameter's value, detached from autodiff, flattened to `[numel]`.
pub fn flat_params<M: Module>(module: &M) -> Vec<Tensor<1>> {
    let mut visitor = Collect {
        grads: None,
        values: Vec::new(),
        gradients: Vec::new(),
    };
    module.visit(&mut visitor);
    visitor.values
}

/// Every float parameter's gradient taken out of `grads`, flattened to `[numel]`
/// (`None` for a parameter the loss does not depend on).
pub fn flat_grads<M: Module>(module: &M, grads: &mut Gradients) -> Vec<Option<Tensor<1>>> {
    let mut visitor = Collect {
        grads: Some(grads),
        values: Vec::new(),
        gradients: Vec::new(),
    };
    module.visit(&mut visitor);
    visitor.gradients
}

struct Replace<F> {
    index: usize,
    update: F,
}

impl<F: FnMut(usize, Tensor<1>) -> Tensor<1>> ModuleMapper for Replace<F> {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        let index = self.index;
        self.index += 1;
        param.map(|value| {
            let dims = value.dims();
            let require_grad = value.is_require_grad();
            let autodiff = value.is_autodiff();
            let flat = value.inner().reshape([dims.iter().product::<usize>()]);
            let updated = (self.update)(index, flat).reshape(dims);
            let updated = if autodiff {
                updated.autodiff()
            } else {
                updated
            };
            if require_grad {
                updated.require_grad()
            } else {
                updated
            }
        })
    }
}

/// Replaces every float parameter by `update(index, flat_value)` (detached, `[numel]`),
/// keeping its shape, its id and whether it requires gradients.
pub fn map_flat_params<M: Module>(
    module: M,
    update: impl FnMut(usize, Tensor<1>) -> Tensor<1>,
) -> M {
    module.map(&mut Replace { index: 0, update })
}

/// `target <- tau * online + (1 - tau) * target`, parameter by parameter (one fused
/// in-place host pass per parameter on CPU backends).
pub fn polyak_update<M: Module>(target: &mut M, online: &M, tau: f32) {
    let online = flat_params(online);
    let moved = take_module(target);
    *target = map_flat_params(moved, |i, t| {
        let o = online[i].clone();
        if is_host(&t.device()) {
            let o = host_data(o);
            update_in_place(t, |t| lerp_into(t, o.as_slice::<f32>().expect("f32"), tau))
        } else {
            t.mul_scalar(1.0 - tau) + o.mul_scalar(tau)
        }
    });
}

struct Hollow;

impl ModuleMapper for Hollow {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        param.map(|value| Tensor::zeros([0; D], &value.device()))
    }
}

/// Moves the module out of `slot`, leaving a placeholder of the same structure whose
/// parameters are empty, so the moved module's tensors are not shared and CPU backends
/// can update them in place.
pub fn take_module<M: Module>(slot: &mut M) -> M {
    let placeholder = slot.clone().map(&mut Hollow);
    std::mem::replace(slot, placeholder)
}

/// Every float parameter's values on the host, in visiting order.
pub fn host_params<M: Module>(module: &M) -> Vec<Vec<f32>> {
    flat_params(module).into_iter().map(to_vec).collect()
}
