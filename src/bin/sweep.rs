//! `sweep`: trains algorithms x seeds into one directory, several runs at a time, tests
//! the scripted baselines on the same table, and writes the seed-aggregated report.
//! Running the same command again resumes unfinished runs and skips finished ones.

use clap::Parser;
use foosball_rl::cli::finish;
use foosball_rl::config::{Algo, Overrides, RunConfig};
use foosball_rl::env::{FoosballConfig, Preset};
use foosball_rl::play::scripted::ScriptedPolicy;
use foosball_rl::report::write_report;
use foosball_rl::run::train::{Event, Progress};
use foosball_rl::sweep::{SweepRun, SweepSpec, baseline, parse_seeds, train_run};
use indicatif::{FormattedDuration, ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Train algorithms x seeds into one sweep directory and report over seeds.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Algorithms, each from `<configs>/<algo>.toml`.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "ppo,sac,td3")]
    algos: Vec<Algo>,
    /// Seeds: `A..B` (B excluded), `1,4,7` or one seed.
    #[arg(long, default_value = "0..5")]
    seeds: String,
    /// Folder of the run configurations.
    #[arg(long, default_value = "configs")]
    configs: PathBuf,
    /// Hidden layer widths of every network, e.g. `64,64` (overrides `<algo>.net.hidden`).
    #[arg(long, value_delimiter = ',')]
    hidden: Option<Vec<usize>>,
    /// Epochs (overrides `protocol.epochs`).
    #[arg(long)]
    epochs: Option<u32>,
    /// Env steps per epoch (overrides `protocol.steps_per_epoch`).
    #[arg(long)]
    steps_per_epoch: Option<u64>,
    /// Rule preset of the table (`reference`, `paper`, `end_on_goal`, `reference_v1`, `paper_v1`):
    /// replaces the configs' `[env]` by the preset's values (their opponent kept).
    #[arg(long)]
    preset: Option<Preset>,
    /// Scripted baselines to test on the same table.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "shooter,dribbler,zero,random"
    )]
    baselines: Vec<ScriptedPolicy>,
    /// Runs trained at once (default: cores / threads per run).
    #[arg(long)]
    jobs: Option<usize>,
    /// Threads of each run (default 1; results do not depend on it).
    #[arg(long, default_value_t = 1)]
    threads_per_run: usize,
    /// Sweep directory.
    #[arg(long, default_value = "sweep")]
    out: PathBuf,
    /// Replace a sweep of another configuration in `--out`.
    #[arg(long)]
    force: bool,
}

fn spec(args: &Args) -> Result<SweepSpec, String> {
    let seeds = parse_seeds(&args.seeds).map_err(|e| e.to_string())?;
    let mut runs = Vec::new();
    for &algo in &args.algos {
        let path = args.configs.join(format!("{algo}.toml"));
        let env = match args.preset {
            // The preset's table with the configuration's opponent.
            Some(preset) => Some(FoosballConfig {
                opponent: RunConfig::load(&path)
                    .map_err(|e| e.to_string())?
                    .env
                    .opponent,
                ..FoosballConfig::preset(preset)
            }),
            None => None,
        };
        let overrides = Overrides {
            seed: Some(0),
            epochs: args.epochs,
            steps_per_epoch: args.steps_per_epoch,
            envs: None,
            threads: Some(args.threads_per_run),
            hidden: args.hidden.clone(),
            env,
        };
        runs.push(RunConfig::load_with(&path, Some(algo), &overrides)?);
    }
    if runs.is_empty() {
        return Err("--algos: give at least one algorithm".into());
    }
    Ok(SweepSpec {
        seeds,
        baselines: args.baselines.clone(),
        runs,
    })
}

/// Overall progress: env steps of every run, a line per finished epoch and run.
struct Overall {
    bar: ProgressBar,
    started: Instant,
    steps: Vec<u64>,
    at_start: u64,
    total: u64,
    done_runs: usize,
    runs: usize,
}

impl Overall {
    fn line(&self, text: String) {
        if self.bar.is_hidden() {
            println!("{text}");
        } else {
            self.bar.println(text);
        }
    }

    fn update(&mut self, name: &str, index: usize, p: &Progress) {
        if p.event == Event::Started {
            // A resumed run's earlier steps were not done at this process's speed.
            self.at_start += p.env_steps - self.steps[index];
        }
        self.steps[index] = p.env_steps;
        let done: u64 = self.steps.iter().sum();
        self.bar.set_position(done);
        let rate = (done - self.at_start) as f64 / self.started.elapsed().as_secs_f64().max(1e-9);
        let eta = Duration::from_secs_f64((self.total - done) as f64 / rate.max(1e-9));
        self.bar.set_message(format!(
            "runs {}/{} | {rate:.0} env steps/s | ETA {}",
            self.done_runs,
            self.runs,
            FormattedDuration(eta)
        ));
        if let Event::Checkpoint(epoch) = p.event {
            self.line(format!(
                "{name}: epoch {epoch} done ({}/{} env steps) | sweep ETA {}",
                p.env_steps,
                p.total_steps,
                FormattedDuration(eta)
            ));
        }
    }
}

fn run(args: &Args) -> Result<String, String> {
    let spec = spec(args)?;
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let plan: Vec<SweepRun> = spec
        .open(&args.out, args.force)
        .map_err(|e| e.to_string())?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let jobs = args
        .jobs
        .unwrap_or((cores / args.threads_per_run.max(1)).max(1))
        .max(1);
    let todo = plan.iter().filter(|r| r.start.is_some()).count();
    println!(
        "sweep {}: {} runs ({} finished, {todo} to train or resume), {jobs} at a time",
        args.out.display(),
        plan.len(),
        plan.len() - todo
    );
    for policy in &spec.baselines {
        let dir = baseline(&spec, *policy, &args.out).map_err(|e| e.to_string())?;
        println!("baseline {} in {}", policy.name(), dir.display());
    }
    let steps: Vec<u64> = plan
        .iter()
        .map(|r| {
            if r.start.is_none() {
                r.total_steps()
            } else {
                0
            }
        })
        .collect();
    let total: u64 = plan.iter().map(SweepRun::total_steps).sum();
    let bar = ProgressBar::new(total).with_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let overall = Mutex::new(Overall {
        bar,
        started: Instant::now(),
        at_start: steps.iter().sum(),
        steps,
        total,
        done_runs: plan.len() - todo,
        runs: plan.len(),
    });
    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..jobs.min(todo.max(1)) {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::SeqCst);
                    let Some(run) = plan.get(i) else { break };
                    if run.start.is_none() {
                        continue;
                    }
                    let name = SweepSpec::run_name(run.config.algo(), run.config.protocol.seed);
                    let result = train_run(run, |p| {
                        overall.lock().expect("progress lock").update(&name, i, p)
                    });
                    let mut o = overall.lock().expect("progress lock");
                    match result {
                        Ok(metrics) => {
                            o.done_runs += 1;
                            let score = metrics.map_or(f64::NAN, |m| m.score_rate.mean);
                            o.line(format!("{name}: finished, test score rate {score:.3}"));
                        }
                        Err(e) => {
                            o.line(format!("{name}: failed: {e}"));
                            failures
                                .lock()
                                .expect("failures lock")
                                .push(format!("{name}: {e}"));
                        }
                    }
                }
            });
        }
    });
    overall
        .into_inner()
        .expect("progress lock")
        .bar
        .finish_and_clear();
    let failures = failures.into_inner().expect("failures lock");
    let report = args.out.join("report");
    let md = write_report(std::slice::from_ref(&args.out), &report).map_err(|e| e.to_string())?;
    if !failures.is_empty() {
        return Err(format!(
            "{} run(s) failed (rerun the same command to resume them):\n{}",
            failures.len(),
            failures.join("\n")
        ));
    }
    Ok(format!("{md}\nreport in {}", report.display()))
}

fn main() -> ExitCode {
    finish(run(&Args::parse()))
}
