//! The arithmetic of a minibatch's losses and their gradients, written once for both
//! network paths: on a Burn device ([`DeviceRows`], tensors that stay there, so a GPU
//! step reads nothing back) and in host memory ([`HostRows`], plain loops beside the
//! host MLP path of `foosball_nets::host_mlp`).
//!
//! Shapes: per-row values `V` are `[batch]`, or `[1]` broadcast over the batch (a mean,
//! the temperature); matrices `M` are row-major `[batch, cols]`.

use crate::tensors::{matrix, vector};
use foosball_nets::{Device, Scalar, Tensor};

/// Element-wise arithmetic on per-row values and the few matrix operations the losses
/// need. Binary operations broadcast a `[1]` operand over the other's rows.
pub trait Rows {
    /// Per-row values, `[batch]` or `[1]`.
    type V: Clone;
    /// A row-major matrix, `[batch, cols]`.
    type M: Clone;

    /// `[data.len()]` values.
    fn vector(&self, data: &[f32]) -> Self::V;
    /// `[data.len() / cols, cols]`, row-major.
    fn matrix(&self, data: &[f32], cols: usize) -> Self::M;
    /// `a + b`.
    fn add(&self, a: &Self::V, b: &Self::V) -> Self::V;
    /// `a - b`.
    fn sub(&self, a: &Self::V, b: &Self::V) -> Self::V;
    /// `a * b`.
    fn mul(&self, a: &Self::V, b: &Self::V) -> Self::V;
    /// `a / b`.
    fn div(&self, a: &Self::V, b: &Self::V) -> Self::V;
    /// `a * scale + shift`.
    fn affine(&self, a: &Self::V, scale: f32, shift: f32) -> Self::V;
    /// `min(a, b)`.
    fn min(&self, a: &Self::V, b: &Self::V) -> Self::V;
    /// `max(a, floor)`.
    fn max_scalar(&self, a: &Self::V, floor: f32) -> Self::V;
    /// `clamp(a, lo, hi)`.
    fn clamp(&self, a: &Self::V, lo: f32, hi: f32) -> Self::V;
    /// 1 where `a <= b`, else 0.
    fn le(&self, a: &Self::V, b: &Self::V) -> Self::V;
    /// `|a|`.
    fn abs(&self, a: &Self::V) -> Self::V;
    /// `a^2`.
    fn square(&self, a: &Self::V) -> Self::V;
    /// `exp(a)`.
    fn exp(&self, a: &Self::V) -> Self::V;
    /// The mean over the rows, `[1]`.
    fn mean(&self, a: &Self::V) -> Self::V;
    /// A `[1]` value as a metric (read at once on the host, kept on a GPU).
    fn scalar(&self, a: &Self::V) -> Scalar;
    /// `m`'s rows `start..start + len`.
    fn rows(&self, m: &Self::M, start: usize, len: usize) -> Self::M;
    /// `a - b`, element-wise.
    fn sub_matrix(&self, a: &Self::M, b: &Self::M) -> Self::M;
    /// `m * scale`, element-wise.
    fn scale_matrix(&self, m: &Self::M, scale: f32) -> Self::M;
    /// `a + b`, element-wise.
    fn add_matrix(&self, a: &Self::M, b: &Self::M) -> Self::M;
    /// `clamp(m, lo, hi)`, element-wise.
    fn clamp_matrix(&self, m: &Self::M, lo: f32, hi: f32) -> Self::M;
    /// The mean of `m`'s squared elements, `[1]`.
    fn mean_square(&self, m: &Self::M) -> Self::V;
}

/// The one-step Bellman target `r + gamma (1 - done) next`, `[batch]`.
pub fn bellman<R: Rows>(r: &R, rewards: &R::V, dones: &R::V, next: &R::V, gamma: f32) -> R::V {
    r.add(rewards, &r.mul(&r.affine(dones, -gamma, gamma), next))
}

/// Tensors on a Burn device without autodiff (the networks keep their own graphs).
#[derive(Clone, Debug)]
pub struct DeviceRows {
    /// Where the values live.
    pub device: Device,
}

impl Rows for DeviceRows {
    type V = Tensor<1>;
    type M = Tensor<2>;

    fn vector(&self, data: &[f32]) -> Tensor<1> {
        vector(data, &self.device)
    }
    fn matrix(&self, data: &[f32], cols: usize) -> Tensor<2> {
        matrix(data, cols, &self.device)
    }
    fn add(&self, a: &Tensor<1>, b: &Tensor<1>) -> Tensor<1> {
        a.clone() + b.clone()
    }
    fn sub(&self, a: &Tensor<1>, b: &Tensor<1>) -> Tensor<1> {
        a.clone() - b.clone()
    }
    fn mul(&self, a: &Tensor<1>, b: &Tensor<1>) -> Tensor<1> {
        a.clone() * b.clone()
    }
    fn div(&self, a: &Tensor<1>, b: &Tensor<1>) -> Tensor<1> {
        a.clone() / b.clone()
    }
    fn affine(&self, a: &Tensor<1>, scale: f32, shift: f32) -> Tensor<1> {
        a.clone().mul_scalar(scale).add_scalar(shift)
    }
    fn min(&self, a: &Tensor<1>, b: &Tensor<1>) -> Tensor<1> {
        a.clone().min_pair(b.clone())
    }
    fn max_scalar(&self, a: &Tensor<1>, floor: f32) -> Tensor<1> {
        a.clone().clamp_min(floor)
    }
    fn clamp(&self, a: &Tensor<1>, lo: f32, hi: f32) -> Tensor<1> {
        a.clone().clamp(lo, hi)
    }
    fn le(&self, a: &Tensor<1>, b: &Tensor<1>) -> Tensor<1> {
        a.clone().lower_equal(b.clone()).float()
    }
    fn abs(&self, a: &Tensor<1>) -> Tensor<1> {
        a.clone().abs()
    }
    fn square(&self, a: &Tensor<1>) -> Tensor<1> {
        a.clone().square()
    }
    fn exp(&self, a: &Tensor<1>) -> Tensor<1> {
        a.clone().exp()
    }
    fn mean(&self, a: &Tensor<1>) -> Tensor<1> {
        a.clone().mean()
    }
    fn scalar(&self, a: &Tensor<1>) -> Scalar {
        Scalar::of(a.clone())
    }
    fn rows(&self, m: &Tensor<2>, start: usize, len: usize) -> Tensor<2> {
        m.clone().narrow(0, start, len)
    }
    fn sub_matrix(&self, a: &Tensor<2>, b: &Tensor<2>) -> Tensor<2> {
        a.clone() - b.clone()
    }
    fn scale_matrix(&self, m: &Tensor<2>, scale: f32) -> Tensor<2> {
        m.clone().mul_scalar(scale)
    }
    fn add_matrix(&self, a: &Tensor<2>, b: &Tensor<2>) -> Tensor<2> {
        a.clone() + b.clone()
    }
    fn clamp_matrix(&self, m: &Tensor<2>, lo: f32, hi: f32) -> Tensor<2> {
        m.clone().clamp(lo, hi)
    }
    fn mean_square(&self, m: &Tensor<2>) -> Tensor<1> {
        m.clone().square().mean()
    }
}

/// A row-major matrix in host memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Matrix {
    /// `[rows, cols]`, row-major.
    pub data: Vec<f32>,
    /// Columns.
    pub cols: usize,
}

/// Plain `Vec<f32>` values and [`Matrix`] matrices in host memory.
#[derive(Clone, Copy, Debug, Default)]
pub struct HostRows;

/// `f(a_i, b_i)` over the rows, a `[1]` operand broadcast.
fn zip(a: &[f32], b: &[f32], f: impl Fn(f32, f32) -> f32) -> Vec<f32> {
    match (a.len(), b.len()) {
        (1, _) => b.iter().map(|&b| f(a[0], b)).collect(),
        (_, 1) => a.iter().map(|&a| f(a, b[0])).collect(),
        (n, m) => {
            assert_eq!(n, m, "per-row values of one batch");
            a.iter().zip(b).map(|(&a, &b)| f(a, b)).collect()
        }
    }
}

/// `f(a_i)` over the rows.
fn map(a: &[f32], f: impl Fn(f32) -> f32) -> Vec<f32> {
    a.iter().map(|&a| f(a)).collect()
}

impl Rows for HostRows {
    type V = Vec<f32>;
    type M = Matrix;

    fn vector(&self, data: &[f32]) -> Vec<f32> {
        data.to_vec()
    }
    fn matrix(&self, data: &[f32], cols: usize) -> Matrix {
        Matrix {
            data: data.to_vec(),
            cols,
        }
    }
    fn add(&self, a: &Vec<f32>, b: &Vec<f32>) -> Vec<f32> {
        zip(a, b, |a, b| a + b)
    }
    fn sub(&self, a: &Vec<f32>, b: &Vec<f32>) -> Vec<f32> {
        zip(a, b, |a, b| a - b)
    }
    fn mul(&self, a: &Vec<f32>, b: &Vec<f32>) -> Vec<f32> {
        zip(a, b, |a, b| a * b)
    }
    fn div(&self, a: &Vec<f32>, b: &Vec<f32>) -> Vec<f32> {
        zip(a, b, |a, b| a / b)
    }
    fn affine(&self, a: &Vec<f32>, scale: f32, shift: f32) -> Vec<f32> {
        map(a, |a| a * scale + shift)
    }
    fn min(&self, a: &Vec<f32>, b: &Vec<f32>) -> Vec<f32> {
        zip(a, b, f32::min)
    }
    fn max_scalar(&self, a: &Vec<f32>, floor: f32) -> Vec<f32> {
        map(a, |a| a.max(floor))
    }
    fn clamp(&self, a: &Vec<f32>, lo: f32, hi: f32) -> Vec<f32> {
        map(a, |a| a.clamp(lo, hi))
    }
    fn le(&self, a: &Vec<f32>, b: &Vec<f32>) -> Vec<f32> {
        zip(a, b, |a, b| f32::from(u8::from(a <= b)))
    }
    fn abs(&self, a: &Vec<f32>) -> Vec<f32> {
        map(a, f32::abs)
    }
    fn square(&self, a: &Vec<f32>) -> Vec<f32> {
        map(a, |a| a * a)
    }
    fn exp(&self, a: &Vec<f32>) -> Vec<f32> {
        map(a, f32::exp)
    }
    fn mean(&self, a: &Vec<f32>) -> Vec<f32> {
        vec![a.iter().sum::<f32>() / a.len() as f32]
    }
    fn scalar(&self, a: &Vec<f32>) -> Scalar {
        Scalar::Host(f64::from(a[0]))
    }
    fn rows(&self, m: &Matrix, start: usize, len: usize) -> Matrix {
        Matrix {
            data: m.data[start * m.cols..(start + len) * m.cols].to_vec(),
            cols: m.cols,
        }
    }
    fn sub_matrix(&self, a: &Matrix, b: &Matrix) -> Matrix {
        Matrix {
            data: zip(&a.data, &b.data, |a, b| a - b),
            cols: a.cols,
        }
    }
    fn scale_matrix(&self, m: &Matrix, scale: f32) -> Matrix {
        Matrix {
            data: map(&m.data, |x| x * scale),
            cols: m.cols,
        }
    }
    fn add_matrix(&self, a: &Matrix, b: &Matrix) -> Matrix {
        Matrix {
            data: zip(&a.data, &b.data, |a, b| a + b),
            cols: a.cols,
        }
    }
    fn clamp_matrix(&self, m: &Matrix, lo: f32, hi: f32) -> Matrix {
        Matrix {
            data: map(&m.data, |x| x.clamp(lo, hi)),
            cols: m.cols,
        }
    }
    fn mean_square(&self, m: &Matrix) -> Vec<f32> {
        self.mean(&self.square(&m.data))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tensors::host;
    use foosball_nets::Backend;

    /// Each operation on both paths, from the same inputs, to within f32 rounding.
    #[test]
    fn the_host_and_device_arithmetic_agree_and_broadcast_one_value() {
        let device = Backend::default_cpu()
            .unwrap()
            .device()
            .unwrap()
            .without_autodiff();
        let d = DeviceRows { device };
        let h = HostRows;
        let (a, b, one) = ([0.5, -1.5, 2.0, 0.0], [1.0, -2.0, 2.0, 3.0], [0.25]);
        let check = |on_host: Vec<f32>, on_device: Tensor<1>| {
            let on_device = host(on_device);
            assert_eq!(on_host.len(), on_device.len());
            for (x, y) in on_host.iter().zip(&on_device) {
                assert!(
                    (x - y).abs() <= 1e-6 * x.abs().max(1.0),
                    "{on_host:?} {on_device:?}"
                );
            }
        };
        let (ha, hb, h1) = (h.vector(&a), h.vector(&b), h.vector(&one));
        let (da, db, d1) = (d.vector(&a), d.vector(&b), d.vector(&one));
        check(h.add(&ha, &hb), d.add(&da, &db));
        check(h.sub(&ha, &h1), d.sub(&da, &d1));
        check(h.mul(&h1, &hb), d.mul(&d1, &db));
        check(h.div(&ha, &hb), d.div(&da, &db));
        check(h.affine(&ha, -2.0, 0.5), d.affine(&da, -2.0, 0.5));
        check(h.min(&ha, &hb), d.min(&da, &db));
        check(h.max_scalar(&ha, 0.1), d.max_scalar(&da, 0.1));
        check(h.clamp(&ha, -1.0, 1.0), d.clamp(&da, -1.0, 1.0));
        check(h.le(&ha, &hb), d.le(&da, &db));
        check(h.abs(&ha), d.abs(&da));
        check(h.square(&ha), d.square(&da));
        check(h.exp(&ha), d.exp(&da));
        check(h.mean(&ha), d.mean(&da));
        check(
            bellman(&h, &ha, &h.vector(&[0.0, 1.0, 0.0, 1.0]), &hb, 0.9),
            bellman(&d, &da, &d.vector(&[0.0, 1.0, 0.0, 1.0]), &db, 0.9),
        );
        assert_eq!(h.le(&ha, &hb), vec![1.0, 0.0, 1.0, 1.0]);
        let (hm, dm) = (h.matrix(&a, 2), d.matrix(&a, 2));
        let (hn, dn) = (h.matrix(&b, 2), d.matrix(&b, 2));
        assert_eq!(h.rows(&hm, 1, 1).data, vec![2.0, 0.0]);
        assert_eq!(host(d.rows(&dm, 1, 1)), vec![2.0, 0.0]);
        check(
            h.mean_square(&h.scale_matrix(&h.sub_matrix(&hm, &hn), 3.0)),
            d.mean_square(&d.scale_matrix(&d.sub_matrix(&dm, &dn), 3.0)),
        );
        let clamped = h.clamp_matrix(&h.add_matrix(&hm, &hn), -1.0, 1.5);
        assert_eq!(clamped.data, vec![1.5, -1.0, 1.5, 1.5]);
        assert_eq!(
            host(d.clamp_matrix(&d.add_matrix(&dm, &dn), -1.0, 1.5)),
            clamped.data
        );
    }
}
