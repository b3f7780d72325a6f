//! `evaluate`: the test phase of a finished or interrupted run, on its saved networks, or
//! of a scripted policy (`--policy shooter|dribbler|zero|random`) under a rule preset.

use clap::{Parser, ValueEnum};
use foosball_rl::agents::{build_agent, device};
use foosball_rl::cli::finish;
use foosball_rl::config::RunConfig;
use foosball_rl::env::seeding::TEST_ENVS;
use foosball_rl::env::{FoosballConfig, Preset};
use foosball_rl::evaluation::{deterministic, play, write_test};
use foosball_rl::policy::{Baseline, ScriptedPolicy};
use foosball_rl::train::TrainError;
use std::path::{Path, PathBuf};
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

/// Test a run's saved networks, or a scripted policy, on the held-out test seeds (the
/// paper's five metrics).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Run directory written by `train`.
    #[arg(long, required_unless_present = "policy")]
    run: Option<PathBuf>,
    /// Test a scripted policy instead of a run's networks.
    #[arg(long, value_enum, conflicts_with_all = ["run", "checkpoint"])]
    policy: Option<ScriptedPolicy>,
    /// With `--policy`: the rule preset of the table (default reference).
    #[arg(long, requires = "policy", conflicts_with = "config")]
    preset: Option<Preset>,
    /// With `--policy`: a run configuration whose `[env]` and `protocol.seed` to use.
    #[arg(long, requires = "policy")]
    config: Option<PathBuf>,
    /// With `--policy`: the seed the test seeds derive from (default the config's, or 0).
    #[arg(long, requires = "policy")]
    seed: Option<u64>,
    /// Test episodes (default: the run's `protocol.test_episodes`, 1000 for a policy).
    #[arg(long)]
    episodes: Option<u32>,
    /// Saved networks to test.
    #[arg(long, value_enum)]
    checkpoint: Option<Checkpoint>,
    /// Where to write metrics and trajectories (default `RUN/evaluate-<checkpoint>`, or
    /// `baselines/<policy>-<preset>` for a policy).
    #[arg(long)]
    out: Option<PathBuf>,
}

fn episodes(args: &Args, default: u32) -> Result<u32, String> {
    match args.episodes.unwrap_or(default) {
        0 => Err("--episodes must be positive".into()),
        n => Ok(n),
    }
}

fn run_networks(args: &Args, run: &Path) -> Result<String, String> {
    let config = RunConfig::load_run(run).map_err(|e| e.to_string())?;
    let name = format!("{:?}", args.checkpoint.unwrap_or(Checkpoint::Best)).to_lowercase();
    let networks = run.join(&name);
    if !networks.is_dir() {
        return Err(format!(
            "{}: no saved networks (the run has not reached its first {name} checkpoint)",
            networks.display()
        ));
    }
    let episodes = episodes(args, config.protocol.test_episodes)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| run.join(format!("evaluate-{name}")));
    let device = device(&config).map_err(|e| e.to_string())?;
    let mut agent = build_agent(&config, &device);
    agent.load(&networks).map_err(|e| e.to_string())?;
    let played = play(
        &mut deterministic(agent.as_mut()),
        &config.env,
        config.protocol.seed,
        TEST_ENVS,
        episodes,
        true,
    )
    .map_err(|e: TrainError| e.to_string())?;
    let metrics = write_test(&out, &played).map_err(|e| e.to_string())?;
    Ok(format!(
        "{}\nresults in {}",
        metrics.to_markdown(),
        out.display()
    ))
}

fn run_policy(args: &Args, policy: ScriptedPolicy) -> Result<String, String> {
    let (env, config_seed) = match &args.config {
        Some(path) => {
            let c = RunConfig::load(path).map_err(|e| e.to_string())?;
            (c.env, c.protocol.seed)
        }
        None => (FoosballConfig::preset(args.preset.unwrap_or_default()), 0),
    };
    let seed = args.seed.unwrap_or(config_seed);
    let episodes = episodes(args, 1000)?;
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from(format!("baselines/{}-{}", policy.name(), env.preset.name()))
    });
    let preset = env.preset.name();
    let metrics = Baseline { policy, seed, env }
        .test(episodes, &out, true)
        .map_err(|e| e.to_string())?;
    Ok(format!(
        "{} under preset {preset}\n{}\nresults in {}",
        policy.name(),
        metrics.to_markdown(),
        out.display()
    ))
}

fn run(args: &Args) -> Result<String, String> {
    match (&args.run, args.policy) {
        (_, Some(policy)) => run_policy(args, policy),
        (Some(run), None) => run_networks(args, run),
        (None, None) => Err("give --run RUN or --policy NAME".into()),
    }
}

fn main() -> ExitCode {
    finish(run(&Args::parse()))
}
