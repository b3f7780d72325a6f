//! A float tensor whose rank is known at run time only, for per-parameter state kept
//! beside parameters of different ranks (Adam's moments, polyak's online values) at the
//! parameter's own shape.

use burn::tensor::{Device, Tensor};
use std::any::Any;

/// A float tensor of rank 1 to 4 (every parameter of the project's networks: biases,
/// linear weights, convolution kernels).
#[derive(Clone, Debug)]
pub enum AnyRank {
    /// Rank 1.
    R1(Tensor<1>),
    /// Rank 2.
    R2(Tensor<2>),
    /// Rank 3.
    R3(Tensor<3>),
    /// Rank 4.
    R4(Tensor<4>),
}

impl AnyRank {
    /// Wraps a tensor of rank `D` (1 to 4).
    ///
    /// # Panics
    /// For a rank above 4 (no network here has such a parameter).
    pub fn new<const D: usize>(tensor: Tensor<D>) -> Self {
        Self::from_any(Box::new(tensor))
            .unwrap_or_else(|| panic!("parameters of rank {D} are not supported (at most 4)"))
    }

    /// The tensor at rank `D` with shape `dims`: as it is when it has that rank (no
    /// reshape, so element-wise kernels that use it can fuse), else reshaped (a state
    /// restored flat from a checkpoint).
    pub fn into_rank<const D: usize>(self, dims: [usize; D]) -> Tensor<D> {
        let any: Box<dyn Any> = match self {
            Self::R1(t) => Box::new(t),
            Self::R2(t) => Box::new(t),
            Self::R3(t) => Box::new(t),
            Self::R4(t) => Box::new(t),
        };
        match any.downcast::<Tensor<D>>() {
            Ok(t) if t.dims() == dims => *t,
            Ok(t) => t.reshape(dims),
            Err(any) => Self::from_any(any)
                .expect("an AnyRank holds ranks 1 to 4")
                .flat()
                .reshape(dims),
        }
    }

    fn from_any(any: Box<dyn Any>) -> Option<Self> {
        let any = match any.downcast::<Tensor<1>>() {
            Ok(t) => return Some(Self::R1(*t)),
            Err(any) => any,
        };
        let any = match any.downcast::<Tensor<2>>() {
            Ok(t) => return Some(Self::R2(*t)),
            Err(any) => any,
        };
        let any = match any.downcast::<Tensor<3>>() {
            Ok(t) => return Some(Self::R3(*t)),
            Err(any) => any,
        };
        any.downcast::<Tensor<4>>().ok().map(|t| Self::R4(*t))
    }

    /// The values flattened to `[numel]`.
    pub fn flat(self) -> Tensor<1> {
        match self {
            Self::R1(t) => t,
            Self::R2(t) => t.flatten(0, 1),
            Self::R3(t) => t.flatten(0, 2),
            Self::R4(t) => t.flatten(0, 3),
        }
    }

    /// `sum(x^2)` over all elements, `[1]`.
    pub fn sum_squares(&self) -> Tensor<1> {
        match self {
            Self::R1(t) => t.clone().square().sum(),
            Self::R2(t) => t.clone().square().sum(),
            Self::R3(t) => t.clone().square().sum(),
            Self::R4(t) => t.clone().square().sum(),
        }
    }

    /// The device holding the tensor.
    pub fn device(&self) -> Device {
        match self {
            Self::R1(t) => t.device(),
            Self::R2(t) => t.device(),
            Self::R3(t) => t.device(),
            Self::R4(t) => t.device(),
        }
    }
}
