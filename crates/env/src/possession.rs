//! ITSF's possession rule: which rod holds the ball, and for how long. A ball whose centre
//! lies within [`MAN_REACH_Y`] of a rod's axis along the table is in that rod's possession
//! (the rods are 15 cm apart, so at most one holds it); a rod that keeps it past its limit
//! (10 s for a five-man rod, 15 s for the others, under ITSF's rules) loses it to the
//! other side ([`crate::config::EpisodeRules::possession`]). A still ball within a rod's
//! reach is that rod's, not a dead ball: under the rule only a ball out of every rod's
//! reach ends a point by lying still (ITSF's dead ball).

use crate::geometry::{MAN_REACH_Y, NUM_RODS, Team, rod_of, rod_y};

/// ITSF's possession limits, seconds: a five-man rod's and every other rod's.
pub const ITSF_LIMITS_S: [f32; 2] = [10.0, 15.0];

/// The rod (global index: yellow's four, then black's) within whose reach the ball's centre
/// lies at world `ball_y` (cm), if any.
pub fn rod_in_reach(ball_y: f32) -> Option<usize> {
    (0..NUM_RODS)
        .map(|i| (i, (ball_y - rod_y(i)).abs()))
        .filter(|&(_, d)| d <= MAN_REACH_Y)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

/// Whether rod `i` is a five-man rod (ITSF's shorter limit).
pub fn is_five_man(i: usize) -> bool {
    rod_of(i).1.men_x.len() == 5
}

/// Counts how long one rod has held the ball, agent step by agent step.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PossessionClock {
    holder: Option<usize>,
    steps: u32,
}

impl PossessionClock {
    /// The rod that holds the ball after the last counted step, if one does.
    pub fn holder(&self) -> Option<usize> {
        self.holder
    }

    /// Counts one agent step after which the ball's centre lies at world `ball_y` (cm).
    /// Returns the team whose rod has now held the ball for at least `limit_steps(rod)`
    /// consecutive agent steps, if one has.
    pub fn update(&mut self, ball_y: f32, limit_steps: impl Fn(usize) -> u32) -> Option<Team> {
        let holder = rod_in_reach(ball_y);
        self.steps = match holder {
            Some(_) if holder == self.holder => self.steps + 1,
            Some(_) => 1,
            None => 0,
        };
        self.holder = holder;
        let rod = holder?;
        (self.steps >= limit_steps(rod)).then(|| rod_of(rod).0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{BALL_RADIUS, ROD_HEIGHT, foosman::FOOT_BOTTOM};

    #[test]
    fn the_reach_is_where_a_turning_foot_meets_the_ball() {
        let below = ROD_HEIGHT - BALL_RADIUS;
        let touch = FOOT_BOTTOM + BALL_RADIUS;
        assert!((MAN_REACH_Y.powi(2) + below.powi(2) - touch.powi(2)).abs() < 0.02);
    }

    #[test]
    fn a_ball_by_a_rod_is_that_rods_and_between_rods_nobodys() {
        assert_eq!(rod_in_reach(-7.5), Some(2), "on yellow's midfield axis");
        assert_eq!(rod_in_reach(-7.5 + 6.5), Some(2));
        assert_eq!(rod_in_reach(7.5 - 6.5), Some(6), "black's midfield");
        assert_eq!(
            rod_in_reach(-15.0),
            None,
            "between yellow's midfield and black's attack"
        );
        assert_eq!(rod_in_reach(-22.5), Some(7), "black's attack");
        assert!(is_five_man(2) && is_five_man(6));
        assert!(!is_five_man(0) && !is_five_man(3) && !is_five_man(7));
    }

    #[test]
    fn the_clock_runs_while_one_rod_holds_the_ball_and_restarts_when_it_changes() {
        let mut clock = PossessionClock::default();
        let limit = |rod: usize| if is_five_man(rod) { 3 } else { 5 };
        assert_eq!(clock.update(-7.5, limit), None);
        assert_eq!(clock.update(-7.0, limit), None);
        assert_eq!(
            clock.update(-8.0, limit),
            Some(Team::Yellow),
            "3 steps on a five-man rod"
        );
        assert_eq!(clock.update(-15.0, limit), None, "free: the clock stops");
        for _ in 0..4 {
            assert_eq!(clock.update(-22.5, limit), None);
        }
        assert_eq!(
            clock.update(-22.5, limit),
            Some(Team::Black),
            "5 steps on black's attack"
        );
        assert_eq!(clock.update(-37.5, limit), None, "another rod starts again");
    }
}
