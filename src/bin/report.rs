//! `report`: compares finished runs grouped over seeds (markdown tables with mean, IQM and
//! bootstrap intervals, the paper's claims with verdicts, PNG charts, JSON).

use clap::Parser;
use foosball_rl::cli::finish;
use foosball_rl::report::write_report;
use std::path::PathBuf;
use std::process::ExitCode;

/// Compare runs over seeds: writes report.md, report.json, metrics.png and curves.png.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Run directories written by `train` (each with `test/metrics.json`), baseline
    /// directories written by `evaluate --policy`, or directories holding those (a sweep).
    #[arg(required = true)]
    runs: Vec<PathBuf>,
    /// Where to write the report.
    #[arg(long, default_value = "report")]
    out: PathBuf,
}

fn run(args: &Args) -> Result<String, String> {
    let md = write_report(&args.runs, &args.out).map_err(|e| e.to_string())?;
    Ok(format!("{md}\nreport in {}", args.out.display()))
}

fn main() -> ExitCode {
    finish(run(&Args::parse()))
}
