//! The multilayer perceptron every actor and critic is built from.

use crate::init::linear;
use crate::params::{map_flat_params, take_module};
use burn::module::Module;
use burn::nn::{LayerNorm, LayerNormConfig, Linear};
use burn::tensor::activation::{relu, tanh};
use burn::tensor::{Device, Tensor, TensorData};
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
/// hidden layer and none after the output layer; with layer normalisation, each hidden
/// layer's output is normalised over its units (learned gain 1 and bias 0 at the start,
/// epsilon 1e-5) before the activation. Maps `[batch, input]` to `[batch, output]`.
#[derive(Module, Debug)]
pub struct Mlp {
    layers: Vec<Linear>,
    /// One per hidden layer, or none.
    norms: Vec<LayerNorm>,
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
        Self::with_layer_norm(input, hidden, output, activation, false, rng, device)
    }

    /// [`Mlp::new`], with a layer normalisation after every hidden layer when
    /// `layer_norm` (it draws nothing from `rng`: the linear layers are the same).
    pub fn with_layer_norm(
        input: usize,
        hidden: &[usize],
        output: usize,
        activation: Activation,
        layer_norm: bool,
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
        let norms = match layer_norm {
            true => hidden
                .iter()
                .map(|&w| LayerNormConfig::new(w).init(device))
                .collect(),
            false => Vec::new(),
        };
        Self {
            layers,
            norms,
            activation,
        }
    }

    /// `[batch, input] -> [batch, output]`.
    pub fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        let last = self.layers.len() - 1;
        self.layers.iter().enumerate().fold(x, |x, (i, layer)| {
            let y = layer.forward(x);
            if i == last {
                return y;
            }
            let y = match self.norms.get(i) {
                Some(norm) => norm.forward(y),
                None => y,
            };
            self.activation.apply(y)
        })
    }

    /// Sets the input layer's weights from the inputs at `inputs` (indices into the
    /// `[batch, input]` columns) to zero: those inputs no longer reach the output until
    /// training moves the weights again. An index past the input width is refused.
    pub fn zero_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        let [width, units] = self.layers[0].weight.dims();
        if let Some(bad) = inputs.iter().find(|&&i| i >= width) {
            return Err(format!("input {bad} of a {width}-wide input layer"));
        }
        let mut keep = vec![1.0_f32; width];
        inputs.iter().for_each(|&i| keep[i] = 0.0);
        let first = take_module(&mut self.layers[0]);
        // The weight, `[input, units]`, comes first in the layer's parameters; the bias stays.
        self.layers[0] = map_flat_params(first, |k, w| match k {
            0 => {
                let mask =
                    Tensor::<2>::from_data(TensorData::new(keep.clone(), [width, 1]), &w.device());
                (w.reshape([width, units]) * mask).reshape([width * units])
            }
            _ => w,
        });
        Ok(())
    }

    /// `[input, hidden..., output]`.
    pub fn widths(&self) -> Vec<usize> {
        std::iter::once(self.input_dim())
            .chain(self.layers.iter().map(|l| l.weight.dims()[1]))
            .collect()
    }

    /// The non-linearity between hidden layers.
    pub fn activation(&self) -> Activation {
        self.activation
    }

    /// Whether every hidden layer is normalised.
    pub fn has_layer_norm(&self) -> bool {
        !self.norms.is_empty()
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
    fn zeroed_inputs_no_longer_reach_the_output_and_the_others_still_do() {
        let device = Backend::default_cpu().unwrap().device().unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut mlp = Mlp::new(4, &[6], 2, Activation::Tanh, &mut rng, &device);
        let out = |mlp: &Mlp, x: [f32; 4]| {
            mlp.forward(Tensor::from_data(
                TensorData::new(x.to_vec(), [1, 4]),
                &device,
            ))
            .into_data()
            .try_into_vec::<f32>()
            .unwrap()
        };
        let base = [0.3, -0.7, 0.0, 0.0];
        let before = out(&mlp, base);
        assert_ne!(before, out(&mlp, [0.3, -0.7, 5.0, -2.0]));
        mlp.zero_inputs(&[2, 3]).unwrap();
        // Where the zeroed inputs are 0 the function is unchanged; elsewhere they are ignored.
        assert_eq!(out(&mlp, base), before);
        assert_eq!(out(&mlp, [0.3, -0.7, 5.0, -2.0]), before);
        assert_ne!(out(&mlp, [0.9, -0.7, 0.0, 0.0]), before);
        let err = mlp.zero_inputs(&[4]).unwrap_err();
        assert!(err.contains("input 4 of a 4-wide"), "{err}");
    }

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

    #[test]
    fn layer_norm_normalises_each_hidden_layer_and_draws_the_same_linears() {
        let device = Backend::default_cpu().unwrap().device().unwrap();
        let plain = Mlp::new(
            3,
            &[4],
            1,
            Activation::Relu,
            &mut ChaCha8Rng::seed_from_u64(3),
            &device,
        );
        let normed = Mlp::with_layer_norm(
            3,
            &[4],
            1,
            Activation::Relu,
            true,
            &mut ChaCha8Rng::seed_from_u64(3),
            &device,
        );
        assert_eq!(normed.num_params(), plain.num_params() + 2 * 4);
        let read = |t: Tensor<2>| t.into_data().try_into_vec::<f32>().unwrap();
        let weights = |m: &Mlp, i: usize| read(m.layers[i].weight.val());
        assert_eq!(weights(&plain, 0), weights(&normed, 0));
        assert_eq!(weights(&plain, 1), weights(&normed, 1));
        // By hand: h = relu(layer_norm(x W0 + b0)), y = h W1 + b1.
        let x = Tensor::from_data(TensorData::new(vec![0.5f32, -1.0, 2.0], [1, 3]), &device);
        let z = read(normed.layers[0].forward(x.clone()));
        let mean = z.iter().sum::<f32>() / 4.0;
        let var = z.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / 4.0;
        let h: Vec<f32> = z
            .iter()
            .map(|v| ((v - mean) / (var + 1e-5).sqrt()).max(0.0))
            .collect();
        let w1 = weights(&normed, 1);
        let b1 = read(normed.layers[1].bias.as_ref().unwrap().val().unsqueeze())[0];
        let expected = b1 + h.iter().zip(&w1).map(|(a, b)| a * b).sum::<f32>();
        let y = read(normed.forward(x))[0];
        assert!((y - expected).abs() < 1e-5, "{y} vs {expected}");
    }
}
