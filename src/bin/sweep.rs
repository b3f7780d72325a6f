//! `sweep`: trains algorithms x seeds into one directory, several runs at a time, tests
//! the scripted baselines on the same table, and writes the seed-aggregated report.
//! Running the same command again resumes unfinished runs and skips finished ones.
//!
//! `--slurm` submits the same sweep as a SLURM job array instead (one task per run and
//! baseline, then the report); `--status` tells where each task stands; `--task I` and
//! `--report-only` are what the array's tasks and the report job run.

use clap::Parser;
use foosball_rl::cli::finish;
use foosball_rl::config::{Algo, Overrides, RunConfig};
use foosball_rl::env::{FoosballConfig, Preset};
use foosball_rl::play::scripted::ScriptedPolicy;
use foosball_rl::report::write_report;
use foosball_rl::run::interrupt;
use foosball_rl::run::lock::RunLock;
use foosball_rl::run::train::{Event, Progress};
use foosball_rl::sweep::slurm::{
    SLURM_DIR, SlurmOptions, Submission, Submissions, queued, report_script, submit, tasks_script,
};
use foosball_rl::sweep::status::status;
use foosball_rl::sweep::{SweepRun, SweepSpec, baseline, parse_seeds, run_task, train_run};
use indicatif::{FormattedDuration, ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
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
    /// Rule preset of the table (`reference`, `reference_v5`, `reference_v4`, `reference_v3`, `reference_v2`, `paper`,
    /// `end_on_goal`, `reference_v1`, `paper_v1`): replaces the configs' `[env]` by the preset's values
    /// (their opponent kept).
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
    /// Test no scripted baseline (an ablation whose baselines are reported elsewhere).
    #[arg(long, conflicts_with = "baselines")]
    no_baselines: bool,
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

    /// Submit the sweep to SLURM as a job array (one task per unfinished run or
    /// baseline, then the report after it) instead of training here. Run again, it
    /// submits only what is neither finished nor queued nor running.
    #[arg(long, help_heading = "SLURM")]
    slurm: bool,
    /// Print the batch scripts `--slurm` would submit, and submit nothing.
    #[arg(long, requires = "slurm", help_heading = "SLURM")]
    dry_run: bool,
    /// Partition of the jobs (`#SBATCH --partition`).
    #[arg(long, requires = "slurm", help_heading = "SLURM")]
    partition: Option<String>,
    /// Account of the jobs (`#SBATCH --account`).
    #[arg(long, requires = "slurm", help_heading = "SLURM")]
    account: Option<String>,
    /// Time limit of each task, e.g. `12:00:00` (`#SBATCH --time`).
    #[arg(long, requires = "slurm", help_heading = "SLURM")]
    time: Option<String>,
    /// CPUs of each task, which its run trains with (default: --threads-per-run).
    #[arg(long, requires = "slurm", help_heading = "SLURM")]
    cpus_per_task: Option<usize>,
    /// A further `#SBATCH` line for the tasks, e.g. `--sbatch=--qos=long` (repeatable).
    #[arg(
        long = "sbatch",
        value_name = "LINE",
        requires = "slurm",
        help_heading = "SLURM"
    )]
    sbatch: Vec<String>,
    /// Print where each run and baseline of the sweep in --out stands (and, for a
    /// submitted sweep, what SLURM says of its tasks).
    #[arg(long, conflicts_with_all = ["slurm", "task", "report_only"], help_heading = "SLURM")]
    status: bool,
    /// Do task I of the sweep in --out alone (its runs in order, then its baselines):
    /// what each SLURM array task runs.
    #[arg(long, value_name = "I", conflicts_with_all = ["slurm", "report_only"], help_heading = "SLURM")]
    task: Option<usize>,
    /// Write the report of the sweep in --out from its finished runs (the report job).
    #[arg(long, conflicts_with = "slurm", help_heading = "SLURM")]
    report_only: bool,
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
            init_from: None,
        };
        runs.push(RunConfig::load_with(&path, Some(algo), &overrides)?);
    }
    if runs.is_empty() {
        return Err("--algos: give at least one algorithm".into());
    }
    Ok(SweepSpec {
        seeds,
        baselines: if args.no_baselines {
            Vec::new()
        } else {
            args.baselines.clone()
        },
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
                // After a stop signal no run starts (the ones in flight stop themselves).
                while !interrupt::requested() {
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

/// `--slurm`: writes the batch scripts and submits what is left to do.
fn submit_sweep(args: &Args) -> Result<String, String> {
    let spec = spec(args)?;
    let out = std::path::absolute(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let runs = if args.dry_run {
        spec.check(&out, args.force)
    } else {
        std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
        spec.open(&out, args.force)
    }
    .map_err(|e| e.to_string())?;
    let tasks = spec.with_baselines(runs);
    let queue = queued(&out).map_err(|e| e.to_string())?;
    let (mut todo, mut finished, mut busy) = (Vec::new(), 0, 0);
    for (i, task) in tasks.iter().enumerate() {
        if task.finished(&spec, &out) {
            finished += 1;
        } else if queue.contains_key(&i) || RunLock::holder(&task.dir(&spec, &out)).is_some() {
            busy += 1;
        } else {
            todo.push(i);
        }
    }
    let exe = std::env::current_exe().map_err(|e| format!("the sweep binary's path: {e}"))?;
    let workdir = std::env::current_dir().map_err(|e| format!("the working directory: {e}"))?;
    let options = SlurmOptions {
        partition: args.partition.clone(),
        account: args.account.clone(),
        time: args.time.clone(),
        cpus_per_task: args.cpus_per_task.unwrap_or(args.threads_per_run).max(1),
        extra: args.sbatch.clone(),
    };
    let state = format!(
        "{} tasks: {finished} finished, {busy} queued or running, {} to submit",
        tasks.len(),
        todo.len()
    );
    if todo.is_empty() {
        return Ok(format!(
            "{state}; nothing submitted (`sweep --status --out {}`)",
            out.display()
        ));
    }
    let scripts = out.join(SLURM_DIR);
    let tasks_file = scripts.join("tasks.sbatch");
    let report_file = scripts.join("report.sbatch");
    let tasks_text = tasks_script(&exe, &out, &workdir, &todo, &options);
    let report_text = report_script(&exe, &out, &workdir, &options);
    if args.dry_run {
        return Ok(format!(
            "# {state}\n# {} \n{tasks_text}\n# {} (submitted with --dependency=afterany:<array job>)\n{report_text}",
            tasks_file.display(),
            report_file.display()
        ));
    }
    for (path, text) in [(&tasks_file, &tasks_text), (&report_file, &report_text)] {
        foosball_rl::files::write_atomic(path, text.as_bytes()).map_err(|e| e.to_string())?;
    }
    let array_job = submit(&tasks_file, None).map_err(|e| e.to_string())?;
    let report_job = submit(&report_file, Some(&array_job)).map_err(|e| e.to_string())?;
    let names: Vec<String> = todo
        .iter()
        .map(|&i| format!("{i}:{}", tasks[i].name(&spec)))
        .collect();
    Submissions::push(
        &out,
        Submission {
            array_job: array_job.clone(),
            tasks: todo,
            report_job: report_job.clone(),
        },
    )
    .map_err(|e| e.to_string())?;
    Ok(format!(
        "{state}\nsubmitted array job {array_job} (tasks {}), report job {report_job} after it\n\
         follow it with `sweep --status --out {}`; logs in {}",
        names.join(" "),
        out.display(),
        scripts.display()
    ))
}

/// `--status`: a line per task.
fn print_status(out: &Path) -> Result<String, String> {
    let lines = status(out).map_err(|e| e.to_string())?;
    Ok(lines
        .iter()
        .map(|l| l.line())
        .collect::<Vec<_>>()
        .join("\n"))
}

/// `--task I`: one task, with a line per epoch and evaluation (batch logs have no bar).
fn one_task(out: &Path, index: usize, threads: usize) -> Result<String, String> {
    let (name, metrics) = run_task(out, index, threads, |p| match p.event {
        Event::Started => println!("[{}/{}] started", p.env_steps, p.total_steps),
        Event::Checkpoint(epoch) => {
            println!(
                "[{}/{}] epoch {epoch} done, checkpoint written",
                p.env_steps, p.total_steps
            )
        }
        Event::Evaluation {
            mean_return,
            score_rate,
        } => println!(
            "[{}/{}] eval return {mean_return:.1} score rate {score_rate:.2}",
            p.env_steps, p.total_steps
        ),
        Event::Test => println!("testing the final networks"),
        Event::Window(_) | Event::Tick(_) => {}
    })?;
    let mut text = match metrics {
        Some(m) => format!("{name}: finished\n{}", m.to_markdown()),
        None => format!("{name}: had finished already"),
    };
    // The last task to finish writes the report, so that it is whole even when a task
    // was requeued after the report job had run.
    let spec = SweepSpec::load(out).map_err(|e| e.to_string())?;
    let tasks = spec.tasks(out).map_err(|e| e.to_string())?;
    if tasks.iter().all(|t| t.finished(&spec, out)) {
        text = format!("{text}\nall tasks finished\n{}", report_only(out)?);
    }
    Ok(text)
}

/// `--report-only`: the report of the finished runs in `out`.
fn report_only(out: &Path) -> Result<String, String> {
    SweepSpec::load(out).map_err(|e| e.to_string())?;
    let report = out.join("report");
    let md = write_report(&[out.to_path_buf()], &report).map_err(|e| e.to_string())?;
    Ok(format!("{md}\nreport in {}", report.display()))
}

fn main() -> ExitCode {
    let args = Args::parse();
    if let Err(e) = interrupt::install() {
        return finish(Err(format!("signal handlers: {e}")));
    }
    finish(if args.status {
        print_status(&args.out)
    } else if let Some(index) = args.task {
        one_task(&args.out, index, args.threads_per_run)
    } else if args.report_only {
        report_only(&args.out)
    } else if args.slurm {
        submit_sweep(&args)
    } else {
        run(&args)
    })
}
