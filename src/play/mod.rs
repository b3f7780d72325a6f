//! Playing episodes: who plays (a run's networks, a scripted policy, a policy from
//! outside), the episodes they
//! play on held-out seeds, the paper's test metrics over them, the recorded
//! trajectories and their animations.
//!
//! Imports run one way: `play` reads [`crate::config`], [`crate::agents`],
//! [`crate::plan`], [`crate::onnx`] and [`crate::files`], and nothing of [`crate::run`], [`crate::sweep`] or [`crate::report`].
//!
//! - [`metrics`]: the paper's test metrics with confidence intervals;
//! - [`trajectories`]: recorded episodes and `trajectories.bin`;
//! - [`evaluation`]: a policy's episodes on held-out seeds, played side by side, and the
//!   test files;
//! - [`scripted`]: scripted yellow policies (shooter, dribbler, zero, random, blocker, and the
//!   planner's ceiling);
//! - [`planned`]: the planner's test episodes and what its searches cost;
//! - [`player`]: who plays test episodes for `evaluate` and `render`;
//! - [`animation`]: episodes as captioned animations (GIF, or MP4 through ffmpeg);
//! - [`contestant`]: who plays one side of a two-sided match (networks, scripted, an ONNX
//!   file or a program);
//! - [`process`]: a policy in another program, spoken to in `act`'s line protocol;
//! - [`matches`]: two-sided matches to N goals, black driven by any contestant;
//! - [`flow`]: where a match's ball goes (time by rod, crossings towards goal, how points
//!   end).

pub mod animation;
pub mod contestant;
pub mod evaluation;
pub mod flow;
pub mod matches;
pub mod metrics;
pub mod planned;
pub mod player;
pub mod process;
pub mod scripted;
pub mod trajectories;
