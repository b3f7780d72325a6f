//! Where a match's ball goes: how long it lies within each rod's reach, how often it
//! crosses each rod's axis towards either goal, and how the points end. It reads a 0:0
//! draw: whether one side never brought the ball forward, or brought it past the other's
//! midfield and defence and met the goalie every time.
//!
//! Counted once an agent step, in the world frame (yellow attacks +y); [`BallFlow::side`]
//! turns it into one side's view: its own rods and the other side's, its attacks and the
//! other side's.

use foosball_env::EndReason;
use foosball_env::geometry::{GOAL_HALF_WIDTH, NUM_RODS, Team, rod_y};
use foosball_env::possession::rod_in_reach;

/// One match's (or several matches') ball flow, in the world frame: rods by global index
/// (yellow's goalie, defence, midfield, attack, then black's).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BallFlow {
    /// Agent steps after which the ball's centre lay within each rod's reach
    /// ([`rod_in_reach`]), and (index 8) out of every rod's reach.
    pub reach_steps: [u64; NUM_RODS + 1],
    /// Times the ball's centre crossed each rod's axis moving towards black's goal (+y).
    pub towards_black: [u32; NUM_RODS],
    /// Times the ball's centre crossed each rod's axis moving towards yellow's goal (-y).
    pub towards_yellow: [u32; NUM_RODS],
    /// Of the crossings of each goalie's axis towards its goal (yellow's, black's), those
    /// within the goal's width (|x| < [`GOAL_HALF_WIDTH`]).
    pub goalie_in_mouth: [u32; 2],
    /// Points ended, by reason (index into [`EndReason::ALL`]).
    pub ends: [u32; EndReason::ALL.len()],
    /// Of the points yellow's and black's rods lost by holding the ball too long, those
    /// with the ball behind the holder's own goalie (between its axis and the end wall),
    /// where no man of a rod that lifts its feet for a ball behind it plays it.
    pub held_behind_goalie: [u32; 2],
    /// Matches that ran to their time limit.
    pub time_limits: u32,
    /// Points served by yellow and by black (a point runs from a serve to its end).
    pub serves: [u32; 2],
    /// Of them, the points the serving side won by a goal.
    pub scored_on_serve: [u32; 2],
    /// The side that served the point in play (0 yellow, 1 black).
    server: usize,
}

impl BallFlow {
    /// Counts a serve by `side`: the point that follows is that side's.
    pub fn serve(&mut self, side: Team) {
        self.server = usize::from(side == Team::Black);
        self.serves[self.server] += 1;
    }

    /// Counts one agent step in which the ball's centre moved from world (x, y) `before`
    /// to `after` (cm).
    pub fn step(&mut self, before: [f32; 2], after: [f32; 2]) {
        let (y0, y1) = (before[1], after[1]);
        self.reach_steps[rod_in_reach(y1).unwrap_or(NUM_RODS)] += 1;
        let in_mouth = u32::from(after[0].abs() < GOAL_HALF_WIDTH);
        for rod in 0..NUM_RODS {
            let y = rod_y(rod);
            if y0 < y && y1 >= y {
                self.towards_black[rod] += 1;
                if rod == 4 {
                    self.goalie_in_mouth[1] += in_mouth;
                }
            } else if y0 >= y && y1 < y {
                self.towards_yellow[rod] += 1;
                if rod == 0 {
                    self.goalie_in_mouth[0] += in_mouth;
                }
            }
        }
    }

    /// Counts a point's end, the ball's centre at world y `ball_y` (cm).
    pub fn end(&mut self, reason: EndReason, ball_y: f32) {
        if let Some(i) = EndReason::ALL.iter().position(|&r| r == reason) {
            self.ends[i] += 1;
        }
        let scorer = match reason {
            EndReason::Scored => Some(0),
            EndReason::Conceded => Some(1),
            _ => None,
        };
        if scorer == Some(self.server) {
            self.scored_on_serve[self.server] += 1;
        }
        match reason {
            EndReason::YellowHeld if ball_y < rod_y(0) => self.held_behind_goalie[0] += 1,
            EndReason::BlackHeld if ball_y > rod_y(4) => self.held_behind_goalie[1] += 1,
            _ => {}
        }
    }

    fn ended(&self, reason: EndReason) -> u32 {
        EndReason::ALL
            .iter()
            .position(|&r| r == reason)
            .map_or(0, |i| self.ends[i])
    }

    /// The flow as the side on yellow (`yellow`) or on black saw it.
    pub fn side(&self, yellow: bool) -> SideFlow {
        let (own, theirs) = if yellow { (0, 4) } else { (4, 0) };
        let (forward, backward) = if yellow {
            (&self.towards_black, &self.towards_yellow)
        } else {
            (&self.towards_yellow, &self.towards_black)
        };
        let (held_own, held_theirs) = if yellow {
            (EndReason::YellowHeld, EndReason::BlackHeld)
        } else {
            (EndReason::BlackHeld, EndReason::YellowHeld)
        };
        let (scored, let_in) = if yellow {
            (EndReason::Scored, EndReason::Conceded)
        } else {
            (EndReason::Conceded, EndReason::Scored)
        };
        SideFlow {
            own_reach: std::array::from_fn(|k| self.reach_steps[own + k]),
            their_reach: std::array::from_fn(|k| self.reach_steps[theirs + k]),
            no_reach: self.reach_steps[NUM_RODS],
            attacks_past: std::array::from_fn(|k| forward[theirs + k]),
            let_past: std::array::from_fn(|k| backward[own + k]),
            attacks_past_goalie_in_mouth: self.goalie_in_mouth[usize::from(yellow)],
            let_past_goalie_in_mouth: self.goalie_in_mouth[usize::from(!yellow)],
            scored: self.ended(scored),
            let_in: self.ended(let_in),
            held_own: self.ended(held_own),
            held_theirs: self.ended(held_theirs),
            held_own_behind_goalie: self.held_behind_goalie[usize::from(!yellow)],
            held_theirs_behind_goalie: self.held_behind_goalie[usize::from(yellow)],
            dead_balls: self.ended(EndReason::Stagnant),
            time_limits: self.time_limits,
            own_serves: self.serves[usize::from(!yellow)],
            scored_on_own_serve: self.scored_on_serve[usize::from(!yellow)],
            their_serves: self.serves[usize::from(yellow)],
            scored_on_their_serve: self.scored_on_serve[usize::from(yellow)],
        }
    }
}

/// A match's ball flow as one side saw it; rods in the order goalie, defence, midfield,
/// attack. Adds up over matches ([`SideFlow::add`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SideFlow {
    /// Agent steps with the ball within reach of each of its own rods.
    pub own_reach: [u64; 4],
    /// Agent steps with the ball within reach of each of the other side's rods.
    pub their_reach: [u64; 4],
    /// Agent steps with the ball out of every rod's reach.
    pub no_reach: u64,
    /// Times the ball crossed each of the other side's rod axes towards the other goal.
    pub attacks_past: [u32; 4],
    /// Times the ball crossed each of its own rod axes towards its own goal.
    pub let_past: [u32; 4],
    /// Of the crossings of the other side's goalie axis, those within the goal's width.
    pub attacks_past_goalie_in_mouth: u32,
    /// Of the crossings of its own goalie's axis, those within the goal's width.
    pub let_past_goalie_in_mouth: u32,
    /// Goals it scored.
    pub scored: u32,
    /// Goals it let in.
    pub let_in: u32,
    /// Points it lost by holding the ball past the possession limit.
    pub held_own: u32,
    /// Points the other side lost so.
    pub held_theirs: u32,
    /// Of `held_own`, those with the ball behind its own goalie.
    pub held_own_behind_goalie: u32,
    /// Of `held_theirs`, those with the ball behind the other side's goalie.
    pub held_theirs_behind_goalie: u32,
    /// Points ended by a dead ball (served again).
    pub dead_balls: u32,
    /// Matches that ran to their time limit.
    pub time_limits: u32,
    /// Points it served.
    pub own_serves: u32,
    /// Of them, those it won by a goal.
    pub scored_on_own_serve: u32,
    /// Points the other side served.
    pub their_serves: u32,
    /// Of them, those the other side won by a goal.
    pub scored_on_their_serve: u32,
}

impl SideFlow {
    /// Adds another match's (or matches') flow.
    pub fn add(&mut self, o: &SideFlow) {
        for k in 0..4 {
            self.own_reach[k] += o.own_reach[k];
            self.their_reach[k] += o.their_reach[k];
            self.attacks_past[k] += o.attacks_past[k];
            self.let_past[k] += o.let_past[k];
        }
        self.no_reach += o.no_reach;
        self.attacks_past_goalie_in_mouth += o.attacks_past_goalie_in_mouth;
        self.let_past_goalie_in_mouth += o.let_past_goalie_in_mouth;
        self.scored += o.scored;
        self.let_in += o.let_in;
        self.held_own += o.held_own;
        self.held_theirs += o.held_theirs;
        self.held_own_behind_goalie += o.held_own_behind_goalie;
        self.held_theirs_behind_goalie += o.held_theirs_behind_goalie;
        self.dead_balls += o.dead_balls;
        self.time_limits += o.time_limits;
        self.own_serves += o.own_serves;
        self.scored_on_own_serve += o.scored_on_own_serve;
        self.their_serves += o.their_serves;
        self.scored_on_their_serve += o.scored_on_their_serve;
    }

    /// One line: the ball's time by rod (per cent of agent steps), the crossings of each
    /// side's rods towards goal and the goals, and how the points ended.
    pub fn summary(&self) -> String {
        let total = (self.own_reach.iter().chain(&self.their_reach).sum::<u64>() + self.no_reach)
            .max(1) as f64;
        let pct = |v: &[u64; 4]| {
            v.iter()
                .map(|&s| format!("{:.0}", 100.0 * s as f64 / total))
                .collect::<Vec<_>>()
                .join("/")
        };
        let count = |v: &[u32; 4]| {
            v.iter()
                .rev()
                .map(u32::to_string)
                .collect::<Vec<_>>()
                .join("/")
        };
        format!(
            "ball within reach of own G/D/M/A {} %, theirs {} %, no rod {:.0} %; \
             past their A/M/D/G towards their goal {} (G within the goal's width {}), \
             goals {}; past own A/M/D/G {} ({}), goals {}; balls held too long: own {} \
             ({} behind the goalie), theirs {} ({}); dead balls {}; matches to the time \
             limit {}; points served: own {} (won by a goal {}), theirs {} ({})",
            pct(&self.own_reach),
            pct(&self.their_reach),
            100.0 * self.no_reach as f64 / total,
            count(&self.attacks_past),
            self.attacks_past_goalie_in_mouth,
            self.scored,
            count(&self.let_past),
            self.let_past_goalie_in_mouth,
            self.let_in,
            self.held_own,
            self.held_own_behind_goalie,
            self.held_theirs,
            self.held_theirs_behind_goalie,
            self.dead_balls,
            self.time_limits,
            self.own_serves,
            self.scored_on_own_serve,
            self.their_serves,
            self.scored_on_their_serve
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ball_rolling_into_blacks_goal_crosses_blacks_rods_in_order() {
        let mut f = BallFlow::default();
        f.serve(Team::Yellow);
        // From yellow's midfield (y = -7.5) to black's goal line, 1 cm a step.
        let ys: Vec<f32> = (0..=72).map(|k| -7.5 + k as f32).collect();
        for w in ys.windows(2) {
            f.step([0.0, w[0]], [0.0, w[1]]);
        }
        f.end(EndReason::Scored, 64.5);
        f.end(EndReason::BlackHeld, rod_y(4) + 5.0);
        f.end(EndReason::YellowHeld, rod_y(2));
        let yellow = f.side(true);
        // Black's midfield, defence and goalie lie ahead (+y); its attack behind.
        assert_eq!(
            yellow.attacks_past,
            [1, 1, 1, 0],
            "goalie, defence, midfield, attack"
        );
        assert_eq!(yellow.let_past, [0; 4]);
        assert_eq!(yellow.attacks_past_goalie_in_mouth, 1);
        assert_eq!((yellow.scored, yellow.let_in), (1, 0));
        // Yellow's attack (y = 22.5) is crossed too, but that is none of black's rods.
        assert_eq!(f.towards_black[3], 1);
        // Black saw the same ball come at it.
        let black = f.side(false);
        assert_eq!(black.let_past, [1, 1, 1, 0]);
        assert_eq!((black.scored, black.let_in), (0, 1));
        assert_eq!(
            (yellow.held_theirs, yellow.held_theirs_behind_goalie),
            (1, 1)
        );
        assert_eq!((yellow.held_own, yellow.held_own_behind_goalie), (1, 0));
        assert_eq!((black.held_own, black.held_own_behind_goalie), (1, 1));
        assert_eq!((yellow.own_serves, yellow.scored_on_own_serve), (1, 1));
        assert_eq!((black.their_serves, black.scored_on_their_serve), (1, 1));
        // Black serves and yellow scores: a goal against the serve.
        f.serve(Team::Black);
        f.end(EndReason::Scored, 64.5);
        let yellow = f.side(true);
        assert_eq!((yellow.their_serves, yellow.scored_on_their_serve), (1, 0));
        assert_eq!(yellow.scored, 2);
        assert_eq!(black.own_reach, yellow.their_reach);
        let steps: u64 = f.reach_steps.iter().sum();
        assert_eq!(steps, 72);
        // Every rod's reach is 2 x 6.7 cm of the 72 cm rolled, except yellow's midfield,
        // whose reach the ball starts in (half of it behind).
        assert!(yellow.own_reach[2] >= 6 && yellow.own_reach[2] <= 8);
        assert!((13..=14).contains(&yellow.their_reach[0]));
    }

    #[test]
    fn a_ball_that_comes_back_counts_each_crossing() {
        let mut f = BallFlow::default();
        let goalie_line = rod_y(4);
        // Twice past black's goalie by the wall, back once.
        f.step([30.0, goalie_line - 1.0], [30.0, goalie_line + 1.0]);
        f.step([30.0, goalie_line + 1.0], [30.0, goalie_line - 1.0]);
        f.step([30.0, goalie_line - 1.0], [30.0, goalie_line + 1.0]);
        assert_eq!(f.towards_black[4], 2);
        assert_eq!(f.towards_yellow[4], 1);
        assert_eq!(
            f.goalie_in_mouth,
            [0, 0],
            "by the wall, not in the goal's width"
        );
        let mut all = SideFlow::default();
        all.add(&f.side(true));
        all.add(&f.side(true));
        assert_eq!(all.attacks_past[0], 4);
        assert!(all.summary().contains(
            "past their A/M/D/G towards their goal 0/0/0/4 (G within the goal's width 0)"
        ));
    }
}
