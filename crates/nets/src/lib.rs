//! Burn networks for foosball-rl: the MLP, the image encoder (NatureCNN) and the
//! actor/critic heads of PPO, SAC and TD3, the MLP on host memory with its backward pass
//! written out (the small-network path, [`host_mlp`], with the three actors, the twin
//! critics on it: [`host_actor`], [`host_critic`]),
//! the action distributions, parameter-wise utilities (polyak averaging, flat and
//! own-rank views), Adam with PyTorch's epsilon and global-norm gradient clipping
//! (computed on the device on GPUs: no host reads in a step), counted host reads and
//! device-resident scalars, backend selection, and files for networks (Burn records)
//! and the rest of the training state (snapshots).
//!
//! Tensors are row-major batches: observations `[batch, obs_dim]`, actions
//! `[batch, action_dim]`, values and log-probabilities `[batch]`. Parameters are drawn
//! from the caller's seeded RNG (PyTorch's default `nn.Linear` law), never from a
//! backend's global RNG, so a seed fixes a network whatever the backend or thread count.

pub mod actor;
pub mod any_rank;
pub mod atomic_file;
pub mod backend;
pub mod cnn;
pub mod critic;
pub mod distributions;
pub mod host;
pub mod host_actor;
pub mod host_critic;
pub mod host_mlp;
pub mod init;
pub mod mlp;
pub mod optim;
pub mod params;
pub mod scalar;
pub mod snapshot;
pub mod store;

pub use actor::{DeterministicActor, GaussianPolicy, SquashedGaussianActor};
pub use backend::{Backend, BackendError};
pub use burn;
pub use burn::tensor::{Device, Tensor, TensorData};
pub use cnn::{CnnConfig, ConvLayer, Encoder, ObsShape};
pub use critic::{QNetwork, TwinQ, ValueCritic};
pub use host_actor::{HostDeterministic, HostGaussianPolicy, HostSquashedGaussian};
pub use host_critic::HostTwinQ;
pub use host_mlp::{HostMlp, MlpTape};
pub use init::NetInit;
pub use mlp::{Activation, Mlp};
pub use optim::{Adam, AdamConfig, StepReport};
pub use params::polyak_update;
pub use scalar::Scalar;
pub use snapshot::{Snapshot, SnapshotError};
