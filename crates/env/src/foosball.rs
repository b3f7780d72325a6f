//! [`FoosballEnv`]: yellow (the agent) against a black [`Opponent`] on the simulated table.
//!
//! One agent step holds the action for `frame_skip` physics steps of `physics_dt`. The
//! reward is `alpha - distance_weight * d + beta * [in goal] - conceded_penalty * [in own
//! goal]` on the ball's position after the step (see [`crate::config::RewardConfig`]),
//! paid on every step. An episode ends when the ball stays at or under
//! `rules.stagnant_speed` for `rules.stagnant_steps` steps or gains no y for `rules.no_progress_steps` steps
//! (terminated; under `rules.possession` only out of every rod's reach), when one rod
//! holds it past its possession limit under `rules.possession` ([`crate::possession`],
//! terminated), when it enters a goal under `rules.end_on_goal` (terminated), reaches
//! `max_episode_steps` (truncated), or the physics fails: a non-finite state or a ball
//! out of the table (truncated, flagged as [`EndReason::PhysicsFault`]). Under
//! `rules.serve_again` the ends of a point (a goal, a stagnant ball, no progress, a ball
//! held too long) serve the
//! ball again instead, as a match does, and the episode goes on to its time limit.

use std::collections::VecDeque;

use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::EnvRng;
use crate::config::{
    ActionMap, BallFrame, ConfigError, EpisodeRules, FoosballConfig, Serve, SpinRule,
};
use crate::env::{Env, EnvError, StepInfo, Transition, check_action};
use crate::geometry::{self, NUM_RODS, Team};
use crate::layout::{
    self, ACTION_DIM, BALL_POS, BALL_VEL, OBS_DIM, ROD_ANGLE, ROD_ANGLE_VEL, ROD_SLIDE,
    ROD_SLIDE_VEL, action_slide, action_turn,
};
use crate::observation::{FrameStack, ObservationKind};
use crate::opponent::Opponent;
use crate::possession::{PossessionClock, is_five_man};
use crate::render::{Frame, Renderer};
use crate::roster::opponent_for;
use crate::spin::SpinMeter;
use crate::starts::{Drill, EpisodeStarts, ReplayStart, drill_at};
use crate::table::{PhysicsParams, Table};

/// Rods per side: yellow's are the first four of the state's rod blocks.
const SIDE_RODS: usize = NUM_RODS / 2;

/// Why an episode ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EndReason {
    /// The ball entered black's goal under `rules.end_on_goal` (terminated).
    Scored,
    /// The ball entered yellow's own goal under `rules.end_on_goal` (terminated).
    Conceded,
    /// The ball stayed slower than `rules.stagnant_speed` too long (terminated).
    Stagnant,
    /// The ball gained no y too long (terminated).
    NoProgress,
    /// `max_episode_steps` reached (truncated).
    TimeLimit,
    /// Non-finite physics state or ball out of the table (truncated).
    PhysicsFault,
    /// One of yellow's rods spun under `rules.spin = "foul"` (terminated).
    SpinFoul,
    /// One of yellow's rods held the ball past its possession limit under
    /// `rules.possession` (terminated).
    YellowHeld,
    /// One of black's rods held the ball past its possession limit under
    /// `rules.possession` (terminated).
    BlackHeld,
    /// The side that served lost the ball under `rules.end_on_lost_ball`: it passed out
    /// of that side's midfield rod's reach towards its own goal (terminated, unpaid).
    LostBall,
}

impl EndReason {
    /// Every reason, in a fixed order (for tallies).
    pub const ALL: [EndReason; 10] = [
        EndReason::Scored,
        EndReason::Conceded,
        EndReason::Stagnant,
        EndReason::NoProgress,
        EndReason::TimeLimit,
        EndReason::PhysicsFault,
        EndReason::SpinFoul,
        EndReason::YellowHeld,
        EndReason::BlackHeld,
        EndReason::LostBall,
    ];

    /// Its name in logs (snake case).
    pub fn name(self) -> &'static str {
        match self {
            EndReason::Scored => "scored",
            EndReason::Conceded => "conceded",
            EndReason::Stagnant => "stagnant",
            EndReason::NoProgress => "no_progress",
            EndReason::TimeLimit => "time_limit",
            EndReason::PhysicsFault => "physics_fault",
            EndReason::SpinFoul => "spin_foul",
            EndReason::YellowHeld => "yellow_held",
            EndReason::BlackHeld => "black_held",
            EndReason::LostBall => "lost_ball",
        }
    }

    /// True where the episode reached a terminal state; false for truncations.
    pub fn is_terminal(self) -> bool {
        !matches!(self, EndReason::TimeLimit | EndReason::PhysicsFault)
    }

    /// True for the ends of a point, which `rules.serve_again` turns into a serve: a goal,
    /// a stagnant ball, a ball without progress, a ball held too long, a lost ball.
    pub fn ends_point(self) -> bool {
        matches!(
            self,
            EndReason::Scored
                | EndReason::Conceded
                | EndReason::Stagnant
                | EndReason::NoProgress
                | EndReason::YellowHeld
                | EndReason::BlackHeld
                | EndReason::LostBall
        )
    }

    /// The side that loses the ball by this end: the scoring side after a goal (the
    /// side scored upon serves), the holding side after a possession foul; `None` for the
    /// other ends (a lost ball is the point's attacker's, which the end alone
    /// does not name).
    pub fn loser_of_the_ball(self) -> Option<Team> {
        match self {
            EndReason::Scored | EndReason::YellowHeld => Some(Team::Yellow),
            EndReason::Conceded | EndReason::BlackHeld => Some(Team::Black),
            _ => None,
        }
    }
}

/// What evaluation needs from each step.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct FoosballInfo {
    /// Set on the last step of an episode.
    pub end: Option<EndReason>,
    /// Distance from the ball (x, y) to `reward.goal`, cm.
    pub goal_distance: f32,
    /// Ball speed, cm/s, as the env's `ball_frame` reads the velocity (in the joint frame
    /// `sqrt(vx² + 2 vy²)`, the reference gym's norm; see [`in_ball_frame`]).
    pub ball_speed: f32,
    /// Agent steps taken in this episode so far, this one included.
    pub steps: u32,
    /// The ball is in black's goal after this step.
    pub in_goal: bool,
    /// The ball is in yellow's own goal after this step.
    pub in_own_goal: bool,
    /// The ball has been in black's goal at some step of this episode, this one included.
    pub episode_scored: bool,
    /// The ball has been in yellow's goal at some step of this episode, this one included.
    pub episode_conceded: bool,
    /// Spins ([`crate::spin`]) of yellow's rods and of black's in this episode so far.
    pub spins: [u32; 2],
    /// Goals in this episode so far: the ball's entries into black's goal (yellow's goals)
    /// and into yellow's (black's goals).
    pub goals: [u32; 2],
    /// Serves after the kick-off in this episode so far (`rules.serve_again`); this step
    /// ended a point and served again when it grew.
    pub serves: u32,
    /// For an episode begun along a recorded one ([`crate::starts`]), the agent steps
    /// replayed before the agent took over (0: at the recorded episode's start); `None`
    /// for an episode the env drew itself.
    pub replayed: Option<u32>,
}

impl StepInfo for FoosballInfo {
    /// The ball lies in a goal, where it stays: a terminated step's reward (beta in
    /// black's goal, minus `conceded_penalty` in yellow's) would be paid on every later
    /// step.
    fn absorbing(&self) -> bool {
        self.in_goal || self.in_own_goal
    }
}

impl FoosballInfo {
    /// The episode has scored (so far): the ball has been in black's goal.
    pub fn scored(&self) -> bool {
        self.episode_scored
    }

    /// The episode has conceded (so far): the ball has been in yellow's goal.
    pub fn conceded(&self) -> bool {
        self.episode_conceded
    }

    /// The physics failed on this step (the observation is the last good one).
    pub fn physics_fault(&self) -> bool {
        self.end == Some(EndReason::PhysicsFault)
    }
}

/// What a reset may fix instead of drawing it ([`FoosballEnv::reset_with`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ResetOptions {
    /// The ball's start at rest, `[x, y]` in cm in the env's `ball_frame`; `None` draws it
    /// from `start` (a seeded draw uses the generator as a drawn start would, so the
    /// episode's other draws are the same either way).
    pub ball: Option<[f32; 2]>,
}

/// One episode's draw of the randomised quantities.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpisodeDraw {
    /// Physical settings of the table for this episode.
    pub physics: PhysicsParams,
    /// Standard deviation of the noise on observed positions.
    pub position_noise_std: f32,
    /// Agent steps by which yellow's actions are delayed.
    pub action_latency: u32,
}

/// Bookkeeping of the episode in progress.
#[derive(Debug, Clone)]
struct Episode {
    draw: EpisodeDraw,
    steps: u32,
    stagnant_steps: u32,
    no_progress_steps: u32,
    prev_ball_y: f32,
    pending: VecDeque<[f32; ACTION_DIM]>,
    /// Noise-free observation after the last step.
    state: [f32; OBS_DIM],
    over: bool,
    spin: SpinMeter,
    spins: [u32; 2],
    /// The ball was in black's goal, in yellow's, after the last step.
    in_goals: [bool; 2],
    /// Entries into black's goal, into yellow's, this episode.
    goals: [u32; 2],
    serves: u32,
    /// Agent steps replayed along a recorded episode before the agent took over.
    replayed: Option<u32>,
    possession: PossessionClock,
    /// The side whose half the point's ball was served on (world y <= 0: yellow's).
    attacker: Team,
}

/// The foosball table as a reinforcement-learning environment (see the module docs).
pub struct FoosballEnv {
    config: FoosballConfig,
    /// The frames of an image observation (None for the state).
    frames: Option<FrameStack>,
    rng: EnvRng,
    opponent: Box<dyn Opponent>,
    table: Option<Table>,
    episode: Option<Episode>,
    /// Chooses training episodes' starts along recorded episodes (None: every start drawn).
    starts: Option<Box<dyn EpisodeStarts>>,
    /// Practice spots for a share of the serves (empty: every serve from `start`).
    drills: Vec<Drill>,
    /// The own stream, kept aside while a replayed episode runs on the recorded one's.
    own_rng: Option<EnvRng>,
    /// Agent steps taken since the env was built (replayed steps not counted).
    agent_steps: u64,
    /// The side that serves next under `start.serve = "conceded"`.
    server: Team,
    /// Image observations only: the state the last frame was drawn from (position noise
    /// included), in the ball frame: what a state teacher reads ([`Env::teacher_view`]).
    state_view: Option<[f32; OBS_DIM]>,
}

fn uniform(rng: &mut EnvRng, [lo, hi]: [f32; 2]) -> f32 {
    lo + (hi - lo) * rng.random::<f32>()
}

fn gaussian(rng: &mut EnvRng) -> f32 {
    rng.sample(StandardNormal)
}

impl FoosballEnv {
    /// An environment with the opponent named in `config`.
    pub fn new(config: FoosballConfig) -> Result<Self, ConfigError> {
        let opponent = opponent_for(config.opponent);
        Self::with_opponent(config, opponent)
    }

    /// An environment with a custom opponent (e.g. a learned policy for self-play); the
    /// config's `opponent` key is ignored.
    pub fn with_opponent(
        config: FoosballConfig,
        opponent: Box<dyn Opponent>,
    ) -> Result<Self, ConfigError> {
        config.validate()?;
        let frames = (config.observation.kind == ObservationKind::Image)
            .then(|| FrameStack::new(config.observation));
        Ok(Self {
            config,
            frames,
            rng: EnvRng::seed_from_u64(0),
            opponent,
            table: None,
            episode: None,
            starts: None,
            drills: Vec::new(),
            own_rng: None,
            agent_steps: 0,
            server: Team::Yellow,
            state_view: None,
        })
    }

    /// This environment with training episodes started where `starts` says (see
    /// [`crate::starts`]): asked at every reset without a seed.
    pub fn with_starts(mut self, starts: Box<dyn EpisodeStarts>) -> Self {
        self.starts = Some(starts);
        self
    }

    /// This environment with a share of its serves put on practice spots ([`Drill`]; a
    /// training env's, never an evaluation's). Valid drills assumed
    /// ([`crate::starts::validate_drills`]); none leaves every draw as it was.
    pub fn with_drills(mut self, drills: Vec<Drill>) -> Self {
        self.drills = drills;
        self
    }

    /// A copy of this env in its current state (table, episode, random streams, opponent)
    /// that steps on exactly as this one would given the same actions: the planner's
    /// searches start their rollouts from one instead of replaying an episode's first
    /// steps. `None` where the opponent cannot be copied (a learned policy's). The copy
    /// chooses its next starts itself (no [`EpisodeStarts`]).
    pub fn snapshot(&self) -> Option<Self> {
        Some(Self {
            config: self.config.clone(),
            frames: self.frames.clone(),
            rng: self.rng.clone(),
            opponent: self.opponent.fork()?,
            table: self.table.clone(),
            episode: self.episode.clone(),
            starts: None,
            drills: self.drills.clone(),
            own_rng: self.own_rng.clone(),
            agent_steps: self.agent_steps,
            server: self.server,
            state_view: self.state_view,
        })
    }

    /// The settings this environment runs with.
    pub fn config(&self) -> &FoosballConfig {
        &self.config
    }

    /// Which side the following serves are on (a match's kick-off rule): `Team::Black`
    /// turns every serve 180 degrees onto black's side (`start.black_share = 1`),
    /// `Team::Yellow` keeps every serve on yellow's (`black_share = 0`, the paper's serve).
    pub fn serve_on(&mut self, side: Team) {
        self.config.start.black_share = match side {
            Team::Yellow => 0.0,
            Team::Black => 1.0,
        };
    }

    /// The table of the current episode (None before the first reset).
    pub fn table(&self) -> Option<&Table> {
        self.table.as_ref()
    }

    /// Mutable access to the table, for scripted scenarios and tests (e.g. placing the
    /// ball). The episode's counters are left as they are.
    pub fn table_mut(&mut self) -> Option<&mut Table> {
        self.table.as_mut()
    }

    /// The current state drawn by `renderer` (None before the first reset): an RGB frame,
    /// `[height, width, 3]` (Gymnasium's `render()` in `rgb_array` mode).
    pub fn render(&self, renderer: &Renderer) -> Option<Frame> {
        self.episode.as_ref().map(|e| renderer.draw(&e.state))
    }

    /// The randomised quantities of the current episode.
    pub fn episode_draw(&self) -> Option<&EpisodeDraw> {
        self.episode.as_ref().map(|e| &e.draw)
    }

    fn draw_episode(&mut self) -> EpisodeDraw {
        let nominal = PhysicsParams::nominal(&self.config);
        let r = &self.config.randomization;
        let rng = &mut self.rng;
        let ball_mass = nominal.ball_mass * uniform(rng, r.ball_mass_scale);
        let ball_friction = nominal.ball_friction * uniform(rng, r.ball_friction_scale);
        let restitution_scale = uniform(rng, r.ball_restitution_scale);
        let ball_restitution = (nominal.ball_restitution * restitution_scale).min(1.0);
        let men_restitution = (nominal.men_restitution * restitution_scale).min(1.0);
        let servo_gain_scale = uniform(rng, r.servo_gain_scale);
        let position_noise_std = uniform(rng, r.position_noise_std);
        let [lo, hi] = r.action_latency_steps;
        let action_latency = rng.random_range(lo..=hi);
        // Drawn last, and only when it varies: the streams of runs without it stay as
        // they were.
        let men_friction_scale = match r.men_friction_scale {
            [lo, hi] if lo == hi => lo,
            range => uniform(rng, range),
        };
        EpisodeDraw {
            physics: PhysicsParams {
                ball_mass,
                ball_friction,
                ball_restitution,
                men_restitution,
                servo_gain_scale,
                men_friction_scale,
                ..nominal
            },
            position_noise_std,
            action_latency,
        }
    }

    /// Starts an episode as [`Env::reset_into`] does, with what `options` fixes: the ball's
    /// start. A value off the playfield (or not finite) is refused with an error naming it,
    /// and the environment is left as it was.
    pub fn reset_with(
        &mut self,
        seed: Option<u64>,
        options: &ResetOptions,
        obs: &mut [f32],
    ) -> Result<(), EnvError> {
        let ball = options
            .ball
            .map(|seen| self.ball_start_world(seen))
            .transpose()?;
        self.resume_own_stream(seed);
        self.start_episode(seed, ball, obs);
        Ok(())
    }

    /// Before a start the env draws itself: a seed restarts its stream (and reseeds the
    /// [`EpisodeStarts`]); without one, the stream kept aside while a replayed episode
    /// ran is taken up again.
    fn resume_own_stream(&mut self, seed: Option<u64>) {
        match seed {
            Some(seed) => {
                self.own_rng = None;
                if let Some(starts) = self.starts.as_mut() {
                    starts.reseed(seed);
                }
            }
            None => {
                if let Some(own) = self.own_rng.take() {
                    self.rng = own;
                }
            }
        }
    }

    /// Starts the episode recorded from `start.seed` and plays `start.actions` on it,
    /// the own stream kept aside; false where that episode ends on the way (another
    /// game's recording), the own stream then still aside for the caller's draw. The
    /// recorded part is served as recorded, without the drills.
    fn replay(&mut self, start: &ReplayStart, obs: &mut [f32]) -> bool {
        let own = self.own_rng.take().unwrap_or_else(|| self.rng.clone());
        self.own_rng = Some(own);
        let drills = std::mem::take(&mut self.drills);
        self.start_episode(Some(start.seed), None, obs);
        let reached = start
            .actions
            .iter()
            .all(|action| matches!(self.advance(action, obs), Ok(t) if !t.done()));
        self.drills = drills;
        if let Some(ep) = self.episode.as_mut() {
            ep.replayed = Some(start.actions.len() as u32);
        }
        reached
    }

    /// `seen` (the ball's `[x, y]` in the env's frame) in world coordinates, if the ball
    /// lies there on the playfield.
    fn ball_start_world(&self, seen: [f32; 2]) -> Result<[f32; 2], EnvError> {
        let [x, y] = self.config.to_world(seen);
        let [limit_x, limit_y] = ball_centre_limits();
        if !(x.abs() <= limit_x && y.abs() <= limit_y) {
            return Err(EnvError::ResetOption {
                key: "ball",
                reason: format!(
                    "{seen:?} ({:?} frame) is not on the playfield: world |x| <= {limit_x}, |y| <= {limit_y}",
                    self.config.ball_frame
                ),
            });
        }
        Ok([x, y])
    }

    /// A new episode: a fresh draw, the ball at `ball` (world) or drawn from `start`.
    fn start_episode(&mut self, seed: Option<u64>, ball: Option<[f32; 2]>, obs: &mut [f32]) {
        if let Some(seed) = seed {
            self.rng = EnvRng::seed_from_u64(seed);
            self.server = Team::Yellow;
        }
        let draw = self.draw_episode();
        let drawn = serve_point(&self.config, &self.drills, self.server, &mut self.rng);
        let [x, y] = ball.unwrap_or(drawn);
        let table = Table::new(&draw.physics, [x, y]);
        let state = Self::observe(&table);
        self.table = Some(table);
        self.opponent.reset(&mut self.rng);
        self.episode = Some(Episode {
            draw,
            steps: 0,
            stagnant_steps: 0,
            no_progress_steps: 0,
            prev_ball_y: y,
            pending: VecDeque::new(),
            state,
            over: false,
            spin: SpinMeter::new(&state[ROD_ANGLE]),
            spins: [0; 2],
            in_goals: [false; 2],
            goals: [0; 2],
            serves: 0,
            replayed: None,
            possession: PossessionClock::default(),
            attacker: served_by(y),
        });
        self.emit(&state, obs, true);
    }

    /// The noise-free observation of the table's state.
    fn observe(table: &Table) -> [f32; OBS_DIM] {
        let mut obs = [0.0; OBS_DIM];
        obs[BALL_POS].copy_from_slice(&table.ball_position());
        obs[BALL_VEL].copy_from_slice(&table.ball_velocity());
        for i in 0..NUM_RODS {
            let s = table.rod_state(i);
            obs[ROD_SLIDE.start + i] = s.slide;
            obs[ROD_SLIDE_VEL.start + i] = s.slide_vel;
            obs[ROD_ANGLE.start + i] = s.angle;
            obs[ROD_ANGLE_VEL.start + i] = s.angle_vel;
        }
        obs
    }

    /// Writes the observation of the world `state` into `out`: the state plus this
    /// episode's position noise, read in the env's `ball_frame`, or for images the stack
    /// with the picture of that noisy world state (filling the stack when `first` of the
    /// episode).
    fn emit(&mut self, state: &[f32; OBS_DIM], out: &mut [f32], first: bool) {
        let mut seen = *state;
        let std = self
            .episode
            .as_ref()
            .map_or(0.0, |e| e.draw.position_noise_std);
        if std > 0.0 {
            for range in [BALL_POS, ROD_SLIDE, ROD_ANGLE] {
                for v in &mut seen[range] {
                    *v += std * gaussian(&mut self.rng);
                }
            }
        }
        match self.frames.as_mut() {
            // The state in the ball frame; pictures are drawn from world coordinates.
            None => {
                out.copy_from_slice(&in_ball_frame(&seen, self.config.ball_frame));
                self.config.observation.conceal(out);
            }
            Some(frames) => {
                self.state_view = Some(in_ball_frame(&seen, self.config.ball_frame));
                if first {
                    frames.reset(&seen);
                } else {
                    frames.push(&seen);
                }
                frames.write(out);
            }
        }
    }

    /// The noise-free 38-dim state after the last step (None before the first reset):
    /// what the renderer and scripted policies read whatever the observation kind.
    pub fn state(&self) -> Option<&[f32; OBS_DIM]> {
        self.episode.as_ref().map(|e| &e.state)
    }

    /// Distance from the ball (world x, y) to the reward's goal point of `config`, cm.
    fn goal_distance(config: &FoosballConfig, ball: &[f32]) -> f32 {
        let [gx, gy] = config.goal_world();
        ((ball[0] - gx).powi(2) + (ball[1] - gy).powi(2)).sqrt()
    }

    /// Sets the four rods from `first_rod` on towards `action` (8 values, one team's).
    fn set_targets(
        table: &mut Table,
        map: ActionMap,
        first_rod: usize,
        action: &[f32; ACTION_DIM],
    ) {
        for r in 0..4 {
            let spec = &geometry::RODS[r];
            table.set_target(
                first_rod + r,
                map.target(action[action_slide(r)], spec.slide_range),
                map.target(action[action_turn(r)], spec.turn_range),
            );
        }
    }
}

/// The world state with its ball position and velocity read in `frame` (rods unchanged).
/// In the joint frame the third components repeat y's joint, as the reference gym reads
/// them (its `ball_z` joint does not exist; MuJoCo's id -1 indexes the last joint, y's).
pub fn in_ball_frame(state: &[f32; OBS_DIM], frame: BallFrame) -> [f32; OBS_DIM] {
    let mut seen = *state;
    if frame == BallFrame::Joint {
        let [ox, oy, _] = BallFrame::JOINT_ORIGIN;
        let (p, v) = (BALL_POS.start, BALL_VEL.start);
        seen[p] = state[p] - ox;
        seen[p + 1] = state[p + 1] - oy;
        seen[p + 2] = seen[p + 1];
        seen[v + 2] = state[v + 1];
    }
    seen
}

/// The inverse of [`in_ball_frame`] for what a hand-written policy reads: the ball's x
/// and y back in world coordinates, its z at the joint frame's origin height (the joint
/// frame's observation does not carry it).
pub fn from_ball_frame(seen: &[f32; OBS_DIM], frame: BallFrame) -> [f32; OBS_DIM] {
    let mut state = *seen;
    if frame == BallFrame::Joint {
        let [ox, oy, oz] = BallFrame::JOINT_ORIGIN;
        let (p, v) = (BALL_POS.start, BALL_VEL.start);
        state[p] = seen[p] + ox;
        state[p + 1] = seen[p + 1] + oy;
        state[p + 2] = oz;
        state[v + 2] = 0.0;
    }
    state
}

/// Which goal the ball at world `(x, y)` is in: `(black's, yellow's)`, black's from
/// `line_y` on, yellow's up to `own_line_y` (both world y).
fn goals(x: f32, y: f32, line_y: f32, own_line_y: f32) -> (bool, bool) {
    let in_mouth = x.abs() <= geometry::GOAL_HALF_WIDTH;
    (in_mouth && y >= line_y, in_mouth && y <= own_line_y)
}

/// Whether the ball of a world `state` (the 38 values of [`layout`], as recorded
/// trajectories hold them) lies in either goal under `config`'s goal lines: the test
/// behind [`FoosballInfo::in_goal`] and [`FoosballInfo::in_own_goal`].
pub fn ball_in_a_goal(config: &FoosballConfig, state: &[f32]) -> bool {
    let (x, y) = (state[BALL_POS.start], state[BALL_POS.start + 1]);
    let (black, yellow) = goals(x, y, config.goal_line_world(), config.own_goal_line_world());
    black || yellow
}

/// Where the ball is: in a goal that ends the episode, out of the table (or
/// non-finite), or in play.
fn ball_event(
    table: &Table,
    rules: &EpisodeRules,
    line_y: f32,
    own_line_y: f32,
) -> Option<EndReason> {
    let [x, y, z] = table.ball_position();
    let v = table.ball_velocity();
    if !(x.is_finite() && y.is_finite() && z.is_finite() && v.iter().all(|c| c.is_finite())) {
        return Some(EndReason::PhysicsFault);
    }
    if rules.end_on_goal && rules.end_episodes {
        match goals(x, y, line_y, own_line_y) {
            (true, _) => return Some(EndReason::Scored),
            (_, true) => return Some(EndReason::Conceded),
            _ => {}
        }
    }
    let margin = 1.0;
    let out = x.abs() > geometry::FIELD_HALF_WIDTH + margin
        || y.abs() > geometry::GOAL_POCKET_BACK + margin
        || z < -margin
        || z > 3.0 * geometry::WALL_HEIGHT;
    out.then_some(EndReason::PhysicsFault)
}

impl Env for FoosballEnv {
    type Info = FoosballInfo;

    fn obs_dim(&self) -> usize {
        self.config.observation.dim()
    }

    fn action_dim(&self) -> usize {
        ACTION_DIM
    }

    fn reset_into(&mut self, seed: Option<u64>, obs: &mut [f32]) {
        if seed.is_none() {
            let steps = self.agent_steps;
            let start = self.starts.as_mut().and_then(|s| s.next_start(steps));
            if start.is_some_and(|start| self.replay(&start, obs)) {
                return;
            }
        }
        self.resume_own_stream(seed);
        self.start_episode(seed, None, obs);
    }

    fn step_into(
        &mut self,
        action: &[f32],
        obs: &mut [f32],
    ) -> Result<Transition<FoosballInfo>, EnvError> {
        let transition = self.advance(action, obs)?;
        self.agent_steps += 1;
        Ok(transition)
    }

    /// For an image observation, the state its last frame was drawn from, in the ball
    /// frame (38 values: what a state learner would have been handed).
    fn teacher_view(&self) -> Option<&[f32]> {
        self.state_view.as_ref().map(|s| &s[..])
    }
}

impl FoosballEnv {
    /// One agent step (what [`Env::step_into`] does, uncounted: a replayed step too).
    fn advance(
        &mut self,
        action: &[f32],
        obs: &mut [f32],
    ) -> Result<Transition<FoosballInfo>, EnvError> {
        check_action(action, ACTION_DIM)?;
        let (Some(table), Some(ep)) = (self.table.as_mut(), self.episode.as_mut()) else {
            return Err(EnvError::NeedsReset);
        };
        if ep.over {
            return Err(EnvError::NeedsReset);
        }
        let mut yellow = [0.0; ACTION_DIM];
        yellow.copy_from_slice(action);
        ep.pending.push_back(yellow);
        let applied = if ep.pending.len() > ep.draw.action_latency as usize {
            ep.pending.pop_front().unwrap_or_default()
        } else {
            [0.0; ACTION_DIM]
        };
        let black_view = layout::mirror_observation(&ep.state);
        let map = self.config.action_map;
        let black = self
            .opponent
            .act_in(map, &black_view, &mut self.rng)
            .map(|a| if a.is_finite() { a } else { 0.0 });
        Self::set_targets(table, map, 0, &applied);
        Self::set_targets(table, map, 4, &black);

        let mut event = None;
        let line_y = self.config.goal_line_world();
        let own_line_y = self.config.own_goal_line_world();
        for _ in 0..self.config.frame_skip {
            table.step();
            event = ball_event(table, &self.config.rules, line_y, own_line_y);
            if event.is_some() {
                break;
            }
        }
        let mut state = Self::observe(table);
        if state.iter().any(|v| !v.is_finite()) {
            event = Some(EndReason::PhysicsFault);
            state = ep.state; // never hand out a poisoned observation
        }

        ep.steps += 1;
        // The ball's speed as the frame reads it (the joint frame's repeated y counts
        // twice, as in the reference's stagnation test).
        let seen = in_ball_frame(&state, self.config.ball_frame);
        let speed = seen[BALL_VEL].iter().map(|v| v * v).sum::<f32>().sqrt();
        let rules = &self.config.rules;
        ep.stagnant_steps = if speed <= rules.stagnant_speed {
            ep.stagnant_steps + 1
        } else {
            0
        };
        let y = state[BALL_POS.start + 1];
        ep.no_progress_steps = if y > ep.prev_ball_y {
            0
        } else {
            ep.no_progress_steps + 1
        };
        ep.prev_ball_y = y;
        let held = if rules.possession {
            let dt = self.config.agent_dt();
            let [five_man, other] = rules
                .possession_limit_s
                .map(|s| (s / dt).round().max(1.0) as u32);
            ep.possession
                .update(y, |rod| if is_five_man(rod) { five_man } else { other })
        } else {
            None
        };
        let spun = ep
            .spin
            .update(&state[ROD_ANGLE], rules.spin_limit_deg.to_radians());
        let count = |rods: &[bool]| rods.iter().filter(|&&s| s).count() as u32;
        let yellow_spins = count(&spun[..SIDE_RODS]);
        ep.spins[0] += yellow_spins;
        ep.spins[1] += count(&spun[SIDE_RODS..]);
        let spin_penalty = match rules.spin {
            SpinRule::Off => 0.0,
            SpinRule::Penalty | SpinRule::Foul => {
                yellow_spins as f32 * self.config.reward.spin_penalty
            }
        };
        let rule_end = if !rules.end_episodes {
            (ep.steps >= self.config.max_episode_steps).then_some(EndReason::TimeLimit)
        } else if rules.spin == SpinRule::Foul && yellow_spins > 0 {
            Some(EndReason::SpinFoul)
        } else if let Some(team) = held {
            Some(match team {
                Team::Yellow => EndReason::YellowHeld,
                Team::Black => EndReason::BlackHeld,
            })
        } else if ep.stagnant_steps >= rules.stagnant_steps && ep.possession.holder().is_none() {
            // (The clock runs only under `rules.possession`: without it nobody holds.)
            Some(EndReason::Stagnant)
        } else if rules.end_on_lost_ball && lost_ball(ep.attacker, y) {
            Some(EndReason::LostBall)
        } else if ep.no_progress_steps >= rules.no_progress_steps {
            Some(EndReason::NoProgress)
        } else if ep.steps >= self.config.max_episode_steps {
            Some(EndReason::TimeLimit)
        } else {
            None
        };
        let point_end = event.or(rule_end);
        let mut end = point_end;
        let mut serve = false;
        if rules.serve_again && end.is_some_and(EndReason::ends_point) {
            // The point is over; the episode only at its time limit.
            end = (ep.steps >= self.config.max_episode_steps).then_some(EndReason::TimeLimit);
            serve = end.is_none();
        }
        let steps = ep.steps;
        let spins = ep.spins;

        let (in_goal, in_own_goal) = goals(state[BALL_POS.start], y, line_y, own_line_y);
        for (side, inside) in [in_goal, in_own_goal].into_iter().enumerate() {
            ep.goals[side] += u32::from(inside && !ep.in_goals[side]);
            ep.in_goals[side] = inside;
        }
        // The ball has been in a goal this episode when it has entered it.
        let [episode_scored, episode_conceded] = ep.goals.map(|g| g > 0);
        let goals_so_far = ep.goals;
        let goal_distance = Self::goal_distance(&self.config, &state[BALL_POS]);
        let rw = &self.config.reward;
        let mut reward = if in_goal && rw.zero_shaping_in_goal {
            0.0
        } else {
            rw.alpha - rw.distance_weight * goal_distance
        };
        if in_goal {
            reward += rw.beta;
        }
        if in_own_goal {
            reward -= rw.conceded_penalty;
        }
        reward -= spin_penalty;
        if self.config.start.serve == Serve::Conceded && (serve || end.is_some()) {
            // The side scored upon serves the next ball, the side that held it too long
            // loses it; after a dead ball, the same side serves again.
            if in_goal {
                self.server = Team::Black;
            } else if in_own_goal {
                self.server = Team::Yellow;
            } else if let Some(loser) = point_end.and_then(EndReason::loser_of_the_ball) {
                self.server = loser.other();
            } else if point_end == Some(EndReason::LostBall) {
                self.server = ep.attacker.other();
            }
        }
        if serve {
            // A match's serve: a fresh table (rods at neutral) with the episode's physics.
            let point = serve_point(&self.config, &self.drills, self.server, &mut self.rng);
            *table = Table::new(&ep.draw.physics, point);
            state = Self::observe(table);
            ep.serves += 1;
            ep.stagnant_steps = 0;
            ep.no_progress_steps = 0;
            ep.prev_ball_y = state[BALL_POS.start + 1];
            ep.in_goals = [false; 2];
            ep.spin = SpinMeter::new(&state[ROD_ANGLE]);
            ep.possession = PossessionClock::default();
            ep.attacker = served_by(state[BALL_POS.start + 1]);
        }
        ep.state = state;
        ep.over = end.is_some();
        let (serves, replayed) = (ep.serves, ep.replayed);
        self.emit(&state, obs, false);
        Ok(Transition {
            reward,
            terminated: end.is_some_and(EndReason::is_terminal),
            truncated: end.is_some_and(|e| !e.is_terminal()),
            info: FoosballInfo {
                end,
                goal_distance,
                ball_speed: speed,
                steps,
                in_goal,
                in_own_goal,
                episode_scored,
                episode_conceded,
                spins,
                goals: goals_so_far,
                serves,
                replayed,
            },
        })
    }
}

/// The side a ball served at world `y` (cm) belongs to: yellow's half is y <= 0.
fn served_by(y: f32) -> Team {
    if y <= 0.0 { Team::Yellow } else { Team::Black }
}

/// Whether `attacker` has lost a ball whose centre lies at world `y` (cm) under
/// `rules.end_on_lost_ball`: it has passed out of the reach of the attacker's midfield rod
/// ([`geometry::MAN_REACH_Y`] from its axis) towards the attacker's own goal.
fn lost_ball(attacker: Team, y: f32) -> bool {
    let midfield = geometry::RODS[2].yellow_y; // in the attacker's own frame
    attacker.sign() * y < midfield - geometry::MAN_REACH_Y
}

/// How far from the centre a ball's centre can lie on the playfield, world |x| and |y|, cm.
fn ball_centre_limits() -> [f32; 2] {
    [
        geometry::FIELD_HALF_WIDTH - geometry::BALL_RADIUS,
        geometry::FIELD_HALF_LENGTH - geometry::BALL_RADIUS,
    ]
}

/// Where a serve puts the ball (world x, y, cm): drawn from `config.start`, or from the
/// drill a first uniform draw picks when there are `drills`, turned 180 degrees about the
/// centre where black serves (in a `black_share` of the serves, or when `server` is black
/// under `start.serve = "conceded"`), kept on the field.
fn serve_point(
    config: &FoosballConfig,
    drills: &[Drill],
    server: Team,
    rng: &mut EnvRng,
) -> [f32; 2] {
    let s = &config.start;
    let drill = if drills.is_empty() {
        None
    } else {
        drill_at(drills, rng.random::<f32>())
    };
    let ([x_mean, y_mean], [x_std, y_std]) = match drill {
        Some(d) => (config.to_world([d.x_mean, d.y_mean]), [d.x_std, d.y_std]),
        None => (config.start_world(), [s.x_std, s.y_std]),
    };
    let [limit_x, limit_y] = ball_centre_limits();
    let x = (x_mean + x_std * gaussian(rng)).clamp(-limit_x, limit_x);
    let y = (y_mean + y_std * gaussian(rng)).clamp(-limit_y, limit_y);
    let black_serves = match s.serve {
        Serve::Conceded => server == Team::Black,
        Serve::Drawn => s.black_share > 0.0 && rng.random::<f32>() < s.black_share,
    };
    if black_serves { [-x, -y] } else { [x, y] }
}
