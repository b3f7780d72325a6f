//! `evaluate`: the test phase of a finished or interrupted run, on its saved networks, of
//! a scripted policy (`--policy shooter|dribbler|zero|random|blocker`) under a rule preset,
//! or of a policy from outside (`--run FILE.onnx`, `--process COMMAND`);
//! with `--opponent`, two-sided matches against another player instead
//! ([`foosball_rl::play::matches`]).

use clap::Parser;
use foosball_rl::cli::finish;
use foosball_rl::config::TestActions;
use foosball_rl::play::contestant::Contestant;
use foosball_rl::play::flow::SideFlow;
use foosball_rl::play::matches::{self, Kickoff, MatchRules, Tally, match_table};
use foosball_rl::play::metrics::wilson_points;
use foosball_rl::play::player::{Player, PlayerArgs};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Test a run's saved networks, or a scripted policy, on the held-out test seeds (the
/// paper's five metrics).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    #[command(flatten)]
    player: PlayerArgs,
    /// Test episodes (default: the run's `protocol.test_episodes`, 1000 for a policy).
    #[arg(long)]
    episodes: Option<u32>,
    /// Where to write metrics and trajectories (default `RUN/evaluate-<checkpoint>`, with
    /// `-stochastic` after it for sampled actions and `-on-<preset>` or `-on-<config's
    /// file stem>` for another game, `baselines/<policy>-<preset>` for a policy,
    /// `<FILE stem>-test-<preset>` beside an ONNX file; required with `--process`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Play two-sided matches against this opponent instead of the test: a scripted
    /// policy or a run directory (`DIR[@best|@last][~sampled]`), on the player's table
    /// under the default match rules (first to 5 goals or 60 s; docs/league.md).
    #[arg(long)]
    opponent: Option<Contestant>,
    /// With `--opponent`: matches, even (half on each side; default 10).
    #[arg(long, requires = "opponent", default_value_t = 10)]
    matches: u32,
    /// With `--opponent`: the seed the serves derive from.
    #[arg(long, requires = "opponent", default_value_t = 0)]
    match_seed: u64,
    /// With `--opponent`: who serves, `conceded` (ITSF: the side scored upon) or `yellow`
    /// (every serve on yellow's side).
    #[arg(long, requires = "opponent", default_value_t = Kickoff::Conceded)]
    kickoff: Kickoff,
    /// With `--opponent`: ITSF's possession limits (10 s on a five-man rod, 15 s
    /// elsewhere; a still ball within a rod's reach is not dead).
    #[arg(long, requires = "opponent")]
    possession: bool,
    /// With `--opponent`: hold these of the player's rods at neutral (`goalie`,
    /// `defence`, `midfield`, `attack`, comma separated), to find which rod's play lets
    /// goals in.
    #[arg(long, requires = "opponent")]
    hold: Option<String>,
}

/// `player` against `opponent`: W-D-L, goals and the points share with its interval.
fn head_to_head(player: &Player, opponent: &Contestant, args: &Args) -> Result<String, String> {
    let (matches, seed, hold) = (args.matches, args.match_seed, args.hold.as_deref());
    if matches == 0 || matches % 2 == 1 {
        return Err(format!(
            "--matches: must be even and at least 2 (sides swap), got {matches}"
        ));
    }
    let rules = MatchRules {
        kickoff: args.kickoff,
        possession: args.possession,
        ..MatchRules::default()
    };
    let table = match_table(player.env(), &rules);
    let me = match hold {
        Some(rods) => player.contestant().holding(rods)?,
        None => player.contestant(),
    };
    let played = matches::head_to_head(&table, &rules, &me, opponent, matches / 2, seed)?;
    let [t, as_yellow, as_black] = matches::tallies(&played);
    let mut o = Tally::default();
    let mut flow = SideFlow::default();
    for p in &played {
        o.add(p.result.side(!p.a_on_yellow));
        flow.add(&p.flow.side(p.a_on_yellow));
    }
    let side = |s: &Tally| {
        format!(
            "{}-{}-{}, goals {}:{}",
            s.wins, s.draws, s.losses, s.scored, s.let_in
        )
    };
    let [lo, hi] = wilson_points(t.points, f64::from(matches)).ci95;
    let dt = table.agent_dt();
    Ok(format!(
        "{} against {opponent}: {matches} matches, {}-{}-{} (W-D-L), goals {}:{}, \
         points share {:.0} % [{:.0}, {:.0}] (95 % Wilson); spins per minute {:.2} vs {:.2}; \
         as yellow {}, as black {} (kick-off: {})\n  its ball: {}",
        match hold {
            Some(rods) => format!("{} holding {rods}", player.describe()),
            None => player.describe(),
        },
        t.wins,
        t.draws,
        t.losses,
        t.scored,
        t.let_in,
        100.0 * t.points / f64::from(matches),
        100.0 * lo,
        100.0 * hi,
        t.spins_per_minute(dt),
        o.spins_per_minute(dt),
        side(&as_yellow),
        side(&as_black),
        rules.kickoff,
        flow.summary()
    ))
}

/// Where the test files go without `--out`: `RUN/evaluate-<checkpoint>[-stochastic]
/// [-on-<game>]`, `baselines/<policy>-<preset>`, or `<FILE stem>-test-<preset>` beside an
/// ONNX file; a program's must be named.
fn default_out(player: &Player, args: &Args) -> Result<PathBuf, String> {
    Ok(match player {
        Player::Networks {
            dir,
            checkpoint,
            actions,
            ..
        } => {
            let mut name = format!("evaluate-{}", checkpoint.name());
            if *actions == TestActions::Stochastic {
                name += "-stochastic";
            }
            if let Some(preset) = args.player.preset {
                name += &format!("-on-{}", preset.name());
            } else if let Some(stem) = args.player.config.as_deref().and_then(Path::file_stem) {
                name += &format!("-on-{}", stem.to_string_lossy());
            }
            dir.join(name)
        }
        Player::Scripted(b) => PathBuf::from(format!(
            "baselines/{}-{}",
            b.policy.name(),
            b.env.preset.name()
        )),
        Player::Outside {
            contestant: Contestant::Onnx { path },
            env,
            ..
        } => path.with_file_name(format!(
            "{}-test-{}",
            path.file_stem().unwrap_or_default().to_string_lossy(),
            env.preset.name()
        )),
        Player::Outside { .. } => return Err("--out: say where a program's test files go".into()),
    })
}

fn run(args: &Args) -> Result<String, String> {
    let player = Player::from_args(&args.player)?;
    if let Some(opponent) = &args.opponent {
        return head_to_head(&player, opponent, args);
    }
    let episodes = match args.episodes.unwrap_or(player.default_episodes()) {
        0 => return Err("--episodes must be positive".into()),
        n => n,
    };
    let out = match &args.out {
        Some(out) => out.clone(),
        None => default_out(&player, args)?,
    };
    let metrics = player.test(episodes, &out)?;
    Ok(format!(
        "{}\n{}\nresults in {}",
        player.describe(),
        metrics.to_markdown(),
        out.display()
    ))
}

fn main() -> ExitCode {
    finish(run(&Args::parse()))
}
