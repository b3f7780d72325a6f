//! [`PlannerConfig`]: the planner's search budget, as a `[planner]` TOML table or file.

use serde::{Deserialize, Serialize};

/// What the search maximises.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Objective {
    /// Scoring first, then sooner: a scoring plan is worth `1e6 - steps to the goal`, any
    /// other `-(the ball's closest approach to the goal point, cm)`. What the score rate
    /// measures.
    Score,
    /// The episode's return, what the learners maximise (under the `reference` rules a
    /// long episode of a slowly advancing ball can earn more than a goal).
    Return,
}

/// Which scoring plan a search keeps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Keep {
    /// The one of highest value under the objective (with `score`: the soonest goal).
    #[default]
    Best,
    /// Among the iteration's plans that score, the one nearest the plan the search
    /// started from (least sum of squared differences over its pieces; the learner's own
    /// actions under `[dagger]`): answers to nearby states of one learner that agree with
    /// each other and with what it played. The best by value where no plan scores or the
    /// search started from none.
    Nearest,
}

/// The cross-entropy search of [`super::cem`]: how many candidate plans, how long, how
/// they are refined. Its cost per episode is at most `population * iterations` rollouts of
/// at most `max_rollout_steps` agent steps each.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlannerConfig {
    /// Candidate plans per iteration (the current best among them).
    pub population: usize,
    /// Best candidates whose mean and spread make the next iteration's sampling.
    pub elites: usize,
    /// Refinements of the sampling distribution, at most.
    pub iterations: usize,
    /// Pieces of a plan: each holds one 8-value action for `segment_steps` agent steps;
    /// the last piece is held to the episode's end.
    pub segments: usize,
    /// Agent steps of each piece.
    pub segment_steps: usize,
    /// Standard deviation of the first iteration's sampling around 0, in action units
    /// (actions are clipped to [-1, 1]).
    pub initial_std: f32,
    /// Floor of the sampling's standard deviation, action units.
    pub min_std: f32,
    /// Agent steps after which a rollout stops counting (its return so far is its value).
    pub max_rollout_steps: u32,
    /// What a plan is worth.
    pub objective: Objective,
    /// Stop searching once a plan scores (the score rate is what the ceiling measures);
    /// false searches the whole budget for the highest return.
    pub stop_when_scored: bool,
    /// Which scoring plan it keeps (`best`, default, or `nearest`).
    #[serde(default, skip_serializing_if = "is_best")]
    pub keep: Keep,
    /// 0 (default): a plan searched for each episode from its own start. N > 0: one plan
    /// searched once for N starts of the planner's own stream (its worth the mean over
    /// them) and played unchanged, open loop, on every episode: what a single motion
    /// earns on starts it never saw (and a consistent demonstration to clone, where
    /// per-episode plans from near-identical starts differ). Stops early only once it
    /// scores from all N.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub shared_starts: usize,
    /// With `shared_starts`: each episode then searches a plan of its own starting from
    /// the shared one (sampling spread `refine_std` around it) instead of playing it
    /// unchanged: per-episode plans that stay near one motion. Absent (default): the
    /// shared plan plays as it is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refine_std: Option<f32>,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

fn is_best(k: &Keep) -> bool {
    *k == Keep::Best
}

impl Default for PlannerConfig {
    fn default() -> Self {
        Self {
            population: 128,
            elites: 12,
            iterations: 15,
            segments: 24,
            segment_steps: 5,
            initial_std: 1.0,
            min_std: 0.05,
            max_rollout_steps: 2000,
            objective: Objective::Score,
            stop_when_scored: true,
            keep: Keep::Best,
            shared_starts: 0,
            refine_std: None,
        }
    }
}

impl PlannerConfig {
    /// Checks every key; the error names the first at fault (`planner.<key>`) and its value.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("population", self.population),
            ("elites", self.elites),
            ("iterations", self.iterations),
            ("segments", self.segments),
            ("segment_steps", self.segment_steps),
            ("max_rollout_steps", self.max_rollout_steps as usize),
        ];
        for (key, value) in positive {
            if value == 0 {
                return Err(format!("planner.{key} = 0: must be at least 1"));
            }
        }
        if self.elites > self.population {
            return Err(format!(
                "planner.elites = {}: must not exceed planner.population = {}",
                self.elites, self.population
            ));
        }
        if self.refine_std.is_some() && self.shared_starts == 0 {
            return Err(
                "planner.refine_std refines a shared plan: set planner.shared_starts".into(),
            );
        }
        let refine = self.refine_std.unwrap_or(0.0);
        for (key, value) in [
            ("initial_std", self.initial_std),
            ("min_std", self.min_std),
            ("refine_std", refine),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(format!("planner.{key} = {value}: must be finite and >= 0"));
            }
        }
        Ok(())
    }

    /// Reads a TOML file of these keys; the error names the file and the key at fault.
    pub fn load(path: &std::path::Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        let config: Self = toml::from_str(&text)
            .map_err(|e| format!("{}: {}", path.display(), e.message().trim()))?;
        config
            .validate()
            .map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_budgets_are_refused_by_key() {
        assert!(PlannerConfig::default().validate().is_ok());
        let zero = PlannerConfig {
            segments: 0,
            ..PlannerConfig::default()
        };
        assert!(
            zero.validate()
                .unwrap_err()
                .contains("planner.segments = 0")
        );
        let elites = PlannerConfig {
            elites: 129,
            ..PlannerConfig::default()
        };
        assert!(
            elites
                .validate()
                .unwrap_err()
                .contains("planner.elites = 129")
        );
        let std = PlannerConfig {
            min_std: f32::NAN,
            ..PlannerConfig::default()
        };
        assert!(std.validate().unwrap_err().contains("planner.min_std"));
        let alone = PlannerConfig {
            refine_std: Some(0.2),
            ..PlannerConfig::default()
        };
        assert!(
            alone
                .validate()
                .unwrap_err()
                .contains("planner.shared_starts")
        );
        let negative = PlannerConfig {
            refine_std: Some(-0.2),
            shared_starts: 2,
            ..PlannerConfig::default()
        };
        assert!(
            negative
                .validate()
                .unwrap_err()
                .contains("planner.refine_std")
        );
        let unknown = toml::from_str::<PlannerConfig>("populaton = 3");
        assert!(unknown.unwrap_err().message().contains("populaton"));
    }
}
