//! `report`: compares finished runs side by side (markdown table, PNG bar chart of the
//! five test metrics, learning curves).

use clap::Parser;
use foosball_rl::cli::finish;
use foosball_rl::report::{RunResults, write_report};
use std::path::PathBuf;
use std::process::ExitCode;

/// Compare runs: writes report.md, report.json, metrics.png and curves.png.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Run directories written by `train` (each with `test/metrics.json`).
    #[arg(required = true)]
    runs: Vec<PathBuf>,
    /// Where to write the report.
    #[arg(long, default_value = "report")]
    out: PathBuf,
}

fn run(args: &Args) -> Result<String, String> {
    let runs = args
        .runs
        .iter()
        .map(|dir| RunResults::read(dir))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let md = write_report(&runs, &args.out).map_err(|e| e.to_string())?;
    Ok(format!("{md}\nreport in {}", args.out.display()))
}

fn main() -> ExitCode {
    finish(run(&Args::parse()))
}
