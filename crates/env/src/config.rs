//! The foosball environment's settings: serde structs with defaults and validation.
//!
//! Every struct rejects unknown keys, and [`FoosballConfig::validate`] names the offending
//! key (dotted path, e.g. `randomization.ball_mass_scale`) and value.

use serde::{Deserialize, Serialize};

use crate::geometry::{BALL_MASS, GOAL_LINE_Y};

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

/// Everything that defines one foosball environment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FoosballConfig {
    /// Length of one physics step, s (default 0.002, the reference's).
    pub physics_dt: f32,
    /// Physics steps per agent step (default 5: the agent acts every 10 ms).
    pub frame_skip: u32,
    /// Agent steps after which an episode is truncated (default 4000 = 40 s at the
    /// default 10 ms agent step, the reference's time limit).
    pub max_episode_steps: u32,
    /// Reward shaping.
    pub reward: RewardConfig,
    /// Episode-ending rules.
    pub rules: EpisodeRules,
    /// Start distribution of the ball.
    pub start: StartConfig,
    /// Nominal ball and surface properties.
    pub ball: BallConfig,
    /// Who plays black.
    pub opponent: OpponentKind,
    /// Per-episode domain randomisation (off by default, as in the paper).
    pub randomization: Randomization,
}

impl Default for FoosballConfig {
    fn default() -> Self {
        Self {
            physics_dt: 0.002,
            frame_skip: 5,
            max_episode_steps: 4000,
            reward: RewardConfig::default(),
            rules: EpisodeRules::default(),
            start: StartConfig::default(),
            ball: BallConfig::default(),
            opponent: OpponentKind::Static,
            randomization: Randomization::default(),
        }
    }
}

/// `alpha - |ball_xy - goal| + beta * [ball_y >= goal_y] - conceded_penalty * [own goal]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RewardConfig {
    /// Constant per-step offset (default 300).
    pub alpha: f32,
    /// Bonus on the step the ball enters black's goal (default 1000).
    pub beta: f32,
    /// Penalty on the step the ball enters yellow's own goal (default 0: the paper's
    /// reward has none).
    pub conceded_penalty: f32,
    /// Point the distance is measured to, cm (default (0, 64), the centre of black's goal).
    pub goal: [f32; 2],
}

impl Default for RewardConfig {
    fn default() -> Self {
        Self {
            alpha: 300.0,
            beta: 1000.0,
            conceded_penalty: 0.0,
            goal: [0.0, GOAL_LINE_Y],
        }
    }
}

/// When an episode ends early (all counted in agent steps).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EpisodeRules {
    /// Ball speed under which the ball counts as stagnant, cm/s (default 0.5).
    pub stagnant_speed: f32,
    /// Consecutive stagnant steps that end the episode (default 10).
    pub stagnant_steps: u32,
    /// Consecutive steps without the ball gaining y that end the episode (default 15).
    pub no_progress_steps: u32,
}

impl Default for EpisodeRules {
    fn default() -> Self {
        Self {
            stagnant_speed: 0.5,
            stagnant_steps: 10,
            no_progress_steps: 15,
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
}

impl Default for BallConfig {
    fn default() -> Self {
        Self {
            mass: BALL_MASS,
            friction: 0.3,
            restitution: 0.6,
            rolling_resistance: 0.015,
        }
    }
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
