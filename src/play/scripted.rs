//! Scripted policies for yellow, played through the same evaluation as trained agents:
//! the yardsticks of the report (`evaluate --policy shooter|dribbler|zero|random|blocker`), and
//! the planner's ceiling (`evaluate --policy planner`, [`super::planned`]).

use super::evaluation::{Episodes, OwnedPolicy, PlayError, PlayedEpisode, play_owned, write_test};
use super::metrics::TestMetrics;
use super::planned::{PlanCost, play_planned};
use crate::files::{RunFileError, write_atomic};
use crate::plan::PlannerConfig;
use foosball_env::foosball::from_ball_frame;
use foosball_env::layout::OBS_DIM;
use foosball_env::opponent::{RandomOpponent, ScriptedOpponent, StaticOpponent};
use foosball_env::scripted::Kicker;
use foosball_env::seeding::TEST_ENVS;
use foosball_env::seeding::derive_seed;
use foosball_env::{EnvRng, Opponent};
use foosball_env::{FoosballConfig, ObservationKind};
use rand::SeedableRng;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A hand-written controller of yellow's four rods.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ScriptedPolicy {
    /// Lines the man behind the ball up with the clearest line to goal and kicks hard.
    Shooter,
    /// The same aim with gentle taps: walks the ball up the table.
    Dribbler,
    /// Every command 0: rods hold neutral, feet down.
    Zero,
    /// Every command uniform in [-1, 1] each step.
    Random,
    /// Feet down, each rod slid to put a man in the ball's path: the goalkeeper-style
    /// blocker that plays black as `env.opponent = "scripted"` and self-play's `scripted`
    /// anchor. It never kicks on purpose.
    Blocker,
    /// Searches the simulator for the best plan of each episode from its start and plays
    /// it: the task's empirical ceiling from those starts (not a policy of observations:
    /// it cannot play black in a match).
    Planner,
}

impl ScriptedPolicy {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            ScriptedPolicy::Shooter => "shooter",
            ScriptedPolicy::Dribbler => "dribbler",
            ScriptedPolicy::Zero => "zero",
            ScriptedPolicy::Random => "random",
            ScriptedPolicy::Blocker => "blocker",
            ScriptedPolicy::Planner => "planner",
        }
    }

    /// The policy over batches of observations of a table configured as `env`; `seed`
    /// fixes the random policy's draws (one stream, rows in batch order, so a fixed batch
    /// layout replays exactly). The hand-written controllers read the ball in world
    /// coordinates and write linear commands: both are translated from and into `env`'s
    /// `ball_frame` and `action_map`. The planner has none: it plans from an episode's
    /// seed, not from observations (the error says so).
    pub fn batch_policy(self, seed: u64, env: &FoosballConfig) -> Result<OwnedPolicy, String> {
        let controller: Box<dyn Opponent> = match self {
            ScriptedPolicy::Shooter => Box::new(Kicker::shooter()),
            ScriptedPolicy::Dribbler => Box::new(Kicker::dribbler()),
            ScriptedPolicy::Zero => Box::new(StaticOpponent),
            ScriptedPolicy::Random => Box::new(RandomOpponent),
            ScriptedPolicy::Blocker => Box::new(ScriptedOpponent),
            ScriptedPolicy::Planner => {
                return Err(
                    "planner: it plans each episode from its seed with the simulator; it has no \
                     policy of observations to play a match or a batch with"
                        .into(),
                );
            }
        };
        let mut policy = controller_policy(controller, seed, env);
        Ok(Box::new(move |obs: &[f32]| Ok(policy(obs))))
    }
}

/// A hand-written controller over batches of observations, movable to another thread: it
/// cannot fail (an [`OwnedPolicy`] of it always answers).
pub type ControllerPolicy = Box<dyn FnMut(&[f32]) -> Vec<f32> + Send>;

/// `controller` (a hand-written player: it reads the ball in world coordinates and writes
/// linear commands) as a policy over batches of observations of a table configured as
/// `env`: each row translated from `env`'s `ball_frame`, each action into its
/// `action_map`; `seed` fixes a random controller's draws (one stream, rows in batch
/// order).
pub fn controller_policy(
    mut controller: Box<dyn Opponent>,
    seed: u64,
    env: &FoosballConfig,
) -> ControllerPolicy {
    let mut rng = EnvRng::seed_from_u64(seed);
    let (frame, map) = (env.ball_frame, env.action_map);
    Box::new(move |obs: &[f32]| {
        obs.chunks_exact(OBS_DIM)
            .flat_map(|row| {
                let row: &[f32; OBS_DIM] = row.try_into().expect("chunks of OBS_DIM");
                controller.act_in(map, &from_ball_frame(row, frame), &mut rng)
            })
            .collect()
    })
}

/// A scripted policy's test on a table (`evaluate --policy`, a sweep's baselines), saved
/// beside its metrics as `baseline.toml`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Baseline {
    /// The scripted policy.
    pub policy: ScriptedPolicy,
    /// The seed the test seeds derive from.
    pub seed: u64,
    /// The table it played on.
    pub env: FoosballConfig,
    /// The planner's search budget (the planner only; its defaults when left out).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub planner: Option<PlannerConfig>,
}

impl Baseline {
    /// Plays `episodes` test episodes (trajectories recorded when `record`) and writes
    /// `metrics.json`, `metrics.md`, `trajectories.bin` and `baseline.toml` into `dir`.
    /// The planner also writes `planner.json` (what its searches cost).
    pub fn test(&self, episodes: u32, dir: &Path, record: bool) -> Result<TestMetrics, PlayError> {
        let (played, cost) = self.play_with_cost(episodes, record)?;
        let metrics = write_test(dir, &played)?;
        if let Some(cost) = cost {
            cost.write(dir)?;
        }
        self.write(dir)?;
        Ok(metrics)
    }

    /// Plays `episodes` test episodes (steps kept when `record`), in seed order.
    pub fn play(&self, episodes: u32, record: bool) -> Result<Vec<PlayedEpisode>, PlayError> {
        Ok(self.play_with_cost(episodes, record)?.0)
    }

    /// [`Baseline::play`], with the planner's search cost.
    fn play_with_cost(
        &self,
        episodes: u32,
        record: bool,
    ) -> Result<(Vec<PlayedEpisode>, Option<PlanCost>), PlayError> {
        if self.policy == ScriptedPolicy::Planner {
            let seeds: Vec<u64> = (0..u64::from(episodes))
                .map(|k| derive_seed(self.seed, TEST_ENVS, k))
                .collect();
            let planner = self.planner.clone().unwrap_or_default();
            let (played, cost) = play_planned(&self.env, &planner, (self.seed, &seeds), record)?;
            return Ok((played, Some(cost)));
        }
        if self.env.observation.kind != ObservationKind::State {
            return Err(PlayError::Env(format!(
                "env.observation.kind: {} reads the 38-dim state; set it to \"state\"",
                self.policy.name()
            )));
        }
        let mut act = self
            .policy
            .batch_policy(self.seed, &self.env)
            .map_err(PlayError::Env)?;
        let episodes = Episodes {
            env: &self.env,
            seed: self.seed,
            stream: TEST_ENVS,
            n: episodes,
            record,
        };
        Ok((play_owned(&mut act, &episodes)?, None))
    }

    /// Writes `dir/baseline.toml`.
    pub fn write(&self, dir: &Path) -> Result<(), RunFileError> {
        let text = toml::to_string_pretty(self).expect("a baseline always serialises");
        write_atomic(&dir.join("baseline.toml"), text.as_bytes())
    }

    /// Reads `dir/baseline.toml`; the error says why it cannot.
    pub fn read(dir: &Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(dir.join("baseline.toml")).map_err(|e| e.to_string())?;
        toml::from_str(&text).map_err(|e| e.message().trim().to_string())
    }
}
