//! Reading tensors back to the host, counted, and host-memory fast paths for CPU
//! backends.
//!
//! Every read of tensor values in the project goes through [`read`] or [`read_all`]
//! (the architecture test keeps it so), which count them per thread: on a GPU each read
//! waits for the device's queue to drain, so a training step should make none
//! ([`reads`] lets tests assert it).
//!
//! On a CPU backend every tensor op is one pass over memory, so Adam written as tensor
//! ops makes about a dozen passes over each parameter. Here the flat values are taken to
//! a `Vec<f32>`, updated in one fused loop (split across rayon threads in fixed chunks,
//! element-wise, so the result does not depend on the thread count) and put back.

use burn::backend::DispatchDevice;
use burn::tensor::{Device, Tensor, TensorData, Transaction};
use rayon::prelude::*;
use std::cell::Cell;

thread_local! {
    static READS: Cell<u64> = const { Cell::new(0) };
}

/// Reads of tensor values made on this thread so far ([`read`] and [`read_all`] calls).
pub fn reads() -> u64 {
    READS.with(Cell::get)
}

fn count_read() {
    READS.with(|r| r.set(r.get() + 1));
}

/// The tensor's values on the host (one counted read; no copy on flex when nothing
/// else shares the tensor).
pub fn read<const D: usize>(t: Tensor<D>) -> TensorData {
    count_read();
    t.into_data()
}

/// Several tensors' values in one transfer (one counted read), in order.
pub fn read_all<const D: usize>(tensors: Vec<Tensor<D>>) -> Vec<TensorData> {
    if tensors.is_empty() {
        return Vec::new();
    }
    count_read();
    tensors
        .into_iter()
        .fold(Transaction::default(), Transaction::register)
        .execute()
}

/// Elements per parallel chunk; fixed so reductions add in the same order on any pool.
pub const CHUNK: usize = 1 << 15;

/// Whether `device` keeps tensors in host memory (flex, ndarray).
pub fn is_host(device: &Device) -> bool {
    let plain = device.clone().without_autodiff();
    match plain.as_dispatch() {
        #[cfg(feature = "flex")]
        DispatchDevice::Flex(_) => true,
        #[cfg(feature = "ndarray")]
        DispatchDevice::NdArray(_) => true,
        _ => false,
    }
}

/// The values of a flat tensor (no copy on flex when nothing else shares the tensor).
pub fn to_vec<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    read(t)
        .try_into_vec::<f32>()
        .expect("float parameters are f32")
}

/// A flat tensor's values as host data: read them with `as_slice::<f32>()`. No copy on
/// flex when nothing else shares the tensor.
pub fn host_data(t: Tensor<1>) -> TensorData {
    read(t)
}

/// `t` changed in place by `f` on its host values (flex hands its buffer over and takes it
/// back without copying when nothing else shares it).
pub fn update_in_place(t: Tensor<1>, f: impl FnOnce(&mut [f32])) -> Tensor<1> {
    let device = t.device();
    let mut data = read(t);
    f(data
        .as_mut_slice::<f32>()
        .expect("float parameters are f32"));
    Tensor::from_data(data, &device)
}

/// `sum(x^2)` in f64, chunk sums added in chunk order.
pub fn sum_squares(x: &[f32]) -> f64 {
    let partial: Vec<f64> = x
        .par_chunks(CHUNK)
        .map(|c| c.iter().map(|&v| f64::from(v) * f64::from(v)).sum())
        .collect();
    partial.iter().sum()
}

/// `target <- (1 - tau) target + tau online`, element-wise.
pub fn lerp_into(target: &mut [f32], online: &[f32], tau: f32) {
    target
        .par_chunks_mut(CHUNK)
        .zip(online.par_chunks(CHUNK))
        .for_each(|(t, o)| {
            for (t, o) in t.iter_mut().zip(o) {
                *t = *t * (1.0 - tau) + o * tau;
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reductions_do_not_depend_on_the_thread_count() {
        let x: Vec<f32> = (0..200_000)
            .map(|i| ((i * 7919) % 1000) as f32 * 1e-3)
            .collect();
        let on = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| sum_squares(&x))
        };
        assert_eq!(on(1).to_bits(), on(2).to_bits());
        assert_eq!(on(1).to_bits(), on(3).to_bits());
    }

    #[test]
    fn cpu_backends_are_host_devices() {
        assert!(is_host(
            &crate::Backend::default_cpu().unwrap().device().unwrap()
        ));
    }
}
