//! Policies in ONNX, the format Stable-Baselines3 and PyTorch users export to: a run's
//! deterministic policy written as one graph from the table's 38 raw state values to its
//! 8 actions ([`export`], [`graph`]: the hidden black rods, observation normalisation and
//! Fourier features folded in), and any such file played in pure Rust by tract ([`runtime`]),
//! wherever a run directory is accepted.
//!
//! The file's contract, whoever wrote it: input 0 is `[batch, 38]` f32 (the table's
//! state observation in its `ball_frame`), output 0 is `[batch, 8]` f32 (slide and turn of
//! the goalie, defence, midfield and attack rods, in the table's `action_map`; values
//! outside `[-1, 1]` are clamped by the table). A file written by `export` also carries
//! the run's whole configuration under the metadata key [`CONFIG_KEY`], so that the
//! players check it fits the table as they check a run and test it on the run's table
//! and seeds.

pub mod export;
pub mod graph;
pub mod runtime;

/// The metadata key under which `export` stores the run's configuration (its
/// `config.toml`).
pub const CONFIG_KEY: &str = "foosball_rl.run_config";
/// The metadata key under which `export` names the networks it wrote
/// (`RUN@best|last`).
pub const SOURCE_KEY: &str = "foosball_rl.source";
/// The metadata key under which `export` stores the commit of the binary that wrote it.
pub const COMMIT_KEY: &str = "foosball_rl.commit";
