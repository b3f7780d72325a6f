//! `league`: a round-robin of two-sided matches among run networks and scripted
//! policies, Bradley-Terry ratings with bootstrap intervals, and the leaderboard
//! (`leaderboard.json`, `leaderboard.md`, `heatmap.png`, `index.html`).
//!
//! The same command again plays only the missing matches; naming more agents adds them
//! without replaying the pairs already played, and a larger `--matches-per-pair` adds
//! rounds to every pair. Settings not given are the league's. Each agent's standard test
//! on `reference` and on the randomised table is played once and kept
//! ([`foosball_rl::league::domains`]).

use clap::Parser;
use foosball_rl::cli::finish;
use foosball_rl::config::RunConfig;
use foosball_rl::env::{FoosballConfig, Preset};
use foosball_rl::league::domains::DomainTests;
use foosball_rl::league::leaderboard::Leaderboard;
use foosball_rl::league::round_robin::{League, LeagueDir};
use foosball_rl::play::matches::{Kickoff, MatchRules};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Play a round-robin of matches and write the leaderboard.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// League directory (created if new).
    #[arg(long)]
    out: PathBuf,
    /// Agents: `shooter`, `dribbler`, `zero`, `random`, or run directories with optional
    /// `@best`/`@last` (default last) and `~sampled` (comma- or space-separated).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    agents: Vec<String>,
    /// Matches per pair, even: half with each agent on yellow (default 10, or the
    /// league's own); more than an existing league's plays only the new rounds.
    #[arg(long)]
    matches_per_pair: Option<u32>,
    /// Goals that win a match (default 5).
    #[arg(long)]
    goals: Option<u32>,
    /// Seconds of play after which the side ahead wins (default 60).
    #[arg(long)]
    time_limit: Option<f32>,
    /// Seconds a dead ball lies before it is served again (default 1).
    #[arg(long)]
    dead_ball: Option<f32>,
    /// Who serves: `conceded` (ITSF: the side scored upon; default) or `yellow` (every
    /// serve on yellow's side).
    #[arg(long)]
    kickoff: Option<Kickoff>,
    /// ITSF's possession limits: a rod that holds the ball over 10 s (five-man) or 15 s
    /// loses it to the other side, and a still ball within a rod's reach is not dead
    /// (default off, or the league's own).
    #[arg(long)]
    possession: bool,
    /// The table's preset (default reference).
    #[arg(long, conflicts_with = "config")]
    preset: Option<Preset>,
    /// A run configuration whose `[env]` is the table.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Seed the match seeds derive from (default 0).
    #[arg(long)]
    seed: Option<u64>,
    /// The agent rated 1000 (default `zero`, the paper's static black, if playing).
    #[arg(long)]
    anchor: Option<String>,
    /// Matches played at once (default one per core; results do not depend on it).
    #[arg(long)]
    threads: Option<usize>,
    /// Episodes of each agent's standard test on `reference` and `reference_randomized`
    /// (the board's domain columns, kept in `domains.csv`: only untested agents play;
    /// default 1000, 0 for none).
    #[arg(long, default_value_t = 1000)]
    test_episodes: u32,
}

fn main() -> ExitCode {
    finish(run(&Args::parse()))
}

fn run(args: &Args) -> Result<String, String> {
    let path = args.out.join("league.toml");
    let old: Option<League> = match std::fs::read_to_string(&path) {
        Ok(text) => Some(toml::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?),
        Err(_) => None,
    };
    let table = match (&args.config, args.preset) {
        (Some(file), _) => RunConfig::load(file).map_err(|e| e.to_string())?.env,
        (None, Some(p)) => FoosballConfig::preset(p),
        (None, None) => old
            .as_ref()
            .map_or_else(FoosballConfig::default, |l| l.table.clone()),
    };
    let defaults = old.clone().unwrap_or_else(|| League {
        seed: 0,
        matches_per_pair: 10,
        anchor: String::new(),
        agents: vec![],
        rules: MatchRules::default(),
        table: table.clone(),
    });
    let mut agents = args.agents.clone();
    agents.retain(|a| !a.trim().is_empty());
    if old.is_none() && agents.is_empty() {
        return Err("--agents: name at least two agents for a new league".into());
    }
    let anchor = args.anchor.clone().unwrap_or_else(|| {
        if old.is_some() {
            defaults.anchor.clone()
        } else if agents.iter().any(|a| a == "zero") {
            "zero".into()
        } else {
            agents[0].clone()
        }
    });
    let new = League {
        seed: args.seed.unwrap_or(defaults.seed),
        matches_per_pair: args.matches_per_pair.unwrap_or(defaults.matches_per_pair),
        anchor,
        agents,
        rules: MatchRules {
            goals_to_win: args.goals.unwrap_or(defaults.rules.goals_to_win),
            time_limit_s: args.time_limit.unwrap_or(defaults.rules.time_limit_s),
            dead_ball_s: args.dead_ball.unwrap_or(defaults.rules.dead_ball_s),
            kickoff: args.kickoff.unwrap_or(defaults.rules.kickoff),
            possession: args.possession || defaults.rules.possession,
            ..defaults.rules
        },
        table,
    };
    let mut league = LeagueDir::open(&args.out, new)?;
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let start = Instant::now();
    league.play(threads, |done, total| {
        let s = start.elapsed().as_secs_f64();
        let eta = s / done as f64 * (total - done) as f64;
        eprintln!(
            "{done}/{total} matches ({:.1} matches/s, ETA {eta:.0} s)",
            done as f64 / s
        );
    })?;
    let mut tests = DomainTests::open(&args.out)?;
    if args.test_episodes > 0 {
        tests.play_missing(
            &league.league.agents,
            args.test_episodes,
            |agent, domain, s| {
                eprintln!("{agent} on {domain}: score rate {}", s.label());
            },
        )?;
    }
    let board = Leaderboard::of(&league).with_tests(&tests);
    board.write(&args.out)?;
    Ok(format!(
        "{}\nwritten to {} (leaderboard.json, leaderboard.md, heatmap.png, index.html)",
        board.to_markdown(),
        args.out.display()
    ))
}
