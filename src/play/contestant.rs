//! Who plays one side of a two-sided match: a run's saved networks, a scripted policy, a
//! policy from outside (an ONNX file, or a program speaking `act`'s line protocol), named
//! on the command line as `shooter`, `blocker`, ..., `DIR[@best|@last][~sampled]`,
//! `FILE.onnx` or `process:COMMAND`, any of them with `+hold=ROD[,ROD]` to hold some of
//! its rods at neutral (a diagnosis: which rod's play lets goals in).

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use clap::ValueEnum;
use foosball_algos::ActMode;
use foosball_env::config::ActionMap;
use foosball_env::geometry::RODS;
use foosball_env::layout::{ACTION_DIM, OBS_DIM, action_slide, action_turn};
use foosball_env::seeding::{ACTION_SAMPLING, derive_seed};
use foosball_env::{FoosballConfig, ObservationKind};
use serde::{Deserialize, Serialize};

use super::evaluation::OwnedPolicy;
use super::process::{ANSWER_LIMIT, ProcessPolicy};
use super::scripted::ScriptedPolicy;
use crate::agents::load_agent;
use crate::config::{Checkpoint, RunConfig, TestActions};
use crate::onnx::CONFIG_KEY;
use crate::onnx::runtime::{OnnxPolicy, read_metadata};

/// One side's player.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Contestant {
    /// A hand-written policy (`zero` holds every rod at neutral: the paper's static black).
    Scripted(ScriptedPolicy),
    /// The networks a run saved.
    Run {
        /// The run directory.
        dir: PathBuf,
        /// Which networks (default last, what a run's test plays).
        checkpoint: Checkpoint,
        /// How they act (default deterministic).
        actions: TestActions,
    },
    /// A policy in an ONNX file (`FILE.onnx`, [`crate::onnx`]): the table's 38 state
    /// values in, 8 actions out.
    Onnx {
        /// The file.
        path: PathBuf,
    },
    /// A program that answers observations with actions in `act`'s line protocol
    /// (`process:COMMAND`, started with `sh -c`; [`super::process`]).
    Process {
        /// The command line.
        command: String,
    },
    /// Another contestant whose commands for some rods are replaced by 0 (the rod held at
    /// neutral, feet down) every step.
    Held {
        /// Who plays the other rods.
        player: Box<Contestant>,
        /// The held rods: indices into [`RODS`] (0 goalie, 1 defence, 2 midfield, 3
        /// attack), ascending, no repeats.
        rods: Vec<usize>,
    },
}

impl FromStr for Contestant {
    type Err = String;

    /// `shooter`, `dribbler`, `zero`, `random`, `blocker`, a run directory with optional
    /// `@best`/`@last` and `~sampled` (e.g. `results/figure2/sac-seed0@best~sampled`), an
    /// ONNX file `FILE.onnx` or `process:COMMAND`, any followed by `+hold=ROD[,ROD]` with
    /// rods named as in [`RODS`].
    fn from_str(s: &str) -> Result<Self, String> {
        if let Some((player, names)) = s.rsplit_once("+hold=") {
            return player
                .parse::<Contestant>()?
                .holding(names)
                .map_err(|why| format!("contestant `{s}`: {why}"));
        }
        if let Some(command) = s.strip_prefix("process:") {
            if command.trim().is_empty() {
                return Err(format!("contestant `{s}`: no command after `process:`"));
            }
            return Ok(Contestant::Process {
                command: command.to_string(),
            });
        }
        if is_onnx(Path::new(s)) {
            let path = PathBuf::from(s);
            if !path.is_file() {
                return Err(format!("contestant `{s}`: no such ONNX file"));
            }
            return Ok(Contestant::Onnx { path });
        }
        for policy in [
            ScriptedPolicy::Shooter,
            ScriptedPolicy::Dribbler,
            ScriptedPolicy::Zero,
            ScriptedPolicy::Random,
            ScriptedPolicy::Blocker,
        ] {
            if s == policy.name() {
                return Ok(Contestant::Scripted(policy));
            }
        }
        let (rest, actions) = match s.strip_suffix("~sampled") {
            Some(rest) => (rest, TestActions::Stochastic),
            None => (s, TestActions::Deterministic),
        };
        let (dir, checkpoint) = match rest.rsplit_once('@') {
            Some((dir, "best")) => (dir, Checkpoint::Best),
            Some((dir, "last")) => (dir, Checkpoint::Last),
            Some((_, other)) => {
                return Err(format!(
                    "contestant `{s}`: unknown networks `@{other}` (best or last)"
                ));
            }
            None => (rest, Checkpoint::Last),
        };
        let dir = PathBuf::from(dir);
        if !dir.join("config.toml").is_file() {
            return Err(format!(
                "contestant `{s}`: neither a scripted policy (shooter, dribbler, zero, \
                 random, blocker) nor a run directory ({} has no config.toml)",
                dir.display()
            ));
        }
        Ok(Contestant::Run {
            dir,
            checkpoint,
            actions,
        })
    }
}

impl fmt::Display for Contestant {
    /// The name it is parsed from (a run by its path).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Contestant::Scripted(p) => f.write_str(p.name()),
            Contestant::Run {
                dir,
                checkpoint,
                actions,
            } => {
                write!(f, "{}@{}", dir.display(), checkpoint.name())?;
                if *actions == TestActions::Stochastic {
                    f.write_str("~sampled")?;
                }
                Ok(())
            }
            Contestant::Onnx { path } => write!(f, "{}", path.display()),
            Contestant::Process { command } => write!(f, "process:{command}"),
            Contestant::Held { player, rods } => {
                write!(f, "{player}+hold={}", rod_names(rods, ","))
            }
        }
    }
}

impl Contestant {
    /// What it is, in one line for a person: a scripted policy's description, or a run's
    /// algorithm, networks, game and opponents in training (read from its `config.toml`).
    pub fn about(&self) -> String {
        match self {
            Contestant::Scripted(p) => {
                let help = p
                    .to_possible_value()
                    .and_then(|v| v.get_help().map(ToString::to_string))
                    .unwrap_or_default();
                format!("scripted: {help}")
            }
            Contestant::Onnx { path } => match exported_config(path) {
                Ok(Some(c)) => format!(
                    "ONNX export of {} {} networks trained {} env steps on {}",
                    c.algo(),
                    c.hidden_label(),
                    c.protocol.total_env_steps(),
                    c.env.preset.name()
                ),
                Ok(None) => "an ONNX policy".to_string(),
                Err(e) => format!("an ONNX policy ({e})"),
            },
            Contestant::Process { .. } => "a program answering in act's line protocol".into(),
            Contestant::Run {
                dir,
                checkpoint,
                actions,
            } => match RunConfig::load_run(dir) {
                Ok(c) => {
                    let own = c.protocol.total_env_steps();
                    let steps = match steps_in_all(&c) {
                        all if all > own => format!("{all} env steps ({own} in its last stage)"),
                        _ => format!("{own} env steps"),
                    };
                    let against = match &c.self_play {
                        Some(_) => "in self-play against its own snapshots".to_string(),
                        None => format!("against black {}", c.env.opponent.name()),
                    };
                    let sampled = match actions {
                        TestActions::Stochastic => ", sampled actions",
                        TestActions::Deterministic => "",
                    };
                    format!(
                        "{} {} networks trained {steps} on {} {against}; its {} \
                         networks{sampled}",
                        c.algo(),
                        c.hidden_label(),
                        c.env.preset.name(),
                        checkpoint.name()
                    )
                }
                Err(e) => format!("a run ({e})"),
            },
            Contestant::Held { player, rods } => {
                format!(
                    "{}; its {} held at neutral",
                    player.about(),
                    rod_names(rods, ", ")
                )
            }
        }
    }

    /// Its run directory (none for a scripted policy).
    pub fn run_dir(&self) -> Option<&Path> {
        match self {
            Contestant::Scripted(_) | Contestant::Onnx { .. } | Contestant::Process { .. } => None,
            Contestant::Run { dir, .. } => Some(dir),
            Contestant::Held { player, .. } => player.run_dir(),
        }
    }

    /// The folder a page links it to: a run's directory, the folder of an ONNX file
    /// (where an outside entry keeps how it was trained and its test); none for a
    /// scripted policy or a program.
    pub fn home(&self) -> Option<&Path> {
        match self {
            Contestant::Onnx { path } => path.parent(),
            other => other.run_dir(),
        }
    }

    /// A short name for tables: a scripted policy's name; a run's last `depth` path
    /// components, `@best` and `~sampled` after them where they apply (the last networks,
    /// deterministic, being the default); `+hold=...` as in its full name.
    pub fn short_name(&self, depth: usize) -> String {
        match self {
            Contestant::Scripted(p) => p.name().to_string(),
            Contestant::Onnx { path } => last_components(path, depth),
            Contestant::Process { command } => format!("process:{command}"),
            Contestant::Run {
                dir,
                checkpoint,
                actions,
            } => {
                let mut name = last_components(dir, depth);
                if *checkpoint == Checkpoint::Best {
                    name += "@best";
                }
                if *actions == TestActions::Stochastic {
                    name += "~sampled";
                }
                name
            }
            Contestant::Held { player, rods } => {
                format!("{}+hold={}", player.short_name(depth), rod_names(rods, ","))
            }
        }
    }

    /// It with the rods named in `names` (`goalie,midfield`: [`RODS`]' names, comma
    /// separated) held at neutral; an error names an unknown rod.
    pub fn holding(self, names: &str) -> Result<Contestant, String> {
        Ok(Contestant::Held {
            player: Box::new(self),
            rods: held_rods(names)?,
        })
    }

    /// Its policy on `table`, seeded by `seed` where it draws (random commands, sampled
    /// actions). A run's networks (and an ONNX file exported from a run) must have been
    /// trained on observations and actions that mean on `table` what they meant in
    /// training; a refusal says what differs. An outside policy without a run's
    /// configuration is taken to read and write the table's own `ball_frame` and
    /// `action_map`.
    pub fn policy(&self, table: &FoosballConfig, seed: u64) -> Result<OwnedPolicy, String> {
        match self {
            Contestant::Scripted(p) => p.batch_policy(seed, table),
            Contestant::Onnx { path } => {
                let onnx = OnnxPolicy::load(path, OBS_DIM, ACTION_DIM)?;
                let trained_map = match exported_config(path)? {
                    Some(c) => {
                        plays_on(&c.env, table)
                            .map_err(|why| format!("{}: {why}", path.display()))?;
                        c.env.action_map
                    }
                    None => table.action_map,
                };
                let table_map = table.action_map;
                Ok(Box::new(move |obs: &[f32]| {
                    Ok(translated(onnx.act(obs)?, trained_map, table_map))
                }))
            }
            Contestant::Process { command } => {
                let mut process =
                    ProcessPolicy::start(command, (OBS_DIM, ACTION_DIM), ANSWER_LIMIT)?;
                Ok(Box::new(move |obs: &[f32]| process.act(obs)))
            }
            Contestant::Run {
                dir,
                checkpoint,
                actions,
            } => {
                let config = RunConfig::load_run(dir).map_err(|e| e.to_string())?;
                plays_on(&config.env, table).map_err(|why| format!("{}: {why}", dir.display()))?;
                let (trained_map, table_map) = (config.env.action_map, table.action_map);
                let mut agent = load_agent(&config, &dir.join(checkpoint.name()))?;
                let mode = match actions {
                    TestActions::Deterministic => ActMode::Deterministic,
                    TestActions::Stochastic => {
                        agent.seed_sampling(derive_seed(seed, ACTION_SAMPLING, 0));
                        ActMode::Sample
                    }
                };
                let observation = config.env.observation;
                Ok(Box::new(move |obs: &[f32]| {
                    let action = if observation.hide_black_rods {
                        let mut seen = obs.to_vec();
                        observation.conceal(&mut seen);
                        agent.act(&seen, mode)
                    } else {
                        agent.act(obs, mode)
                    };
                    Ok(translated(action, trained_map, table_map))
                }))
            }
            Contestant::Held { player, rods } => {
                let mut policy = player.policy(table, seed)?;
                let held: Vec<usize> = rods
                    .iter()
                    .flat_map(|&r| [action_slide(r), action_turn(r)])
                    .collect();
                Ok(Box::new(move |obs: &[f32]| {
                    let mut action = policy(obs)?;
                    for &i in &held {
                        if let Some(a) = action.get_mut(i) {
                            *a = 0.0;
                        }
                    }
                    Ok(action)
                }))
            }
        }
    }
}

/// `actions` (`[n, 8]`) written in `trained`'s action map, in `table`'s
/// ([`foosball_env::config::ActionMap::translate`]: the same servo targets).
fn translated(actions: Vec<f32>, trained: ActionMap, table: ActionMap) -> Vec<f32> {
    if trained == table {
        return actions;
    }
    actions
        .chunks_exact(ACTION_DIM)
        .flat_map(|row| {
            let row: [f32; ACTION_DIM] = row.try_into().expect("chunks of 8");
            trained.translate(table, row)
        })
        .collect()
}

/// The configuration of the run an ONNX file was exported from, where `export` wrote it
/// into the file; an error names the file.
pub fn exported_config(path: &Path) -> Result<Option<RunConfig>, String> {
    let Some(text) = read_metadata(path, CONFIG_KEY)? else {
        return Ok(None);
    };
    let name = path.join(CONFIG_KEY);
    RunConfig::from_toml(&text, &name)
        .map(Some)
        .map_err(|e| e.to_string())
}

/// Whether `path` names an ONNX file rather than a run directory (its extension).
pub fn is_onnx(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "onnx")
}

/// The last `depth` (at least one) components of `path`, joined by `/`.
fn last_components(path: &Path, depth: usize) -> String {
    let parts: Vec<String> = path
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    parts[parts.len().saturating_sub(depth.max(1))..].join("/")
}

/// Env steps a run's networks trained in all: its own protocol's and those of the runs
/// it started from (`protocol.init_from`, followed back while their directories hold a
/// run; at most 64 stages, so a cycle ends).
fn steps_in_all(config: &RunConfig) -> u64 {
    let mut steps = config.protocol.total_env_steps();
    let mut from = config.protocol.init_from.clone();
    for _ in 0..64 {
        let Some(Ok(Contestant::Run { dir, .. })) = from.as_deref().map(str::parse) else {
            break;
        };
        let Ok(earlier) = RunConfig::load_run(&dir) else {
            break;
        };
        steps += earlier.protocol.total_env_steps();
        from = earlier.protocol.init_from;
    }
    steps
}

/// The names of rods by index ([`RODS`]' names, `?` for none), joined by `sep`.
fn rod_names(rods: &[usize], sep: &str) -> String {
    let names: Vec<&str> = rods
        .iter()
        .map(|&r| RODS.get(r).map_or("?", |rod| rod.name))
        .collect();
    names.join(sep)
}

/// Rod indices from `goalie,midfield`-style names: ascending, each once.
fn held_rods(names: &str) -> Result<Vec<usize>, String> {
    let mut rods = names
        .split(',')
        .map(|name| {
            RODS.iter().position(|r| r.name == name).ok_or_else(|| {
                let known: Vec<&str> = RODS.iter().map(|r| r.name).collect();
                format!("unknown rod `{name}` to hold ({})", known.join(", "))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    rods.sort_unstable();
    rods.dedup();
    Ok(rods)
}

/// Whether networks trained on `trained` can start a run on `table`: the state
/// observation, read and written alike ([`means_the_same`]).
pub fn fits(trained: &FoosballConfig, table: &FoosballConfig) -> Result<(), String> {
    plays_on(trained, table)?;
    acts_alike(trained, table)
}

/// Whether a policy trained on `trained` can play a match on `table`: the state
/// observation in the same ball frame. Its actions are translated into `table`'s action
/// map where the maps differ ([`foosball_env::config::ActionMap::translate`]: the same
/// servo targets), so runs trained under either map meet on one table.
pub fn plays_on(trained: &FoosballConfig, table: &FoosballConfig) -> Result<(), String> {
    if trained.observation.kind != ObservationKind::State {
        return Err("it sees images; matches are played on the state observation".into());
    }
    sees_alike(trained, table)
}

/// Whether `table`'s observations and actions mean what they meant on `trained`: the
/// same ball frame and action map.
pub fn means_the_same(trained: &FoosballConfig, table: &FoosballConfig) -> Result<(), String> {
    sees_alike(trained, table)?;
    acts_alike(trained, table)
}

fn sees_alike(trained: &FoosballConfig, table: &FoosballConfig) -> Result<(), String> {
    if trained.ball_frame != table.ball_frame {
        return Err(format!(
            "it was trained with ball_frame = {:?}, the table has {:?}",
            trained.ball_frame, table.ball_frame
        ));
    }
    Ok(())
}

fn acts_alike(trained: &FoosballConfig, table: &FoosballConfig) -> Result<(), String> {
    if trained.action_map != table.action_map {
        return Err(format!(
            "it was trained with action_map = {:?}, the table has {:?}",
            trained.action_map, table.action_map
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn held_rods_parse_print_and_hold() {
        let c: Contestant = "random+hold=midfield,goalie,midfield".parse().unwrap();
        assert_eq!(
            c,
            Contestant::Held {
                player: Box::new(Contestant::Scripted(ScriptedPolicy::Random)),
                rods: vec![0, 2],
            }
        );
        assert_eq!(c.to_string(), "random+hold=goalie,midfield");
        let table = FoosballConfig::default();
        let mut policy = c.policy(&table, 3).unwrap();
        for _ in 0..20 {
            let a = policy(&[0.0; OBS_DIM]).unwrap();
            assert_eq!([a[0], a[1], a[4], a[5]], [0.0; 4]);
            assert!([a[2], a[3], a[6], a[7]].iter().all(|v| *v != 0.0));
        }
    }

    #[test]
    fn an_unknown_held_rod_is_named() {
        let err = "zero+hold=keeper".parse::<Contestant>().unwrap_err();
        assert!(err.contains("unknown rod `keeper`"), "{err}");
        assert!(err.contains("goalie, defence, midfield, attack"), "{err}");
        let err = "nowhere+hold=goalie".parse::<Contestant>().unwrap_err();
        assert!(err.contains("nowhere"), "{err}");
    }
}
