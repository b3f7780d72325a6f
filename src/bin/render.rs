//! `render`: animated GIFs of recorded episodes (a run's `test/trajectories.bin`), drawn
//! top-down by `foosball_env::render`.

use clap::Parser;
use foosball_rl::animation::episode_gif;
use foosball_rl::cli::finish;
use foosball_rl::env::render::Renderer;
use foosball_rl::run_dir::{RecordedEpisode, by_return, read_trajectories};
use std::path::PathBuf;
use std::process::ExitCode;

/// Turn recorded episodes into animated GIFs.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// A `trajectories.bin` (e.g. `RUN/test/trajectories.bin`).
    #[arg(long)]
    trajectories: PathBuf,
    /// Episodes by index, e.g. `0,5,9`.
    #[arg(long, value_delimiter = ',', conflicts_with_all = ["best", "worst"])]
    episodes: Option<Vec<usize>>,
    /// The N episodes of highest return.
    #[arg(long, value_name = "N", conflicts_with = "worst")]
    best: Option<usize>,
    /// The N episodes of lowest return.
    #[arg(long, value_name = "N")]
    worst: Option<usize>,
    /// Pixels per cm.
    #[arg(long, default_value_t = 3.0)]
    scale: f32,
    /// Draw every Nth step.
    #[arg(long, default_value_t = 5)]
    every: usize,
    /// Delay between frames, hundredths of a second.
    #[arg(long, default_value_t = 4)]
    delay_cs: u16,
    /// Output folder (one `episode-<index>.gif` each).
    #[arg(long, default_value = "render")]
    out: PathBuf,
}

/// Indices of the episodes to draw.
fn pick(args: &Args, episodes: &[RecordedEpisode]) -> Result<Vec<usize>, String> {
    let by_return = by_return(episodes);
    let picked = match (&args.episodes, args.best, args.worst) {
        (Some(list), _, _) => list.clone(),
        (None, Some(n), _) => by_return.into_iter().take(n).collect(),
        (None, None, Some(n)) => by_return.into_iter().rev().take(n).collect(),
        (None, None, None) => vec![0],
    };
    match picked.iter().find(|&&i| i >= episodes.len()) {
        Some(i) => Err(format!(
            "--episodes: episode {i} is out of range ({} episodes recorded)",
            episodes.len()
        )),
        None => Ok(picked),
    }
}

fn run(args: &Args) -> Result<String, String> {
    if !(args.scale > 0.0 && args.scale <= 20.0) || args.every == 0 {
        return Err(format!(
            "--scale must be in (0, 20] and --every positive, got {} and {}",
            args.scale, args.every
        ));
    }
    let episodes = read_trajectories(&args.trajectories)?;
    if episodes.is_empty() {
        return Err(format!(
            "{}: no episodes recorded",
            args.trajectories.display()
        ));
    }
    let renderer = Renderer::new(args.scale);
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let mut written = Vec::new();
    for index in pick(args, &episodes)? {
        let t = &episodes[index].trajectory;
        let path = args.out.join(format!("episode-{index}.gif"));
        episode_gif(&path, t, &renderer, args.every, args.delay_cs)?;
        written.push(format!(
            "{} ({} steps, return {:.0}, seed {})",
            path.display(),
            t.rewards.len(),
            episodes[index].ret(),
            episodes[index].seed
        ));
    }
    Ok(written.join("\n"))
}

fn main() -> ExitCode {
    finish(run(&Args::parse()))
}
