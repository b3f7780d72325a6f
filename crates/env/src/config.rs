//! The foosball environment's settings: serde structs with defaults and validation.
//!
//! Every struct rejects unknown keys, and [`FoosballConfig::validate`] names the offending
//! key (dotted path, e.g. `randomization.ball_mass_scale`) and value.
//!
//! A configuration starts from a [`Preset`] (`preset = "reference" | "paper_reachable" |
//! "paper" | "end_on_goal"`, default `reference`): keys written in the file
//! override the preset's values, keys left out take them. The presets' rules, with units:
//!
//! | key | `paper_reachable` | `paper` | `reference` | `end_on_goal` |
//! | --- | --- | --- | --- | --- |
//! | `physics_dt` (s) | 0.002 | 0.002 | 0.002 | 0.002 |
//! | `frame_skip` (physics steps per agent step) | 5 | 5 | 1 | 5 |
//! | `max_episode_steps` (agent steps) | 4000 (40 s) | 4000 (40 s) | 20000 (40 s) | 4000 (40 s) |
//! | `rules.stagnant_steps` (agent steps at <= `stagnant_speed` = 0.5 cm/s) | 10 (100 ms) | 10 (100 ms) | 10 (20 ms) | 10 (100 ms) |
//! | `rules.no_progress_steps` (agent steps without +y) | 15 (150 ms) | 15 (150 ms) | 15 (30 ms) | 15 (150 ms) |
//! | `rules.end_on_goal` | false | false | false | true |
//! | `reward.goal` (cm) | (0, 64) | (0, 64) | (0, 65) | (0, 64) |
//! | `reward.goal_line_y` (ball in goal when y >= it, cm) | 64 | 64 | 65 | 64 |
//! | `reward.beta` | 1000 per step in goal | 1000 per step in goal | 1000 per step in goal | 1000 once |
//! | `reward.zero_shaping_in_goal` (`alpha - d` is 0 in goal) | false | false | true | false |
//! | `reward.conceded_penalty` (per step in own goal) | 0 | 0 | 1000 | 0 |
//! | `start.y_mean` (cm) | -4.0 | -0.1 | -4.0 | -0.1 |
//! | `ball.planar` (no vertical ball motion) | true | false | true | false |

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::geometry::{self, BALL_MASS, GOAL_LINE_Y};
use crate::observation::ObservationConfig;

/// A setting with a value it must not take.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid value for `{key}`: {message}")]
pub struct ConfigError {
    /// Dotted path of the setting, e.g. `rules.stagnant_steps`.
    pub key: String,
    /// What is wrong with its value.
    pub message: String,
}

impl ConfigError {
    /// An error for the dotted `key`.
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            key: key.into(),
            message: message.into(),
        }
    }

    /// The same error with `prefix.` put before its key (for a section nested in a
    /// larger configuration).
    pub fn under(self, prefix: &str) -> Self {
        Self::new(format!("{prefix}.{}", self.key), self.message)
    }
}

/// A named bundle of rules (see the module docs for its values).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Preset {
    /// The paper's rules with the ball its code used: as `Paper`, but the ball starts at
    /// y ~ N(-4, 0.5²), in reach of yellow's midfield, and moves in the table's plane
    /// (the reference model's ball has no z joint). The text's start at y ~ -0.1 is out
    /// of every man's reach, and a free ball kicked hard flies off the table.
    PaperReachable,
    /// The paper's text made exact: `alpha - |ball_xy - (0, 64)| + beta * [ball_y >= 64]`
    /// on every step, no end on a goal, the agent acting every 10 ms, ball start
    /// y ~ N(-0.1, 0.5²), the ball free in 3-D.
    Paper,
    /// The paper's code (Foosball_CU v2 gym): one 2 ms physics step per agent step (so its
    /// counters are 20 ms and 30 ms), goal at y >= 65 paying 1000 a step and no shaping
    /// there, distance to (0, 65), -1000 per step in the own goal, ball start
    /// y ~ N(-4, 0.5²) (its draws are offsets from the ball body at y = -4), planar ball.
    /// The default: it is what produced the paper's figures, and agents learn on it.
    #[default]
    Reference,
    /// This project's first rule: a goal ends the episode and pays `beta` once.
    EndOnGoal,
}

impl Preset {
    /// Every preset, in documentation order.
    pub const ALL: [Preset; 4] = [
        Preset::PaperReachable,
        Preset::Paper,
        Preset::Reference,
        Preset::EndOnGoal,
    ];

    /// Its name in configuration files.
    pub fn name(self) -> &'static str {
        match self {
            Preset::PaperReachable => "paper_reachable",
            Preset::Paper => "paper",
            Preset::Reference => "reference",
            Preset::EndOnGoal => "end_on_goal",
        }
    }
}

impl std::str::FromStr for Preset {
    type Err = String;

    /// A preset by its name, e.g. `paper_reachable`.
    fn from_str(name: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|p| p.name() == name)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|p| p.name()).collect();
                format!(
                    "unknown preset `{name}`; expected one of {}",
                    names.join(", ")
                )
            })
    }
}

/// Everything that defines one foosball environment.
///
/// Deserialising starts from the values of the `preset` key (default `reference`) and
/// applies the keys present on top of them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(remote = "Self", deny_unknown_fields, default)]
pub struct FoosballConfig {
    /// The rule set the other keys start from.
    pub preset: Preset,
    /// Length of one physics step, s (default 0.002, the reference's).
    pub physics_dt: f32,
    /// Physics steps per agent step (`reference`: 1, the agent acting every 2 ms; the paper
    /// presets: 5, every 10 ms).
    pub frame_skip: u32,
    /// Agent steps after which an episode is truncated (40 s, the reference's time limit:
    /// 20,000 steps of 2 ms under `reference`, 4,000 of 10 ms under the paper presets).
    pub max_episode_steps: u32,
    /// Reward shaping.
    pub reward: RewardConfig,
    /// Episode-ending rules.
    pub rules: EpisodeRules,
    /// Start distribution of the ball.
    pub start: StartConfig,
    /// Nominal ball and surface properties.
    pub ball: BallConfig,
    /// How each rod is held to the table (default `joint`).
    pub rod_mount: RodMount,
    /// Who plays black.
    pub opponent: OpponentKind,
    /// Per-episode domain randomisation (off by default, as in the paper).
    pub randomization: Randomization,
    /// What the agent observes: the 38-dim state (default) or stacked frames.
    pub observation: ObservationConfig,
}

impl Default for FoosballConfig {
    fn default() -> Self {
        Self::preset(Preset::default())
    }
}

impl FoosballConfig {
    /// The configuration of a preset (see the module docs).
    pub fn preset(preset: Preset) -> Self {
        let paper = Self {
            preset,
            physics_dt: 0.002,
            frame_skip: 5,
            max_episode_steps: 4000,
            reward: RewardConfig::default(),
            rules: EpisodeRules::default(),
            start: StartConfig::default(),
            ball: BallConfig::default(),
            rod_mount: RodMount::default(),
            opponent: OpponentKind::Static,
            randomization: Randomization::default(),
            observation: ObservationConfig::default(),
        };
        let reachable_ball = (
            StartConfig {
                y_mean: -4.0,
                ..paper.start
            },
            BallConfig {
                planar: true,
                ..paper.ball
            },
        );
        match preset {
            Preset::Paper => paper,
            Preset::PaperReachable => Self {
                start: reachable_ball.0,
                ball: reachable_ball.1,
                ..paper
            },
            Preset::Reference => Self {
                frame_skip: 1,
                max_episode_steps: 20_000,
                reward: RewardConfig {
                    goal: [0.0, 65.0],
                    goal_line_y: 65.0,
                    zero_shaping_in_goal: true,
                    conceded_penalty: 1000.0,
                    ..paper.reward
                },
                start: reachable_ball.0,
                ball: reachable_ball.1,
                ..paper
            },
            Preset::EndOnGoal => Self {
                rules: EpisodeRules {
                    end_on_goal: true,
                    ..paper.rules
                },
                ..paper
            },
        }
    }
}

impl Serialize for FoosballConfig {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        FoosballConfig::serialize(self, serializer)
    }
}

impl<'de> Deserialize<'de> for FoosballConfig {
    /// Reads the keys as a table, lays them over the preset's values and deserialises
    /// the result (unknown keys are refused by name).
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let given = toml::Table::deserialize(deserializer)?;
        let preset = match given.get("preset") {
            Some(toml::Value::String(name)) => name.parse().map_err(D::Error::custom)?,
            Some(other) => {
                return Err(D::Error::custom(format!(
                    "preset: expected a name, got `{other}`"
                )));
            }
            None => Preset::default(),
        };
        let mut merged = toml::Table::try_from(Self::preset(preset)).map_err(D::Error::custom)?;
        overlay(&mut merged, given);
        FoosballConfig::deserialize(toml::Value::Table(merged))
            .map_err(|e| D::Error::custom(e.message().trim()))
    }
}

/// Writes `top` over `base`, table by table (values that are not tables replace).
fn overlay(base: &mut toml::Table, top: toml::Table) {
    for (key, value) in top {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(t)) => overlay(b, t),
            (_, v) => {
                base.insert(key, v);
            }
        }
    }
}

/// Per agent step: `alpha - d + beta * [in goal] - conceded_penalty * [in own goal]`, with
/// `d = |ball_xy - goal|` (`alpha - d` is replaced by 0 in the goal under
/// `zero_shaping_in_goal`). The ball is in
/// black's goal when its y >= `goal_line_y` inside the mouth, in yellow's when y <=
/// -`goal_line_y`. Under `rules.end_on_goal` the episode ends there, so the bonus or the
/// penalty is paid once.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RewardConfig {
    /// Constant per-step offset (default 300).
    pub alpha: f32,
    /// Bonus on every step the ball is in black's goal (default 1000).
    pub beta: f32,
    /// Penalty on every step the ball is in yellow's own goal (default 0: the paper's
    /// reward has none; the reference code's is 1000).
    pub conceded_penalty: f32,
    /// Point the distance is measured to, cm (default (0, 64), the centre of black's goal).
    pub goal: [f32; 2],
    /// The ball is in a goal when |y| >= this, cm (default 64; the reference's 65).
    pub goal_line_y: f32,
    /// The `alpha - d` term is 0 while the ball is in black's goal, which then pays
    /// `beta` alone (the reference code's rule; default false).
    pub zero_shaping_in_goal: bool,
}

impl Default for RewardConfig {
    fn default() -> Self {
        Self {
            alpha: 300.0,
            beta: 1000.0,
            conceded_penalty: 0.0,
            goal: [0.0, GOAL_LINE_Y],
            goal_line_y: GOAL_LINE_Y,
            zero_shaping_in_goal: false,
        }
    }
}

/// When an episode ends early (counters in agent steps: multiply by `physics_dt *
/// frame_skip` for seconds).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EpisodeRules {
    /// Ball speed at or under which the ball counts as stagnant, cm/s (default 0.5).
    pub stagnant_speed: f32,
    /// Consecutive stagnant steps that end the episode (default 10).
    pub stagnant_steps: u32,
    /// Consecutive steps without the ball gaining y that end the episode (default 15).
    pub no_progress_steps: u32,
    /// A goal (either side) ends the episode (default false: the paper's and its code's
    /// episodes go on with the ball in the goal).
    pub end_on_goal: bool,
}

impl Default for EpisodeRules {
    fn default() -> Self {
        Self {
            stagnant_speed: 0.5,
            stagnant_steps: 10,
            no_progress_steps: 15,
            end_on_goal: false,
        }
    }
}

/// Ball start: at rest on the playfield at x ~ N(x_mean, x_std²), y ~ N(y_mean, y_std²).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StartConfig {
    pub x_mean: f32,
    pub x_std: f32,
    pub y_mean: f32,
    pub y_std: f32,
}

impl Default for StartConfig {
    fn default() -> Self {
        Self {
            x_mean: -0.5,
            x_std: 0.5,
            y_mean: -0.1,
            y_std: 0.5,
        }
    }
}

/// Nominal ball and contact properties.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BallConfig {
    /// kg (default 0.1).
    pub mass: f32,
    /// Coulomb friction coefficient of ball contacts (default 0.3).
    pub friction: f32,
    /// Restitution of ball contacts with men and walls (default 0.6).
    pub restitution: f32,
    /// Rolling resistance: deceleration of a rolling ball as a fraction of g (default
    /// 0.015, about 15 cm/s²).
    pub rolling_resistance: f32,
    /// The ball moves in the playfield's plane only, its centre held at z = its radius
    /// (the reference model's ball has no z joint). Default false: a kick can lift the
    /// ball, and a ball lifted off the table ends the episode as a physics fault.
    pub planar: bool,
}

impl Default for BallConfig {
    fn default() -> Self {
        Self {
            mass: BALL_MASS,
            friction: 0.3,
            restitution: 0.6,
            rolling_resistance: 0.015,
            planar: false,
        }
    }
}

/// How a rod is held to the table, leaving it free to slide along and turn about its
/// axis. Both give the same mechanics (mass and inertia about the axis, gravity's torque
/// on the hanging men, a hard stop at the slide range); they differ in cost and in how
/// exactly rapier holds the axis.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RodMount {
    /// A generic impulse joint locking the other four degrees of freedom (solved with
    /// the contacts each step, to the solver's tolerance), with a limit on the slide.
    #[default]
    Joint,
    /// The rod body's other four degrees of freedom locked outright (`LockedAxes`), its
    /// centre of mass put on the axis with the men's gravity applied as a torque, and a
    /// joint carrying only the slide limit: about twice the bare physics speed.
    LockedAxes,
}

impl RodMount {
    /// Both mounts.
    pub const ALL: [RodMount; 2] = [RodMount::Joint, RodMount::LockedAxes];
}

/// Who controls black's rods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OpponentKind {
    /// Holds every rod at neutral (the paper's setting).
    Static,
    /// Uniform random commands each step, from the environment's RNG.
    Random,
    /// Slides each rod so its nearest man tracks the ball's x, feet down.
    Scripted,
}

/// Ranges sampled uniformly once per episode from the environment's RNG. A range `[a, a]`
/// fixes the value; the defaults fix everything at nominal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Randomization {
    /// Multiplier on the ball's mass.
    pub ball_mass_scale: [f32; 2],
    /// Multiplier on the ball's friction coefficient.
    pub ball_friction_scale: [f32; 2],
    /// Multiplier on the ball's restitution (the result is capped at 1).
    pub ball_restitution_scale: [f32; 2],
    /// Multiplier on every servo's kp and kv.
    pub servo_gain_scale: [f32; 2],
    /// Standard deviation of Gaussian noise on observed positions (ball and slides in cm,
    /// angles in rad); velocities are observed without noise.
    pub position_noise_std: [f32; 2],
    /// Agent steps by which yellow's actions reach the servos.
    pub action_latency_steps: [u32; 2],
}

impl Default for Randomization {
    fn default() -> Self {
        Self {
            ball_mass_scale: [1.0, 1.0],
            ball_friction_scale: [1.0, 1.0],
            ball_restitution_scale: [1.0, 1.0],
            servo_gain_scale: [1.0, 1.0],
            position_noise_std: [0.0, 0.0],
            action_latency_steps: [0, 0],
        }
    }
}

fn positive(key: &str, v: f32) -> Result<(), ConfigError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ConfigError::new(
            key,
            format!("must be a finite number > 0, got {v}"),
        ))
    }
}

fn non_negative(key: &str, v: f32) -> Result<(), ConfigError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(ConfigError::new(
            key,
            format!("must be a finite number >= 0, got {v}"),
        ))
    }
}

fn finite(key: &str, v: f32) -> Result<(), ConfigError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(ConfigError::new(key, format!("must be finite, got {v}")))
    }
}

fn at_least_one(key: &str, v: u32) -> Result<(), ConfigError> {
    if v >= 1 {
        Ok(())
    } else {
        Err(ConfigError::new(key, "must be at least 1, got 0"))
    }
}

fn range(key: &str, [lo, hi]: [f32; 2], allow_zero: bool) -> Result<(), ConfigError> {
    let ok_lo = lo.is_finite() && (lo > 0.0 || (allow_zero && lo == 0.0));
    if !ok_lo || !hi.is_finite() || hi < lo {
        let floor = if allow_zero { ">= 0" } else { "> 0" };
        return Err(ConfigError::new(
            key,
            format!("must be [low, high] with {floor} and low <= high, got [{lo}, {hi}]"),
        ));
    }
    Ok(())
}

impl FoosballConfig {
    /// Checks every value; the error names the first bad key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.observation
            .validate()
            .map_err(|e| e.under("observation"))?;
        positive("physics_dt", self.physics_dt)?;
        if self.physics_dt > 0.02 {
            return Err(ConfigError::new(
                "physics_dt",
                format!(
                    "{} s is too coarse for the rod servos; use <= 0.02",
                    self.physics_dt
                ),
            ));
        }
        at_least_one("frame_skip", self.frame_skip)?;
        at_least_one("max_episode_steps", self.max_episode_steps)?;
        finite("reward.alpha", self.reward.alpha)?;
        finite("reward.beta", self.reward.beta)?;
        finite("reward.conceded_penalty", self.reward.conceded_penalty)?;
        finite("reward.goal[0]", self.reward.goal[0])?;
        finite("reward.goal[1]", self.reward.goal[1])?;
        let line = self.reward.goal_line_y;
        let deepest = geometry::GOAL_POCKET_BACK - geometry::BALL_RADIUS;
        if !(line.is_finite() && line > geometry::FIELD_HALF_LENGTH && line < deepest) {
            return Err(ConfigError::new(
                "reward.goal_line_y",
                format!(
                    "must lie where the ball's centre can go in the goal pocket ({} < y < {deepest}), got {line}",
                    geometry::FIELD_HALF_LENGTH,
                ),
            ));
        }
        non_negative("rules.stagnant_speed", self.rules.stagnant_speed)?;
        at_least_one("rules.stagnant_steps", self.rules.stagnant_steps)?;
        at_least_one("rules.no_progress_steps", self.rules.no_progress_steps)?;
        finite("start.x_mean", self.start.x_mean)?;
        finite("start.y_mean", self.start.y_mean)?;
        non_negative("start.x_std", self.start.x_std)?;
        non_negative("start.y_std", self.start.y_std)?;
        positive("ball.mass", self.ball.mass)?;
        non_negative("ball.friction", self.ball.friction)?;
        non_negative("ball.restitution", self.ball.restitution)?;
        if self.ball.restitution > 1.0 {
            return Err(ConfigError::new(
                "ball.restitution",
                format!("must be <= 1, got {}", self.ball.restitution),
            ));
        }
        non_negative("ball.rolling_resistance", self.ball.rolling_resistance)?;
        let r = &self.randomization;
        range("randomization.ball_mass_scale", r.ball_mass_scale, false)?;
        range(
            "randomization.ball_friction_scale",
            r.ball_friction_scale,
            true,
        )?;
        range(
            "randomization.ball_restitution_scale",
            r.ball_restitution_scale,
            true,
        )?;
        range("randomization.servo_gain_scale", r.servo_gain_scale, false)?;
        range(
            "randomization.position_noise_std",
            r.position_noise_std,
            true,
        )?;
        let [lo, hi] = r.action_latency_steps;
        if hi < lo || hi > 100 {
            return Err(ConfigError::new(
                "randomization.action_latency_steps",
                format!("must be [low, high] with low <= high <= 100, got [{lo}, {hi}]"),
            ));
        }
        Ok(())
    }

    /// Length of one agent step, s.
    pub fn agent_dt(&self) -> f32 {
        self.physics_dt * self.frame_skip as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        FoosballConfig::default().validate().unwrap();
    }

    #[test]
    fn errors_name_the_key() {
        let c = FoosballConfig {
            physics_dt: -1.0,
            ..FoosballConfig::default()
        };
        assert_eq!(c.validate().unwrap_err().key, "physics_dt");
        let mut c = FoosballConfig::default();
        c.randomization.ball_mass_scale = [1.2, 0.8];
        let e = c.validate().unwrap_err();
        assert_eq!(e.key, "randomization.ball_mass_scale");
        assert!(e.to_string().contains("[1.2, 0.8]"), "{e}");
        let mut c = FoosballConfig::default();
        c.rules.stagnant_steps = 0;
        assert_eq!(c.validate().unwrap_err().key, "rules.stagnant_steps");
    }

    #[test]
    fn unknown_keys_are_rejected() {
        let err = serde_json::from_str::<FoosballConfig>(r#"{"frame_skp": 3}"#).unwrap_err();
        assert!(err.to_string().contains("frame_skp"), "{err}");
        let c: FoosballConfig =
            serde_json::from_str(r#"{"frame_skip": 3, "opponent": "scripted"}"#).unwrap();
        assert_eq!(c.frame_skip, 3);
        assert_eq!(c.opponent, OpponentKind::Scripted);
        assert_eq!(c.physics_dt, 0.002);
    }
}
