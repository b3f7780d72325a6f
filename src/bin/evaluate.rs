//! `evaluate`: the test phase of a finished or interrupted run, on its saved networks.

use clap::{Parser, ValueEnum};
use foosball_rl::cli::finish;
use foosball_rl::config::RunConfig;
use foosball_rl::env::seeding::TEST_ENVS;
use foosball_rl::train::{TrainError, build_agent, device, play, write_test};
use std::path::PathBuf;
use std::process::ExitCode;

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Which saved networks to test.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum Checkpoint {
    /// The networks of the best evaluation.
    Best,
    /// The networks after the last finished epoch.
    Last,
}

/// Test a run's saved networks on the held-out test seeds (the paper's five metrics).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Run directory written by `train`.
    #[arg(long)]
    run: PathBuf,
    /// Test episodes (default: the run's `protocol.test_episodes`).
    #[arg(long)]
    episodes: Option<u32>,
    /// Saved networks to test.
    #[arg(long, value_enum, default_value = "best")]
    checkpoint: Checkpoint,
    /// Where to write metrics and trajectories (default `RUN/evaluate-<checkpoint>`).
    #[arg(long)]
    out: Option<PathBuf>,
}

fn run(args: &Args) -> Result<String, String> {
    let config = RunConfig::load_run(&args.run).map_err(|e| e.to_string())?;
    let name = format!("{:?}", args.checkpoint).to_lowercase();
    let networks = args.run.join(&name);
    if !networks.is_dir() {
        return Err(format!(
            "{}: no saved networks (the run has not reached its first {name} checkpoint)",
            networks.display()
        ));
    }
    let episodes = args.episodes.unwrap_or(config.protocol.test_episodes);
    if episodes == 0 {
        return Err("--episodes must be positive".into());
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| args.run.join(format!("evaluate-{name}")));
    let device = device(&config).map_err(|e| e.to_string())?;
    let mut agent = build_agent(&config, &device);
    agent.load(&networks).map_err(|e| e.to_string())?;
    let played = play(agent.as_mut(), &config, TEST_ENVS, episodes, true)
        .map_err(|e: TrainError| e.to_string())?;
    let metrics = write_test(&out, &played).map_err(|e| e.to_string())?;
    Ok(format!(
        "{}\nresults in {}",
        metrics.to_markdown(),
        out.display()
    ))
}

fn main() -> ExitCode {
    finish(run(&Args::parse()))
}
