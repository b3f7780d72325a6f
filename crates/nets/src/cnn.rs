//! Image encoders: what a network sees of an observation before its MLP. A vector
//! observation goes to the MLP as it is; an image goes through a CNN, SB3's NatureCNN by
//! default (Mnih et al. 2015: conv 32 8x8 stride 4, conv 64 4x4 stride 2, conv 64 3x3
//! stride 1, each with ReLU, flattened, linear to 512 features with ReLU).
//!
//! Images arrive flat, `[batch, channels * height * width]` channel-first with values in
//! `[0, 1]` (SB3 divides bytes by 255 in the same place), and are reshaped to
//! `[batch, channels, height, width]`. Parameters follow PyTorch's default law for
//! `nn.Conv2d` and `nn.Linear`: `U(-1/sqrt(fan_in), 1/sqrt(fan_in))`, weight before bias.

use crate::init::{linear, uniform_tensor};
use burn::module::{Module, Param};
use burn::nn::conv::Conv2d;
use burn::nn::{Linear, PaddingConfig2d};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor};
use rand::Rng;

/// The shape of an observation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum ObsShape {
    /// A flat vector of this many values.
    Vector(usize),
    /// A channel-first image.
    Image {
        /// Channels (stacked frames times colour channels).
        channels: usize,
        /// Rows, pixels.
        height: usize,
        /// Columns, pixels.
        width: usize,
    },
}

impl ObsShape {
    /// Values in one observation.
    pub fn dim(&self) -> usize {
        match *self {
            ObsShape::Vector(n) => n,
            ObsShape::Image {
                channels,
                height,
                width,
            } => channels * height * width,
        }
    }
}

impl From<usize> for ObsShape {
    fn from(dim: usize) -> Self {
        ObsShape::Vector(dim)
    }
}

/// One convolution: output channels, square kernel side, stride (no padding).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ConvLayer {
    /// Output channels.
    pub channels: usize,
    /// Kernel side, pixels.
    pub kernel: usize,
    /// Stride, pixels.
    pub stride: usize,
}

/// `[<algo>.net.cnn]`: the image encoder's layers (used only for image observations).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CnnConfig {
    /// Convolutions, input side first, each followed by ReLU.
    pub convs: Vec<ConvLayer>,
    /// Width of the linear layer (with ReLU) after the flattened convolutions.
    pub features: usize,
}

impl Default for CnnConfig {
    /// SB3's NatureCNN.
    fn default() -> Self {
        let conv = |channels, kernel, stride| ConvLayer {
            channels,
            kernel,
            stride,
        };
        Self {
            convs: vec![conv(32, 8, 4), conv(64, 4, 2), conv(64, 3, 1)],
            features: 512,
        }
    }
}

impl CnnConfig {
    /// Refuses zero sizes; the message names the key (`features`, `convs[i]`).
    pub fn validate(&self) -> Result<(), String> {
        if self.features == 0 {
            return Err("features: must be positive".into());
        }
        match self
            .convs
            .iter()
            .position(|l| l.channels == 0 || l.kernel == 0 || l.stride == 0)
        {
            Some(i) => Err(format!(
                "convs[{i}]: channels, kernel and stride must be positive"
            )),
            None => Ok(()),
        }
    }

    /// `(channels, height, width)` after the convolutions of an image of `(height,
    /// width)`, or why the layers do not fit it (the message names the layer).
    pub fn conv_output(
        &self,
        channels: usize,
        height: usize,
        width: usize,
    ) -> Result<[usize; 3], String> {
        self.validate()?;
        let (mut c, mut h, mut w) = (channels, height, width);
        for (i, l) in self.convs.iter().enumerate() {
            if h < l.kernel || w < l.kernel {
                return Err(format!(
                    "convs[{i}]: a {}x{} kernel does not fit the {h}x{w} input of this layer \
                     (image {height}x{width}): use larger frames or smaller kernels",
                    l.kernel, l.kernel
                ));
            }
            (c, h, w) = (
                l.channels,
                (h - l.kernel) / l.stride + 1,
                (w - l.kernel) / l.stride + 1,
            );
        }
        Ok([c, h, w])
    }
}

/// A CNN encoder: `[batch, channels * height * width] -> [batch, features]`.
#[derive(Module, Debug)]
pub struct Cnn {
    convs: Vec<Conv2d>,
    linear: Linear,
    #[module(skip)]
    input: [usize; 3],
}

impl Cnn {
    /// Layers drawn in order from `rng`, input side first; the config must fit the image
    /// (see [`CnnConfig::conv_output`]).
    pub fn new(
        input: [usize; 3],
        config: &CnnConfig,
        rng: &mut impl Rng,
        device: &Device,
    ) -> Result<Self, String> {
        let [c, h, w] = config.conv_output(input[0], input[1], input[2])?;
        let mut in_channels = input[0];
        let convs = config
            .convs
            .iter()
            .map(|l| {
                let fan_in = in_channels * l.kernel * l.kernel;
                let bound = 1.0 / (fan_in as f32).sqrt();
                let shape = [l.channels, in_channels, l.kernel, l.kernel];
                let weight = uniform_tensor(shape, bound, rng, device);
                let bias = uniform_tensor([l.channels], bound, rng, device);
                in_channels = l.channels;
                Conv2d {
                    weight: Param::from_tensor(weight),
                    bias: Some(Param::from_tensor(bias)),
                    stride: [l.stride, l.stride],
                    kernel_size: [l.kernel, l.kernel],
                    dilation: [1, 1],
                    groups: 1,
                    padding: PaddingConfig2d::Valid,
                }
            })
            .collect();
        let linear = linear(c * h * w, config.features, rng, device);
        Ok(Self {
            convs,
            linear,
            input,
        })
    }

    /// Width of the features.
    pub fn features(&self) -> usize {
        self.linear.weight.dims()[1]
    }

    /// `[batch, channels * height * width] -> [batch, features]`. The convolutions run
    /// channels-last as one matrix product each (see [`conv_nhwc`]); the last one's
    /// output is flattened channel-first, as PyTorch's `nn.Flatten` does.
    pub fn forward(&self, obs: Tensor<2>) -> Tensor<2> {
        let batch = obs.dims()[0];
        let [c, h, w] = self.input;
        let nhwc = obs.reshape([batch, c, h, w]).permute([0, 2, 3, 1]);
        let x = self
            .convs
            .iter()
            .fold(nhwc, |x, conv| relu(conv_nhwc(x, conv)));
        relu(self.linear.forward(x.permute([0, 3, 1, 2]).flatten(1, 3)))
    }
}

/// `conv`'s valid convolution of a channels-last batch `[batch, height, width, in]` to
/// `[batch, height', width', out]`, as im2col: the windows gathered by two `unfold`s into
/// rows `[batch * height' * width', in * k * k]` times the weight `[in * k * k, out]`.
/// The same numbers as `Conv2d::forward` up to summation order. On burn-flex a SAC step
/// with a small CNN took 170 ms this way against 398 ms through `Conv2d::forward` (its
/// direct convolution); gathering the windows with `k * k` strided slices and `cat`
/// instead took 234 ms (one budget estimate each, 2-core machine loaded by a sweep).
pub fn conv_nhwc(x: Tensor<4>, conv: &Conv2d) -> Tensor<4> {
    let [out, inp, kh, kw] = conv.weight.dims();
    let [sh, sw] = conv.stride;
    let batch = x.dims()[0];
    let windows: Tensor<6> = x.unfold::<5, _>(1, kh, sh).unfold(2, kw, sw);
    let [_, ho, wo, _, _, _] = windows.dims();
    let rows = windows.reshape([batch * ho * wo, inp * kh * kw]);
    let weight = conv.weight.val().reshape([out, inp * kh * kw]).transpose();
    let mut y = rows.matmul(weight);
    if let Some(bias) = &conv.bias {
        y = y + bias.val().unsqueeze::<2>();
    }
    y.reshape([batch, ho, wo, out])
}

/// What a network puts in front of its MLP: nothing for a vector observation, a CNN for
/// an image (no parameters and no RNG draws in the first case).
#[derive(Module, Debug)]
pub struct Encoder {
    cnn: Option<Cnn>,
}

impl Encoder {
    /// The encoder of `shape`, drawn next from `rng` (a CNN of `config` for an image).
    pub fn new(
        shape: ObsShape,
        config: &CnnConfig,
        rng: &mut impl Rng,
        device: &Device,
    ) -> Result<Self, String> {
        let cnn = match shape {
            ObsShape::Vector(_) => None,
            ObsShape::Image {
                channels,
                height,
                width,
            } => Some(Cnn::new([channels, height, width], config, rng, device)?),
        };
        Ok(Self { cnn })
    }

    /// Width of what it hands the MLP for an observation of `shape`.
    pub fn output_dim(&self, shape: ObsShape) -> usize {
        self.cnn.as_ref().map_or(shape.dim(), Cnn::features)
    }

    /// Refuses an image observation, whose values have no input weights of their own.
    pub fn per_value_inputs(&self) -> Result<(), String> {
        match self.cnn {
            Some(_) => {
                Err("an image observation's pixels have no input weights of their own".into())
            }
            None => Ok(()),
        }
    }

    /// `[batch, obs_dim] -> [batch, output_dim]`.
    pub fn forward(&self, obs: Tensor<2>) -> Tensor<2> {
        match &self.cnn {
            Some(cnn) => cnn.forward(obs),
            None => obs,
        }
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
    fn nature_cnn_on_84x84_has_sb3s_sizes() {
        let c = CnnConfig::default();
        // 84 -> 20 -> 9 -> 7: 64 * 7 * 7 = 3136 inputs to the 512-wide linear layer.
        assert_eq!(c.conv_output(4, 84, 84), Ok([64, 7, 7]));
        let device = Backend::default_cpu().unwrap().device().unwrap();
        let cnn = Cnn::new([4, 84, 84], &c, &mut ChaCha8Rng::seed_from_u64(0), &device).unwrap();
        let params =
            (32 * 4 * 64 + 32) + (64 * 32 * 16 + 64) + (64 * 64 * 9 + 64) + (3136 * 512 + 512);
        assert_eq!(cnn.num_params(), params);
        assert_eq!(cnn.features(), 512);
    }

    #[test]
    fn the_matrix_product_convolution_matches_burns_conv2d() {
        let device = Backend::default_cpu().unwrap().device().unwrap();
        let config = CnnConfig {
            convs: vec![ConvLayer {
                channels: 5,
                kernel: 3,
                stride: 2,
            }],
            features: 4,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let cnn = Cnn::new([3, 11, 8], &config, &mut rng, &device).unwrap();
        let values: Vec<f32> = (0..2 * 3 * 11 * 8)
            .map(|i| ((i * 7) % 23) as f32 / 23.0)
            .collect();
        let x = Tensor::<4>::from_data(TensorData::new(values, [2, 3, 11, 8]), &device);
        let direct = cnn.convs[0].forward(x.clone());
        let nhwc = conv_nhwc(x.permute([0, 2, 3, 1]), &cnn.convs[0]).permute([0, 3, 1, 2]);
        assert_eq!((direct.dims(), nhwc.dims()), ([2, 5, 5, 3], [2, 5, 5, 3]));
        let direct: Vec<f32> = direct.into_data().try_into_vec().unwrap();
        let im2col: Vec<f32> = nhwc.into_data().try_into_vec().unwrap();
        for (a, b) in direct.iter().zip(&im2col) {
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
    }

    #[test]
    fn too_small_images_are_refused_naming_the_layer() {
        let e = CnnConfig::default().conv_output(1, 30, 84).unwrap_err();
        assert!(
            e.starts_with("convs[2]: a 3x3 kernel does not fit the 2x9 input"),
            "{e}"
        );
    }

    #[test]
    fn forward_and_backward_have_the_right_shapes_and_the_seed_fixes_them() {
        let device = Backend::default_cpu().unwrap().device().unwrap();
        let config = CnnConfig {
            convs: vec![ConvLayer {
                channels: 3,
                kernel: 3,
                stride: 2,
            }],
            features: 5,
        };
        let build = |seed| {
            Cnn::new(
                [2, 9, 7],
                &config,
                &mut ChaCha8Rng::seed_from_u64(seed),
                &device,
            )
            .unwrap()
        };
        let cnn = build(1);
        let values: Vec<f32> = (0..3 * 2 * 9 * 7).map(|i| (i % 17) as f32 / 17.0).collect();
        let obs = Tensor::<2>::from_data(TensorData::new(values, [3, 126]), &device);
        let out = cnn.forward(obs.clone());
        assert_eq!(out.dims(), [3, 5]);
        let y: Vec<f32> = out.clone().into_data().try_into_vec().unwrap();
        assert!(y.iter().all(|v| *v >= 0.0 && v.is_finite()));
        let again: Vec<f32> = build(1)
            .forward(obs.clone())
            .into_data()
            .try_into_vec()
            .unwrap();
        assert_eq!(y, again);
        let other: Vec<f32> = build(2).forward(obs).into_data().try_into_vec().unwrap();
        assert_ne!(y, other);
        // Gradients reach every parameter with its own shape.
        let grads = out.sum().backward();
        let conv_grad = cnn.convs[0].weight.grad(&grads).unwrap();
        assert_eq!(conv_grad.dims(), [3, 2, 3, 3]);
        assert_eq!(
            cnn.linear.weight.grad(&grads).unwrap().dims(),
            [3 * 4 * 3, 5]
        );
    }
}
