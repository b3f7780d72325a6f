//! The run configuration: one TOML file (`configs/<algo>.toml`) holding the protocol, the
//! environment and the algorithm's settings. Unknown keys and invalid values are refused
//! with the file, the line and the dotted key.

use crate::plan::PlannerConfig;
use foosball_algos::{
    FourierConfig, NetConfig, NormalizeConfig, OffPolicyConfig, PpoConfig, SacConfig, Td3Config,
};
use foosball_env::config_file::{self, ExtendsError, Layers, line_at};
use foosball_env::starts::validate_drills;
use foosball_env::{ConfigError, Drill, FoosballConfig, ObservationKind, OpponentKind, Serve};
use foosball_nets::Backend;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::fmt;
use std::path::{Path, PathBuf};

/// The widest hidden layer `backend = "auto"` puts on the host MLP path, in units. On one
/// thread that path's updates measured 1.6-2.9x flex's at 64x64 and about even at
/// 256x256 (0.8-1.5x over PPO, SAC and TD3, docs/table.md); wider layers, where flex's
/// threaded matrix products pay, stay on the default CPU backend.
pub const AUTO_HOST_WIDTH: usize = 256;

/// Which algorithm a run trains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Algo {
    /// Proximal Policy Optimization.
    Ppo,
    /// Soft Actor-Critic.
    Sac,
    /// Twin Delayed DDPG.
    Td3,
}

impl Algo {
    /// Lower-case name, as in file names and TOML.
    pub fn name(self) -> &'static str {
        match self {
            Algo::Ppo => "ppo",
            Algo::Sac => "sac",
            Algo::Td3 => "td3",
        }
    }
}

impl fmt::Display for Algo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// How a trained agent acts in a test: the paper's text tests deterministically, its code
/// (`model.predict(obs)`, SB3's default `deterministic=False`) samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum TestActions {
    /// The policy's deterministic action (the text's test).
    #[default]
    Deterministic,
    /// A draw from the policy's action distribution (the code's test); TD3's policy has
    /// no distribution, so its draw is its deterministic action, as in SB3.
    Stochastic,
}

impl TestActions {
    /// Lower-case name, as in TOML.
    pub fn name(self) -> &'static str {
        match self {
            TestActions::Deterministic => "deterministic",
            TestActions::Stochastic => "stochastic",
        }
    }
}

/// Which saved networks of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Checkpoint {
    /// The networks of the best evaluation.
    Best,
    /// The networks after the last finished epoch.
    #[default]
    Last,
}

impl Checkpoint {
    /// Lower-case name, also the folder the run keeps them in.
    pub fn name(self) -> &'static str {
        match self {
            Checkpoint::Best => "best",
            Checkpoint::Last => "last",
        }
    }
}

/// What makes an evaluation the best so far (the networks kept in `best/`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BestBy {
    /// The highest mean return (SB3's `EvalCallback`, the paper code's `best_model.zip`).
    #[default]
    Return,
    /// The highest score rate, ties broken by the mean return (under `reference` the
    /// return rewards a slowly advancing ball more than a goal: docs/planner.md).
    ScoreRate,
}

/// The training and testing protocol (the paper's by default).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Protocol {
    /// Run seed; every random stream derives from it.
    pub seed: u64,
    /// Epochs (a checkpoint is written at the end of each).
    pub epochs: u32,
    /// Env steps per epoch, counted over all rollout workers.
    pub steps_per_epoch: u64,
    /// Env steps between evaluations.
    pub eval_every: u64,
    /// Deterministic episodes per evaluation, on held-out seeds.
    pub eval_episodes: u32,
    /// Episodes of the final test, on seeds held out from both.
    pub test_episodes: u32,
    /// How the agent acts in the final test: `deterministic` (the paper's text, default)
    /// or `stochastic` (its code). Evaluations during training are always deterministic.
    pub test_actions: TestActions,
    /// Which networks the final test plays: `last` (after the last epoch, default) or
    /// `best` (of the best evaluation by mean return, as the paper code's test loads
    /// SB3's `best_model.zip`).
    pub test_networks: Checkpoint,
    /// What makes an evaluation the best so far: `return` (default) or `score_rate`.
    pub best_by: BestBy,
    /// Rollout workers (environments stepped together).
    pub envs: usize,
    /// Rayon threads for env workers and the backend; 0 means one per core.
    pub threads: usize,
    /// Network backend; the default CPU backend when absent.
    pub backend: Option<Backend>,
    /// Networks to start from instead of fresh ones: a run's saved networks,
    /// `DIR[@best|@last]` (default last), trained with the same algorithm, network shapes,
    /// observation, ball frame and action map. Optimiser, buffer and counters start
    /// fresh (fine-tuning, e.g. self-play from a trained agent). Absent: fresh networks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub init_from: Option<String>,
    /// With `init_from`: zero every loaded network's input weights from black's 16 rod
    /// values ([`foosball_env::layout::black_rod_inputs`]), so the networks start blind to
    /// black and learn to read it again. For networks trained against the static black,
    /// whose rods barely move: their weights on those inputs were never fitted and answer
    /// a moving black with values far outside anything trained (docs/league.md). Default
    /// false (the networks as saved); refused when nothing is loaded.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub init_blind_to_black: bool,
    /// A `trajectories.bin` (what `evaluate` writes, e.g. the planner's episodes), or a
    /// list of them, whose transitions SAC and TD3 mix into their minibatches at
    /// `off_policy.demo_share`; their episodes must start from seeds other than this
    /// run's evaluation and test starts (`evaluate --seed` other than the run's).
    /// Absent: none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub demonstrations: Option<DemonstrationFiles>,
}

/// `protocol.demonstrations`: one file (`"a.bin"`) or several (`["a.bin", "b.bin"]`),
/// whose episodes fill one demonstration buffer in the order given (episodes recorded
/// against different opponents, say).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum DemonstrationFiles {
    /// One file.
    One(String),
    /// Several files.
    Many(Vec<String>),
}

impl DemonstrationFiles {
    /// The files, in order.
    pub fn paths(&self) -> &[String] {
        match self {
            DemonstrationFiles::One(path) => std::slice::from_ref(path),
            DemonstrationFiles::Many(paths) => paths,
        }
    }
}

impl Protocol {
    /// Env steps of the whole run: `epochs * steps_per_epoch`.
    pub fn total_env_steps(&self) -> u64 {
        u64::from(self.epochs) * self.steps_per_epoch
    }
}

impl Default for Protocol {
    fn default() -> Self {
        Self {
            seed: 0,
            epochs: 15,
            steps_per_epoch: 100_000,
            eval_every: 3_000,
            eval_episodes: 10,
            test_episodes: 1_000,
            test_actions: TestActions::Deterministic,
            test_networks: Checkpoint::Last,
            best_by: BestBy::Return,
            envs: 1,
            threads: 0,
            backend: None,
            init_from: None,
            init_blind_to_black: false,
            demonstrations: None,
        }
    }
}

/// Self-play (`[self_play]`; absent: black is `env.opponent`, as in the paper): black is
/// drawn per training episode from a pool of the learner's own snapshots and fixed anchors
/// (see `crate::self_play`). Evaluations and the test still play `env.opponent`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SelfPlayConfig {
    /// Env steps between snapshots of the learner into the pool (the first at step 0).
    pub snapshot_every: u64,
    /// The newest snapshots that can be drawn (older ones stay on disk, out of play).
    pub pool_size: usize,
    /// Share of episodes against the newest snapshot.
    pub latest_share: f64,
    /// Share of episodes against an anchor (uniform among `anchors`).
    pub anchor_share: f64,
    /// Fixed opponents, built-in black policies.
    pub anchors: Vec<OpponentKind>,
    /// More fixed opponents, named as `league` names its contestants: a run directory
    /// (`DIR[@best|@last][~sampled]`, its saved networks playing black, e.g. a trained
    /// agent the learner draws against in the league) or a scripted player (`blocker`,
    /// ...). Drawn like the anchors and after them: an anchor episode picks uniformly
    /// among `anchors` and `rivals` together. Each environment plays its own copy, seeded
    /// from the run's seed and the environment's index. Default none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub rivals: Vec<String>,
    /// Prioritised fictitious self-play over the rest: snapshot `j` is drawn with weight
    /// `(1 - p_j)^pfsp_power`, `p_j` the learner's points share against it (a win 1, a
    /// draw 1/2, one virtual draw as prior); 0 draws uniformly.
    pub pfsp_power: f64,
    /// Reward lost per agent step while the ball is in the learner's own goal (black
    /// scored); the own-goal line is black's goal line mirrored, as in matches.
    pub conceded_penalty: f32,
    /// Keep the table's "no progress" end (default false: off, as in matches, so that
    /// black's attacks play out; true keeps the paper's episode, where an attack of
    /// black's ends the episode within `rules.no_progress_steps`).
    pub no_progress_end: bool,
    /// Share of training episodes served on black's side (the table's start turned 180
    /// degrees, `env.start.black_share` of the learner's table): black's kick-off, as
    /// the learner meets it when it plays black in a match. Default 0 (every serve
    /// the learner's, as in the paper).
    pub black_serve_share: f32,
    /// Who serves the training episodes' balls (`env.start.serve` of the learner's
    /// table): `drawn` by `black_serve_share` (default), or `conceded`, as a match
    /// serves: after a goal the side scored upon, after a dead ball the side that served
    /// it, across a training env's episodes and the points of a `serve_again` one.
    #[serde(skip_serializing_if = "Serve::is_drawn")]
    pub serve: Serve,
    /// Training episodes played like a match (`env.rules.serve_again` on the learner's
    /// table): a goal, a dead ball or a ball without progress serves again, and the
    /// episode ends at `episode_steps`. Default false (the paper's episode: a still ball
    /// ends it, which a learner that loses more than it wins takes as its way out).
    pub serve_again: bool,
    /// Training episodes' time limit, agent steps (default: the table's
    /// `max_episode_steps`, 20,000 = 40 s under `reference`). A learner's record against
    /// an opponent counts episodes: goals for against goals against.
    pub episode_steps: Option<u32>,
}

impl Default for SelfPlayConfig {
    fn default() -> Self {
        Self {
            snapshot_every: 50_000,
            pool_size: 20,
            latest_share: 0.5,
            anchor_share: 0.2,
            anchors: vec![
                OpponentKind::Static,
                OpponentKind::Random,
                OpponentKind::Scripted,
                OpponentKind::Shooter,
            ],
            rivals: Vec::new(),
            pfsp_power: 2.0,
            conceded_penalty: 1000.0,
            no_progress_end: false,
            black_serve_share: 0.0,
            serve: Serve::Drawn,
            serve_again: false,
            episode_steps: None,
        }
    }
}

impl SelfPlayConfig {
    /// How many fixed opponents an anchor episode picks among: `anchors` then `rivals`.
    pub fn fixed_opponents(&self) -> usize {
        self.anchors.len() + self.rivals.len()
    }

    /// Rejects out-of-range values; keys under `self_play`.
    fn validate(&self) -> Result<(), ConfigError> {
        let err =
            |key: &str, message: String| ConfigError::new(format!("self_play.{key}"), message);
        if self.snapshot_every == 0 {
            return Err(err("snapshot_every", "must be positive".into()));
        }
        if self.pool_size == 0 {
            return Err(err("pool_size", "must be positive".into()));
        }
        for (key, v) in [
            ("latest_share", self.latest_share),
            ("anchor_share", self.anchor_share),
            ("black_serve_share", f64::from(self.black_serve_share)),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(err(key, format!("must be in [0, 1], got {v}")));
            }
        }
        if self.serve == Serve::Conceded && self.black_serve_share != 0.0 {
            return Err(err(
                "black_serve_share",
                format!(
                    "{} draws the serving side: leave it at 0 under self_play.serve = \"conceded\"",
                    self.black_serve_share
                ),
            ));
        }
        if self.latest_share + self.anchor_share > 1.0 {
            return Err(err(
                "anchor_share",
                format!(
                    "latest_share + anchor_share must be at most 1, got {} + {}",
                    self.latest_share, self.anchor_share
                ),
            ));
        }
        if self.anchor_share > 0.0 && self.fixed_opponents() == 0 {
            return Err(err(
                "anchors",
                "empty, and so is self_play.rivals, but anchor_share > 0 draws from them: \
                 name at least one (static, random, scripted, shooter, dribbler) or set \
                 anchor_share = 0"
                    .into(),
            ));
        }
        if self.episode_steps == Some(0) {
            return Err(err("episode_steps", "must be at least 1".into()));
        }
        if !(self.pfsp_power.is_finite() && self.pfsp_power >= 0.0) {
            return Err(err(
                "pfsp_power",
                format!("must be a finite number >= 0, got {}", self.pfsp_power),
            ));
        }
        if !(self.conceded_penalty.is_finite() && self.conceded_penalty >= 0.0) {
            return Err(err(
                "conceded_penalty",
                format!(
                    "must be a finite number >= 0, got {}",
                    self.conceded_penalty
                ),
            ));
        }
        Ok(())
    }
}

/// The algorithm a run trains with its settings: the TOML's `algo` and its section.
#[derive(Clone, Debug, PartialEq)]
pub enum AlgoConfig {
    /// `algo = "ppo"` and `[ppo]`.
    Ppo(PpoConfig),
    /// `algo = "sac"` and `[sac]`.
    Sac(SacConfig),
    /// `algo = "td3"` and `[td3]`.
    Td3(Td3Config),
}

impl AlgoConfig {
    /// `algo`'s default settings.
    pub fn default_for(algo: Algo) -> Self {
        match algo {
            Algo::Ppo => AlgoConfig::Ppo(PpoConfig::default()),
            Algo::Sac => AlgoConfig::Sac(SacConfig::default()),
            Algo::Td3 => AlgoConfig::Td3(Td3Config::default()),
        }
    }

    /// Which algorithm.
    pub fn algo(&self) -> Algo {
        match self {
            AlgoConfig::Ppo(_) => Algo::Ppo,
            AlgoConfig::Sac(_) => Algo::Sac,
            AlgoConfig::Td3(_) => Algo::Td3,
        }
    }

    /// The networks' settings.
    pub fn net(&self) -> &NetConfig {
        match self {
            AlgoConfig::Ppo(c) => &c.net,
            AlgoConfig::Sac(c) => &c.net,
            AlgoConfig::Td3(c) => &c.net,
        }
    }

    /// The networks' settings, to change.
    pub fn net_mut(&mut self) -> &mut NetConfig {
        match self {
            AlgoConfig::Ppo(c) => &mut c.net,
            AlgoConfig::Sac(c) => &mut c.net,
            AlgoConfig::Td3(c) => &mut c.net,
        }
    }

    /// The replay schedule of SAC and TD3 (`None` for PPO).
    pub fn off_policy(&self) -> Option<&OffPolicyConfig> {
        match self {
            AlgoConfig::Ppo(_) => None,
            AlgoConfig::Sac(c) => Some(&c.off_policy),
            AlgoConfig::Td3(c) => Some(&c.off_policy),
        }
    }

    /// The key that says how the learner takes demonstrations (SAC's and TD3's
    /// `off_policy.demo_share`, the share of each minibatch they fill; PPO's
    /// `[ppo.demonstrations]`, its cloning steps) and whether it is set.
    pub fn demonstrations_key(&self) -> (&'static str, bool) {
        match self {
            AlgoConfig::Ppo(c) => ("ppo.demonstrations", c.demonstrations.is_some()),
            AlgoConfig::Sac(c) => (
                "sac.off_policy.demo_share",
                c.off_policy.demo_share.is_some(),
            ),
            AlgoConfig::Td3(c) => (
                "td3.off_policy.demo_share",
                c.off_policy.demo_share.is_some(),
            ),
        }
    }

    /// Rejects out-of-range values; keys are under the algorithm's section.
    fn validate(&self) -> Result<(), ConfigError> {
        match self {
            AlgoConfig::Ppo(c) => c.validate(),
            AlgoConfig::Sac(c) => c.validate(),
            AlgoConfig::Td3(c) => c.validate(),
        }
        .map_err(|e| e.under(self.algo().name()))
    }
}

/// How the starts of a `[curriculum]` move back from the teacher's goals.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CurriculumSchedule {
    /// On a clock: linearly with the run's env steps, the teacher's own start at `whole_at`.
    #[default]
    Clock,
    /// On the learner's success (Salimans and Chen's rule): `advance` agent steps further
    /// back each time the learner scored in at least `success_rate` of the last `window`
    /// episodes begun on the teacher's.
    Success,
}

/// Training episodes begun along a teacher's scoring episodes (`[curriculum]`, issue 49's
/// reverse curriculum; absent: every training episode from the table's own start). A share
/// of the training episodes starts on one of the teacher's episodes (drawn uniformly among
/// those that score), a number of agent steps before its goal that grows during the run:
/// `first_back` steps at the start, then further back by `schedule`: on a clock, the
/// teacher's whole episode from `whole_at` of the run's env steps on; or as the learner
/// succeeds from where it begins. The point is reached exactly, by replaying the teacher's
/// actions from its episode's seed ([`foosball_env::starts`]). Evaluations and the test
/// start as without it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CurriculumConfig {
    /// The teacher's episodes: a `trajectories.bin` that `evaluate` wrote (the planner's,
    /// say) or a list of them, recorded on this run's game against `env.opponent`, from
    /// seeds other than the run's evaluation and test starts.
    pub trajectories: DemonstrationFiles,
    /// Share of training episodes begun on a teacher's episode, in [0, 1].
    pub share: f64,
    /// Agent steps before the teacher's goal where those episodes begin at the run's start
    /// (at least 1).
    pub first_back: u32,
    /// How the starts move back: `"clock"` (by `whole_at`) or `"success"` (by
    /// `success_rate`, `window` and `advance`).
    pub schedule: CurriculumSchedule,
    /// Fraction of the run's env steps, in (0, 1], from which they begin at the teacher's
    /// own start; the distance to the goal grows linearly until then (`schedule = "clock"`).
    pub whole_at: f64,
    /// Share of the last `window` teacher-begun episodes, in (0, 1], in which the learner
    /// must score for the starts to move back (`schedule = "success"`).
    pub success_rate: f64,
    /// Teacher-begun episodes judged together, at least 1 (`schedule = "success"`): after
    /// each `window` of them the starts move back or stay.
    pub window: u32,
    /// Agent steps the starts move back by at each success, at least 1
    /// (`schedule = "success"`).
    pub advance: u32,
}

impl Default for CurriculumConfig {
    fn default() -> Self {
        Self {
            trajectories: DemonstrationFiles::Many(Vec::new()),
            share: 0.5,
            first_back: 5,
            schedule: CurriculumSchedule::Clock,
            whole_at: 0.5,
            success_rate: 0.5,
            window: 20,
            advance: 2,
        }
    }
}

impl CurriculumConfig {
    /// Rejects out-of-range values; keys under `curriculum`.
    fn validate(&self) -> Result<(), ConfigError> {
        let err =
            |key: &str, message: String| ConfigError::new(format!("curriculum.{key}"), message);
        if self.trajectories.paths().is_empty() {
            return Err(err(
                "trajectories",
                "name at least one trajectories.bin (the teacher's episodes)".into(),
            ));
        }
        if !(0.0..=1.0).contains(&self.share) {
            return Err(err(
                "share",
                format!("must be in [0, 1], got {}", self.share),
            ));
        }
        if self.first_back == 0 {
            return Err(err("first_back", "must be at least 1".into()));
        }
        if !(self.whole_at > 0.0 && self.whole_at <= 1.0) {
            return Err(err(
                "whole_at",
                format!("must be in (0, 1], got {}", self.whole_at),
            ));
        }
        if !(self.success_rate > 0.0 && self.success_rate <= 1.0) {
            return Err(err(
                "success_rate",
                format!("must be in (0, 1], got {}", self.success_rate),
            ));
        }
        if self.window == 0 {
            return Err(err("window", "must be at least 1".into()));
        }
        if self.advance == 0 {
            return Err(err("advance", "must be at least 1".into()));
        }
        Ok(())
    }
}

/// The planner as an interactive teacher (`[dagger]`, issue 49; Ross et al.'s DAgger):
/// every `every` env steps the learner plays `episodes` episodes of its own (from starts
/// of a stream of their own, [`foosball_env::seeding::DAGGER`]); in each, the planner
/// takes over at one step drawn uniformly, searching from the state the learner reached
/// there, its first sampling centred on what the learner played from that step on; where
/// it finds a goal, the states from that step on with the planner's actions join the
/// run's demonstrations (the aggregate, never dropped), which fill
/// `off_policy.demo_share` of each minibatch (SAC and TD3, cloned with `bc_weight`) or
/// are cloned after each update (PPO's `[ppo.demonstrations]`). The learner's episodes
/// and the planner's searches are played against `env.opponent`, under `[self_play]` too
/// (whose training draws black from its pool): the scripted black whose defence the
/// labels answer. They are simulated, not counted as the run's env steps (the scalars log
/// them: `train/dagger_*`). Evaluations and the test play the networks alone.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DaggerConfig {
    /// Env steps of training between two rounds of queries (at least 1).
    pub every: u64,
    /// The learner's episodes per round, one query each (at least 1).
    pub episodes: u32,
    /// How the learner acts in them.
    pub actions: TestActions,
    /// The search of each query ([`PlannerConfig`]; its `initial_std` is the spread of
    /// the first sampling around the learner's own actions). Absent: [`DaggerConfig::planner_budget`];
    /// a `[dagger.planner]` table is a whole planner budget, its missing keys the
    /// planner's own defaults (as `evaluate --planner FILE` reads them).
    pub planner: PlannerConfig,
}

impl Default for DaggerConfig {
    fn default() -> Self {
        Self {
            every: 1_000,
            episodes: 4,
            actions: TestActions::Deterministic,
            planner: Self::planner_budget(),
        }
    }
}

impl DaggerConfig {
    /// A query's search when `[dagger.planner]` is absent: 32 candidates, 4 elites, at
    /// most 8 refinements of 6 segments of 5 steps (the last held), each rollout at most
    /// 60 agent steps, sampled 0.3 around the learner's actions; at most 249 rollouts.
    pub fn planner_budget() -> PlannerConfig {
        PlannerConfig {
            population: 32,
            elites: 4,
            iterations: 8,
            segments: 6,
            segment_steps: 5,
            initial_std: 0.3,
            max_rollout_steps: 60,
            ..PlannerConfig::default()
        }
    }

    /// Rejects out-of-range values; keys under `dagger`.
    fn validate(&self) -> Result<(), ConfigError> {
        let err = |key: &str, message: String| ConfigError::new(format!("dagger.{key}"), message);
        if self.every == 0 {
            return Err(err("every", "must be at least 1".into()));
        }
        if self.episodes == 0 {
            return Err(err("episodes", "must be at least 1".into()));
        }
        self.planner
            .validate()
            .map_err(|why| ConfigError::new("dagger", why))?;
        if self.planner.shared_starts != 0 {
            return Err(err(
                "planner.shared_starts",
                "a query searches from one state: leave it out".into(),
            ));
        }
        Ok(())
    }
}

/// A whole run's settings: `algo`, `[protocol]`, `[env]` and the algorithm's section.
/// Read and written in the TOML shape below; only the algorithm's own section can exist.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RunConfigFile", into = "RunConfigFile")]
pub struct RunConfig {
    /// Epochs, evaluation, test, workers, seed.
    pub protocol: Protocol,
    /// The foosball environment.
    pub env: FoosballConfig,
    /// The algorithm to train and its settings.
    pub algorithm: AlgoConfig,
    /// Self-play against a pool of the learner's snapshots (`None`: off).
    pub self_play: Option<SelfPlayConfig>,
    /// Training episodes begun along a teacher's (`None`: off).
    pub curriculum: Option<CurriculumConfig>,
    /// Practice spots for a share of the training envs' serves (`[[drills]]`; empty:
    /// off). Evaluations and the test serve from `env.start` alone.
    pub drills: Vec<Drill>,
    /// The planner relabelling states the learner reaches (`None`: off).
    pub dagger: Option<DaggerConfig>,
    /// Running normalisation of the learner's observations and rewards, SB3's
    /// `VecNormalize` (`None`: off, as in the paper).
    pub normalize: Option<NormalizeConfig>,
    /// Fourier features of the (normalised) observation as the networks' input (`None`:
    /// the values themselves).
    pub fourier: Option<FourierConfig>,
}

/// A run configuration as TOML writes it: `algo` names the algorithm and at most that
/// algorithm's section is present (absent: its defaults).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RunConfigFile {
    algo: Algo,
    #[serde(default)]
    protocol: Protocol,
    #[serde(default)]
    env: FoosballConfig,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    ppo: Option<PpoConfig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    sac: Option<SacConfig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    td3: Option<Td3Config>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    self_play: Option<SelfPlayConfig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    curriculum: Option<CurriculumConfig>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    drills: Vec<Drill>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    dagger: Option<DaggerConfig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    normalize: Option<NormalizeConfig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    fourier: Option<FourierConfig>,
}

impl TryFrom<RunConfigFile> for RunConfig {
    type Error = ConfigError;

    /// Refuses a section of another algorithm than `algo`.
    fn try_from(f: RunConfigFile) -> Result<Self, ConfigError> {
        let other = |name: &str| {
            ConfigError::new(
                name,
                format!("section for another algorithm (algo = \"{}\")", f.algo),
            )
        };
        let algorithm = match (f.algo, f.ppo, f.sac, f.td3) {
            (Algo::Ppo, c, None, None) => AlgoConfig::Ppo(c.unwrap_or_default()),
            (Algo::Sac, None, c, None) => AlgoConfig::Sac(c.unwrap_or_default()),
            (Algo::Td3, None, None, c) => AlgoConfig::Td3(c.unwrap_or_default()),
            (_, Some(_), _, _) if f.algo != Algo::Ppo => return Err(other("ppo")),
            (_, _, Some(_), _) if f.algo != Algo::Sac => return Err(other("sac")),
            _ => return Err(other("td3")),
        };
        Ok(RunConfig {
            protocol: f.protocol,
            env: f.env,
            algorithm,
            self_play: f.self_play,
            curriculum: f.curriculum,
            drills: f.drills,
            dagger: f.dagger,
            normalize: f.normalize,
            fourier: f.fourier,
        })
    }
}

impl From<RunConfig> for RunConfigFile {
    fn from(c: RunConfig) -> Self {
        let algo = c.algorithm.algo();
        let (mut ppo, mut sac, mut td3) = (None, None, None);
        match c.algorithm {
            AlgoConfig::Ppo(a) => ppo = Some(a),
            AlgoConfig::Sac(a) => sac = Some(a),
            AlgoConfig::Td3(a) => td3 = Some(a),
        }
        RunConfigFile {
            algo,
            protocol: c.protocol,
            env: c.env,
            ppo,
            sac,
            td3,
            self_play: c.self_play,
            curriculum: c.curriculum,
            drills: c.drills,
            dagger: c.dagger,
            normalize: c.normalize,
            fourier: c.fourier,
        }
    }
}

/// Command-line overrides of a run configuration (`None`: keep the file's value).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overrides {
    /// `protocol.seed`.
    pub seed: Option<u64>,
    /// `protocol.epochs`.
    pub epochs: Option<u32>,
    /// `protocol.steps_per_epoch`.
    pub steps_per_epoch: Option<u64>,
    /// `protocol.envs`.
    pub envs: Option<usize>,
    /// `protocol.threads`.
    pub threads: Option<usize>,
    /// `<algo>.net.hidden`.
    pub hidden: Option<Vec<usize>>,
    /// `env`, replaced whole (e.g. by a preset's values).
    pub env: Option<FoosballConfig>,
    /// `protocol.init_from`.
    pub init_from: Option<String>,
}

/// A configuration that could not be used; `Display` names the file, line and key.
#[derive(Debug, thiserror::Error)]
pub enum ConfigFileError {
    /// A run directory without its `config.toml`.
    #[error("{dir}: not a run directory (no config.toml)")]
    NotARun {
        /// The directory.
        dir: PathBuf,
    },
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The file is not valid TOML or does not fit the schema (unknown key, wrong type).
    #[error("{path}:{line}: {}{message}", key.as_ref().map_or(String::new(), |k| format!("{k}: ")))]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line of the offending text.
        line: usize,
        /// The dotted key written on that line, if it assigns one.
        key: Option<String>,
        /// The parser's message.
        message: String,
    },
    /// A value is out of its range.
    #[error("{path}:{line}: {key}: {message}", line = line.map_or("?".into(), |l| l.to_string()))]
    Invalid {
        /// The file.
        path: PathBuf,
        /// 1-based line of the key, where it is written in the file.
        line: Option<usize>,
        /// Dotted key.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// A file it extends is missing or unreadable, or the files extend each other in a
    /// cycle.
    #[error(transparent)]
    Extends(#[from] ExtendsError),
}

impl RunConfig {
    /// Reads and checks a TOML file.
    pub fn load(path: &Path) -> Result<Self, ConfigFileError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigFileError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_toml(&text, path)
    }

    /// Reads `path`, checks it trains `algo` (when given), applies `overrides` and checks
    /// the result; the error names the file and the key.
    pub fn load_with(
        path: &Path,
        algo: Option<Algo>,
        overrides: &Overrides,
    ) -> Result<Self, String> {
        let mut c = Self::load(path).map_err(|e| e.to_string())?;
        if let Some(algo) = algo
            && algo != c.algo()
        {
            return Err(format!(
                "--algo {algo} but {} has algo = \"{}\"",
                path.display(),
                c.algo()
            ));
        }
        let (o, p) = (overrides, &mut c.protocol);
        p.seed = o.seed.unwrap_or(p.seed);
        p.epochs = o.epochs.unwrap_or(p.epochs);
        p.steps_per_epoch = o.steps_per_epoch.unwrap_or(p.steps_per_epoch);
        p.envs = o.envs.unwrap_or(p.envs);
        p.threads = o.threads.unwrap_or(p.threads);
        if let Some(init) = &o.init_from {
            p.init_from = Some(init.clone());
        }
        if let Some(hidden) = &o.hidden {
            c.algorithm.net_mut().hidden = hidden.clone();
        }
        if let Some(env) = &o.env {
            c.env = env.clone();
        }
        c.validate().map_err(|e| {
            format!(
                "{} (after command-line overrides): {}: {}",
                path.display(),
                e.key,
                e.message
            )
        })?;
        Ok(c)
    }

    /// The saved configuration of the run in `dir` (its `config.toml`).
    pub fn load_run(dir: &Path) -> Result<Self, ConfigFileError> {
        let path = dir.join("config.toml");
        if !path.is_file() {
            return Err(ConfigFileError::NotARun {
                dir: dir.to_path_buf(),
            });
        }
        Self::load(&path)
    }

    /// Parses and checks TOML `text`; `path` names it in errors. A top-level `extends =
    /// "base.toml"` (relative to `path`'s folder) lays the text over that file
    /// ([`foosball_env::config_file`]); an error then names the file of the chain that
    /// writes the key at fault.
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, ConfigFileError> {
        match config_file::layers(text, path)? {
            None => Self::from_one_file(text, path),
            Some(layers) => Self::from_layers(&layers),
        }
    }

    /// A chain of files merged; errors name the file that writes the key at fault and
    /// its line there.
    fn from_layers(layers: &Layers) -> Result<Self, ConfigFileError> {
        let merged = toml::to_string(&layers.merged).expect("a parsed table serialises");
        let place = |key: &str| {
            let layer = layers.writer_of(key);
            (layer.path.clone(), line_of_key(&layer.text, key))
        };
        Self::from_one_file(&merged, &layers.files[0].path).map_err(|e| match e {
            ConfigFileError::Parse { key, message, .. } => {
                let (path, line) = match &key {
                    Some(k) => place(k),
                    None => (layers.files[0].path.clone(), None),
                };
                ConfigFileError::Parse {
                    path,
                    line: line.unwrap_or(1),
                    key,
                    message,
                }
            }
            ConfigFileError::Invalid { key, message, .. } => {
                let (path, line) = place(&key);
                ConfigFileError::Invalid {
                    path,
                    line,
                    key,
                    message,
                }
            }
            other => other,
        })
    }

    /// One file's text, without `extends`.
    fn from_one_file(text: &str, path: &Path) -> Result<Self, ConfigFileError> {
        let text = &*migrate_legacy_keys(text);
        let file: RunConfigFile = toml::from_str(text).map_err(|e| {
            let line = e.span().map_or(1, |s| line_at(text, s.start));
            ConfigFileError::Parse {
                path: path.to_path_buf(),
                line,
                key: key_on_line(text, line),
                message: e.message().trim().to_string(),
            }
        })?;
        let invalid = |e: ConfigError| ConfigFileError::Invalid {
            path: path.to_path_buf(),
            line: line_of_key(text, &e.key),
            key: e.key,
            message: e.message,
        };
        let config = RunConfig::try_from(file).map_err(invalid)?;
        config.validate().map_err(invalid)?;
        Ok(config)
    }

    /// The effective configuration as TOML (what a run saves as `config.toml`), arrays on
    /// one line.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a run config always serialises")
    }

    /// Rejects out-of-range values, naming the dotted key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let p = &self.protocol;
        let positive = |ok: bool, key: &str| {
            if ok {
                Ok(())
            } else {
                Err(ConfigError::new(
                    format!("protocol.{key}"),
                    "must be positive",
                ))
            }
        };
        positive(p.epochs > 0, "epochs")?;
        positive(p.steps_per_epoch > 0, "steps_per_epoch")?;
        positive(p.eval_every > 0, "eval_every")?;
        positive(p.eval_episodes > 0, "eval_episodes")?;
        positive(p.test_episodes > 0, "test_episodes")?;
        positive(p.envs > 0, "envs")?;
        if p.test_networks == Checkpoint::Best && p.eval_every > p.total_env_steps() {
            return Err(ConfigError::new(
                "protocol.test_networks",
                format!(
                    "`best` needs an evaluation, but eval_every ({}) exceeds the run's {} env steps",
                    p.eval_every,
                    p.total_env_steps()
                ),
            ));
        }
        if let Some(b) = p.backend
            && !b.is_compiled()
        {
            return Err(ConfigError::new(
                "protocol.backend",
                format!("`{b}` is not compiled in: rebuild with `--features foosball-nets/{b}`"),
            ));
        }
        self.env.validate().map_err(|e| e.under("env"))?;
        self.algorithm.validate()?;
        let (demo_key, takes_demos) = self.algorithm.demonstrations_key();
        match (&p.demonstrations, takes_demos) {
            (Some(files), _) if files.paths().is_empty() => {
                return Err(ConfigError::new(
                    "protocol.demonstrations",
                    "an empty list: name at least one trajectories.bin, or leave the key out",
                ));
            }
            (Some(_), false) => {
                return Err(ConfigError::new(
                    "protocol.demonstrations",
                    format!("set {demo_key}: how the learner takes them"),
                ));
            }
            (None, true) if self.dagger.is_none() => {
                return Err(ConfigError::new(
                    demo_key,
                    "learns from demonstrations: set protocol.demonstrations (or [dagger])",
                ));
            }
            _ => {}
        }
        if let Some(sp) = &self.self_play {
            sp.validate()?;
        }
        validate_drills(&self.drills)?;
        if let Some(c) = &self.curriculum {
            c.validate()?;
            if self.self_play.is_some() {
                return Err(ConfigError::new(
                    "curriculum",
                    "not with [self_play]: the teacher's episodes were recorded against \
                     env.opponent",
                ));
            }
            if self.env.observation.kind != ObservationKind::State {
                return Err(ConfigError::new(
                    "curriculum",
                    "replays recorded states: this run observes images",
                ));
            }
        }
        if let Some(d) = &self.dagger {
            d.validate()?;
            if !takes_demos {
                return Err(ConfigError::new(
                    "dagger",
                    format!("its labels are demonstrations: set {demo_key}"),
                ));
            }
            if self.env.observation.kind != ObservationKind::State {
                return Err(ConfigError::new(
                    "dagger",
                    "labels states: this run observes images",
                ));
            }
        }
        // A teacher named by a run directory is looked for when the run starts (so a
        // finished run's file loads where its teacher's directory is not).
        if let AlgoConfig::Ppo(ppo) = &self.algorithm
            && let Some(teacher) = &ppo.kickstart.teacher
            && OpponentKind::Random.name() == teacher
        {
            return Err(ConfigError::new(
                "ppo.kickstart.teacher",
                "`random` draws its actions: a teacher acts on the state alone",
            ));
        }
        if let Some(n) = &self.normalize {
            n.validate().map_err(|e| e.under("normalize"))?;
            if n.obs && self.env.observation.kind != ObservationKind::State {
                return Err(ConfigError::new(
                    "normalize.obs",
                    "standardises the state vector: this run observes images (set obs = false)",
                ));
            }
        }
        if let Some(f) = &self.fourier {
            if self.env.observation.kind == ObservationKind::State {
                f.validate(self.env.observation.dim())
                    .map_err(|e| e.under("fourier"))?;
            } else {
                return Err(ConfigError::new(
                    "fourier",
                    "encodes the state vector: this run observes images",
                ));
            }
        }
        let o = &self.env.observation;
        if o.kind == ObservationKind::Image {
            let (h, w) = (o.height as usize, o.width as usize);
            self.algorithm
                .net()
                .cnn
                .conv_output(o.channels(), h, w)
                .map_err(|e| ConfigError::new(format!("{}.net.cnn", self.algo()), e))?;
        }
        if p.backend == Some(Backend::Host) {
            self.check_host_path()?;
        }
        Ok(())
    }

    /// What `backend = "host"` computes: the learners' MLPs on vector observations,
    /// without layer normalisation (SAC's and TD3's critics).
    fn check_host_path(&self) -> Result<(), ConfigError> {
        match self.host_path_refusal() {
            None => Ok(()),
            Some(why) => Err(ConfigError::new(
                "protocol.backend",
                format!("`host` {why}"),
            )),
        }
    }

    /// Why the host path cannot compute this run's networks, if it cannot.
    fn host_path_refusal(&self) -> Option<String> {
        if self.env.observation.kind == ObservationKind::Image {
            Some("computes vector observations only: use flex or a GPU backend for images".into())
        } else if self.algo() != Algo::Ppo && self.algorithm.net().critic_layer_norm {
            Some(format!(
                "does not compute layer normalisation: set {}.net.critic_layer_norm = false or use flex",
                self.algo()
            ))
        } else {
            None
        }
    }

    /// Whether the networks compute on the host MLP path: `backend = "host"`, or
    /// `"auto"` where that path computes them and no hidden layer is wider than
    /// [`AUTO_HOST_WIDTH`] (the widths at which it was measured faster than flex on one
    /// thread: docs/table.md). The rule is part of what an `auto` run's configuration
    /// means: a run replays only under the rule it was trained with.
    pub fn computes_on_host(&self) -> bool {
        match self.protocol.backend {
            Some(Backend::Host) => true,
            Some(Backend::Auto) => {
                self.host_path_refusal().is_none()
                    && self.hidden().iter().all(|&w| w <= AUTO_HOST_WIDTH)
            }
            _ => false,
        }
    }

    /// The algorithm to train.
    pub fn algo(&self) -> Algo {
        self.algorithm.algo()
    }

    /// The hidden widths of the algorithm's networks.
    pub fn hidden(&self) -> &[usize] {
        &self.algorithm.net().hidden
    }

    /// The hidden widths as a label, e.g. `64x64`.
    pub fn hidden_label(&self) -> String {
        let widths: Vec<String> = self.hidden().iter().map(usize::to_string).collect();
        widths.join("x")
    }
}

/// Rewrites keys of earlier releases in a run or sweep file to today's shape; `text`
/// itself when it has none (so that errors keep pointing at its lines).
///
/// - `[sac.off_policy].gamma` and `[td3.off_policy].gamma` (before the discount moved to
///   `[sac].gamma` and `[td3].gamma`, the shape of `[ppo].gamma`).
pub(crate) fn migrate_legacy_keys(text: &str) -> Cow<'_, str> {
    fn migrate(table: &mut toml::Table) -> bool {
        let mut moved = false;
        for (key, value) in table.iter_mut() {
            match value {
                toml::Value::Table(t) => {
                    if matches!(key.as_str(), "sac" | "td3") && !t.contains_key("gamma") {
                        let gamma = t
                            .get_mut("off_policy")
                            .and_then(toml::Value::as_table_mut)
                            .and_then(|o| o.remove("gamma"));
                        if let Some(g) = gamma {
                            t.insert("gamma".into(), g);
                            moved = true;
                        }
                    }
                    moved |= migrate(t);
                }
                toml::Value::Array(items) => {
                    for t in items.iter_mut().filter_map(toml::Value::as_table_mut) {
                        moved |= migrate(t);
                    }
                }
                _ => {}
            }
        }
        moved
    }
    let Ok(mut table) = text.parse::<toml::Table>() else {
        return Cow::Borrowed(text);
    };
    if migrate(&mut table) {
        Cow::Owned(toml::to_string(&table).expect("a parsed table serialises"))
    } else {
        Cow::Borrowed(text)
    }
}

/// The dotted key that 1-based `line` of `text` assigns (under the nearest `[table]`
/// header above it), if it assigns one.
fn key_on_line(text: &str, line: usize) -> Option<String> {
    let lines: Vec<&str> = text.lines().collect();
    let (key, _) = lines.get(line.checked_sub(1)?)?.split_once('=')?;
    let key = key.trim();
    if key.is_empty() || key.starts_with(['#', '[']) {
        return None;
    }
    let table = lines[..line - 1]
        .iter()
        .map(|l| l.trim())
        .rfind(|l| l.starts_with('['))
        .and_then(|h| h.trim_start_matches('[').split(']').next())
        .map(str::trim);
    Some(match table {
        Some(t) if !t.is_empty() => format!("{t}.{key}"),
        _ => key.to_string(),
    })
}

/// 1-based line where the dotted `key` is written (or its deepest written parent); a
/// part `name[i]` is the `i`-th table of the array `name` (`[[name]]`).
fn line_of_key(text: &str, key: &str) -> Option<usize> {
    let doc = toml::de::DeTable::parse(text).ok()?;
    let mut table = doc.get_ref();
    let mut line = None;
    for part in key.split('.') {
        let (name, index) = match part.strip_suffix(']').and_then(|p| p.split_once('[')) {
            Some((name, i)) => (name, i.parse::<usize>().ok()),
            None => (part, None),
        };
        let Some((k, v)) = table.iter().find(|(k, _)| k.get_ref().as_ref() == name) else {
            break;
        };
        line = Some(line_at(text, k.span().start));
        let v = match (v.get_ref(), index) {
            (toml::de::DeValue::Array(items), Some(i)) => match items.get(i) {
                Some(item) => {
                    line = Some(line_at(text, item.span().start));
                    item
                }
                None => break,
            },
            _ => v,
        };
        match v.get_ref() {
            toml::de::DeValue::Table(t) => table = t,
            _ => break,
        }
    }
    line
}
