//! The learner a run configuration asks for, on the device of its backend.

use crate::config::{AlgoConfig, RunConfig};
use crate::train::TrainError;
use foosball_algos::{Agent, Ppo, Sac, Td3};
use foosball_env::layout;
use foosball_env::seeding::{LEARNER, derive_seed};
use foosball_nets::{Backend, Device};

/// The agent `config` asks for, its networks drawn from the learner stream; its input is
/// the observation `config.env` gives (38 state values, or an image's pixels flattened).
pub fn build_agent(config: &RunConfig, device: &Device) -> Box<dyn Agent + Send> {
    let seed = derive_seed(config.protocol.seed, LEARNER, 0);
    let (o, a) = (config.env.observation.dim(), layout::ACTION_DIM);
    match &config.algorithm {
        AlgoConfig::Ppo(c) => Box::new(Ppo::new(o, a, c.clone(), seed, device)),
        AlgoConfig::Sac(c) => Box::new(Sac::agent(o, a, c.clone(), seed, device)),
        AlgoConfig::Td3(c) => Box::new(Td3::agent(o, a, c.clone(), seed, device)),
    }
}

/// The device of the configured backend (the default CPU backend when unset).
pub fn device(config: &RunConfig) -> Result<Device, TrainError> {
    let backend = match config.protocol.backend {
        Some(b) => b,
        None => Backend::default_cpu()?,
    };
    Ok(backend.device()?)
}
