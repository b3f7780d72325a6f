//! The learner a run configuration asks for, on the device of its backend.

use crate::config::{AlgoConfig, RunConfig};
use foosball_algos::{Agent, FourierFeatures, Normalized, Ppo, Sac, Td3};
use foosball_env::layout;
use foosball_env::seeding::{LEARNER, derive_seed};
use foosball_env::{ObservationConfig, ObservationKind};
use foosball_nets::{Backend, BackendError, Device, ObsShape};
use std::path::Path;

/// Why a validated config's networks compute on the host path.
const VALIDATED: &str = "RunConfig::validate admits only what the host path computes";

/// The agent `config` asks for, its networks drawn from the learner stream; its input is
/// the observation `config.env` gives (38 state values, or an image through a CNN). Where
/// [`RunConfig::computes_on_host`] the same networks compute on the host MLP path (a
/// validated config). Under `[normalize]` the learner sees normalised observations and
/// rewards ([`Normalized`]); under `[fourier]` its networks read the Fourier features of
/// the (normalised) observation ([`FourierFeatures`]).
pub fn build_agent(config: &RunConfig, device: &Device) -> Box<dyn Agent + Send> {
    let learner = match (&config.fourier, obs_shape(&config.env.observation)) {
        (Some(f), ObsShape::Vector(width)) => {
            let inner = build_learner(config, ObsShape::Vector(f.width(width)), device);
            Box::new(FourierFeatures::new(inner, f.clone(), width))
        }
        (_, shape) => build_learner(config, shape, device),
    };
    match &config.normalize {
        Some(n) => Box::new(Normalized::new(learner, n.clone())),
        None => learner,
    }
}

/// The algorithm's learner alone, without normalisation, its networks reading `o`.
fn build_learner(config: &RunConfig, o: ObsShape, device: &Device) -> Box<dyn Agent + Send> {
    let seed = derive_seed(config.protocol.seed, LEARNER, 0);
    let a = layout::ACTION_DIM;
    let on_host = config.computes_on_host();
    match &config.algorithm {
        AlgoConfig::Ppo(c) => {
            let mut agent = Ppo::new(o, a, c.clone(), seed, device);
            if on_host {
                agent.on_host_path().expect(VALIDATED);
            }
            Box::new(agent)
        }
        AlgoConfig::Sac(c) => {
            let mut agent = Sac::agent(o, a, c.clone(), seed, device);
            if on_host {
                agent.learner_mut().on_host_path().expect(VALIDATED);
            }
            Box::new(agent)
        }
        AlgoConfig::Td3(c) => {
            let mut agent = Td3::agent(o, a, c.clone(), seed, device);
            if on_host {
                agent.learner_mut().on_host_path().expect(VALIDATED);
            }
            Box::new(agent)
        }
    }
}

/// The networks' view of the observation `observation` configures.
pub fn obs_shape(observation: &ObservationConfig) -> ObsShape {
    match observation.kind {
        ObservationKind::State => ObsShape::Vector(observation.dim()),
        ObservationKind::Image => ObsShape::Image {
            channels: observation.channels(),
            height: observation.height as usize,
            width: observation.width as usize,
        },
    }
}

/// The device of the configured backend (the default CPU backend when unset).
pub fn device(config: &RunConfig) -> Result<Device, BackendError> {
    let backend = match config.protocol.backend {
        Some(b) => b,
        None => Backend::default_cpu()?,
    };
    backend.device()
}

/// The agent `config` asks for with the networks saved in `networks` (a run's `best/` or
/// `last/`), on its backend's device; an error names the folder.
pub fn load_agent(config: &RunConfig, networks: &Path) -> Result<Box<dyn Agent + Send>, String> {
    let device = device(config).map_err(|e| e.to_string())?;
    let mut agent = build_agent(config, &device);
    agent
        .load(networks)
        .map_err(|e| format!("{}: {e}", networks.display()))?;
    Ok(agent)
}
