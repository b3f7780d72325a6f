//! `evaluate`: the test phase of a finished or interrupted run, on its saved networks, or
//! of a scripted policy (`--policy shooter|dribbler|zero|random`) under a rule preset.

use clap::Parser;
use foosball_rl::cli::finish;
use foosball_rl::config::TestActions;
use foosball_rl::play::player::{Player, PlayerArgs};
use std::path::PathBuf;
use std::process::ExitCode;

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Test a run's saved networks, or a scripted policy, on the held-out test seeds (the
/// paper's five metrics).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    #[command(flatten)]
    player: PlayerArgs,
    /// Test episodes (default: the run's `protocol.test_episodes`, 1000 for a policy).
    #[arg(long)]
    episodes: Option<u32>,
    /// Where to write metrics and trajectories (default `RUN/evaluate-<checkpoint>`, with
    /// `-stochastic` after it for sampled actions, or `baselines/<policy>-<preset>` for a
    /// policy).
    #[arg(long)]
    out: Option<PathBuf>,
}

fn run(args: &Args) -> Result<String, String> {
    let player = Player::from_args(&args.player)?;
    let episodes = match args.episodes.unwrap_or(player.default_episodes()) {
        0 => return Err("--episodes must be positive".into()),
        n => n,
    };
    let out = args.out.clone().unwrap_or_else(|| match &player {
        Player::Networks {
            dir,
            checkpoint,
            actions,
            ..
        } => dir.join(match actions {
            TestActions::Deterministic => format!("evaluate-{}", checkpoint.name()),
            TestActions::Stochastic => format!("evaluate-{}-stochastic", checkpoint.name()),
        }),
        Player::Scripted(b) => PathBuf::from(format!(
            "baselines/{}-{}",
            b.policy.name(),
            b.env.preset.name()
        )),
    });
    let metrics = player.test(episodes, &out)?;
    Ok(format!(
        "{}\n{}\nresults in {}",
        player.describe(),
        metrics.to_markdown(),
        out.display()
    ))
}

fn main() -> ExitCode {
    finish(run(&Args::parse()))
}
