//! The multilayer perceptron every actor and critic is built from.

use crate::init::linear;
use burn::module::Module;
use burn::nn::Linear;
use burn::tensor::activation::{relu, tanh};
use burn::tensor::{Device, Tensor};
use rand::Rng;

/// The non-linearity between hidden layers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Activation {
    /// `max(x, 0)`: SB3's default for SAC and TD3 (and the paper's networks).
    #[default]
    Relu,
    /// `tanh(x)`: SB3's default for PPO.
    Tanh,
}

impl Activation {
    fn apply<const D: usize>(self, x: Tensor<D>) -> Tensor<D> {
        match self {
            Activation::Relu => relu(x),
            Activation::Tanh => tanh(x),
        }
    }
}

/// `input -> hidden[0] -> ... -> hidden[k-1] -> output`, the activation after every
/// hidden layer and none after the output layer. Maps `[batch, input]` to `[batch, output]`.
#[derive(Module, Debug)]
pub struct Mlp {
    layers: Vec<Linear>,
    #[module(skip)]
    activation: Activation,
}

impl Mlp {
    /// Layers drawn in order, input side first (see [`crate::init::linear`]).
    pub fn new(
        input: usize,
        hidden: &[usize],
        output: usize,
        activation: Activation,
        rng: &mut impl Rng,
        device: &Device,
    ) -> Self {
        let widths: Vec<usize> = std::iter::once(input)
            .chain(hidden.iter().copied())
            .chain(std::iter::once(output))
            .collect();
        let layers = widths
            .windows(2)
            .map(|w| linear(w[0], w[1], rng, device))
            .collect();
        Self { layers, activation }
    }

    /// `[batch, input] -> [batch, output]`.
    pub fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        let last = self.layers.len() - 1;
        self.layers.iter().enumerate().fold(x, |x, (i, layer)| {
            let y = layer.forward(x);
            if i < last {
                self.activation.apply(y)
            } else {
                y
            }
        })
    }

    /// Width of the input layer.
    pub fn input_dim(&self) -> usize {
        self.layers[0].weight.dims()[0]
    }

    /// Width of the output layer.
    pub fn output_dim(&self) -> usize {
        self.layers[self.layers.len() - 1].weight.dims()[1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Backend;
    use burn::tensor::TensorData;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn forward_matches_a_hand_computation() {
        let device = Backend::default_cpu().unwrap().device().unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mlp = Mlp::new(3, &[4, 5], 2, Activation::Relu, &mut rng, &device);
        assert_eq!((mlp.input_dim(), mlp.output_dim()), (3, 2));
        assert_eq!(mlp.num_params(), 3 * 4 + 4 + 4 * 5 + 5 + 5 * 2 + 2);

        let x = [0.5f32, -1.0, 2.0];
        let y = mlp
            .forward(Tensor::from_data(
                TensorData::new(x.to_vec(), [1, 3]),
                &device,
            ))
            .into_data()
            .try_into_vec::<f32>()
            .unwrap();

        let mut h = x.to_vec();
        for (i, layer) in mlp.layers.iter().enumerate() {
            let w = layer
                .weight
                .val()
                .into_data()
                .try_into_vec::<f32>()
                .unwrap();
            let b = layer.bias.as_ref().unwrap().val().into_data();
            let b = b.try_into_vec::<f32>().unwrap();
            let (d_in, d_out) = (h.len(), b.len());
            h = (0..d_out)
                .map(|o| {
                    let z = b[o] + (0..d_in).map(|k| h[k] * w[k * d_out + o]).sum::<f32>();
                    if i + 1 < mlp.layers.len() {
                        z.max(0.0)
                    } else {
                        z
                    }
                })
                .collect();
        }
        for (a, b) in y.iter().zip(&h) {
            assert!((a - b).abs() < 1e-5, "{y:?} vs {h:?}");
        }
    }
}
