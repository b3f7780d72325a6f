//! Moving row-major host batches to and from tensors, and host-drawn noise.

use foosball_nets::host::to_vec;
use foosball_nets::{Device, Scalar, Tensor, TensorData};
use rand::Rng;
use rand_distr::StandardNormal;

/// The rows `rows` of the row-major `src` (`width` values a row), in that order:
/// `[rows.len(), width]`.
pub fn gather_rows(src: &[f32], width: usize, rows: &[usize]) -> Vec<f32> {
    rows.iter()
        .flat_map(|&i| src[i * width..(i + 1) * width].iter().copied())
        .collect()
}

/// `[data.len() / cols, cols]` tensor on `device`.
pub fn matrix(data: &[f32], cols: usize, device: &Device) -> Tensor<2> {
    Tensor::from_data(
        TensorData::new(data.to_vec(), [data.len() / cols, cols]),
        device,
    )
}

/// `[data.len()]` tensor on `device`.
pub fn vector(data: &[f32], device: &Device) -> Tensor<1> {
    Tensor::from_data(TensorData::new(data.to_vec(), [data.len()]), device)
}

/// The tensor's values, row-major (one counted host read).
pub fn host<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    to_vec(t)
}

/// The mean of the tensor's values (read at once on a CPU backend, kept on a GPU).
pub fn mean(t: Tensor<1>) -> Scalar {
    Scalar::of(t.mean())
}

/// `rows * cols` standard-normal draws from `rng`, row-major.
pub fn standard_normal(rows: usize, cols: usize, rng: &mut impl Rng) -> Vec<f32> {
    (0..rows * cols)
        .map(|_| rng.sample(StandardNormal))
        .collect()
}
