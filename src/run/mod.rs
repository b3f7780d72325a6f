//! One training run and its directory: the loop shared by PPO, SAC and TD3, its
//! checkpoints, its logs and what it will cost.
//!
//! Imports run one way: `run` plays its evaluations and test through [`crate::play`] and
//! reads [`crate::config`], [`crate::agents`] and [`crate::files`]; [`crate::sweep`] and
//! [`crate::report`] sit above it.
//!
//! A run directory, every file but the append-only CSV logs written atomically
//! ([`crate::files`]); a resume cuts the logs back to its checkpoint:
//!
//! ```text
//! RUN/config.toml          effective configuration
//! RUN/episodes.csv         env_step,return,length,scored,end  (training episodes)
//! RUN/evaluations.csv      env_step and the mean metrics ([`log::EvaluationRow`])
//! RUN/scalars.csv          env_step,tag,value                 (every TensorBoard scalar)
//! RUN/tensorboard/         TensorBoard event files
//! RUN/last/, RUN/best/     networks (Burn records) after the last epoch / best evaluation
//! RUN/checkpoint/          the resumable state of the last epoch end ([`checkpoint`])
//! RUN/lock                 held by the process training the run ([`lock`])
//! RUN/test/metrics.json    the paper's five metrics with 95 % intervals
//! RUN/test/metrics.md      the same as a markdown table
//! RUN/test/trajectories.bin  every test episode's steps ([`crate::play::trajectories`])
//! ```
//!
//! - [`train`]: a run: the protocol composed with what its configuration adds;
//! - [`protocol`]: the protocol's loop for any agent on the table (evaluations, best
//!   and last networks, checkpoints, the test); [`hooks`]: what a run adds to it, in
//!   the manner of SB3's callbacks; [`progress`]: the events it reports; [`error`]: why
//!   a run stopped;
//! - [`checkpoint`]: resumable checkpoints at epoch ends;
//! - [`init`]: networks to start from (`protocol.init_from`, fine-tuning);
//! - [`demonstrations`]: episodes to learn from beside the agent's own
//!   (`protocol.demonstrations`);
//! - [`curriculum`]: training episodes begun along a teacher's (`[curriculum]`);
//! - [`dagger`]: the planner labelling states the learner reaches (`[dagger]`);
//! - [`kickstart`]: a built-in player labelling every state PPO acts on
//!   (`[ppo.kickstart]`);
//! - [`log`]: training logs (CSV and TensorBoard);
//! - [`budget`]: memory and time a run will need, told before it starts;
//! - [`lock`]: one process at a time trains a run directory;
//! - [`interrupt`]: SIGTERM and SIGINT stop a run between two env steps.

pub mod budget;
pub mod checkpoint;
pub mod curriculum;
pub mod dagger;
pub mod demonstrations;
pub mod error;
pub mod hooks;
pub mod init;
pub mod interrupt;
pub mod kickstart;
pub mod lock;
pub mod log;
pub mod progress;
pub mod protocol;
pub mod train;
