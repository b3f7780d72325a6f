//! `act`: a run's networks (or an ONNX policy file) as a line protocol, for instruments
//! outside Rust. Each line on stdin is one observation (the run's table's 38 state
//! values, in its `ball_frame`, separated by spaces or commas); each line on stdout is the
//! policy's deterministic action for it (8 values in [-1, 1]), written as soon as the
//! line is read. The run's `[env.observation]` is applied as its env applies it (black's
//! rods hidden where the run hid them; an exported file has it folded in).
//! `tools/transfer.py` plays a run on the paper code's MuJoCo model so; the same protocol
//! brings a program's policy in (`process:COMMAND`, [`foosball_rl::play::process`]).

use clap::Parser;
use foosball_rl::agents::load_agent;
use foosball_rl::algos::ActMode;
use foosball_rl::config::{Checkpoint, RunConfig};
use foosball_rl::env::ObservationKind;
use foosball_rl::env::layout::{ACTION_DIM, OBS_DIM};
use foosball_rl::onnx::runtime::OnnxPolicy;
use foosball_rl::play::contestant::is_onnx;
use foosball_rl::play::process::{format_values, parse_values};
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::process::ExitCode;

/// Answer observations on stdin with a run's actions on stdout.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Run directory written by `train`, or an ONNX policy file (`FILE.onnx`).
    #[arg(long)]
    run: PathBuf,
    /// Which saved networks of a run.
    #[arg(long, value_enum, default_value_t = Checkpoint::Last)]
    checkpoint: Checkpoint,
}

/// The deterministic action of one observation (already concealed where the run hides
/// values).
type Respond = Box<dyn FnMut(&mut [f32; OBS_DIM]) -> Result<Vec<f32>, String>>;

/// The policy `args` names: a run's networks, or an ONNX file.
fn responder(args: &Args) -> Result<Respond, String> {
    if is_onnx(&args.run) {
        let onnx = OnnxPolicy::load(&args.run, OBS_DIM, ACTION_DIM)?;
        return Ok(Box::new(move |obs| onnx.act(obs.as_slice())));
    }
    let config = RunConfig::load_run(&args.run).map_err(|e| e.to_string())?;
    if config.env.observation.kind != ObservationKind::State {
        return Err(format!(
            "{}: the run observes images; act answers state observations only",
            args.run.display()
        ));
    }
    let mut agent = load_agent(&config, &args.run.join(args.checkpoint.name()))?;
    Ok(Box::new(move |obs| {
        config.env.observation.conceal(obs);
        Ok(agent.act(obs.as_slice(), ActMode::Deterministic))
    }))
}

fn run(args: &Args) -> Result<String, String> {
    let mut respond = responder(args)?;
    let (stdin, stdout) = (std::io::stdin(), std::io::stdout());
    let mut out = stdout.lock();
    let mut answered = 0usize;
    for (i, line) in stdin.lock().lines().enumerate() {
        let line = line.map_err(|e| format!("stdin: {e}"))?;
        if line.trim().is_empty() {
            continue;
        }
        let values = parse_values(&line, OBS_DIM, &format!("line {}", i + 1))?;
        let mut obs: [f32; OBS_DIM] = values.try_into().expect("OBS_DIM values parsed");
        let action = respond(&mut obs)?;
        debug_assert_eq!(action.len(), ACTION_DIM);
        writeln!(out, "{}", format_values(&action))
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
