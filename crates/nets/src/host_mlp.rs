//! The multilayer perceptron in host memory with its backward pass written out: one flat
//! parameter buffer, each layer's forward and backward as matrix products (the `gemm`
//! crate, one thread, so a result never depends on the thread count) into buffers kept
//! from call to call, no autodiff graph, and no allocation once the buffers have their
//! batch's size. The small-network path of issue 51: at 64x64 a Burn step spends most of
//! its time on per-operation overhead (docs/table.md, "where an update's time goes").
//!
//! The network is [`crate::Mlp`]'s without layer normalisation: per layer `z = x W + b`
//! (`W: [in, out]` row-major, `b: [out]`), the activation after every hidden layer, none
//! after the output layer. Parameters lie in the order Burn visits an `Mlp`'s
//! (`W0, b0, W1, b1, ...`), so [`HostMlp::from_mlp`] and [`HostMlp::write_to`] copy one
//! buffer, and a gradient buffer has the same layout as the parameters (one Adam step over
//! the whole network: [`crate::Adam::step_flat`]).
//!
//! Backward, for a loss `L` with `dy = dL/dy` given (rows are samples), from the output
//! layer down: `dz = da * f'(a)` for a hidden layer (`f'` from its output `a`: ReLU
//! `a > 0`, tanh `1 - a^2`; `dz = dy` at the output), `dW += x^T dz`,
//! `db += sum over rows of dz`, `dx = dz W^T`. The unit tests hold every layer shape the
//! configs use to Burn's autodiff within 1e-5.

use crate::mlp::{Activation, Mlp};
use crate::params::{host_params, map_flat_params};
use burn::tensor::{Tensor, TensorData};
use std::ops::Range;

/// An MLP's widths, activation and parameters, in host memory.
#[derive(Clone, Debug, PartialEq)]
pub struct HostMlp {
    /// `[input, hidden..., output]`.
    widths: Vec<usize>,
    activation: Activation,
    /// Per layer `W` (`[in, out]`, row-major) then `b` (`[out]`).
    params: Vec<f32>,
}

/// What a forward pass keeps for the backward pass, and the backward pass's scratch
/// space: buffers sized for the latest batch and reused by the next call.
#[derive(Clone, Debug, Default)]
pub struct MlpTape {
    batch: usize,
    /// The input `[batch, widths[0]]`, then each layer's output `[batch, widths[l + 1]]`
    /// (after the activation for hidden layers).
    values: Vec<Vec<f32>>,
    /// `dL/dz` of the layer being walked back, and of the one below it.
    delta: Vec<f32>,
    delta_below: Vec<f32>,
}

impl MlpTape {
    /// Rows of the latest forward pass.
    pub fn batch(&self) -> usize {
        self.batch
    }

    /// The latest forward pass's output, `[batch, output]` (empty before one).
    pub fn output(&self) -> &[f32] {
        self.values.last().map_or(&[], Vec::as_slice)
    }
}

/// Parameters of a dense layer of widths `[d_in, d_out]`: `W` and `b`.
fn layer_len(widths: &[usize]) -> usize {
    (widths[0] + 1) * widths[1]
}

/// A row-major operand of a matrix product: `data[i * row_stride + j * col_stride]` is
/// element `(i, j)`.
#[derive(Clone, Copy)]
struct View<'a> {
    data: &'a [f32],
    row_stride: usize,
    col_stride: usize,
}

impl<'a> View<'a> {
    /// `data` as a `[rows, cols]` row-major matrix.
    fn rows(data: &'a [f32], cols: usize) -> Self {
        Self {
            data,
            row_stride: cols,
            col_stride: 1,
        }
    }

    /// The transpose of `data` taken as a `[rows, cols]` row-major matrix.
    fn transposed(data: &'a [f32], cols: usize) -> Self {
        Self {
            data,
            row_stride: 1,
            col_stride: cols,
        }
    }

    /// Whether element `(rows - 1, cols - 1)` lies inside `data`.
    fn holds(&self, rows: usize, cols: usize) -> bool {
        rows == 0
            || cols == 0
            || (rows - 1) * self.row_stride + (cols - 1) * self.col_stride < self.data.len()
    }
}

/// `dst [m, n] = lhs [m, k] rhs [k, n]`, added to what `dst` holds when `accumulate`.
fn matmul(dst: &mut [f32], m: usize, n: usize, k: usize, lhs: View, rhs: View, accumulate: bool) {
    assert!(dst.len() >= m * n && lhs.holds(m, k) && rhs.holds(k, n));
    if m == 0 || n == 0 {
        return;
    }
    if k == 0 {
        if !accumulate {
            dst[..m * n].fill(0.0);
        }
        return;
    }
    // SAFETY: the asserts above keep every element the product reads or writes inside
    // the three slices; `dst` is borrowed mutably, so it aliases neither operand.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst.as_mut_ptr(),
            1,
            n as isize,
            accumulate,
            lhs.data.as_ptr(),
            lhs.col_stride as isize,
            lhs.row_stride as isize,
            rhs.data.as_ptr(),
            rhs.col_stride as isize,
            rhs.row_stride as isize,
            1.0,
            1.0,
            false,
            false,
            false,
            gemm::Parallelism::None,
        );
    }
}

impl HostMlp {
    /// A network of `widths` (`[input, hidden..., output]`, at least two, none zero) with
    /// `params` laid out as the module docs say; an error says what does not fit.
    pub fn new(
        widths: Vec<usize>,
        activation: Activation,
        params: Vec<f32>,
    ) -> Result<Self, String> {
        if widths.len() < 2 || widths.contains(&0) {
            return Err(format!(
                "an MLP needs an input and an output width, none zero: {widths:?}"
            ));
        }
        let expected: usize = widths.windows(2).map(layer_len).sum();
        if params.len() != expected {
            return Err(format!(
                "{} parameters for widths {widths:?}, which take {expected}",
                params.len()
            ));
        }
        Ok(Self {
            widths,
            activation,
            params,
        })
    }

    /// A copy of `mlp`'s parameters (one read each from its device); an error for a
    /// network with layer normalisation, which this path does not compute.
    pub fn from_mlp(mlp: &Mlp) -> Result<Self, String> {
        if mlp.has_layer_norm() {
            return Err("layer normalisation is not on the host MLP path".into());
        }
        Self::new(mlp.widths(), mlp.activation(), host_params(mlp).concat())
    }

    /// `mlp` with this network's parameters (same widths and activation; their ids and
    /// whether they require gradients kept).
    pub fn write_to(&self, mlp: Mlp) -> Result<Mlp, String> {
        if mlp.widths() != self.widths || mlp.has_layer_norm() {
            return Err(format!(
                "a host MLP of widths {:?} written to an Mlp of widths {:?}",
                self.widths,
                mlp.widths()
            ));
        }
        let mut offset = 0;
        Ok(map_flat_params(mlp, |_, p| {
            let n = p.dims()[0];
            let values = self.params[offset..offset + n].to_vec();
            offset += n;
            Tensor::from_data(TensorData::new(values, [n]), &p.device())
        }))
    }

    /// `[input, hidden..., output]`.
    pub fn widths(&self) -> &[usize] {
        &self.widths
    }

    /// The non-linearity after every hidden layer.
    pub fn activation(&self) -> Activation {
        self.activation
    }

    /// Width of the input layer.
    pub fn input_dim(&self) -> usize {
        self.widths[0]
    }

    /// Width of the output layer.
    pub fn output_dim(&self) -> usize {
        self.widths[self.widths.len() - 1]
    }

    /// The parameters, laid out as the module docs say.
    pub fn params(&self) -> &[f32] {
        &self.params
    }

    /// The parameters, to change in place (an optimiser step, Polyak averaging).
    pub fn params_mut(&mut self) -> &mut [f32] {
        &mut self.params
    }

    /// Where layer `l`'s `W` then `b` lie in the parameters (and in a gradient buffer).
    fn layer_range(&self, l: usize) -> Range<usize> {
        let start: usize = self.widths[..=l].windows(2).map(layer_len).sum();
        start..start + layer_len(&self.widths[l..l + 2])
    }

    /// Layer `l`'s `(W, b)`: `W` `[widths[l], widths[l + 1]]` row-major, `b`
    /// `[widths[l + 1]]`.
    pub fn layer(&self, l: usize) -> (&[f32], &[f32]) {
        let d_in_out = self.widths[l] * self.widths[l + 1];
        self.params[self.layer_range(l)].split_at(d_in_out)
    }

    /// `x [batch, input] -> [batch, output]`, kept in `tape` for [`HostMlp::backward`].
    pub fn forward<'t>(&self, x: &[f32], tape: &'t mut MlpTape) -> &'t [f32] {
        let layers = self.widths.len() - 1;
        let batch = x.len() / self.input_dim();
        assert_eq!(
            x.len(),
            batch * self.input_dim(),
            "input rows of {}",
            self.input_dim()
        );
        tape.batch = batch;
        tape.values.resize_with(layers + 1, Vec::new);
        tape.values[0].clear();
        tape.values[0].extend_from_slice(x);
        for l in 0..layers {
            let (d_in, d_out) = (self.widths[l], self.widths[l + 1]);
            let (weight, bias) = self.layer(l);
            let (below, above) = tape.values.split_at_mut(l + 1);
            let (x, z) = (&below[l], &mut above[0]);
            z.clear();
            for _ in 0..batch {
                z.extend_from_slice(bias);
            }
            let (x, w) = (View::rows(x, d_in), View::rows(weight, d_out));
            matmul(z, batch, d_out, d_in, x, w, true);
            if l + 1 < layers {
                match self.activation {
                    Activation::Relu => z.iter_mut().for_each(|v| *v = v.max(0.0)),
                    Activation::Tanh => z.iter_mut().for_each(|v| *v = v.tanh()),
                }
            }
        }
        &tape.values[layers]
    }

    /// The backward pass of the latest [`HostMlp::forward`] on `tape`: with
    /// `dy = dL/dy` (`[batch, output]`) adds `dL/dparams` to `grads` when given (the
    /// parameters' layout; zero it first for a fresh gradient) and writes `dL/dx`
    /// (`[batch, input]`) to `dx` when given (a critic walked back to its action input
    /// for an actor's loss needs no gradient of its own parameters).
    pub fn backward(
        &self,
        tape: &mut MlpTape,
        dy: &[f32],
        mut grads: Option<&mut [f32]>,
        dx: Option<&mut [f32]>,
    ) {
        let layers = self.widths.len() - 1;
        let batch = tape.batch;
        assert_eq!(
            dy.len(),
            batch * self.output_dim(),
            "dy of the forward's shape"
        );
        if let Some(grads) = &grads {
            assert_eq!(
                grads.len(),
                self.params.len(),
                "grads of the params' layout"
            );
        }
        let MlpTape {
            values,
            delta,
            delta_below,
            ..
        } = tape;
        delta.clear();
        delta.extend_from_slice(dy);
        for l in (0..layers).rev() {
            let (d_in, d_out) = (self.widths[l], self.widths[l + 1]);
            if l + 1 < layers {
                let a = &values[l + 1];
                match self.activation {
                    // A select, not a branch: the loop vectorises.
                    Activation::Relu => delta
                        .iter_mut()
                        .zip(a)
                        .for_each(|(d, &a)| *d = if a > 0.0 { *d } else { 0.0 }),
                    Activation::Tanh => delta
                        .iter_mut()
                        .zip(a)
                        .for_each(|(d, &a)| *d *= 1.0 - a * a),
                }
            }
            if let Some(grads) = grads.as_deref_mut() {
                let (grad_w, grad_b) = grads[self.layer_range(l)].split_at_mut(d_in * d_out);
                for row in delta.chunks_exact(d_out) {
                    grad_b.iter_mut().zip(row).for_each(|(g, d)| *g += d);
                }
                let x_t = View::transposed(&values[l], d_in);
                matmul(
                    grad_w,
                    d_in,
                    d_out,
                    batch,
                    x_t,
                    View::rows(delta, d_out),
                    true,
                );
            }
            if l > 0 || dx.is_some() {
                let (weight, _) = self.layer(l);
                delta_below.resize(batch * d_in, 0.0);
                let w_t = View::transposed(weight, d_out);
                matmul(
                    delta_below,
                    batch,
                    d_in,
                    d_out,
                    View::rows(delta, d_out),
                    w_t,
                    false,
                );
                std::mem::swap(delta, delta_below);
            }
        }
        if let Some(dx) = dx {
            dx.copy_from_slice(&delta[..batch * self.input_dim()]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Backend;
    use crate::host::to_vec;
    use crate::params::flat_grads;
    use burn::tensor::Device;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn device() -> Device {
        Backend::default_cpu().unwrap().device().unwrap()
    }

    fn random(n: usize, rng: &mut ChaCha8Rng) -> Vec<f32> {
        (0..n).map(|_| rng.random_range(-1.0..1.0)).collect()
    }

    /// `mlp`'s parameter gradients taken out of `grads`, in the host layout.
    fn burn_gradients(mlp: &Mlp, grads: &mut burn::tensor::Gradients) -> Vec<f32> {
        flat_grads(mlp, grads)
            .into_iter()
            .flat_map(|g| to_vec(g.expect("every parameter has a gradient")))
            .collect()
    }

    /// Largest `|a - b|` over the largest `|b|` (at least 1).
    fn relative_gap(a: &[f32], b: &[f32]) -> f32 {
        assert_eq!(a.len(), b.len());
        let scale = b.iter().fold(1.0_f32, |m, v| m.max(v.abs()));
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max)
            / scale
    }

    /// Output, parameter gradients and input gradients of `L = sum(y * dy)` for a random
    /// batch through an `Mlp` drawn from `seed`: Burn's autodiff beside the host path.
    fn compare(widths: &[usize], activation: Activation, batch: usize, seed: u64) {
        let device = device();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (input, output) = (widths[0], widths[widths.len() - 1]);
        let hidden = &widths[1..widths.len() - 1];
        let mlp = Mlp::new(input, hidden, output, activation, &mut rng, &device);
        let x = random(batch * input, &mut rng);
        let dy = random(batch * output, &mut rng);

        let x_t = Tensor::<2>::from_data(TensorData::new(x.clone(), [batch, input]), &device)
            .require_grad();
        let y_t = mlp.forward(x_t.clone());
        let dy_t = Tensor::<2>::from_data(TensorData::new(dy.clone(), [batch, output]), &device);
        let mut grads = (y_t.clone() * dy_t).sum().backward();
        let burn_dx = to_vec(x_t.grad(&grads).unwrap());
        let burn_grads = burn_gradients(&mlp, &mut grads);
        let burn_y = to_vec(y_t.inner());

        let host = HostMlp::from_mlp(&mlp).unwrap();
        assert_eq!(host.widths(), widths);
        let mut tape = MlpTape::default();
        let y = host.forward(&x, &mut tape).to_vec();
        let mut g = vec![0.0; host.params().len()];
        let mut dx = vec![0.0; batch * input];
        host.backward(&mut tape, &dy, Some(&mut g), Some(&mut dx));
        let what = format!("{widths:?} {activation:?} batch {batch}");
        assert!(relative_gap(&y, &burn_y) < 1e-5, "output of {what}");
        assert!(
            relative_gap(&g, &burn_grads) < 1e-5,
            "parameter gradients of {what}"
        );
        assert!(
            relative_gap(&dx, &burn_dx) < 1e-5,
            "input gradients of {what}"
        );

        // A second backward adds to the gradients; without `dx` the parameters' are the
        // same, and without parameter gradients `dx` is.
        let mut twice = g.clone();
        host.backward(&mut tape, &dy, Some(&mut twice), None);
        let doubled: Vec<f32> = g.iter().map(|v| 2.0 * v).collect();
        assert!(
            relative_gap(&twice, &doubled) < 1e-6,
            "accumulation of {what}"
        );
        let mut dx_alone = vec![0.0; batch * input];
        host.backward(&mut tape, &dy, None, Some(&mut dx_alone));
        assert_eq!(dx_alone, dx, "input gradients alone of {what}");
    }

    #[test]
    fn gradients_match_burns_on_the_configs_small_layer_shapes() {
        // SAC's actor (mean and log-std of 8 actions) and critic (observation and
        // action in), TD3's actor, PPO's tanh policy and value: 64x64 and 256x256.
        for hidden in [64, 256] {
            let relu = Activation::Relu;
            compare(&[38, hidden, hidden, 16], relu, 256, 1);
            compare(&[46, hidden, hidden, 1], relu, 256, 2);
            compare(&[38, hidden, hidden, 8], relu, 256, 3);
            compare(&[38, hidden, hidden, 8], Activation::Tanh, 64, 4);
            compare(&[38, hidden, hidden, 1], Activation::Tanh, 64, 5);
        }
        // Odd sizes and a single row.
        compare(&[3, 5, 7, 2], Activation::Relu, 1, 6);
        compare(&[7, 1], Activation::Tanh, 9, 7);
    }

    #[test]
    fn gradients_match_burns_on_the_papers_3000_wide_layers() {
        // The 7x3000 configs' layer shapes: 38 or 46 in, 3000 x 3000 inside, 16 or 1 out.
        compare(&[46, 3000, 3000, 16], Activation::Relu, 3, 8);
        compare(&[38, 3000, 1], Activation::Relu, 3, 9);
    }

    #[test]
    fn an_adam_step_on_the_flat_buffer_is_the_modules_step() {
        use crate::optim::{Adam, AdamConfig};
        use crate::snapshot::Snapshot;
        let device = device();
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let mut mlp = Mlp::new(5, &[8, 8], 3, Activation::Relu, &mut rng, &device);
        let mut host = HostMlp::from_mlp(&mlp).unwrap();
        let config = AdamConfig {
            max_grad_norm: Some(0.5),
            ..AdamConfig::default()
        };
        let mut module_adam = Adam::new(config.clone());
        let mut flat_adam = Adam::new(config);
        let dir = std::env::temp_dir().join(format!("host-mlp-adam-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for step in 0..4 {
            let x = random(10 * 5, &mut rng);
            // The same loss twice (deterministic): one gradient for each optimiser.
            let loss = |mlp: &Mlp| {
                let x = Tensor::<2>::from_data(TensorData::new(x.clone(), [10, 5]), &device);
                mlp.forward(x).square().sum().backward()
            };
            let g = burn_gradients(&mlp, &mut loss(&mlp));
            let mut grads = loss(&mlp);
            let module_report = module_adam.step_in_place(&mut mlp, &mut grads, 1e-2);
            let flat_report = flat_adam.step_flat(&mut [host.params_mut()], &g, 1e-2);
            assert_eq!(flat_report.applied.read(), 1.0);
            let norms = (module_report.grad_norm.read(), flat_report.grad_norm.read());
            assert!((norms.0 - norms.1).abs() <= 1e-6 * norms.0, "{norms:?}");
            let module_params = HostMlp::from_mlp(&mlp).unwrap();
            let gap = relative_gap(host.params(), module_params.params());
            assert!(gap < 1e-6, "step {step}: {gap}");
            if step == 1 {
                // Through a snapshot file, as a resumed run takes it.
                let file = dir.join("adam.snap");
                let mut snap = Snapshot::new();
                flat_adam.save_state(&mut snap, "adam");
                snap.write(&file).unwrap();
                flat_adam = Adam::new(flat_adam.config().clone());
                flat_adam
                    .load_state(&Snapshot::read(&file).unwrap(), "adam", &device)
                    .unwrap();
                assert_eq!(flat_adam.steps(), 2);
            }
        }
        // A gradient that is not finite changes nothing.
        let before = host.clone();
        let mut bad = vec![0.0; host.params().len()];
        bad[3] = f32::NAN;
        let report = flat_adam.step_flat(&mut [host.params_mut()], &bad, 1e-2);
        assert_eq!(report.applied.read(), 0.0);
        assert_eq!((host, flat_adam.steps()), (before, 4));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn parameters_round_trip_through_an_mlp_and_bad_shapes_are_refused() {
        let device = device();
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let a = Mlp::new(4, &[6], 2, Activation::Relu, &mut rng, &device);
        let b = Mlp::new(4, &[6], 2, Activation::Relu, &mut rng, &device);
        let host_a = HostMlp::from_mlp(&a).unwrap();
        let b = host_a.write_to(b).unwrap();
        assert_eq!(HostMlp::from_mlp(&b).unwrap(), host_a);

        let wider = Mlp::new(4, &[7], 2, Activation::Relu, &mut rng, &device);
        assert!(host_a.write_to(wider).unwrap_err().contains("[4, 7, 2]"));
        let normed = Mlp::with_layer_norm(4, &[6], 2, Activation::Relu, true, &mut rng, &device);
        assert!(
            HostMlp::from_mlp(&normed)
                .unwrap_err()
                .contains("layer normalisation")
        );
        let err = HostMlp::new(vec![4, 6, 2], Activation::Relu, vec![0.0; 3]).unwrap_err();
        assert!(err.contains("take 44"), "{err}");
        assert!(HostMlp::new(vec![4], Activation::Relu, vec![]).is_err());
    }
}
