//! Log-densities and entropies of the policies' action distributions (SB3's definitions).
//!
//! Shapes: `mean`, `log_std`, actions `[batch, action_dim]`; results `[batch]`, summed
//! over the action axis.

use burn::tensor::Tensor;
use burn::tensor::activation::tanh;

/// Lower clamp of SAC's log standard deviation (SB3's `LOG_STD_MIN`).
pub const LOG_STD_MIN: f32 = -20.0;
/// Upper clamp of SAC's log standard deviation (SB3's `LOG_STD_MAX`).
pub const LOG_STD_MAX: f32 = 2.0;

/// `0.5 * ln(2 pi)`.
pub const HALF_LN_2PI: f32 = 0.918_938_5;

/// SB3's epsilon inside `log(1 - tanh(u)^2 + eps)`, which keeps the squashing
/// correction finite when `|tanh(u)|` rounds to 1.
pub const TANH_EPSILON: f32 = 1e-6;

/// `sum_i log N(x_i; mean_i, exp(log_std_i)^2)`.
pub fn diag_gaussian_log_prob(mean: Tensor<2>, log_std: Tensor<2>, x: Tensor<2>) -> Tensor<1> {
    let z = (x - mean) / log_std.clone().exp();
    (z.square().mul_scalar(-0.5) - log_std)
        .sub_scalar(HALF_LN_2PI)
        .sum_dim(1)
        .squeeze_dim(1)
}

/// `sum_i (0.5 + 0.5 ln(2 pi) + log_std_i)`, the entropy of a diagonal Gaussian.
pub fn diag_gaussian_entropy(log_std: Tensor<2>) -> Tensor<1> {
    log_std
        .add_scalar(0.5 + HALF_LN_2PI)
        .sum_dim(1)
        .squeeze_dim(1)
}

/// Log-density of `a = tanh(u)` for `u ~ N(mean, exp(log_std)^2)`, given `u`:
/// `log N(u) - sum_i log(1 - tanh(u_i)^2 + eps)` (SB3's `SquashedDiagGaussianDistribution`).
pub fn squashed_gaussian_log_prob(mean: Tensor<2>, log_std: Tensor<2>, u: Tensor<2>) -> Tensor<1> {
    let a = tanh(u.clone());
    let correction = a
        .square()
        .neg()
        .add_scalar(1.0 + TANH_EPSILON)
        .log()
        .sum_dim(1)
        .squeeze_dim(1);
    diag_gaussian_log_prob(mean, log_std, u) - correction
}
