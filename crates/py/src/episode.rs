//! The paper's per-episode metrics, tallied step by step as `src/play/metrics.rs` of the
//! training framework defines them: return, length, whether the ball reached black's
//! goal, mean ball-to-goal distance and ball speed over the episode's steps, and the
//! distance at its last step.

use foosball_env::FoosballInfo;

/// Sums over the steps of the episode in progress.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EpisodeTally {
    ret: f64,
    steps: u32,
    distance_sum: f64,
    speed_sum: f64,
}

/// One finished episode's metrics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpisodeStats {
    /// Undiscounted return.
    pub ret: f64,
    /// Agent steps.
    pub length: u32,
    /// The ball reached black's goal at some step.
    pub scored: bool,
    /// Mean over the steps of the ball-to-goal distance, cm.
    pub mean_goal_distance: f64,
    /// Mean over the steps of the ball speed, cm/s.
    pub mean_ball_speed: f64,
    /// Ball-to-goal distance at the last step, cm.
    pub final_goal_distance: f64,
}

impl EpisodeTally {
    /// Adds one step; returns the episode's metrics (and starts a new tally) when `done`.
    pub fn add(&mut self, reward: f32, info: &FoosballInfo, done: bool) -> Option<EpisodeStats> {
        self.ret += f64::from(reward);
        self.steps += 1;
        self.distance_sum += f64::from(info.goal_distance);
        self.speed_sum += f64::from(info.ball_speed);
        done.then(|| {
            let n = f64::from(self.steps);
            let stats = EpisodeStats {
                ret: self.ret,
                length: self.steps,
                scored: info.scored(),
                mean_goal_distance: self.distance_sum / n,
                mean_ball_speed: self.speed_sum / n,
                final_goal_distance: f64::from(info.goal_distance),
            };
            *self = Self::default();
            stats
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn means_are_over_the_episode_and_the_tally_restarts() {
        let mut tally = EpisodeTally::default();
        let info = |d: f32, v: f32| FoosballInfo {
            goal_distance: d,
            ball_speed: v,
            ..FoosballInfo::default()
        };
        assert_eq!(tally.add(1.0, &info(10.0, 4.0), false), None);
        let stats = tally.add(2.0, &info(30.0, 0.0), true).unwrap();
        assert_eq!(stats.ret, 3.0);
        assert_eq!(stats.length, 2);
        assert_eq!(stats.mean_goal_distance, 20.0);
        assert_eq!(stats.mean_ball_speed, 2.0);
        assert_eq!(stats.final_goal_distance, 30.0);
        assert!(!stats.scored);
        assert_eq!(tally, EpisodeTally::default());
    }
}
