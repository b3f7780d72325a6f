//! Who plays one side of a two-sided match: a run's saved networks or a scripted policy,
//! named on the command line as `shooter`, `blocker`, ... or `DIR[@best|@last][~sampled]`.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use foosball_algos::ActMode;
use foosball_env::seeding::{ACTION_SAMPLING, derive_seed};
use foosball_env::{FoosballConfig, ObservationKind};
use serde::{Deserialize, Serialize};

use super::evaluation::OwnedPolicy;
use super::scripted::ScriptedPolicy;
use crate::agents::load_agent;
use crate::config::{Checkpoint, RunConfig, TestActions};

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
}

impl FromStr for Contestant {
    type Err = String;

    /// `shooter`, `dribbler`, `zero`, `random`, `blocker`, or a run directory with optional
    /// `@best`/`@last` and `~sampled` (e.g. `results/figure2/sac-seed0@best~sampled`).
    fn from_str(s: &str) -> Result<Self, String> {
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
        }
    }
}

impl Contestant {
    /// Its policy on `table`, seeded by `seed` where it draws (random commands, sampled
    /// actions). A run's networks must have been trained on observations and actions
    /// that mean on `table` what they meant in training; a refusal says what differs.
    pub fn policy(&self, table: &FoosballConfig, seed: u64) -> Result<OwnedPolicy, String> {
        match self {
            Contestant::Scripted(p) => p.batch_policy(seed, table),
            Contestant::Run {
                dir,
                checkpoint,
                actions,
            } => {
                let config = RunConfig::load_run(dir).map_err(|e| e.to_string())?;
                fits(&config.env, table).map_err(|why| format!("{}: {why}", dir.display()))?;
                let mut agent = load_agent(&config, &dir.join(checkpoint.name()))?;
                Ok(match actions {
                    TestActions::Deterministic => {
                        Box::new(move |obs: &[f32]| agent.act(obs, ActMode::Deterministic))
                    }
                    TestActions::Stochastic => {
                        agent.seed_sampling(derive_seed(seed, ACTION_SAMPLING, 0));
                        Box::new(move |obs: &[f32]| agent.act(obs, ActMode::Sample))
                    }
                })
            }
        }
    }
}

/// Whether a policy trained on `trained` reads and writes `table`'s observations and
/// actions alike: the state observation, the same ball frame and action map.
pub fn fits(trained: &FoosballConfig, table: &FoosballConfig) -> Result<(), String> {
    if trained.observation.kind != ObservationKind::State {
        return Err("it sees images; matches are played on the state observation".into());
    }
    if trained.ball_frame != table.ball_frame {
        return Err(format!(
            "it was trained with ball_frame = {:?}, the match table has {:?}",
            trained.ball_frame, table.ball_frame
        ));
    }
    if trained.action_map != table.action_map {
        return Err(format!(
            "it was trained with action_map = {:?}, the match table has {:?}",
            trained.action_map, table.action_map
        ));
    }
    Ok(())
}
