//! `train`: trains PPO, SAC or TD3 on the foosball table with a run configuration
//! (`configs/<algo>.toml` unless `--config` is given), then tests the final networks.

use clap::Parser;
use foosball_rl::config::{Algo, RunConfig};
use foosball_rl::train::{Progress, train};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

/// glibc page-faults large freed blocks back in on every update; mimalloc keeps them.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Train an agent on the foosball table and test it (the paper's protocol by default).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Algorithm; loads `configs/<algo>.toml` unless `--config` is given.
    #[arg(long, value_enum)]
    algo: Option<Algo>,
    /// Run configuration file (TOML).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Run seed (overrides `protocol.seed`).
    #[arg(long)]
    seed: Option<u64>,
    /// Epochs (overrides `protocol.epochs`).
    #[arg(long)]
    epochs: Option<u32>,
    /// Env steps per epoch (overrides `protocol.steps_per_epoch`).
    #[arg(long)]
    steps_per_epoch: Option<u64>,
    /// Hidden layer widths of every network, e.g. `256,256` (overrides `<algo>.net.hidden`).
    #[arg(long, value_delimiter = ',')]
    hidden: Option<Vec<usize>>,
    /// Rollout workers (overrides `protocol.envs`).
    #[arg(long)]
    envs: Option<usize>,
    /// Threads, 0 = one per core (overrides `protocol.threads`).
    #[arg(long)]
    threads: Option<usize>,
    /// Run directory (default `runs/<algo>-seed<seed>`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write into a run directory that already holds a run.
    #[arg(long)]
    force: bool,
}

fn config(args: &Args) -> Result<RunConfig, String> {
    let path = match (&args.config, args.algo) {
        (Some(path), _) => path.clone(),
        (None, Some(algo)) => PathBuf::from(format!("configs/{algo}.toml")),
        (None, None) => return Err("give --algo ppo|sac|td3 or --config FILE".into()),
    };
    let mut c = RunConfig::load(&path).map_err(|e| e.to_string())?;
    if let Some(algo) = args.algo
        && algo != c.algo
    {
        return Err(format!(
            "--algo {algo} but {} has algo = \"{}\"",
            path.display(),
            c.algo
        ));
    }
    let p = &mut c.protocol;
    p.seed = args.seed.unwrap_or(p.seed);
    p.epochs = args.epochs.unwrap_or(p.epochs);
    p.steps_per_epoch = args.steps_per_epoch.unwrap_or(p.steps_per_epoch);
    p.envs = args.envs.unwrap_or(p.envs);
    p.threads = args.threads.unwrap_or(p.threads);
    if let Some(hidden) = &args.hidden {
        c.set_hidden(hidden.clone());
    }
    c.validate().map_err(|e| {
        format!(
            "{} (after command-line overrides): {}: {}",
            path.display(),
            e.key,
            e.message
        )
    })?;
    Ok(c)
}

fn run_dir(args: &Args, c: &RunConfig) -> Result<PathBuf, String> {
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("runs").join(format!("{}-seed{}", c.algo, c.protocol.seed)));
    if dir.join("config.toml").exists() && !args.force {
        return Err(format!(
            "{} already holds a run: pass --force to overwrite it or choose another --out",
            dir.display()
        ));
    }
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    Ok(dir)
}

fn show(p: &Progress) {
    let done = p.env_steps as f64 / p.total_steps as f64;
    let eta = Duration::from_secs_f64(
        (p.total_steps - p.env_steps.min(p.total_steps)) as f64 / p.steps_per_second.max(1e-9),
    );
    println!(
        "[{:>9}/{} {:5.1}%] {:7.0} steps/s  ETA {:>5} min  eval return {:9.1}  score rate {:.2}",
        p.env_steps,
        p.total_steps,
        100.0 * done,
        p.steps_per_second,
        eta.as_secs() / 60,
        p.eval_return,
        p.eval_score_rate
    );
}

fn main() -> ExitCode {
    let args = Args::parse();
    let result = config(&args).and_then(|c| {
        let dir = run_dir(&args, &c)?;
        println!(
            "# effective configuration ({})\n{}",
            dir.join("config.toml").display(),
            c.to_toml()
        );
        let metrics = train(&c, &dir, show).map_err(|e| e.to_string())?;
        println!(
            "\n{}\nresults in {}",
            metrics.to_markdown(),
            dir.join("test").display()
        );
        Ok(())
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}
