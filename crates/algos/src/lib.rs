//! Learning algorithms for foosball-rl: PPO, SAC and TD3 with Stable-Baselines3's
//! definitions, the replay buffer SAC and TD3 share (`replay`; image planes stored once
//! each in `plane_store`), PPO's rollout buffer and GAE (`rollout_buffer`), the collector
//! that steps a VecEnv for any of them (`rollout`), demonstrations mixed into SAC's and
//! TD3's minibatches (`demonstrations`) and cloned beside PPO (`demo_cloning`), running normalisation of observations and rewards
//! around any learner (`normalize`, SB3's `VecNormalize`), Fourier features of the
//! observation around any learner (`fourier`), exploration noise correlated over an
//! episode's steps (`correlated_noise`: PPO's `noise_correlation`, TD3's
//! `action_noise_correlation`), PPO's self-imitation of its own past episodes
//! (`self_imitation`), PPO's cloning term towards a teacher's labels of its own states
//! (`kickstart`), the [`Agent`] shape through which one training loop
//! drives all three, and the deterministic policy as fixed steps for an exporter
//! (`policy_chain`).
//!
//! Each algorithm file states its update equations at the top (CleanRL style); the
//! networks and Adam live in `foosball-nets`, the environments in `foosball-env`.

pub mod agent;
pub mod config;
pub mod correlated_noise;
pub mod critics;
pub mod demo_cloning;
pub mod demonstrations;
pub mod fourier;
pub mod kickstart;
pub mod network_path;
pub mod normalize;
pub mod off_policy;
pub mod plane_store;
pub mod policy_chain;
pub mod ppo;
pub mod ppo_networks;
pub mod replay;
pub mod rollout;
pub mod rollout_buffer;
pub mod rows;
pub mod sac;
pub mod sac_networks;
pub mod schedule;
pub mod self_imitation;
pub mod td3;
pub mod td3_networks;
pub mod tensors;
#[cfg(test)]
mod test_support;

pub use agent::{ActMode, Agent, AgentError, Experience, Metrics};
pub use config::{ConfigError, NetConfig, OffPolicyConfig};
pub use demo_cloning::DemoCloningConfig;
pub use demonstrations::Demonstration;
pub use fourier::{FourierConfig, FourierFeatures};
pub use kickstart::KickstartConfig;
pub use normalize::{NormalizeConfig, Normalized};
pub use policy_chain::Step;
pub use ppo::{Ppo, PpoConfig};
pub use replay::{ReplayBatch, ReplayBuffer};
pub use rollout::{
    BatchPolicy, Collector, Episode, EpisodeLog, deterministic, play_episode, play_episodes,
    sampled,
};
pub use sac::{Sac, SacAgent, SacConfig};
pub use schedule::LrSchedule;
pub use td3::{Td3, Td3Agent, Td3Config};
