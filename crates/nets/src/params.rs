//! Parameter-wise views of a module, in the module's visiting order (field order, layers
//! input side first): every float parameter flattened to `[numel]` (host fast paths and
//! checkpoints), or kept at its own rank (device paths: GPU kernel fusion does not reach
//! across a reshape that drops a dimension). Optimisers, polyak averaging and
//! checkpoints all walk parameters through these functions.

use crate::any_rank::AnyRank;
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

/// A change made to every float parameter at its own rank.
pub trait ParamFn {
    /// The new value of parameter `index` (visiting order) from its current `value`,
    /// detached from autodiff; the shape must not change.
    fn apply<const D: usize>(&mut self, index: usize, value: Tensor<D>) -> Tensor<D>;
}

/// Every float parameter's value at its own rank, detached from autodiff.
pub fn params_any_rank<M: Module>(module: &M) -> Vec<AnyRank> {
    struct Values(Vec<AnyRank>);
    impl ModuleVisitor for Values {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            self.0.push(AnyRank::new(param.val().inner()));
        }
    }
    let mut visitor = Values(Vec::new());
    module.visit(&mut visitor);
    visitor.0
}

/// Every float parameter's gradient at its own rank, taken out of `grads` (`None` for a
/// parameter the loss does not depend on).
pub fn grads_any_rank<M: Module>(module: &M, grads: &mut Gradients) -> Vec<Option<AnyRank>> {
    struct Take<'g>(&'g mut Gradients, Vec<Option<AnyRank>>);
    impl ModuleVisitor for Take<'_> {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            self.1
                .push(param.val().grad_remove(self.0).map(AnyRank::new));
        }
    }
    let mut visitor = Take(grads, Vec::new());
    module.visit(&mut visitor);
    visitor.1
}

struct Replace<F> {
    index: usize,
    update: F,
}

impl<F: ParamFn> ModuleMapper for Replace<F> {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        let index = self.index;
        self.index += 1;
        param.map(|value| {
            let require_grad = value.is_require_grad();
            let autodiff = value.is_autodiff();
            let updated = self.update.apply(index, value.inner());
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

/// Replaces every float parameter by `update.apply(index, value)` (detached, at its own
/// rank), keeping its shape, its id and whether it requires gradients.
pub fn map_params<M: Module>(module: M, update: impl ParamFn) -> M {
    module.map(&mut Replace { index: 0, update })
}

/// A flat view for [`map_params`]: the parameter flattened to `[numel]` and back.
struct Flat<F>(F);

impl<F: FnMut(usize, Tensor<1>) -> Tensor<1>> ParamFn for Flat<F> {
    fn apply<const D: usize>(&mut self, index: usize, value: Tensor<D>) -> Tensor<D> {
        let dims = value.dims();
        let flat = value.reshape([dims.iter().product::<usize>()]);
        (self.0)(index, flat).reshape(dims)
    }
}

/// Replaces every float parameter by `update(index, flat_value)` (detached, `[numel]`),
/// keeping its shape, its id and whether it requires gradients.
pub fn map_flat_params<M: Module>(
    module: M,
    update: impl FnMut(usize, Tensor<1>) -> Tensor<1>,
) -> M {
    map_params(module, Flat(update))
}

/// `target <- tau * online + (1 - tau) * target`, parameter by parameter: one fused
/// in-place host pass per parameter on CPU backends, elsewhere element-wise tensor ops
/// at the parameter's own rank (one fused kernel per parameter).
pub fn polyak_update<M: Module>(target: &mut M, online: &M, tau: f32) {
    let moved = take_module(target);
    *target = if on_host(online) {
        let online = flat_params(online);
        map_flat_params(moved, |i, t| {
            let o = host_data(online[i].clone());
            update_in_place(t, |t| lerp_into(t, o.as_slice::<f32>().expect("f32"), tau))
        })
    } else {
        map_params(
            moved,
            Lerp {
                online: params_any_rank(online),
                tau,
            },
        )
    };
}

/// Whether the module's parameters live in host memory (CPU backends); false for a module
/// without parameters.
pub fn on_host<M: Module>(module: &M) -> bool {
    struct First(Option<bool>);
    impl ModuleVisitor for First {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            self.0.get_or_insert_with(|| is_host(&param.val().device()));
        }
    }
    let mut visitor = First(None);
    module.visit(&mut visitor);
    visitor.0.unwrap_or(false)
}

/// Polyak averaging as tensor ops: `target * (1 - tau) + online * tau`.
struct Lerp {
    online: Vec<AnyRank>,
    tau: f32,
}

impl ParamFn for Lerp {
    fn apply<const D: usize>(&mut self, index: usize, target: Tensor<D>) -> Tensor<D> {
        let dims = target.dims();
        let online = self.online[index].clone().into_rank(dims);
        target.mul_scalar(1.0 - self.tau) + online.mul_scalar(self.tau)
    }
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
