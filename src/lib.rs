//! foosball-rl: deep reinforcement learning on a simulated foosball table, in Rust.
//!
//! - [`env`]: the table (rapier3d), Pendulum, vectorised environments, seeding;
//! - [`nets`]: Burn networks, distributions, Adam;
//! - [`algos`]: PPO, SAC, TD3, buffers and the agent/rollout shape;
//! - [`agents`]: the learner a run configuration asks for, on its backend's device;
//! - [`animation`]: episodes as captioned animations (GIF, or MP4 through ffmpeg);
//! - [`budget`]: memory a run will need, checked before allocating;
//! - [`cli`]: what the command-line tools share;
//! - [`config`]: the run configuration (`configs/*.toml`);
//! - [`evaluation`]: the evaluation API: a policy's episodes on held-out seeds, played
//!   side by side, and the test files;
//! - [`font`]: the bundled font of charts and captions;
//! - [`metrics`]: the paper's test metrics with confidence intervals;
//! - [`player`]: who plays test episodes (a run's networks or a scripted policy);
//! - [`policy`]: scripted yellow policies (shooter, dribbler, zero, random);
//! - [`report`]: side-by-side tables and charts of several runs;
//! - [`run_dir`]: the files of a run, written atomically;
//! - [`run_log`]: training logs (CSV and TensorBoard);
//! - [`checkpoint`]: resumable checkpoints at epoch ends;
//! - [`stats`]: aggregates over seeds (mean, IQM, bootstrap intervals);
//! - [`sweep`]: algorithms x seeds into one directory, resumable;
//! - [`train`]: the training loop shared by the three algorithms.

pub mod agents;
pub mod animation;
pub mod budget;
pub mod checkpoint;
pub mod cli;
pub mod config;
pub mod evaluation;
pub mod font;
pub mod metrics;
pub mod player;
pub mod policy;
pub mod report;
pub mod run_dir;
pub mod run_log;
pub mod stats;
pub mod sweep;
pub mod train;

pub use foosball_algos as algos;
pub use foosball_env as env;
pub use foosball_nets as nets;
