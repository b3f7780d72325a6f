//! The learner a run configuration asks for, on the device of its backend.

use crate::config::{Algo, RunConfig};
use crate::train::TrainError;
use foosball_algos::{Agent, Ppo, Sac, Td3};
use foosball_env::layout;
use foosball_env::seeding::{LEARNER, derive_seed};
use foosball_nets::{Backend, Device};

/// The agent `config` asks for, its networks drawn from the learner stream.
pub fn build_agent(config: &RunConfig, device: &Device) -> Box<dyn Agent + Send> {
    let seed = derive_seed(config.protocol.seed, LEARNER, 0);
    let (o, a) = (layout::OBS_DIM, layout::ACTION_DIM);
    match config.algo {
        Algo::Ppo => Box::new(Ppo::new(
            o,
            a,
            config.ppo.clone().expect("filled"),
            seed,
            device,
        )),
        Algo::Sac => Box::new(Sac::agent(
            o,
            a,
            config.sac.clone().expect("filled"),
            seed,
            device,
        )),
        Algo::Td3 => Box::new(Td3::agent(
            o,
            a,
            config.td3.clone().expect("filled"),
            seed,
            device,
        )),
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
