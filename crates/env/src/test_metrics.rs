//! The paper's five test metrics with 95 % confidence intervals, over the episodes of a
//! test however they were played (the framework's `evaluate`, the Python front's
//! `foosball_rl.evaluate`).
//!
//! Over `n` deterministic test episodes: score rate (share of episodes whose ball crossed
//! the attacked goal line), mean ball-to-goal distance over all steps of all episodes
//! (cm), mean ball speed over all steps (cm/s), mean episode return, mean distance at the
//! last step of each episode (cm). Intervals: Wilson's for the score rate, the normal
//! approximation for means over episodes, and for the all-steps means (ratios of sums)
//! the delta method with episodes as clusters.

use crate::{EndReason, FoosballInfo};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// Deterministic episodes played side by side in evaluations and tests (part of the
/// protocol: it fixes the policy's batch shape).
pub const EVAL_BATCH: usize = 10;

/// z for a two-sided 95 % interval.
const Z95: f64 = 1.959_963_984_540_054;

/// What one test episode contributes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EpisodeSummary {
    /// Agent steps.
    pub steps: u64,
    /// Undiscounted return.
    pub ret: f64,
    /// The ball crossed the attacked goal line.
    pub scored: bool,
    /// Sum over steps of the ball-to-goal distance, cm.
    pub distance_sum: f64,
    /// Sum over steps of the ball speed, cm/s.
    pub speed_sum: f64,
    /// Ball-to-goal distance at the last step, cm.
    pub final_distance: f64,
    /// Why the episode ended (None while it runs).
    pub end: Option<EndReason>,
}

impl EpisodeSummary {
    /// Adds one step that paid `reward` and ended as `info` says.
    pub fn add(&mut self, reward: f32, info: &FoosballInfo) {
        self.steps += 1;
        self.ret += f64::from(reward);
        self.distance_sum += f64::from(info.goal_distance);
        self.speed_sum += f64::from(info.ball_speed);
        self.final_distance = f64::from(info.goal_distance);
        self.scored |= info.scored();
        self.end = info.end;
    }
}

/// A point estimate and its 95 % confidence interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// The estimate.
    pub mean: f64,
    /// Lower and upper bound of the 95 % interval.
    pub ci95: [f64; 2],
}

impl Estimate {
    fn symmetric(mean: f64, half_width: f64) -> Self {
        Self {
            mean,
            ci95: [mean - half_width, mean + half_width],
        }
    }
}

/// The test metrics of a run (`test/metrics.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TestMetrics {
    /// Episodes played.
    pub episodes: usize,
    /// Share of episodes that scored, in [0, 1].
    pub score_rate: Estimate,
    /// Mean ball-to-goal distance over all steps, cm.
    pub mean_goal_distance: Estimate,
    /// Mean ball speed over all steps, cm/s.
    pub mean_ball_speed: Estimate,
    /// Mean episode return.
    pub mean_return: Estimate,
    /// Mean ball-to-goal distance at the last step, cm.
    pub mean_final_distance: Estimate,
    /// Mean episode length, agent steps.
    pub mean_length: Estimate,
    /// Share of episodes that ended for each reason (names as in [`EndReason::name`]).
    #[serde(default)]
    pub end_reasons: BTreeMap<String, f64>,
}

/// Share of each end reason among `ends` (reasons that never occur are left out).
pub fn end_shares(ends: impl Iterator<Item = EndReason>) -> BTreeMap<String, f64> {
    let mut counts = BTreeMap::new();
    let mut n = 0usize;
    for end in ends {
        *counts.entry(end.name().to_string()).or_insert(0usize) += 1;
        n += 1;
    }
    counts
        .into_iter()
        .map(|(k, c)| (k, c as f64 / n as f64))
        .collect()
}

/// Wilson score interval of `k` successes in `n` trials.
pub fn wilson(k: usize, n: usize) -> Estimate {
    wilson_points(k as f64, n as f64)
}

/// Wilson score interval of a share `points / n` of `n > 0` trials whose points may be
/// halves (a draw in a match counts half a win).
pub fn wilson_points(points: f64, n: f64) -> Estimate {
    let p = points / n;
    let z2 = Z95 * Z95;
    let centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
    let half = Z95 / (1.0 + z2 / n) * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
    Estimate {
        mean: p,
        ci95: [(centre - half).max(0.0), (centre + half).min(1.0)],
    }
}

/// Mean of `x` with the normal-approximation interval (sample standard deviation).
pub fn mean_estimate(x: &[f64]) -> Estimate {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    if x.len() < 2 {
        return Estimate::symmetric(mean, f64::NAN);
    }
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    Estimate::symmetric(mean, Z95 * (var / n).sqrt())
}

/// `sum(y) / sum(m)` with the delta-method interval, each `(y_i, m_i)` one cluster.
pub fn ratio_estimate(y: &[f64], m: &[f64]) -> Estimate {
    let n = y.len() as f64;
    let ratio = y.iter().sum::<f64>() / m.iter().sum::<f64>();
    if y.len() < 2 {
        return Estimate::symmetric(ratio, f64::NAN);
    }
    let m_bar = m.iter().sum::<f64>() / n;
    let s2 = y
        .iter()
        .zip(m)
        .map(|(y, m)| (y - ratio * m).powi(2))
        .sum::<f64>()
        / (n - 1.0);
    Estimate::symmetric(ratio, Z95 * (s2 / n).sqrt() / m_bar)
}

impl TestMetrics {
    /// The metrics a test wrote to `path` (`metrics.json`); the error says what is wrong
    /// with the file (the caller names it).
    pub fn read(path: &Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{e} (has the run finished its test?)"))?;
        serde_json::from_str(&text).map_err(|e| e.to_string())
    }

    /// The metrics of `episodes` (at least one).
    pub fn from_episodes(episodes: &[EpisodeSummary]) -> Self {
        assert!(!episodes.is_empty(), "metrics need at least one episode");
        let col = |f: fn(&EpisodeSummary) -> f64| -> Vec<f64> { episodes.iter().map(f).collect() };
        let steps = col(|e| e.steps as f64);
        Self {
            episodes: episodes.len(),
            score_rate: wilson(episodes.iter().filter(|e| e.scored).count(), episodes.len()),
            mean_goal_distance: ratio_estimate(&col(|e| e.distance_sum), &steps),
            mean_ball_speed: ratio_estimate(&col(|e| e.speed_sum), &steps),
            mean_return: mean_estimate(&col(|e| e.ret)),
            mean_final_distance: mean_estimate(&col(|e| e.final_distance)),
            mean_length: mean_estimate(&steps),
            end_reasons: end_shares(episodes.iter().filter_map(|e| e.end)),
        }
    }

    /// The five paper metrics (and the episode length) as rows `(name, estimate)`.
    pub fn rows(&self) -> [(&'static str, Estimate); 6] {
        [
            ("score rate", self.score_rate),
            ("mean distance to goal (cm)", self.mean_goal_distance),
            ("mean ball speed (cm/s)", self.mean_ball_speed),
            ("mean episode reward", self.mean_return),
            ("mean final distance (cm)", self.mean_final_distance),
            ("mean episode length (steps)", self.mean_length),
        ]
    }

    /// A markdown table of the metrics with their intervals.
    pub fn to_markdown(&self) -> String {
        let mut out = format!(
            "| metric ({} episodes) | value | 95 % CI |\n| --- | --- | --- |\n",
            self.episodes
        );
        for (name, e) in self.rows() {
            out += &format!(
                "| {name} | {:.4} | [{:.4}, {:.4}] |\n",
                e.mean, e.ci95[0], e.ci95[1]
            );
        }
        let ends: Vec<String> = self
            .end_reasons
            .iter()
            .map(|(k, v)| format!("{k} {:.1} %", 100.0 * v))
            .collect();
        out += &format!("\nEpisodes ended: {}\n", ends.join(", "));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_the_textbook_example() {
        // 8 of 10: Wilson 95 % interval [0.4902, 0.9433] (e.g. Newcombe 1998).
        let e = wilson(8, 10);
        assert_eq!(e.mean, 0.8);
        assert!(
            (e.ci95[0] - 0.4902).abs() < 1e-4 && (e.ci95[1] - 0.9433).abs() < 1e-4,
            "{e:?}"
        );
        assert_eq!(wilson(0, 5).ci95[0], 0.0);
    }

    #[test]
    fn means_over_steps_weight_long_episodes_more() {
        let e = |steps, distance_sum, scored| EpisodeSummary {
            steps,
            ret: distance_sum,
            scored,
            distance_sum,
            speed_sum: 2.0 * distance_sum,
            final_distance: 1.0,
            end: Some(if scored {
                EndReason::Stagnant
            } else {
                EndReason::NoProgress
            }),
        };
        let m = TestMetrics::from_episodes(&[e(1, 10.0, true), e(3, 6.0, false)]);
        assert_eq!(m.mean_goal_distance.mean, 16.0 / 4.0);
        assert_eq!(m.mean_ball_speed.mean, 32.0 / 4.0);
        assert_eq!(m.mean_return.mean, 8.0);
        assert_eq!(m.score_rate.mean, 0.5);
        assert_eq!(m.mean_final_distance.ci95, [1.0, 1.0]);
        // Mean 8, sample sd 2.828: half-width 1.96 * 2 = 3.92.
        assert!((m.mean_return.ci95[1] - 8.0 - Z95 * 2.0).abs() < 1e-9);
        assert!(m.to_markdown().contains("| score rate | 0.5000 |"));
        assert_eq!(m.end_reasons["stagnant"], 0.5);
        assert!(
            m.to_markdown().contains("no_progress 50.0 %"),
            "{}",
            m.to_markdown()
        );
    }
}
