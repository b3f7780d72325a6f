//! foosball-rl: deep reinforcement learning on a simulated foosball table, in Rust.
//!
//! The workspace's crates, re-exported:
//! - [`env`]: the table (rapier3d), Pendulum, vectorised environments, seeding;
//! - [`nets`]: Burn networks, distributions, Adam;
//! - [`algos`]: PPO, SAC, TD3, buffers and the agent/rollout shape.
//!
//! This package, in layers (a module imports only from the layers below it):
//! 1. [`config`] (the run configuration, `configs/*.toml`), [`agents`] (the learner a
//!    configuration asks for), [`files`] (run files written atomically), [`cli`] (what
//!    the command-line tools share), [`font`] (the bundled font of charts and captions),
//!    [`png`] (charts written atomically), [`provenance`] (the commit a binary was
//!    built from), [`plan`] (the planner: the simulator searched
//!    for each episode's best plan), [`onnx`] (policies written as ONNX and played by
//!    tract);
//! 2. [`play`]: who plays, episodes on held-out seeds, test metrics, trajectories,
//!    animations;
//! 3. [`self_play`]: the opponent pool of self-play training (snapshots, anchors,
//!    prioritised fictitious self-play);
//! 4. [`run`]: one training run (the loop, checkpoints, logs, budget);
//! 5. [`sweep`] (algorithms x seeds into one directory, resumable), [`report`]
//!    (side-by-side tables and charts of several runs) and [`league`] (round-robins of
//!    two-sided matches, ratings, the leaderboard).
//!
//! `tests/suite/architecture.rs` checks that no import runs back up.

pub mod agents;
pub mod cli;
pub mod config;
pub mod files;
pub mod font;
pub mod league;
pub mod onnx;
pub mod plan;
pub mod play;
pub mod png;
pub mod provenance;
pub mod report;
pub mod run;
pub mod self_play;
pub mod sweep;

pub use foosball_algos as algos;
pub use foosball_env as env;
pub use foosball_nets as nets;
