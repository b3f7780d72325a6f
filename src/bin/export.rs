//! `export`: a run's deterministic policy as one ONNX file, from the table's 38 raw state
//! values (its `ball_frame`) to the 8 actions (its `action_map`), with the black rods the
//! run hid, its observation normalisation and its Fourier features folded in
//! ([`foosball_rl::onnx`]). The file plays wherever a run directory does (`evaluate
//! --run FILE.onnx`, a league contestant, `render`, `act`), and in onnxruntime or any ONNX
//! runtime outside Rust.

use clap::Parser;
use foosball_rl::cli::finish;
use foosball_rl::config::{Checkpoint, RunConfig};
use foosball_rl::files::write_atomic;
use foosball_rl::onnx::export::exported_policy;
use std::path::PathBuf;
use std::process::ExitCode;

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Write a run's deterministic policy as an ONNX file.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Run directory written by `train`.
    #[arg(long)]
    run: PathBuf,
    /// Which saved networks.
    #[arg(long, value_enum, default_value_t = Checkpoint::Last)]
    checkpoint: Checkpoint,
    /// The file to write (default `RUN/policy-<checkpoint>.onnx`).
    #[arg(long)]
    out: Option<PathBuf>,
}

fn run(args: &Args) -> Result<String, String> {
    let config = RunConfig::load_run(&args.run).map_err(|e| e.to_string())?;
    let source = format!("{}@{}", args.run.display(), args.checkpoint.name());
    let networks = args.run.join(args.checkpoint.name());
    let bytes = exported_policy(&config, &networks, &source)?;
    let out = args.out.clone().unwrap_or_else(|| {
        args.run
            .join(format!("policy-{}.onnx", args.checkpoint.name()))
    });
    write_atomic(&out, &bytes).map_err(|e| e.to_string())?;
    Ok(format!(
        "{source}: {} bytes in {}",
        bytes.len(),
        out.display()
    ))
}

fn main() -> ExitCode {
    finish(run(&Args::parse()))
}
