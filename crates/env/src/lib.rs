//! The foosball table and other environments for foosball-rl.
//!
//! - [`FoosballEnv`]: the ITSF Tornado T-3000 table in rapier3d (cm, kg, s), yellow (the
//!   agent) against a black [`Opponent`], Gymnasium-style ([`Env`]).
//! - [`Pendulum`]: Gymnasium's `Pendulum-v1`, exact, for validating learners; [`block`]:
//!   a one-step foosball sub-task seen as pixels, for validating image learners.
//! - [`VecEnv`]: many environments stepped in parallel with rayon, auto-reset,
//!   reproducible whatever the thread count.
//! - [`render`]: top-down RGB frames of a table state (Gymnasium's `rgb_array`);
//!   [`observation`]: the state or stacked frames of it as what the agent sees.
//! - [`scripted`]: hand-written shooter and dribbler, the yardsticks for learners;
//!   [`roster`]: the built-in opponents by name; [`spin`]: spinning rods counted;
//!   [`possession`]: ITSF's possession limits; [`starts`]: training episodes begun along
//!   recorded ones (a reverse curriculum).
//! - [`soft_contact`] and [`soft_stop`]: MuJoCo's soft constraints (the ball on the men,
//!   the bumpers on the walls); [`man_field`], [`man_octree`] and [`sdf_search`]: the
//!   reference man's distance field (its plugin's own octree, or sampled) and MuJoCo's
//!   contact search on it; [`carried_shape`]: a rod's colliders there, carrying its mass
//!   alone; [`servo`]: the rods' position servos.
//! - [`config`]: the table's settings and presets, refused by key ([`config_error`]);
//!   [`config_file`]: a TOML file and the files it `extends`, merged.
//! - [`geometry`] and [`layout`]: the table's numbers and the observation/action index
//!   table; [`seeding`]: how every random stream derives from one run seed;
//!   [`test_metrics`]: the paper's five test metrics with their intervals.
//!
//! Knows nothing of neural networks: observations and actions cross as flat `f32`.

pub mod block;
pub mod carried_shape;
pub mod config;
pub mod config_error;
pub mod config_file;
pub mod env;
pub mod foosball;
pub mod geometry;
pub mod layout;
pub mod man_field;
pub mod man_octree;
pub mod observation;
pub mod opponent;
pub mod pendulum;
pub mod possession;
pub mod render;
pub mod roster;
pub mod scripted;
pub mod sdf_search;
pub mod seeding;
pub mod servo;
pub mod soft_contact;
pub mod soft_stop;
pub mod spin;
pub mod starts;
pub mod table;
pub mod test_metrics;
pub mod vec_env;

pub use config::{
    ConfigError, FoosballConfig, OpponentKind, Preset, Randomization, RodMount, Serve,
};
pub use env::{Env, EnvError, StepInfo, Transition};
pub use foosball::{EndReason, FoosballEnv, FoosballInfo, ResetOptions, ball_in_a_goal};
pub use observation::{ObservationConfig, ObservationKind};
pub use opponent::Opponent;
pub use pendulum::Pendulum;
pub use starts::{Drill, EpisodeStarts, ReplayStart};
pub use vec_env::{VecEnv, VecEnvError, VecStep};

/// The random number generator every environment owns: ChaCha8, whose stream is fixed by
/// its seed on every platform and in every version of `rand_chacha`.
pub type EnvRng = rand_chacha::ChaCha8Rng;
