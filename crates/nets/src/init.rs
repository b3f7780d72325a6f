//! Parameter initialisation from the caller's RNG, with PyTorch's `nn.Linear` law.

use burn::module::Param;
use burn::nn::Linear;
use burn::tensor::{Device, Tensor, TensorData};
use rand::Rng;
use rand_distr::{Distribution, Uniform};

/// `shape.iter().product()` values drawn uniformly from `[-bound, bound)`.
pub fn uniform_tensor<const D: usize>(
    shape: [usize; D],
    bound: f32,
    rng: &mut impl Rng,
    device: &Device,
) -> Tensor<D> {
    let n = shape.iter().product();
    let law = Uniform::new(-bound, bound).expect("bound is positive and finite");
    let values: Vec<f32> = (0..n).map(|_| law.sample(rng)).collect();
    Tensor::from_data(TensorData::new(values, shape), device)
}

/// A trainable dense layer `y = x W + b` with `W: [d_in, d_out]`, `b: [d_out]`, both
/// drawn from `U(-1/sqrt(d_in), 1/sqrt(d_in))` as PyTorch's `nn.Linear` does
/// (kaiming-uniform with `a = sqrt(5)`). The weight is drawn before the bias.
pub fn linear(d_in: usize, d_out: usize, rng: &mut impl Rng, device: &Device) -> Linear {
    let bound = 1.0 / (d_in as f32).sqrt();
    let weight = uniform_tensor([d_in, d_out], bound, rng, device);
    let bias = uniform_tensor([d_out], bound, rng, device);
    Linear {
        weight: Param::from_tensor(weight),
        bias: Some(Param::from_tensor(bias)),
    }
}

/// Everything an agent's networks are drawn from: the env's sizes, the hidden layers
/// shared by all its networks, their activation, the image encoder's layers, the seeded
/// RNG and the device. Networks built from one `NetInit` draw from the RNG in
/// construction order.
pub struct NetInit<'a, R: Rng> {
    /// Observation shape.
    pub obs: crate::ObsShape,
    /// Action width.
    pub action_dim: usize,
    /// Hidden layer widths.
    pub hidden: &'a [usize],
    /// Non-linearity between hidden layers.
    pub activation: crate::Activation,
    /// The CNN in front of each network when the observation is an image.
    pub cnn: &'a crate::CnnConfig,
    /// Layer normalisation after every hidden layer of the Q-networks
    /// ([`NetInit::q_mlp`]).
    pub critic_layer_norm: bool,
    /// Where parameters are drawn from.
    pub rng: &'a mut R,
    /// Where parameters live (an autodiff device to train them).
    pub device: &'a Device,
}

impl<R: Rng> NetInit<'_, R> {
    /// An observation encoder drawn next from the RNG (nothing for a vector) and the
    /// width of what it outputs.
    ///
    /// # Panics
    /// If the CNN does not fit the image; check with [`crate::CnnConfig::conv_output`]
    /// first (run configurations do).
    pub fn encoder(&mut self) -> (crate::Encoder, usize) {
        let encoder = crate::Encoder::new(self.obs, self.cnn, self.rng, self.device)
            .unwrap_or_else(|e| panic!("cnn: {e}"));
        let width = encoder.output_dim(self.obs);
        (encoder, width)
    }

    /// An MLP `input -> hidden -> output` drawn next from the RNG.
    pub fn mlp(&mut self, input: usize, output: usize) -> crate::Mlp {
        crate::Mlp::new(
            input,
            self.hidden,
            output,
            self.activation,
            self.rng,
            self.device,
        )
    }

    /// An MLP of a Q-network, `input -> hidden -> output`, drawn next from the RNG, with
    /// layer normalisation when `critic_layer_norm`.
    pub fn q_mlp(&mut self, input: usize, output: usize) -> crate::Mlp {
        crate::Mlp::with_layer_norm(
            input,
            self.hidden,
            output,
            self.activation,
            self.critic_layer_norm,
            self.rng,
            self.device,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Backend;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn linear_layers_follow_pytorchs_bound_and_the_seed() {
        let device = Backend::default_cpu().unwrap().device().unwrap();
        let draw = |seed| {
            let layer = linear(16, 8, &mut ChaCha8Rng::seed_from_u64(seed), &device);
            layer
                .weight
                .val()
                .into_data()
                .try_into_vec::<f32>()
                .unwrap()
        };
        let w = draw(1);
        assert_eq!(w.len(), 128);
        assert!(w.iter().all(|x| x.abs() <= 0.25));
        assert!(w.iter().any(|x| x.abs() > 0.2), "uses the whole range");
        assert_eq!(w, draw(1));
        assert_ne!(w, draw(2));
    }
}
