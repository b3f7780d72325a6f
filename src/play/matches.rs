//! Two-sided matches: yellow and black each driven by any [`Contestant`], both sides
//! scoring, the ball served again after every goal, to a number of goals or a time limit.
//!
//! Black sees the table through [`foosball_env::layout::mirror_observation`] carried into its ball frame
//! ([`PolicyOpponent`]), so a policy trained as yellow plays black unchanged.
//!
//! The match rules on top of the table's ([`match_table`]): a goal at either end ends the
//! point; yellow's own goal line is black's goal line mirrored (the reference code's own-goal
//! test, world y < -69, cannot be reached); the "no progress" rule of the training episode
//! is off (black attacks the other way); a dead ball (slower than the table's
//! `stagnant_speed` for `dead_ball_s`) is served again without a goal. The table hands
//! out the whole state; a run trained with `observation.hide_black_rods` hides the other
//! side's rods from itself ([`Contestant::policy`]), whichever side it plays.
//!
//! Kick-off ([`Kickoff`]): every serve draws the ball from the table's own start
//! distribution (for `reference`, at rest 4 cm on yellow's side of the centre line, by
//! yellow's midfield) from the match's own seed stream, on the serving side's half (black's
//! serve is that point turned 180 degrees). By default the side scored upon serves next
//! (ITSF's rule), the match's first serve is yellow's and a dead ball is served again by
//! the side that served it; `kickoff = "yellow"` serves every ball on yellow's side. The
//! serve favours neither side over a league because every pair plays each serve sequence
//! twice, sides swapped.
//!
//! Possession ([`MatchRules::possession`], off by default): ITSF's limits, 10 s on a
//! five-man rod and 15 s elsewhere; a rod that holds the ball longer loses it to the
//! other side's serve, and a still ball within a rod's reach is that rod's, not a dead
//! ball, so a served ball that nobody plays no longer stalls a match.

use foosball_env::layout::{ACTION_DIM, OBS_DIM};
use foosball_env::seeding::{MATCHES, derive_seed};
use foosball_env::{
    EndReason, Env, EnvRng, FoosballConfig, FoosballEnv, Opponent, foosball::in_ball_frame,
};
use serde::{Deserialize, Serialize};
use std::sync::{Arc, Mutex, PoisonError};

use super::contestant::Contestant;
use super::evaluation::OwnedPolicy;
use super::flow::BallFlow;
use foosball_env::config::BallFrame;
use foosball_env::geometry::Team;

/// How a match is played.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MatchRules {
    /// The first side to this many goals wins (default 5, ITSF's game).
    pub goals_to_win: u32,
    /// Seconds of play after which the side ahead wins, or it is a draw (default 60).
    pub time_limit_s: f32,
    /// Seconds a ball may lie dead before it is served again (default 1).
    pub dead_ball_s: f32,
    /// Who serves (default `conceded`, ITSF's rule).
    pub kickoff: Kickoff,
    /// ITSF's possession limits (default false, the leagues made before 2026-11-29): a rod
    /// that holds the ball longer than `possession_limit_s` loses it (the point ends, the
    /// other side serves under `kickoff = "conceded"`), and a still ball within a rod's
    /// reach is not dead ([`foosball_env::possession`]).
    pub possession: bool,
    /// The limits, seconds: a five-man rod's and every other rod's (default ITSF's 10, 15).
    pub possession_limit_s: [f32; 2],
}

/// Who serves the next ball of a match.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kickoff {
    /// ITSF's rule: after a goal the side scored upon serves; the first serve is
    /// yellow's, a dead ball is served again by the side that served it.
    #[default]
    Conceded,
    /// Every serve on yellow's side, whoever scored: black always meets the other
    /// side's serve (the rule of the leagues made before 2026-11-28).
    Yellow,
}

impl Kickoff {
    /// The side that serves after a point served by `served` ended with `end`.
    pub fn next_server(self, served: Team, end: Option<EndReason>) -> Team {
        match (self, end.and_then(EndReason::loser_of_the_ball)) {
            (Kickoff::Yellow, _) => Team::Yellow,
            (Kickoff::Conceded, Some(loser)) => loser.other(),
            (Kickoff::Conceded, None) => served,
        }
    }

    /// The rule in a few words.
    pub fn meaning(self) -> &'static str {
        match self {
            Kickoff::Conceded => "the side scored upon serves (ITSF)",
            Kickoff::Yellow => "every serve on yellow's side",
        }
    }

    /// The rule's name in configs and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Kickoff::Conceded => "conceded",
            Kickoff::Yellow => "yellow",
        }
    }
}

impl std::str::FromStr for Kickoff {
    type Err = String;

    /// `conceded` or `yellow`.
    fn from_str(name: &str) -> Result<Self, String> {
        [Kickoff::Conceded, Kickoff::Yellow]
            .into_iter()
            .find(|k| k.name() == name)
            .ok_or_else(|| format!("unknown kick-off rule `{name}`; expected conceded or yellow"))
    }
}

impl std::fmt::Display for Kickoff {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl Default for MatchRules {
    fn default() -> Self {
        Self {
            goals_to_win: 5,
            time_limit_s: 60.0,
            dead_ball_s: 1.0,
            kickoff: Kickoff::Conceded,
            possession: false,
            possession_limit_s: foosball_env::possession::ITSF_LIMITS_S,
        }
    }
}

impl MatchRules {
    /// Checks the values; the error names the key.
    pub fn validate(&self) -> Result<(), String> {
        if self.goals_to_win == 0 {
            return Err("match.goals_to_win: must be at least 1".into());
        }
        let [five_man, other] = self.possession_limit_s;
        for (key, v) in [
            ("match.time_limit_s", self.time_limit_s),
            ("match.dead_ball_s", self.dead_ball_s),
            ("match.possession_limit_s", five_man),
            ("match.possession_limit_s", other),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{key}: must be a finite number > 0, got {v}"));
            }
        }
        Ok(())
    }
}

/// How a match ended.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MatchResult {
    /// Goals yellow scored.
    pub yellow_goals: u32,
    /// Goals black scored.
    pub black_goals: u32,
    /// Agent steps played.
    pub steps: u64,
    /// Serves (kick-offs and dead-ball serves).
    pub serves: u32,
    /// Spins of yellow's rods ([`foosball_env::spin`]); no rule punishes them in a match.
    #[serde(default)]
    pub yellow_spins: u32,
    /// Spins of black's rods.
    #[serde(default)]
    pub black_spins: u32,
}

impl MatchResult {
    /// Yellow's points: 1 for a win, 0.5 for a draw, 0 for a loss.
    pub fn yellow_points(&self) -> f64 {
        self.side(true).points
    }

    /// The match as one side saw it (`yellow`: yellow's side, else black's).
    pub fn side(&self, yellow: bool) -> SideResult {
        let (scored, let_in, spins) = if yellow {
            (self.yellow_goals, self.black_goals, self.yellow_spins)
        } else {
            (self.black_goals, self.yellow_goals, self.black_spins)
        };
        let points = match scored.cmp(&let_in) {
            std::cmp::Ordering::Greater => 1.0,
            std::cmp::Ordering::Equal => 0.5,
            std::cmp::Ordering::Less => 0.0,
        };
        SideResult {
            scored,
            let_in,
            points,
            spins,
            steps: self.steps,
        }
    }
}

/// One side's view of a match.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SideResult {
    /// Goals it scored.
    pub scored: u32,
    /// Goals it let in.
    pub let_in: u32,
    /// Its points: 1 for a win, 0.5 for a draw, 0 for a loss.
    pub points: f64,
    /// Spins of its rods.
    pub spins: u32,
    /// Agent steps the match lasted.
    pub steps: u64,
}

/// One side's matches added up.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tally {
    /// Matches played.
    pub matches: u32,
    /// Wins.
    pub wins: u32,
    /// Draws.
    pub draws: u32,
    /// Losses.
    pub losses: u32,
    /// Goals scored.
    pub scored: u64,
    /// Goals let in.
    pub let_in: u64,
    /// Points: a win 1, a draw 0.5.
    pub points: f64,
    /// Spins of its rods.
    pub spins: u64,
    /// Agent steps played.
    pub steps: u64,
}

impl Tally {
    /// Adds one match as the side saw it.
    pub fn add(&mut self, s: SideResult) {
        self.matches += 1;
        self.scored += u64::from(s.scored);
        self.let_in += u64::from(s.let_in);
        self.points += s.points;
        self.spins += u64::from(s.spins);
        self.steps += s.steps;
        match s.scored.cmp(&s.let_in) {
            std::cmp::Ordering::Greater => self.wins += 1,
            std::cmp::Ordering::Equal => self.draws += 1,
            std::cmp::Ordering::Less => self.losses += 1,
        }
    }

    /// Goals scored minus goals let in.
    pub fn goal_difference(&self) -> i64 {
        self.scored as i64 - self.let_in as i64
    }

    /// Spins per minute of play, on a table whose agent step lasts `agent_dt` seconds.
    pub fn spins_per_minute(&self, agent_dt: f32) -> f64 {
        self.spins as f64 / (self.steps as f64 * f64::from(agent_dt) / 60.0)
    }
}

/// The first contestant's matches of [`head_to_head`] added up: `[all, as yellow, as
/// black]` (under `kickoff = "yellow"` every serve lies on yellow's side).
pub fn tallies(played: &[Played]) -> [Tally; 3] {
    let mut t = [Tally::default(); 3];
    for p in played {
        t[0].add(p.a_side());
        t[if p.a_on_yellow { 1 } else { 2 }].add(p.a_side());
    }
    t
}

/// `table` with the match rules of the module docs.
pub fn match_table(table: &FoosballConfig, rules: &MatchRules) -> FoosballConfig {
    let mut t = symmetric_goals(table);
    t.rules.end_on_goal = true;
    t.rules.no_progress_steps = u32::MAX;
    t.rules.stagnant_steps = ((rules.dead_ball_s / t.agent_dt()).ceil() as u32).max(1);
    t.max_episode_steps = u32::MAX;
    t.observation.hide_black_rods = false;
    t.rules.possession = rules.possession;
    t.rules.possession_limit_s = rules.possession_limit_s;
    t.rules.end_on_lost_ball = false; // a training rule: a match's points end only as above
    t
}

/// `table` with yellow's own-goal line at black's goal line mirrored, so that a goal by
/// black counts (the reference's own-goal line, world y < -69, cannot be reached).
pub fn symmetric_goals(table: &FoosballConfig) -> FoosballConfig {
    let mut t = table.clone();
    // own_goal_line_world = -own_goal_line_y + oy  must equal  -(goal_line_y + oy).
    let oy = t.ball_frame.origin()[1];
    t.reward.own_goal_line_y = t.reward.goal_line_y + 2.0 * oy;
    t
}

/// Black driven by a policy trained as yellow: it is handed black's mirrored view in
/// the table's ball frame, and its action is black's in black's own frame. Where the
/// policy fails (an outside policy's error), black's rods hold and the first error is
/// kept in its [`PolicyOpponent::fault`] for whoever drives the table.
pub struct PolicyOpponent {
    policy: OwnedPolicy,
    frame: BallFrame,
    fault: Arc<Mutex<Option<String>>>,
}

impl PolicyOpponent {
    /// `policy` playing black on a table whose ball numbers are in `frame`.
    pub fn new(policy: OwnedPolicy, frame: BallFrame) -> Self {
        Self {
            policy,
            frame,
            fault: Arc::default(),
        }
    }

    /// Where its policy's first error is kept (shared: read it after the opponent has
    /// moved into a table).
    pub fn fault(&self) -> Arc<Mutex<Option<String>>> {
        Arc::clone(&self.fault)
    }
}

impl Opponent for PolicyOpponent {
    fn act(&mut self, obs: &[f32; OBS_DIM], _rng: &mut EnvRng) -> [f32; ACTION_DIM] {
        match (self.policy)(&in_ball_frame(obs, self.frame)) {
            Ok(action) => std::array::from_fn(|i| action.get(i).copied().unwrap_or(0.0)),
            Err(e) => {
                let mut fault = self.fault.lock().unwrap_or_else(PoisonError::into_inner);
                fault.get_or_insert(e);
                [0.0; ACTION_DIM]
            }
        }
    }
}

/// Plays one match of `yellow` against `black` on `table` (already a [`match_table`]);
/// serve `k` is drawn from `derive_seed(seed, MATCHES, k)` on the side `rules.kickoff`
/// names (whatever the table's `start.black_share`), and each side's own random draws
/// from the same seed. A side's non-finite action counts as all zeros (the rods hold), as
/// the env does for black.
pub fn play_match(
    table: &FoosballConfig,
    rules: &MatchRules,
    yellow: &Contestant,
    black: &Contestant,
    seed: u64,
) -> Result<MatchResult, String> {
    play_match_traced(table, rules, yellow, black, seed).map(|(result, _)| result)
}

/// [`play_match`] with where its ball went ([`BallFlow`]).
pub fn play_match_traced(
    table: &FoosballConfig,
    rules: &MatchRules,
    yellow: &Contestant,
    black: &Contestant,
    seed: u64,
) -> Result<(MatchResult, BallFlow), String> {
    let mut act = yellow.policy(table, derive_seed(seed, MATCHES, u64::MAX))?;
    let black_name = black.to_string();
    let black = black.policy(table, derive_seed(seed, MATCHES, u64::MAX - 1))?;
    let opponent = PolicyOpponent::new(black, table.ball_frame);
    let black_fault = opponent.fault();
    let mut env = FoosballEnv::with_opponent(table.clone(), Box::new(opponent))
        .map_err(|e| format!("match table: env.{e}"))?;
    let limit = (f64::from(rules.time_limit_s) / f64::from(table.agent_dt())).round() as u64;
    let mut result = MatchResult::default();
    let mut flow = BallFlow::default();
    let ball_xy = |env: &FoosballEnv| {
        env.table()
            .map_or([0.0; 2], |t| std::array::from_fn(|i| t.ball_position()[i]))
    };
    let mut server = Team::Yellow;
    while result.steps < limit && result.yellow_goals.max(result.black_goals) < rules.goals_to_win {
        env.serve_on(server);
        flow.serve(server);
        let mut obs = env.reset(Some(derive_seed(seed, MATCHES, u64::from(result.serves))));
        result.serves += 1;
        let mut spins = [0; 2];
        let mut xy = ball_xy(&env);
        while result.steps < limit {
            let mut action = act(&obs).map_err(|e| format!("yellow ({yellow}): {e}"))?;
            action.resize(ACTION_DIM, 0.0);
            action
                .iter_mut()
                .filter(|a| !a.is_finite())
                .for_each(|a| *a = 0.0);
            let (next, t) = env.step(&action).map_err(|e| e.to_string())?;
            if let Some(e) = black_fault.lock().ok().and_then(|mut f| f.take()) {
                return Err(format!("black ({black_name}): {e}"));
            }
            result.steps += 1;
            obs = next;
            spins = t.info.spins;
            let after = ball_xy(&env);
            flow.step(xy, after);
            xy = after;
            match t.info.end {
                Some(EndReason::Scored) => result.yellow_goals += 1,
                Some(EndReason::Conceded) => result.black_goals += 1,
                _ => {}
            }
            if let Some(end) = t.info.end {
                flow.end(end, xy[1]);
            }
            if t.done() {
                server = rules.kickoff.next_server(server, t.info.end);
                break;
            }
        }
        result.yellow_spins += spins[0];
        result.black_spins += spins[1];
    }
    if result.steps >= limit {
        flow.time_limits += 1;
    }
    Ok((result, flow))
}

/// The serve seed of round `round` of a pair under a league or head-to-head `seed`: both
/// matches of a round (sides swapped) are served alike.
pub fn round_seed(seed: u64, round: u32) -> u64 {
    derive_seed(seed, MATCHES, u64::from(round))
}

/// One match of a [`head_to_head`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Played {
    /// The first contestant played yellow.
    pub a_on_yellow: bool,
    /// How it ended.
    pub result: MatchResult,
    /// Where its ball went.
    pub flow: BallFlow,
}

impl Played {
    /// The first contestant's view of the match.
    pub fn a_side(&self) -> SideResult {
        self.result.side(self.a_on_yellow)
    }
}

/// `rounds` rounds of `a` against `b`, each a match with `a` on yellow and one with `b`
/// on yellow from the same serves, in that order.
pub fn head_to_head(
    table: &FoosballConfig,
    rules: &MatchRules,
    a: &Contestant,
    b: &Contestant,
    rounds: u32,
    seed: u64,
) -> Result<Vec<Played>, String> {
    let mut out = Vec::with_capacity(2 * rounds as usize);
    for round in 0..rounds {
        let s = round_seed(seed, round);
        for (a_on_yellow, yellow, black) in [(true, a, b), (false, b, a)] {
            let (result, flow) = play_match_traced(table, rules, yellow, black, s)?;
            out.push(Played {
                a_on_yellow,
                result,
                flow,
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_side_scored_upon_serves_under_itsf_rules() {
        use EndReason::{Conceded, Scored, Stagnant};
        let k = Kickoff::Conceded;
        assert_eq!(k.next_server(Team::Yellow, Some(Scored)), Team::Black);
        assert_eq!(k.next_server(Team::Black, Some(Scored)), Team::Black);
        assert_eq!(k.next_server(Team::Black, Some(Conceded)), Team::Yellow);
        // A dead ball is served again by the side that served it.
        assert_eq!(k.next_server(Team::Black, Some(Stagnant)), Team::Black);
        assert_eq!(k.next_server(Team::Yellow, Some(Stagnant)), Team::Yellow);
        // A rod that held the ball too long loses it to the other side.
        assert_eq!(
            k.next_server(Team::Yellow, Some(EndReason::YellowHeld)),
            Team::Black
        );
        assert_eq!(
            k.next_server(Team::Yellow, Some(EndReason::BlackHeld)),
            Team::Yellow
        );
        assert_eq!(
            k.next_server(Team::Black, Some(EndReason::BlackHeld)),
            Team::Yellow
        );
        for end in [Some(Scored), Some(Conceded), Some(Stagnant), None] {
            assert_eq!(Kickoff::Yellow.next_server(Team::Black, end), Team::Yellow);
        }
        assert_eq!("yellow".parse::<Kickoff>(), Ok(Kickoff::Yellow));
        assert_eq!("conceded".parse::<Kickoff>(), Ok(Kickoff::Conceded));
        assert!("loser".parse::<Kickoff>().unwrap_err().contains("`loser`"));
    }

    #[test]
    fn tallies_split_the_matches_by_side() {
        let m = |a_on_yellow, yellow_goals, black_goals| Played {
            a_on_yellow,
            result: MatchResult {
                yellow_goals,
                black_goals,
                ..MatchResult::default()
            },
            flow: BallFlow::default(),
        };
        // As yellow: a 2:0 win and a 1:1 draw; as black: a loss, yellow won 5:0.
        let played = [m(true, 2, 0), m(true, 1, 1), m(false, 5, 0)];
        let [all, yellow, black] = tallies(&played);
        assert_eq!((all.matches, all.wins, all.draws, all.losses), (3, 1, 1, 1));
        assert_eq!((all.scored, all.let_in), (3, 6));
        assert_eq!(
            (yellow.wins, yellow.draws, yellow.scored, yellow.let_in),
            (1, 1, 3, 1)
        );
        assert_eq!((black.losses, black.scored, black.let_in), (1, 0, 5));
    }
}
