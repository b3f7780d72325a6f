//! Which Burn backend runs the networks, chosen at run time among those compiled in.

use burn::tensor::Device;
use std::fmt;
use std::str::FromStr;

/// A Burn execution backend. Each variant exists at run time only when its cargo
/// feature is compiled in; [`Backend::device`] says so otherwise.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// burn-flex: pure-Rust CPU backend (feature `flex`, the default; measured fastest on CPU).
    Flex,
    /// burn-ndarray: the older CPU backend (feature `ndarray`).
    Ndarray,
    /// wgpu: Vulkan/Metal/DX12 GPUs, the API and shader compiler settled at run time
    /// (feature `wgpu`).
    Wgpu,
    /// wgpu pinned to Vulkan with the SPIR-V compiler (feature `vulkan`).
    Vulkan,
    /// CUDA GPUs (feature `cuda`).
    Cuda,
    /// The host MLP path ([`crate::host_mlp`]): small networks in host memory with their
    /// backward passes written out, on one thread; vector observations (PPO, SAC and
    /// TD3). Its device is the default CPU backend's, where the networks are made, saved
    /// and read.
    Host,
    /// The host path where it computes the run's networks and they are small, the
    /// default CPU backend otherwise: the run's configuration decides (the root
    /// package's `RunConfig::computes_on_host`). Its device is the default CPU backend's.
    Auto,
}

/// A backend that is unknown or not compiled into this binary.
#[derive(Debug, thiserror::Error)]
pub enum BackendError {
    /// The name is not one of `flex`, `ndarray`, `wgpu`, `vulkan`, `cuda`, `host`, `auto`.
    #[error("unknown backend `{0}` (expected flex, ndarray, wgpu, vulkan, cuda, host or auto)")]
    Unknown(String),
    /// The backend exists but this binary was built without its cargo feature.
    #[error("backend `{0}` is not compiled in: rebuild with `--features {0}`")]
    NotCompiled(Backend),
}

impl Backend {
    /// All backends.
    pub const ALL: [Backend; 7] = [
        Backend::Cuda,
        Backend::Vulkan,
        Backend::Wgpu,
        Backend::Flex,
        Backend::Ndarray,
        Backend::Host,
        Backend::Auto,
    ];

    /// The backend's name, as in configs and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Flex => "flex",
            Backend::Ndarray => "ndarray",
            Backend::Wgpu => "wgpu",
            Backend::Vulkan => "vulkan",
            Backend::Cuda => "cuda",
            Backend::Host => "host",
            Backend::Auto => "auto",
        }
    }

    /// Whether this binary has the backend's cargo feature.
    pub fn is_compiled(self) -> bool {
        match self {
            Backend::Flex => cfg!(feature = "flex"),
            Backend::Ndarray => cfg!(feature = "ndarray"),
            Backend::Wgpu => cfg!(feature = "wgpu"),
            Backend::Vulkan => cfg!(feature = "vulkan"),
            Backend::Cuda => cfg!(feature = "cuda"),
            Backend::Host | Backend::Auto => Backend::default_cpu().is_ok(),
        }
    }

    /// The default CPU backend: flex when compiled in, else ndarray.
    pub fn default_cpu() -> Result<Backend, BackendError> {
        [Backend::Flex, Backend::Ndarray]
            .into_iter()
            .find(|b| b.is_compiled())
            .ok_or(BackendError::NotCompiled(Backend::Flex))
    }

    /// The backend's first device, with autodiff enabled.
    pub fn device(self) -> Result<Device, BackendError> {
        let device = match self {
            #[cfg(feature = "flex")]
            Backend::Flex => Device::flex(),
            // Deprecated upstream in favour of flex; kept because the design names it.
            #[cfg(feature = "ndarray")]
            #[allow(deprecated)]
            Backend::Ndarray => Device::ndarray(),
            #[cfg(feature = "wgpu")]
            Backend::Wgpu => Device::wgpu(Default::default()),
            #[cfg(feature = "vulkan")]
            Backend::Vulkan => Device::vulkan(Default::default()),
            #[cfg(feature = "cuda")]
            Backend::Cuda => Device::cuda(0),
            Backend::Host | Backend::Auto => return Backend::default_cpu()?.device(),
            #[allow(unreachable_patterns)]
            other => return Err(BackendError::NotCompiled(other)),
        };
        Ok(device.autodiff())
    }
}

impl fmt::Display for Backend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Backend {
    type Err = BackendError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Backend::ALL
            .into_iter()
            .find(|b| b.name() == s)
            .ok_or_else(|| BackendError::Unknown(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_errors() {
        for b in Backend::ALL {
            assert_eq!(b.name().parse::<Backend>().unwrap(), b);
        }
        let err = "tpu".parse::<Backend>().unwrap_err();
        assert!(err.to_string().contains("tpu"));
    }

    #[test]
    fn the_default_cpu_backend_gives_an_autodiff_device() {
        let device = Backend::default_cpu().unwrap().device().unwrap();
        assert!(device.is_autodiff());
    }
}
