//! Planning with the simulator itself: an empirical ceiling of the task from given starts.
//!
//! - [`config`]: the search budget ([`PlannerConfig`], a `[planner]` TOML table);
//! - [`cem`]: the cross-entropy method over open-loop plans, each candidate valued by
//!   playing it on a table of the same config from the same seed, or one plan for many
//!   starts (`shared_starts`).
//!
//! Reads only the environment crate; [`crate::play`] plays its plans as test episodes.

pub mod cem;
pub mod config;

pub use cem::{Outcome, Plan, PlanStart, Search, SharedSearch, follow, search, search_shared};
pub use config::{Keep, Objective, PlannerConfig};
