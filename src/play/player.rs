//! Who plays test episodes for `evaluate` and `render`: a run's saved networks, a
//! scripted policy, or a policy from outside (an ONNX file, a program) on a table, chosen
//! by the same command-line options in both.

use super::contestant::{Contestant, exported_config, is_onnx, means_the_same, plays_on};
use super::evaluation::{Episodes, PlayedEpisode, play_agent, play_owned, write_test};
use super::metrics::TestMetrics;
use super::scripted::{Baseline, ScriptedPolicy};
use crate::agents::load_agent;
use crate::config::{Checkpoint, RunConfig, TestActions};
use crate::plan::PlannerConfig;
use foosball_env::seeding::TEST_ENVS;
use foosball_env::{FoosballConfig, Preset};
use std::path::{Path, PathBuf};

/// The command-line options that choose a [`Player`].
#[derive(clap::Args, Clone, Debug, Default)]
pub struct PlayerArgs {
    /// Run directory written by `train`, or an ONNX policy file (`FILE.onnx`: the 38
    /// state values in, 8 actions out; `export` writes one from a run).
    #[arg(long)]
    pub run: Option<PathBuf>,
    /// A program that answers observations with actions in `act`'s line protocol
    /// (started with `sh -c`), instead of a run's networks.
    #[arg(long, conflicts_with_all = ["run", "policy"])]
    pub process: Option<String>,
    /// Saved networks of the run (default best).
    #[arg(long, value_enum, requires = "run")]
    pub checkpoint: Option<Checkpoint>,
    /// How the run's networks act (default the run's `protocol.test_actions`).
    #[arg(long, value_enum, requires = "run")]
    pub actions: Option<TestActions>,
    /// Short for `--actions stochastic`: actions drawn from the policy, as the paper
    /// code's test does.
    #[arg(long, requires = "run", conflicts_with = "actions")]
    pub stochastic: bool,
    /// A scripted policy instead of a run's networks.
    #[arg(long, value_enum, conflicts_with_all = ["run", "checkpoint"])]
    pub policy: Option<ScriptedPolicy>,
    /// With `--policy`: the rule preset of the table (default reference). With `--run`:
    /// a game to test the run's networks on instead of its own (the preset's table with
    /// the run's observation and opponent; refused where the networks' observations or
    /// actions would mean something else there).
    #[arg(long, conflicts_with = "config")]
    pub preset: Option<Preset>,
    /// With `--policy`: a run configuration whose `[env]` and `protocol.seed` to use.
    /// With `--run`: a run configuration whose `[env]` to test the run's networks on
    /// instead of its own, on the run's own test seeds (e.g. a run trained on a
    /// randomised table tested on the plain one; refused where the networks' observations
    /// or actions would mean something else there).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// With `--policy`, `--process` or an ONNX file: the seed the test seeds derive from
    /// (default the config's, an exported run's, or 0).
    #[arg(long)]
    pub seed: Option<u64>,
    /// With `--policy planner`: a TOML file of the search budget (`population`,
    /// `iterations`, ...; default the planner's defaults).
    #[arg(long, requires = "policy")]
    pub planner: Option<PathBuf>,
}

/// The table `--preset` or `--config` puts a run's networks on instead of their own
/// (`own`), with the option that named it; `None` without either.
fn other_table(
    args: &PlayerArgs,
    own: &FoosballConfig,
) -> Result<Option<(String, FoosballConfig)>, String> {
    Ok(match (args.preset, &args.config) {
        (Some(preset), _) => Some((
            format!("--preset {}", preset.name()),
            FoosballConfig {
                observation: own.observation,
                opponent: own.opponent,
                ..FoosballConfig::preset(preset)
            },
        )),
        (None, Some(path)) => {
            let option = format!("--config {}", path.display());
            let env = RunConfig::load(path).map_err(|e| e.to_string())?.env;
            if env.observation != own.observation {
                return Err(format!(
                    "{option}: its env.observation {:?} is not the run's {:?}",
                    env.observation, own.observation
                ));
            }
            Some((option, env))
        }
        (None, None) => None,
    })
}

/// An outside `contestant`'s player: on the table of `--config` or `--preset`, else of
/// the run it was `exported` from, else `reference`; from `--seed`'s test seeds, else the
/// config's or the run's seed, else 0.
fn outside(
    contestant: Contestant,
    exported: Option<RunConfig>,
    args: &PlayerArgs,
) -> Result<Player, String> {
    if args.planner.is_some() {
        return Err("--planner sets the planner's budget; it plays no outside policy".into());
    }
    let (env, seed) = match (&args.config, args.preset, exported) {
        (Some(path), _, _) => {
            let c = RunConfig::load(path).map_err(|e| e.to_string())?;
            (c.env, c.protocol.seed)
        }
        (None, Some(preset), _) => (FoosballConfig::preset(preset), 0),
        (None, None, Some(c)) => (c.env, c.protocol.seed),
        (None, None, None) => (FoosballConfig::default(), 0),
    };
    if env.observation.kind != foosball_env::ObservationKind::State {
        return Err(format!(
            "{contestant}: an outside policy reads the 38 state values; the table's \
             env.observation.kind is not \"state\""
        ));
    }
    Ok(Player::Outside {
        contestant,
        env: Box::new(env),
        seed: args.seed.unwrap_or(seed),
    })
}

/// What plays: a run's networks or a scripted policy, each on its own table and seeds.
#[derive(Clone, Debug)]
pub enum Player {
    /// The networks a run saved in `dir/<checkpoint>`.
    Networks {
        /// The run directory.
        dir: PathBuf,
        /// Its configuration (table, seed, algorithm, backend).
        config: Box<RunConfig>,
        /// Which networks.
        checkpoint: Checkpoint,
        /// How they act.
        actions: TestActions,
    },
    /// A scripted policy on a table.
    Scripted(Box<Baseline>),
    /// A policy from outside (an ONNX file or a program) on a table, from `seed`'s test
    /// seeds.
    Outside {
        /// Who plays ([`Contestant::Onnx`] or [`Contestant::Process`]).
        contestant: Contestant,
        /// The table.
        env: Box<FoosballConfig>,
        /// The seed the test seeds derive from.
        seed: u64,
    },
}

impl Player {
    /// The player the options name; an error says which option is missing or at fault.
    pub fn from_args(args: &PlayerArgs) -> Result<Self, String> {
        if let Some(command) = &args.process {
            let contestant = Contestant::Process {
                command: command.clone(),
            };
            return outside(contestant, None, args);
        }
        if let Some(path) = args.run.as_ref().filter(|p| is_onnx(p)) {
            if args.checkpoint.is_some() || args.actions.is_some() || args.stochastic {
                return Err(format!(
                    "--run {}: an ONNX file holds one deterministic policy (no --checkpoint, \
                     --actions or --stochastic)",
                    path.display()
                ));
            }
            let exported = exported_config(path)?;
            let contestant = format!("{}", path.display()).parse::<Contestant>()?;
            return outside(contestant, exported, args);
        }
        if let (Some(dir), Some(_)) = (&args.run, args.seed) {
            return Err(format!(
                "--seed: a run ({}) is tested on its own seeds",
                dir.display()
            ));
        }
        match (&args.run, args.policy) {
            (_, Some(policy)) => {
                let (env, config_seed) = match &args.config {
                    Some(path) => {
                        let c = RunConfig::load(path).map_err(|e| e.to_string())?;
                        (c.env, c.protocol.seed)
                    }
                    None => (FoosballConfig::preset(args.preset.unwrap_or_default()), 0),
                };
                let seed = args.seed.unwrap_or(config_seed);
                let planner = match (&args.planner, policy) {
                    (None, _) => None,
                    (Some(path), ScriptedPolicy::Planner) => Some(PlannerConfig::load(path)?),
                    (Some(_), other) => {
                        return Err(format!(
                            "--planner sets the planner's budget; --policy is {}",
                            other.name()
                        ));
                    }
                };
                Ok(Player::Scripted(Box::new(Baseline {
                    policy,
                    seed,
                    env,
                    planner,
                })))
            }
            (Some(dir), None) => {
                let mut config = RunConfig::load_run(dir).map_err(|e| e.to_string())?;
                if let Some((option, table)) = other_table(args, &config.env)? {
                    means_the_same(&config.env, &table)
                        .map_err(|why| format!("{option}: {}: {why}", dir.display()))?;
                    config.env = table;
                }
                let checkpoint = args.checkpoint.unwrap_or(Checkpoint::Best);
                let networks = dir.join(checkpoint.name());
                if !networks.is_dir() {
                    return Err(format!(
                        "{}: no saved networks (the run has not reached its first {} checkpoint)",
                        networks.display(),
                        checkpoint.name()
                    ));
                }
                let actions = match (args.stochastic, args.actions) {
                    (true, _) => TestActions::Stochastic,
                    (false, Some(a)) => a,
                    (false, None) => config.protocol.test_actions,
                };
                Ok(Player::Networks {
                    dir: dir.clone(),
                    config: Box::new(config),
                    checkpoint,
                    actions,
                })
            }
            (None, None) => Err("give --run RUN or --policy NAME".into()),
        }
    }

    /// `contestant`'s standard test on `preset`'s table against the static black: a run
    /// on its own test seeds, keeping its observation and its action map (a map only says
    /// how its outputs become servo targets, as a match translates them), whatever
    /// opponent it trained against; an ONNX file or a program as `evaluate --preset`
    /// plays it (an exported run's seeds, else seed 0's), a scripted policy on seed 0's.
    /// A contestant with held rods plays matches only.
    pub fn standard_test(contestant: &Contestant, preset: Preset) -> Result<Player, String> {
        let table = FoosballConfig::preset(preset);
        let on = PlayerArgs {
            preset: Some(preset),
            ..PlayerArgs::default()
        };
        let args = match contestant {
            Contestant::Run {
                dir,
                checkpoint,
                actions,
            } => {
                let mut config = RunConfig::load_run(dir).map_err(|e| e.to_string())?;
                plays_on(&config.env, &table).map_err(|why| format!("{}: {why}", dir.display()))?;
                config.env = FoosballConfig {
                    observation: config.env.observation,
                    action_map: config.env.action_map,
                    ..table
                };
                return Ok(Player::Networks {
                    dir: dir.clone(),
                    config: Box::new(config),
                    checkpoint: *checkpoint,
                    actions: *actions,
                });
            }
            Contestant::Scripted(policy) => PlayerArgs {
                policy: Some(*policy),
                ..on
            },
            Contestant::Onnx { path } => PlayerArgs {
                run: Some(path.clone()),
                ..on
            },
            Contestant::Process { command } => PlayerArgs {
                process: Some(command.clone()),
                ..on
            },
            Contestant::Held { .. } => {
                return Err(format!(
                    "{contestant}: a contestant with held rods plays matches, not the test"
                ));
            }
        };
        Player::from_args(&args)
    }

    /// The table it plays on.
    pub fn env(&self) -> &FoosballConfig {
        match self {
            Player::Networks { config, .. } => &config.env,
            Player::Scripted(b) => &b.env,
            Player::Outside { env, .. } => env,
        }
    }

    /// Test episodes when none are asked for: the run's protocol, or 1,000.
    pub fn default_episodes(&self) -> u32 {
        match self {
            Player::Networks { config, .. } => config.protocol.test_episodes,
            Player::Scripted(_) | Player::Outside { .. } => 1000,
        }
    }

    /// A short name: `sac 64x64 (last networks of runs/x, deterministic actions) on
    /// reference`, `shooter under reference`.
    pub fn describe(&self) -> String {
        match self {
            Player::Networks {
                dir,
                config,
                checkpoint,
                actions,
            } => format!(
                "{} {} ({} networks of {}, {} actions) on {}",
                config.algo(),
                config.hidden_label(),
                checkpoint.name(),
                dir.display(),
                actions.name(),
                config.env.preset.name()
            ),
            Player::Scripted(b) => format!("{} under {}", b.policy.name(), b.env.preset.name()),
            Player::Outside {
                contestant, env, ..
            } => format!(
                "{contestant} ({}) on {}",
                contestant.about(),
                env.preset.name()
            ),
        }
    }

    /// Plays `episodes` test episodes on the test seeds (steps kept when `record`), in
    /// seed order.
    pub fn play(&self, episodes: u32, record: bool) -> Result<Vec<PlayedEpisode>, String> {
        match self {
            Player::Networks {
                dir,
                config,
                checkpoint,
                actions,
            } => {
                let mut agent = load_agent(config, &dir.join(checkpoint.name()))?;
                let episodes = Episodes {
                    env: &config.env,
                    seed: config.protocol.seed,
                    stream: TEST_ENVS,
                    n: episodes,
                    record,
                };
                play_agent(agent.as_mut(), *actions, &episodes).map_err(|e| e.to_string())
            }
            Player::Scripted(b) => b.play(episodes, record).map_err(|e| e.to_string()),
            Player::Outside {
                contestant,
                env,
                seed,
            } => {
                let mut policy = contestant.policy(env, *seed)?;
                let episodes = Episodes {
                    env,
                    seed: *seed,
                    stream: TEST_ENVS,
                    n: episodes,
                    record,
                };
                play_owned(&mut policy, &episodes).map_err(|e| e.to_string())
            }
        }
    }

    /// It as one side of a two-sided match.
    pub fn contestant(&self) -> Contestant {
        match self {
            Player::Networks {
                dir,
                checkpoint,
                actions,
                ..
            } => Contestant::Run {
                dir: dir.clone(),
                checkpoint: *checkpoint,
                actions: *actions,
            },
            Player::Scripted(b) => Contestant::Scripted(b.policy),
            Player::Outside { contestant, .. } => contestant.clone(),
        }
    }

    /// Plays `episodes` test episodes and writes the test files into `dir` (with
    /// `baseline.toml` for a scripted policy).
    pub fn test(&self, episodes: u32, dir: &Path) -> Result<TestMetrics, String> {
        match self {
            Player::Networks { .. } | Player::Outside { .. } => {
                let played = self.play(episodes, true)?;
                write_test(dir, &played).map_err(|e| e.to_string())
            }
            Player::Scripted(b) => b.test(episodes, dir, true).map_err(|e| e.to_string()),
        }
    }
}
