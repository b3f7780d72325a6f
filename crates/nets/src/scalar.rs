//! One-element values (losses, norms, the temperature) that stay on the device until
//! they are read together.
//!
//! On a CPU backend a value is read at once (a read costs nothing there, and the host
//! arithmetic stays what it always was); on a GPU it stays a one-element tensor, so a
//! training step queues its work without waiting for the device, and a log window's
//! values come back in one transfer ([`Scalar::read_all`]).

use crate::host::{is_host, read, read_all};
use burn::tensor::{Tensor, TensorData};

/// A one-element value, on the host or still on the device.
#[derive(Clone, Debug)]
pub enum Scalar {
    /// Read already.
    Host(f64),
    /// A `[1]` tensor on a device.
    Device(Box<Tensor<1>>),
}

impl From<f64> for Scalar {
    fn from(x: f64) -> Self {
        Self::Host(x)
    }
}

impl Scalar {
    /// The value of a one-element tensor: read now on a host device, else kept on the
    /// device.
    pub fn of(t: Tensor<1>) -> Self {
        if is_host(&t.device()) {
            Self::Host(f64::from(first(read(t))))
        } else {
            Self::Device(Box::new(t))
        }
    }

    /// The mean of several values (`None` for none): on the host `((x1 + x2) + ...) / n`
    /// in f64; when any is on the device, the f32 mean there.
    pub fn mean(values: Vec<Scalar>) -> Option<Scalar> {
        let n = values.len();
        let device = values.iter().find_map(|v| match v {
            Self::Device(t) => Some(t.device()),
            Self::Host(_) => None,
        });
        let Some(device) = device else {
            let mut host = values.into_iter().map(|v| match v {
                Self::Host(x) => x,
                Self::Device(_) => unreachable!("no device values here"),
            });
            let first = host.next()?;
            return Some(Self::Host(host.fold(first, |s, x| s + x) / n as f64));
        };
        let tensors: Vec<Tensor<1>> = values
            .into_iter()
            .map(|v| match v {
                Self::Device(t) => *t,
                Self::Host(x) => Tensor::from_data(TensorData::new(vec![x as f32], [1]), &device),
            })
            .collect();
        Some(Self::Device(Box::new(Tensor::cat(tensors, 0).mean())))
    }

    /// Every value on the host, the device ones read in one transfer.
    pub fn read_all(values: Vec<Scalar>) -> Vec<f64> {
        let device: Vec<Tensor<1>> = values
            .iter()
            .filter_map(|v| match v {
                Self::Device(t) => Some(t.as_ref().clone()),
                Self::Host(_) => None,
            })
            .collect();
        let mut read = read_all(device).into_iter().map(first);
        values
            .into_iter()
            .map(|v| match v {
                Self::Host(x) => x,
                Self::Device(_) => f64::from(read.next().expect("one read per device value")),
            })
            .collect()
    }

    /// The value on the host (one read for a device value).
    pub fn read(self) -> f64 {
        Self::read_all(vec![self])[0]
    }
}

/// The first value of a one-element tensor's data.
fn first(data: TensorData) -> f32 {
    data.iter::<f32>().next().expect("a one-element tensor")
}
