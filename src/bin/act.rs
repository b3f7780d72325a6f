//! `act`: a run's networks as a line protocol, for instruments outside Rust. Each line on
//! stdin is one observation (the run's table's 38 state values, in its `ball_frame`,
//! separated by spaces or commas); each line on stdout is the policy's deterministic
//! action for it (8 values in [-1, 1]), written as soon as the line is read. The run's
//! `[env.observation]` is applied as its env applies it (black's rods hidden where the
//! run hid them). `tools/transfer.py` plays a run on the paper code's MuJoCo model so.

use clap::Parser;
use foosball_rl::agents::load_agent;
use foosball_rl::algos::ActMode;
use foosball_rl::config::{Checkpoint, RunConfig};
use foosball_rl::env::ObservationKind;
use foosball_rl::env::layout::{ACTION_DIM, OBS_DIM};
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::process::ExitCode;

/// Answer observations on stdin with a run's actions on stdout.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Run directory written by `train`.
    #[arg(long)]
    run: PathBuf,
    /// Which saved networks.
    #[arg(long, value_enum, default_value_t = Checkpoint::Last)]
    checkpoint: Checkpoint,
}

/// The observation on line `number` (1-based).
fn parse(line: &str, number: usize) -> Result<[f32; OBS_DIM], String> {
    let values: Vec<&str> = line
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .collect();
    if values.len() != OBS_DIM {
        return Err(format!(
            "line {number}: {} values, expected {OBS_DIM}",
            values.len()
        ));
    }
    let mut obs = [0.0; OBS_DIM];
    for (i, (slot, text)) in obs.iter_mut().zip(values).enumerate() {
        *slot = text
            .parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("line {number}: value {i} is not a finite number: `{text}`"))?;
    }
    Ok(obs)
}

fn run(args: &Args) -> Result<String, String> {
    let config = RunConfig::load_run(&args.run).map_err(|e| e.to_string())?;
    if config.env.observation.kind != ObservationKind::State {
        return Err(format!(
            "{}: the run observes images; act answers state observations only",
            args.run.display()
        ));
    }
    let mut agent = load_agent(&config, &args.run.join(args.checkpoint.name()))?;
    let (stdin, stdout) = (std::io::stdin(), std::io::stdout());
    let mut out = stdout.lock();
    let mut answered = 0usize;
    for (i, line) in stdin.lock().lines().enumerate() {
        let line = line.map_err(|e| format!("stdin: {e}"))?;
        if line.trim().is_empty() {
            continue;
        }
        let mut obs = parse(&line, i + 1)?;
        config.env.observation.conceal(&mut obs);
        let action = agent.act(&obs, ActMode::Deterministic);
        debug_assert_eq!(action.len(), ACTION_DIM);
        let text: Vec<String> = action.iter().map(|a| format!("{a:.7}")).collect();
        writeln!(out, "{}", text.join(" "))
            .and_then(|()| out.flush())
            .map_err(|e| format!("stdout: {e}"))?;
        answered += 1;
    }
    Ok(format!("answered {answered} observations"))
}

fn main() -> ExitCode {
    let args = Args::parse();
    match run(&args) {
        Ok(summary) => {
            eprintln!("{summary}");
            ExitCode::SUCCESS
        }
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}
