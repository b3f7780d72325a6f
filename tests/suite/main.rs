//! The integration tests, one module per subject (docs/testing.md lists what each
//! asserts), built as one test binary: each binary links the whole stack (burn, wgpu,
//! rapier) at about 120 MB, so one instead of 28 saves the links and their disk in a
//! release build. Run one subject with a filter on its module:
//! `cargo test --release --features wgpu --test suite report::`.
//!
//! Tests of all modules run side by side in one process: none may change process-wide
//! state (environment variables, the working directory, rayon's global pool), and each
//! scratch directory is named after its test ([`common::scratch`]).

mod common;

mod act;
mod algo_reproducibility;
mod architecture;
mod committed_runs;
mod config_files;
mod curriculum;
mod dagger;
mod demonstrations;
mod docs_links;
mod drills;
mod evaluation;
mod foosball_env;
mod image_obs;
mod league;
mod league_page;
mod learning;
mod learning_foosball;
mod learning_images;
mod one_step_parity;
mod onnx;
mod pendulum_parity;
mod planner;
mod presets;
mod python_fixture;
mod reference_parity;
mod render;
mod report;
mod resume;
mod sb3_math;
mod sdf_contacts;
mod self_play;
mod slurm;
mod step_response;
mod sweep;
mod table_physics;
mod train_cli;
mod two_sided;
mod vec_env;
#[cfg(feature = "wgpu")]
mod wgpu_train;
