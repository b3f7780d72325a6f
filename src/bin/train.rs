//! `train`: trains PPO, SAC or TD3 on the foosball table with a run configuration
//! (`configs/<algo>.toml` unless `--config` is given), then tests the final networks;
//! `train --resume RUN` goes on from a run's last checkpoint.

use clap::Parser;
use foosball_rl::cli::finish;
use foosball_rl::config::{Algo, Overrides, RunConfig};
use foosball_rl::run::log::Speed;
use foosball_rl::run::train::{Event, Progress, Start, train};
use foosball_rl::run::{budget, interrupt};
use indicatif::{FormattedDuration, ProgressBar, ProgressStyle};
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
    /// Start from a run's saved networks, `DIR[@best|@last]` (overrides
    /// `protocol.init_from`): fine-tuning with a fresh optimiser and buffer.
    #[arg(long, value_name = "NETWORKS")]
    init_from: Option<String>,
    /// Rollout workers (overrides `protocol.envs`).
    #[arg(long)]
    envs: Option<usize>,
    /// Threads, 0 = one per core (overrides `protocol.threads`).
    #[arg(long)]
    threads: Option<usize>,
    /// Run directory (default `runs/<algo>-seed<seed>`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write into a run directory that already holds a run (replacing it).
    #[arg(long)]
    force: bool,
    /// Go on from the last checkpoint of this run directory (its own `config.toml`;
    /// only `--threads` may be changed, which does not change the results).
    #[arg(long, value_name = "RUN", conflicts_with_all = [
        "algo", "config", "seed", "epochs", "steps_per_epoch", "hidden", "init_from", "envs", "out",
        "force"
    ])]
    resume: Option<PathBuf>,
}

fn config(args: &Args) -> Result<RunConfig, String> {
    let path = match (&args.config, args.algo) {
        (Some(path), _) => path.clone(),
        (None, Some(algo)) => PathBuf::from(format!("configs/{algo}.toml")),
        (None, None) => return Err("give --algo ppo|sac|td3 or --config FILE".into()),
    };
    let overrides = Overrides {
        seed: args.seed,
        epochs: args.epochs,
        steps_per_epoch: args.steps_per_epoch,
        envs: args.envs,
        threads: args.threads,
        hidden: args.hidden.clone(),
        env: None,
        init_from: args.init_from.clone(),
    };
    RunConfig::load_with(&path, args.algo, &overrides)
}

fn run_dir(args: &Args, c: &RunConfig) -> Result<PathBuf, String> {
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("runs").join(format!("{}-seed{}", c.algo(), c.protocol.seed)));
    if dir.join("config.toml").exists() && !args.force {
        return Err(format!(
            "{} already holds a run: pass --force to overwrite it or choose another --out",
            dir.display()
        ));
    }
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    Ok(dir)
}

/// Shows training progress: a bar on a terminal (steps/s, updates/s, ETA, last
/// evaluation), and a line per evaluation and checkpoint in any case. The speeds shown
/// are the last logging window's; the ETA is from the average speed since this process
/// started training (a window of PPO's collection alone runs several times faster than
/// the run, its updates included).
struct Display {
    bar: ProgressBar,
    speed: String,
    eval: String,
    window: Option<Speed>,
    average: Option<Speed>,
}

impl Display {
    fn new(total: u64) -> Self {
        let bar = ProgressBar::new(total).with_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        Self {
            bar,
            speed: String::new(),
            eval: "no evaluation yet".into(),
            window: None,
            average: None,
        }
    }

    fn line(&self, text: String) {
        if self.bar.is_hidden() {
            println!("{text}");
        } else {
            self.bar.println(text);
        }
    }

    /// The last window's speeds and the ETA at the average pace (each standing in for
    /// the other until both have been reported).
    fn speed_line(&self, p: &Progress) -> String {
        let (Some(shown), Some(pace)) =
            (self.window.or(self.average), self.average.or(self.window))
        else {
            return String::new();
        };
        let left = p.total_steps.saturating_sub(p.env_steps) as f64;
        let eta = Duration::from_secs_f64(left / pace.steps_per_second.max(1e-9));
        format!(
            "{:.0} steps/s {:.1} updates/s ETA {}",
            shown.steps_per_second,
            shown.updates_per_second,
            FormattedDuration(eta)
        )
    }

    fn show(&mut self, p: &Progress) {
        self.bar.set_position(p.env_steps);
        match p.event {
            Event::Window(s) => {
                self.window = Some(s);
                self.speed = self.speed_line(p);
            }
            Event::Tick(s) => {
                self.average = Some(s);
                self.speed = self.speed_line(p);
            }
            Event::Evaluation {
                mean_return,
                score_rate,
            } => {
                self.eval = format!("eval return {mean_return:.1} score rate {score_rate:.2}");
                self.line(format!(
                    "[{:>9}/{}] {}  {}",
                    p.env_steps, p.total_steps, self.eval, self.speed
                ));
            }
            Event::Checkpoint(epoch) => self.line(format!(
                "[{:>9}/{}] epoch {epoch} done, checkpoint written",
                p.env_steps, p.total_steps
            )),
            Event::Started => {}
            Event::Test => {
                self.bar.finish_and_clear();
                println!("testing the final networks");
            }
        }
        self.bar
            .set_message(format!("{} | {}", self.speed, self.eval));
    }
}

/// The configuration of a resumed run, with `--threads` applied.
fn resumed(dir: &Path, threads: Option<usize>) -> Result<RunConfig, String> {
    let mut c = RunConfig::load_run(dir).map_err(|e| e.to_string())?;
    c.protocol.threads = threads.unwrap_or(c.protocol.threads);
    Ok(c)
}

fn main() -> ExitCode {
    let args = Args::parse();
    if let Err(e) = interrupt::install() {
        return finish(Err(format!("signal handlers: {e}")));
    }
    let available = budget::available_bytes();
    let fits = |c: RunConfig| budget::check(&c, available).map(|()| c);
    let setup = match &args.resume {
        Some(dir) => resumed(dir, args.threads)
            .and_then(fits)
            .map(|c| (c, dir.clone(), Start::Resume)),
        None => config(&args).and_then(fits).and_then(|c| {
            let dir = run_dir(&args, &c)?;
            Ok((c, dir, Start::Fresh))
        }),
    };
    let result = setup.and_then(|(c, dir, start)| {
        let time = budget::time_budget(&c).map_err(|e| e.to_string())?;
        println!(
            "# effective configuration ({})\n{}",
            dir.join("config.toml").display(),
            c.to_toml()
        );
        println!("{}", budget::describe(&c, &time, available));
        let total = c.protocol.total_env_steps();
        let mut display = Display::new(total);
        let metrics = train(&c, &dir, start, |p| display.show(p)).map_err(|e| e.to_string())?;
        Ok(format!(
            "\n{}\nresults in {}",
            metrics.to_markdown(),
            dir.join("test").display()
        ))
    });
    finish(result)
}
