//! Image encoders: what a network sees of an observation before its MLP. A vector
//! observation goes to the MLP as it is; an image goes through a CNN, SB3's NatureCNN by
//! default (Mnih et al. 2015: conv 32 8x8 stride 4, conv 64 4x4 stride 2, conv 64 3x3
//! stride 1, each with ReLU, flattened, linear to 512 features with ReLU).
//!
//! With `spatial_softmax` the last convolution's maps are read as keypoints instead of
//! flattened (Levine, Finn, Darrell and Abbeel, "End-to-End Training of Deep Visuomotor
//! Policies", 2016): per channel `c` a softmax over its `H x W` positions and the expected
//! position under it, `(x_c, y_c) = sum_p softmax(a_c)_p (u_p, v_p)` with `u, v` the
//! pixel centres mapped to `[-1, 1]` (column left to right, row top to bottom), `2 C`
//! values in all: a position finer than the map's grid, which is what a policy that aims
//! a kick at a 3.5 cm ball needs from a picture a pixel to the cm. With
//! `keypoint_frequencies = K` > 0 each coordinate `k` then reaches the linear layer as
//! `[k, sin(pi k), cos(pi k), ..., sin(2^(K-1) pi k), cos(2^(K-1) pi k)]` (the `[fourier]`
//! encoding the state learners use, on the keypoints: Tancik et al. 2020 on why a small
//! network needs it to resolve fine differences of a position).
//!
//! Images arrive flat, `[batch, channels * height * width]` channel-first with values in
//! `[0, 1]` (SB3 divides bytes by 255 in the same place), and are reshaped to
//! `[batch, channels, height, width]`. Parameters follow PyTorch's default law for
//! `nn.Conv2d` and `nn.Linear`: `U(-1/sqrt(fan_in), 1/sqrt(fan_in))`, weight before bias.

use crate::init::{linear, uniform_tensor};
use burn::module::{Module, Param};
use burn::nn::conv::Conv2d;
use burn::nn::{Linear, PaddingConfig2d};
use burn::tensor::activation::{relu, softmax};
use burn::tensor::{Device, Tensor, TensorData};
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
    /// Width of the linear layer (with ReLU) after the flattened convolutions (or their
    /// keypoints).
    pub features: usize,
    /// The last convolution's maps read as `2 x channels` keypoint coordinates (spatial
    /// soft-argmax) instead of flattened.
    pub spatial_softmax: bool,
    /// With `spatial_softmax`: the sin/cos pairs of each keypoint coordinate (0: the
    /// coordinates alone), frequencies `pi 2^k`, `k` = 0..K.
    pub keypoint_frequencies: u32,
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
            spatial_softmax: false,
            keypoint_frequencies: 0,
        }
    }
}

impl CnnConfig {
    /// Refuses zero sizes; the message names the key (`features`, `convs[i]`).
    pub fn validate(&self) -> Result<(), String> {
        if self.features == 0 {
            return Err("features: must be positive".into());
        }
        if self.keypoint_frequencies > 0 && !self.spatial_softmax {
            return Err("keypoint_frequencies: encodes keypoints: set spatial_softmax".into());
        }
        if self.keypoint_frequencies > MAX_KEYPOINT_FREQUENCIES {
            return Err(format!(
                "keypoint_frequencies: at most {MAX_KEYPOINT_FREQUENCIES}, got {}",
                self.keypoint_frequencies
            ));
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

    /// Values the convolutions hand the linear layer for an image of `(channels,
    /// height, width)`: the flattened maps, or two coordinates a channel.
    pub fn conv_features(
        &self,
        channels: usize,
        height: usize,
        width: usize,
    ) -> Result<usize, String> {
        let [c, h, w] = self.conv_output(channels, height, width)?;
        let per_coordinate = 1 + 2 * self.keypoint_frequencies as usize;
        Ok(if self.spatial_softmax {
            2 * c * per_coordinate
        } else {
            c * h * w
        })
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
    /// Keypoints instead of flattened maps ([`CnnConfig::spatial_softmax`]).
    #[module(skip)]
    spatial_softmax: bool,
    /// Sin/cos pairs of each keypoint coordinate ([`CnnConfig::keypoint_frequencies`]).
    #[module(skip)]
    keypoint_frequencies: u32,
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
        let flat = config.conv_features(input[0], input[1], input[2])?;
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
        let linear = linear(flat, config.features, rng, device);
        Ok(Self {
            convs,
            linear,
            input,
            spatial_softmax: config.spatial_softmax,
            keypoint_frequencies: config.keypoint_frequencies,
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
        let flat = if self.spatial_softmax {
            fourier(keypoints(x), self.keypoint_frequencies)
        } else {
            x.permute([0, 3, 1, 2]).flatten(1, 3)
        };
        relu(self.linear.forward(flat))
    }
}

/// Most sin/cos pairs a keypoint coordinate may get.
pub const MAX_KEYPOINT_FREQUENCIES: u32 = 12;

/// `[batch, n]` values `k`, each as `[k, sin(pi k), cos(pi k), ..., sin(2^(K-1) pi k),
/// cos(2^(K-1) pi k)]`: `[batch, n (1 + 2K)]`, one value's block after another; the
/// values alone where `K` = 0.
pub fn fourier(values: Tensor<2>, frequencies: u32) -> Tensor<2> {
    if frequencies == 0 {
        return values;
    }
    let [batch, n] = values.dims();
    let k = frequencies as usize;
    let device = values.device();
    let scales: Vec<f32> = (0..k)
        .map(|j| std::f32::consts::PI * 2f32.powi(j as i32))
        .collect();
    let scales = Tensor::<3>::from_data(TensorData::new(scales, [1, 1, k]), &device);
    let angles = values.clone().reshape([batch, n, 1]) * scales;
    // [batch, n, K, 2]: each frequency's sin beside its cos.
    let pairs = Tensor::stack::<4>(vec![angles.clone().sin(), angles.cos()], 3);
    let pairs = pairs.reshape([batch, n, 2 * k]);
    Tensor::cat(vec![values.reshape([batch, n, 1]), pairs], 2).reshape([batch, n * (1 + 2 * k)])
}

/// The spatial soft-argmax of channels-last maps `[batch, height, width, channels]`:
/// `[batch, 2 * channels]`, channel `c`'s expected column coordinate at `2c` and row
/// coordinate at `2c + 1`, each in `[-1, 1]` (pixel centres, first to last).
pub fn keypoints(maps: Tensor<4>) -> Tensor<2> {
    let [batch, h, w, c] = maps.dims();
    let device = maps.device();
    let logits = maps.permute([0, 3, 1, 2]).reshape([batch * c, h * w]);
    let weights = softmax(logits, 1);
    let centre = |i: usize, n: usize| {
        if n > 1 {
            2.0 * i as f32 / (n - 1) as f32 - 1.0
        } else {
            0.0
        }
    };
    let grid: Vec<f32> = (0..h * w)
        .flat_map(|p| [centre(p % w, w), centre(p / w, h)])
        .collect();
    let grid = Tensor::<2>::from_data(TensorData::new(grid, [h * w, 2]), &device);
    weights.matmul(grid).reshape([batch, 2 * c])
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
            ..CnnConfig::default()
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

    /// A channel hot at one pixel points there (`[-1, 1]` over the pixel centres); a flat
    /// channel points at the middle; the head hands the linear layer two values a channel.
    #[test]
    fn keypoints_are_the_expected_positions_under_each_channels_softmax() {
        let device = Backend::default_cpu().unwrap().device().unwrap();
        let (h, w, c) = (3, 5, 2);
        let mut values = vec![0.0_f32; h * w * c];
        // Channel 0 hot at row 1, column 3 (channels last).
        values[(w + 3) * c] = 60.0;
        let maps = Tensor::<4>::from_data(TensorData::new(values, [1, h, w, c]), &device);
        let points: Vec<f32> = keypoints(maps).into_data().try_into_vec().unwrap();
        let expected = [0.5, 0.0, 0.0, 0.0];
        for (p, e) in points.iter().zip(expected) {
            assert!((p - e).abs() < 1e-5, "{points:?}");
        }
        let config = CnnConfig {
            spatial_softmax: true,
            ..CnnConfig::default()
        };
        assert_eq!(config.conv_features(4, 84, 84), Ok(128));
        assert_eq!(CnnConfig::default().conv_features(4, 84, 84), Ok(3136));
        let cnn = Cnn::new(
            [4, 84, 84],
            &config,
            &mut ChaCha8Rng::seed_from_u64(0),
            &device,
        )
        .unwrap();
        let out = cnn.forward(Tensor::<2>::zeros([2, 4 * 84 * 84], &device));
        assert_eq!(out.dims(), [2, 512]);
        let encoded = CnnConfig {
            keypoint_frequencies: 3,
            ..config
        };
        assert_eq!(encoded.conv_features(4, 84, 84), Ok(128 * 7));
        let values = Tensor::<2>::from_data(TensorData::new(vec![0.25_f32, -0.5], [1, 2]), &device);
        let f: Vec<f32> = fourier(values, 3).into_data().try_into_vec().unwrap();
        let pi = std::f32::consts::PI;
        for (v, block) in [0.25_f32, -0.5].iter().zip(f.chunks(7)) {
            let mut expected = vec![*v];
            for j in 0..3 {
                let a = pi * 2f32.powi(j) * v;
                expected.extend([a.sin(), a.cos()]);
            }
            for (x, e) in block.iter().zip(&expected) {
                assert!((x - e).abs() < 1e-5, "{block:?} vs {expected:?}");
            }
        }
        let bad = CnnConfig {
            keypoint_frequencies: 2,
            ..CnnConfig::default()
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .starts_with("keypoint_frequencies")
        );
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
            ..CnnConfig::default()
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
