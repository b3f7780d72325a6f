//! The foosball environment's settings: serde structs with defaults and validation.
//!
//! Every struct rejects unknown keys, and [`FoosballConfig::validate`] names the offending
//! key (dotted path, e.g. `randomization.ball_mass_scale`) and value.
//!
//! A configuration starts from a [`Preset`] (`preset = "reference" | "reference_randomized" | "reference_v5" | "reference_v4" |
//! "reference_v3" | "reference_v2" | "paper" | "end_on_goal" | "reference_v1" |
//! "paper_v1"`, default
//! `reference`): keys written in the file override the preset's values, keys left out
//! take them. The presets, with units:
//!
//! | key | `reference` | `reference_randomized` | `reference_v5` | `reference_v4` | `reference_v3` | `reference_v2` | `paper` | `end_on_goal` | `reference_v1` | `paper_v1` |
//! | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |
//! | `ball_frame` (frame of every ball number, below) | joint | joint | joint | joint | joint | joint | joint | joint | world | world |
//! | `action_map` | saturating | saturating | saturating | saturating | saturating | saturating | saturating | saturating | linear | linear |
//! | `slide_stops` | bumpers | bumpers | bumpers | bumpers | bumpers | bumpers | bumpers | bumpers | control_range | control_range |
//! | `ball.model` | reference | reference | reference | reference | reference | reference | reference | reference | rolling | rolling |
//! | `men_shape` | mesh | mesh | mesh | mesh | mesh | reference | reference | reference | box | box |
//! | `contact_recycling` (rapier's; stale contacts at cm scale) | false | false | false | false | false | false | false | false | true | true |
//! | `physics_dt` (s) | 0.002 | 0.002 | 0.002 | 0.002 | 0.002 | 0.002 | 0.002 | 0.002 | 0.002 | 0.002 |
//! | `frame_skip` (physics steps per agent step) | 1 | 1 | 1 | 1 | 1 | 1 | 5 | 5 | 1 | 5 |
//! | `max_episode_steps` (agent steps) | 20000 (40 s) | 20000 (40 s) | 20000 (40 s) | 20000 (40 s) | 20000 (40 s) | 20000 (40 s) | 4000 (40 s) | 4000 (40 s) | 20000 (40 s) | 4000 (40 s) |
//! | `rules.stagnant_steps` (agent steps at <= `stagnant_speed` = 0.5 cm/s) | 10 (20 ms) | 10 (20 ms) | 10 (20 ms) | 10 (20 ms) | 10 (20 ms) | 10 (20 ms) | 10 (100 ms) | 10 (100 ms) | 10 (20 ms) | 10 (100 ms) |
//! | `rules.no_progress_steps` (agent steps without +y) | 15 (30 ms) | 15 (30 ms) | 15 (30 ms) | 15 (30 ms) | 15 (30 ms) | 15 (30 ms) | 15 (150 ms) | 15 (150 ms) | 15 (30 ms) | 15 (150 ms) |
//! | `rules.end_on_goal` | false | false | false | false | false | false | false | true | false | false |
//! | `rules.serve_again` (a point's end serves again, the episode goes on) | false | false | false | false | false | false | false | false | false | false |
//! | `rules.possession` (ITSF's possession limits end a point) | false | false | false | false | false | false | false | false | false | false |
//! | `rules.end_on_lost_ball` (a point ends when its server loses the ball) | false | false | false | false | false | false | false | false | false | false |
//! | `reward.goal` (cm, in `ball_frame`) | (0, 65) | (0, 65) | (0, 65) | (0, 65) | (0, 65) | (0, 65) | (0, 64) | (0, 64) | (0, 65) | (0, 64) |
//! | `reward.goal_line_y` (in black's goal when y >= it) | 65 | 65 | 65 | 65 | 65 | 65 | 64 | 64 | 65 | 64 |
//! | `reward.own_goal_line_y` (in yellow's goal when y <= -it) | 65 | 65 | 65 | 65 | 65 | 65 | 64 | 64 | 65 | 64 |
//! | `reward.beta` | 1000 per step in goal | 1000 per step in goal | 1000 per step in goal | 1000 per step in goal | 1000 per step in goal | 1000 per step in goal | 1000 per step in goal | 1000 once | 1000 per step in goal | 1000 per step in goal |
//! | `reward.zero_shaping_in_goal` (`alpha - d` is 0 in goal) | true | true | true | true | true | true | false | false | true | false |
//! | `reward.conceded_penalty` (per step in own goal) | 1000 | 1000 | 1000 | 1000 | 1000 | 1000 | 0 | 0 | 1000 | 0 |
//! | `start.y_mean` (cm, in `ball_frame`) | 0.0 | 0.0 | 0.0 | 0.0 | 0.0 | 0.0 | -0.1 | -0.1 | -4.0 | -0.1 |
//! | `integrator` (how a physics step is taken) | mujoco_euler | mujoco_euler | mujoco_euler | mujoco_euler | mujoco_euler | rapier | rapier | rapier | rapier | rapier |
//! | `man_contacts` (the ball's contacts with the men) | mujoco_octree | mujoco_octree | mujoco_sdf | mujoco_soft | rapier | rapier | rapier | rapier | rapier | rapier |
//! | `ball.friction` (of every ball contact) | 1.0 | 1.0 | 1.0 | 1.0 | 1.0 | 0.01 | 0.01 | 0.01 | 0.3 | 0.3 |
//! | `rod_mount` | locked_axes | locked_axes | locked_axes | locked_axes | locked_axes | joint | joint | joint | joint | joint |
//! | `ball.planar` (no vertical ball motion) | true | true | true | true | true | true | true | true | true | false |
//! | `randomization` (drawn each episode) | none | ball mass x 0.8-1.2, friction x 0.7-1.3, restitution x 0.5-1.5, servo gains x 0.85-1.15 | none | none | none | none | none | none | none | none |
//!
//! `reference` is the paper's code (Foosball_CU v2 gym and its MuJoCo model), its rods
//! moved step by step as MuJoCo moves them and the ball's contacts with the men found and
//! made as MuJoCo finds and makes them (its SDF search on the model's own octree of the
//! man, soft contacts); `reference_randomized` is that game on a table whose ball and
//! servos are drawn anew each episode (the leaderboard's second domain); `reference_v5` is the same game with the man's field sampled every
//! 0.1 cm; `reference_v4` is the same game with one soft contact per man on our men's
//! colliders, `reference_v3` the same game with rapier's rigid contacts between the ball
//! and the men (both kept so that the runs made on them still replay);
//! `reference_v2` is `reference_v3` with this project's first servo, whose rods lag the
//! model's first steps (kept for its runs too); `paper` and `end_on_goal` read the text's
//! numbers in the code's frame on the code's table (with the first servo);
//! `reference_v1` and `paper_v1` are the first games of this project (world frame, linear
//! actions, a rolling, bouncing ball), kept so that the runs made on them still replay.
//!
//! In the `joint` frame a ball number is an offset from the ball body of the reference
//! model at world (0, -4, 1.705) ([`BallFrame::JOINT_ORIGIN`]): the reference's goal line
//! 65 is world y = 61, 0.9 cm past the mouth.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

pub use crate::config_error::ConfigError;
use crate::geometry::{self, BALL_MASS, GOAL_LINE_Y, REFERENCE_BALL_DECELERATION};
use crate::layout::{ACTION_DIM, action_slide};
use crate::observation::ObservationConfig;

/// A named bundle of rules (see the module docs for its values).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Preset {
    /// The paper's code (Foosball_CU v2 gym on its MuJoCo model): every ball number in
    /// the ball joint's frame (goal line y > 65, distance to (0, 65), -1000 per step with
    /// the ball past -65, start y ~ N(0, 0.5²)), actions saturating at each actuator's
    /// control range, the model's sliding ball with dry friction per axis and dead
    /// contacts, slides stopped by the rods' bumpers, one 2 ms physics step per agent step
    /// (its counters are 20 ms and 30 ms), each step taken as MuJoCo takes it
    /// ([`Integrator::MujocoEuler`]) with the mesh's men ([`MenShape::Mesh`]), the
    /// ball's contacts with them found by the model's own search on its man field and
    /// made soft as MuJoCo makes them ([`ManContacts::MujocoOctree`]: the search on the
    /// model's own octree of the man). The default: it is what produced the paper's
    /// figures.
    #[default]
    Reference,
    /// `reference` on a randomised table: every episode draws the ball's mass (x
    /// 0.8-1.2), friction (x 0.7-1.3) and restitution (x 0.5-1.5) and the servos' gains
    /// (x 0.85-1.15) anew ([`Randomization`]; the ranges of this project's randomised
    /// training, `configs/ppo-study/*-randomized.toml`). The leaderboard's second domain:
    /// a policy that scores here does not lean on the model's exact numbers.
    ReferenceRandomized,
    /// The fifth `reference` of this project: the same game with the man's field sampled
    /// every 0.1 cm ([`ManContacts::MujocoSdf`]), whose contacts' normals stray from the
    /// model's by 2.4 degrees (median; 12 at one pose in ten) and whose kicks part from the
    /// model's from the same state. The game of `results/figure2-v5`, `results/ppo-study`
    /// and the fifth league.
    ReferenceV5,
    /// The fourth `reference` of this project: the same game with one soft contact per
    /// man on our men's colliders ([`ManContacts::MujocoSoft`]), whose kicks leave 11 %
    /// slower and 5 degrees further off the model's. The game of `results/figure2-v4`,
    /// `results/recipe-v4`, `results/planner/reference-v4` and `results/league/leaderboard-v4`.
    ReferenceV4,
    /// The third `reference` of this project: the same game with rapier's rigid contacts
    /// between the ball and the men ([`ManContacts::Rapier`]), whose constant-kick and
    /// random episodes end 15-25 % sooner than the model's. The game of
    /// `results/figure2-host` and `results/planner/reference-v3`.
    ReferenceV3,
    /// The second `reference` of this project: the same rules, with this project's first
    /// step ([`Integrator::Rapier`]), leg blocks and the ball's own friction (0.01), whose
    /// rods reach the reference's end states but lag its first steps 2-4x. The game of
    /// `results/figure2`, the recipe and the first leagues.
    ReferenceV2,
    /// The paper's text made exact on the code's table: `alpha - |ball_xy - (0, 64)| +
    /// beta * [ball_y >= 64]` on every step (the text's numbers read in the code's frame),
    /// no end on a goal, the agent acting every 10 ms, ball start y ~ N(-0.1, 0.5²).
    Paper,
    /// This project's first rule on the code's table: as `Paper`, but a goal ends the
    /// episode and pays `beta` once.
    EndOnGoal,
    /// The first `reference` of this project: the code's rules read in world
    /// coordinates, linear actions, a rolling ball that bounces (restitution 0.6). The
    /// game of `results/figure2-v1`.
    ReferenceV1,
    /// The first `paper` of this project: the text's numbers in world coordinates (its
    /// start out of every man's reach), linear actions, a rolling ball free in 3-D.
    PaperV1,
}

impl Preset {
    /// Every preset, in documentation order.
    pub const ALL: [Preset; 10] = [
        Preset::Reference,
        Preset::ReferenceRandomized,
        Preset::ReferenceV5,
        Preset::ReferenceV4,
        Preset::ReferenceV3,
        Preset::ReferenceV2,
        Preset::Paper,
        Preset::EndOnGoal,
        Preset::ReferenceV1,
        Preset::PaperV1,
    ];

    /// Its name in configuration files.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Reference => "reference",
            Preset::ReferenceRandomized => "reference_randomized",
            Preset::ReferenceV5 => "reference_v5",
            Preset::ReferenceV4 => "reference_v4",
            Preset::ReferenceV3 => "reference_v3",
            Preset::ReferenceV2 => "reference_v2",
            Preset::Paper => "paper",
            Preset::EndOnGoal => "end_on_goal",
            Preset::ReferenceV1 => "reference_v1",
            Preset::PaperV1 => "paper_v1",
        }
    }
}

impl std::str::FromStr for Preset {
    type Err = String;

    /// A preset by its name, e.g. `reference_v1`.
    fn from_str(name: &str) -> Result<Self, String> {
        if name == "paper_reachable" {
            return Err(
                "preset `paper_reachable` is gone: its reachable start is what `paper` \
                        now has (the text's numbers read in the code's frame); its old game is \
                        `paper_v1` with `start.y_mean = -4.0` and `ball.planar = true`"
                    .into(),
            );
        }
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
    /// The frame every ball number of the rules, the start and the observation is given
    /// in (`world`, or `joint`: the reference's ball joint coordinates).
    pub ball_frame: BallFrame,
    /// How an action in [-1, 1] becomes the rods' servo targets.
    pub action_map: ActionMap,
    /// What stops a rod's slide: its control range, or its rubber bumpers (shorter).
    pub slide_stops: SlideStops,
    /// The men's colliders (`box`: a symmetric leg block; `reference`: the leg where the
    /// reference mesh has it at the ball's height).
    pub men_shape: MenShape,
    /// Rapier's contact recycling: a contact pair whose bodies moved less than 5 cm
    /// (its 0.05 x our length unit of 100 cm) since its last full update keeps its old
    /// contact normal and distance. At a table's scale that is a ghost collision: a ball
    /// gliding 0.6 cm past a man's foot is deflected by the normal frozen when it was 1.8
    /// cm away. Off in the current presets; on in the `*_v1` ones, whose runs were made so.
    pub contact_recycling: bool,
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
    /// How each rod is held to the table.
    pub rod_mount: RodMount,
    /// How a physics step is taken.
    pub integrator: Integrator,
    /// How the ball's contacts with the men are made.
    pub man_contacts: ManContacts,
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
        let paper_v1 = Self {
            preset,
            ball_frame: BallFrame::World,
            action_map: ActionMap::Linear,
            slide_stops: SlideStops::ControlRange,
            contact_recycling: true,
            men_shape: MenShape::Box,
            physics_dt: 0.002,
            frame_skip: 5,
            max_episode_steps: 4000,
            reward: RewardConfig::default(),
            rules: EpisodeRules::default(),
            start: StartConfig::default(),
            ball: BallConfig::default(),
            rod_mount: RodMount::default(),
            integrator: Integrator::Rapier,
            man_contacts: ManContacts::Rapier,
            opponent: OpponentKind::Static,
            randomization: Randomization::default(),
            observation: ObservationConfig::default(),
        };
        let code_reward = RewardConfig {
            goal: [0.0, 65.0],
            goal_line_y: 65.0,
            own_goal_line_y: 65.0,
            zero_shaping_in_goal: true,
            conceded_penalty: 1000.0,
            ..paper_v1.reward
        };
        let code_table = Self {
            ball_frame: BallFrame::Joint,
            action_map: ActionMap::Saturating,
            slide_stops: SlideStops::Bumpers,
            contact_recycling: false,
            men_shape: MenShape::Reference,
            ball: BallConfig::reference(),
            ..paper_v1.clone()
        };
        match preset {
            Preset::PaperV1 => paper_v1,
            Preset::ReferenceV1 => Self {
                frame_skip: 1,
                max_episode_steps: 20_000,
                reward: code_reward,
                start: StartConfig {
                    y_mean: -4.0,
                    ..paper_v1.start
                },
                ball: BallConfig {
                    planar: true,
                    ..paper_v1.ball
                },
                ..paper_v1
            },
            Preset::Paper => code_table,
            Preset::EndOnGoal => Self {
                rules: EpisodeRules {
                    end_on_goal: true,
                    ..code_table.rules
                },
                ..code_table
            },
            Preset::ReferenceV2 => Self {
                frame_skip: 1,
                max_episode_steps: 20_000,
                reward: code_reward,
                start: StartConfig {
                    y_mean: 0.0,
                    ..code_table.start
                },
                ..code_table
            },
            Preset::Reference => Self {
                preset,
                man_contacts: ManContacts::MujocoOctree,
                ..Self::preset(Preset::ReferenceV5)
            },
            Preset::ReferenceRandomized => Self {
                preset,
                randomization: Randomization {
                    ball_mass_scale: [0.8, 1.2],
                    ball_friction_scale: [0.7, 1.3],
                    ball_restitution_scale: [0.5, 1.5],
                    servo_gain_scale: [0.85, 1.15],
                    ..Randomization::default()
                },
                ..Self::preset(Preset::Reference)
            },
            Preset::ReferenceV5 => Self {
                preset,
                man_contacts: ManContacts::MujocoSdf,
                ..Self::preset(Preset::ReferenceV4)
            },
            Preset::ReferenceV4 => Self {
                preset,
                man_contacts: ManContacts::MujocoSoft,
                ..Self::preset(Preset::ReferenceV3)
            },
            Preset::ReferenceV3 => Self {
                preset,
                ball: BallConfig {
                    friction: geometry::REFERENCE_CONTACT_FRICTION,
                    ..BallConfig::reference()
                },
                men_shape: MenShape::Mesh,
                rod_mount: RodMount::LockedAxes,
                integrator: Integrator::MujocoEuler,
                ..Self::preset(Preset::ReferenceV2)
            },
        }
    }

    /// The keys that decide how an action moves the rods and the ball: a state and an
    /// action recorded on one table are the same transition on another only where these
    /// agree (the rules, the reward, the starts and the opponent may differ).
    pub const TABLE_KEYS: [&'static str; 10] = [
        "action_map",
        "slide_stops",
        "men_shape",
        "contact_recycling",
        "physics_dt",
        "frame_skip",
        "ball",
        "rod_mount",
        "integrator",
        "man_contacts",
    ];

    /// The first of [`Self::TABLE_KEYS`] (dotted below `ball`) on which `other` is another
    /// table than `self`: `(key, self's value, other's value)`, the values as TOML writes
    /// them; `None` on the same table.
    pub fn table_difference(&self, other: &Self) -> Option<(String, String, String)> {
        let toml_of =
            |c: &Self| toml::Value::try_from(c).expect("a configuration always serialises");
        let (ours, theirs) = (toml_of(self), toml_of(other));
        Self::TABLE_KEYS
            .iter()
            .find_map(|&key| first_difference(key.to_string(), ours.get(key), theirs.get(key)))
    }

    /// A point `[x, y]` of the ball frame (cm) in world coordinates, cm.
    pub fn to_world(&self, [x, y]: [f32; 2]) -> [f32; 2] {
        let [ox, oy, _] = self.ball_frame.origin();
        [x + ox, y + oy]
    }

    /// The reward's goal point in world coordinates, cm.
    pub fn goal_world(&self) -> [f32; 2] {
        self.to_world(self.reward.goal)
    }

    /// World y past which the ball is in black's goal (inside the mouth), cm.
    pub fn goal_line_world(&self) -> f32 {
        self.reward.goal_line_y + self.ball_frame.origin()[1]
    }

    /// World y short of which the ball is in yellow's goal (inside the mouth), cm: the
    /// own-goal line `-own_goal_line_y` carried into the world.
    pub fn own_goal_line_world(&self) -> f32 {
        -self.reward.own_goal_line_y + self.ball_frame.origin()[1]
    }

    /// The ball start's means in world coordinates, cm.
    pub fn start_world(&self) -> [f32; 2] {
        self.to_world([self.start.x_mean, self.start.y_mean])
    }
}

/// The first dotted key below `key` where `a` and `b` differ, with both values as TOML
/// writes them (`unset` where one has no such key).
fn first_difference(
    key: String,
    a: Option<&toml::Value>,
    b: Option<&toml::Value>,
) -> Option<(String, String, String)> {
    if let (Some(toml::Value::Table(x)), Some(toml::Value::Table(y))) = (a, b) {
        return x
            .keys()
            .chain(y.keys())
            .find_map(|k| first_difference(format!("{key}.{k}"), x.get(k), y.get(k)));
    }
    let show = |v: Option<&toml::Value>| v.map_or("unset".to_string(), |v| v.to_string());
    (a != b).then(|| (key, show(a), show(b)))
}

/// The frame of the ball's numbers in the rules, the start and the observation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BallFrame {
    /// World coordinates: the centre of the playfield at (0, 0), its surface at z = 0.
    World,
    /// The reference code's reading: the ball's joint coordinates, offsets from the ball
    /// body at [`BallFrame::JOINT_ORIGIN`]. In the observation, the ball's third position
    /// and velocity components repeat y's (the gym reads a `ball_z` joint the model does
    /// not have, and MuJoCo's id -1 indexes y's joint; see the README), and the ball speed
    /// of the stagnation rule is the norm of that observed velocity, as the code's.
    #[default]
    Joint,
}

impl BallFrame {
    /// World position of the reference model's ball body, the origin of its joint
    /// coordinates, cm.
    pub const JOINT_ORIGIN: [f32; 3] = [0.0, -4.0, 1.705];

    /// World position of this frame's origin, cm.
    pub fn origin(self) -> [f32; 3] {
        match self {
            BallFrame::World => [0.0; 3],
            BallFrame::Joint => Self::JOINT_ORIGIN,
        }
    }
}

/// How yellow's action (8 values in [-1, 1]) becomes servo targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ActionMap {
    /// `a * range`: the whole of [-1, 1] spans each joint's control range.
    Linear,
    /// The reference code's: `clamp(a * 20, -range, range)` (its gym's action space is
    /// [-20, 20], which SB3 rescales the policy's [-1, 1] onto, and MuJoCo clamps each
    /// control to its actuator's range): a turn is at its full ±2.5 rad once |a| > 0.125.
    #[default]
    Saturating,
}

/// The shape of the men's colliders: a torso block around the rod and a leg block below.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MenShape {
    /// The leg block centred under the axis, ±1.2 cm along the table.
    Box,
    /// The leg block where the reference mesh's leg is at the ball's height: 1.3 cm
    /// behind the axis to 0.9 cm in front of it.
    #[default]
    Reference,
    /// The reference mesh's lower leg and foot as a convex prism: its outline seen along
    /// the rod ([`crate::geometry::foosman::MESH_LEG_PROFILE`]), tapering from 2.4 cm deep
    /// at the shin to 0.6 cm at the sole, where the blocks keep 2.2 cm down to the sole
    /// (they meet a ball in front of a turning man 1-2 steps early).
    Mesh,
}

impl ActionMap {
    /// The servo target that action value `a` sets on a joint whose control range is
    /// `[-range, range]`.
    pub fn target(self, a: f32, range: f32) -> f32 {
        match self {
            ActionMap::Linear => a.clamp(-1.0, 1.0) * range,
            ActionMap::Saturating => (a * geometry::REFERENCE_ACTION_BOUND).clamp(-range, range),
        }
    }

    /// The action of this map that sets the same servo targets as `linear` does under the
    /// linear map (exact: a saturating action inside the range is linear too).
    pub fn from_linear(self, linear: [f32; ACTION_DIM]) -> [f32; ACTION_DIM] {
        match self {
            ActionMap::Linear => linear,
            ActionMap::Saturating => core::array::from_fn(|i| {
                linear[i].clamp(-1.0, 1.0) * control_range(i) / geometry::REFERENCE_ACTION_BOUND
            }),
        }
    }

    /// The linear action (each value in [-1, 1]) that sets the servo targets `action`
    /// sets under this map.
    pub fn to_linear(self, action: [f32; ACTION_DIM]) -> [f32; ACTION_DIM] {
        core::array::from_fn(|i| {
            let range = control_range(i);
            self.target(action[i], range) / range
        })
    }

    /// `action` of this map as the action of `to` that sets the same servo targets
    /// (exact both ways: a policy trained under one map plays a table of the other).
    pub fn translate(self, to: ActionMap, action: [f32; ACTION_DIM]) -> [f32; ACTION_DIM] {
        if self == to {
            return action;
        }
        to.from_linear(self.to_linear(action))
    }
}

/// The control range of action value `i` (foosball's 8-dim layout): the rod's slide
/// range (cm) or turn range (rad).
pub fn control_range(i: usize) -> f32 {
    let spec = &geometry::RODS[i / 2];
    if i == action_slide(i / 2) {
        spec.slide_range
    } else {
        spec.turn_range
    }
}

/// What ends a rod's slide travel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SlideStops {
    /// A hard stop at the servo's control range.
    ControlRange,
    /// The rubber bumpers on the rod meet the side walls, short of the control range
    /// (as measured in the reference model: [`crate::geometry::RodSpec::bumper_travel`]).
    #[default]
    Bumpers,
}

impl Serialize for FoosballConfig {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        FoosballConfig::serialize(self, serializer)
    }
}

impl<'de> Deserialize<'de> for FoosballConfig {
    /// Reads the keys as a table, lays them over the preset's values and deserialises
    /// the result (unknown keys and bad values are refused by dotted key).
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
        // The merged table has no spans; the error names the dotted key instead.
        let mut track = serde_path_to_error::Track::new();
        let keys = serde_path_to_error::Deserializer::new(toml::Value::Table(merged), &mut track);
        FoosballConfig::deserialize(keys).map_err(|e| {
            let message = e.message().trim();
            match track.path().to_string().as_str() {
                "." => D::Error::custom(message),
                key => D::Error::custom(format!("{key}: {message}")),
            }
        })
    }
}

/// Writes `top` over `base`, table by table (values that are not tables replace): how a
/// configuration's keys are laid over its preset's, and how a caller layers overrides.
pub fn overlay(base: &mut toml::Table, top: toml::Table) {
    for (key, value) in top {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(t)) => overlay(b, t),
            (_, v) => {
                base.insert(key, v);
            }
        }
    }
}

/// Per agent step: `alpha - distance_weight * d + beta * [in goal] - conceded_penalty *
/// [in own goal]`, with `d = |ball_xy - goal|` (the shaping `alpha - distance_weight * d`
/// is replaced by 0 in the goal under `zero_shaping_in_goal`). The ball is in black's goal
/// when its y >= `goal_line_y` inside the mouth, in yellow's when y <= -`own_goal_line_y`;
/// every number is in the env's `ball_frame`. Under `rules.end_on_goal` the episode ends there, so the bonus or the
/// penalty is paid once.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RewardConfig {
    /// Constant per-step offset (default 300).
    pub alpha: f32,
    /// Weight of the ball's distance to `goal` (cm) in the per-step shaping (default 1,
    /// the paper's). With `alpha = 0` and 0 here only goals pay: `beta` for, minus
    /// `conceded_penalty` against, a match's reward.
    pub distance_weight: f32,
    /// Bonus on every step the ball is in black's goal (default 1000).
    pub beta: f32,
    /// Penalty on every step the ball is in yellow's own goal (default 0: the paper's
    /// reward has none; the reference code's is 1000).
    pub conceded_penalty: f32,
    /// Point the distance is measured to, cm (default (0, 64), the centre of black's goal).
    pub goal: [f32; 2],
    /// The ball is in black's goal when y >= this, cm (default 64; the reference's 65).
    pub goal_line_y: f32,
    /// The ball is in yellow's goal when y <= -this, cm (default 64; the reference's 65,
    /// which in its frame is world y = -69, behind the pocket: it never concedes).
    pub own_goal_line_y: f32,
    /// The `alpha - d` term is 0 while the ball is in black's goal, which then pays
    /// `beta` alone (the reference code's rule; default false).
    pub zero_shaping_in_goal: bool,
    /// Reward lost per spin of a yellow rod under `rules.spin = "penalty"` or `"foul"`
    /// (default 1000, a goal's worth).
    pub spin_penalty: f32,
}

impl Default for RewardConfig {
    fn default() -> Self {
        Self {
            alpha: 300.0,
            distance_weight: 1.0,
            beta: 1000.0,
            conceded_penalty: 0.0,
            goal: [0.0, GOAL_LINE_Y],
            goal_line_y: GOAL_LINE_Y,
            own_goal_line_y: GOAL_LINE_Y,
            zero_shaping_in_goal: false,
            spin_penalty: 1000.0,
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
    /// What a spin of one of yellow's rods costs ([`crate::spin`]; default `off`, as in
    /// the paper: spins are counted in the info, nothing more).
    pub spin: SpinRule,
    /// Rotation in one direction that makes a spin, degrees (default 360, ITSF's).
    pub spin_limit_deg: f32,
    /// A point's end does not end the episode (default false, the paper's episode): a goal
    /// under `end_on_goal`, a stagnant ball or one without progress serves the ball again,
    /// drawn from `start` as at a reset, at rest, on a table whose rods are back at neutral
    /// (a match's serve); the episode's draw, its opponent and its counters carry on, and it
    /// ends at `max_episode_steps` (truncated), a physics fault or a spin foul. The step's
    /// reward and info are those of the point's end; its observation is the served table.
    pub serve_again: bool,
    /// The rules above end episodes (default true). False for a probe that steps a table
    /// past every point's end: no goal, stagnant ball, lack of progress or spin foul ends
    /// it (nor serves again); only `max_episode_steps` and a physics fault do. Rewards and
    /// the info's counters are as with the rules on.
    pub end_episodes: bool,
    /// ITSF's possession limits (default false: the paper has none). A ball kept within
    /// reach of one rod ([`crate::geometry::MAN_REACH_Y`]) for longer than that rod's
    /// limit (`possession_limit_s`) ends the point ([`crate::EndReason::YellowHeld`] or
    /// [`crate::EndReason::BlackHeld`], terminated); under `start.serve = "conceded"` the
    /// other side serves the next ball. A still ball within a rod's reach is that rod's,
    /// not dead: `stagnant_steps` ends only points whose ball lies out of every rod's reach.
    pub possession: bool,
    /// The possession limits, seconds: a five-man rod's and every other rod's (default
    /// ITSF's 10 and 15).
    pub possession_limit_s: [f32; 2],
    /// A point ends when its server loses the ball (default false: the paper has no such
    /// end). The side on whose half the point's ball was served (world y <= 0: yellow)
    /// attacks; once the ball passes out of its midfield rod's reach towards its own goal
    /// (world y < -7.5 - 6.71 cm for yellow, y > 14.21 for black) it has lost the ball
    /// and the point ends, unpaid ([`crate::EndReason::LostBall`], terminated; under
    /// `start.serve = "conceded"` the other side serves). Yellow's serves are attack
    /// drills in which a missed shot costs no counter-attack, black's defence drills that
    /// end when yellow wins the ball.
    pub end_on_lost_ball: bool,
}

impl Default for EpisodeRules {
    fn default() -> Self {
        Self {
            stagnant_speed: 0.5,
            stagnant_steps: 10,
            no_progress_steps: 15,
            end_on_goal: false,
            spin: SpinRule::Off,
            spin_limit_deg: 360.0,
            serve_again: false,
            end_episodes: true,
            possession: false,
            possession_limit_s: crate::possession::ITSF_LIMITS_S,
            end_on_lost_ball: false,
        }
    }
}

/// The spinning rule for yellow (the learner).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpinRule {
    /// Spins are counted, not punished.
    #[default]
    Off,
    /// Each spin costs `reward.spin_penalty`.
    Penalty,
    /// A spin is a foul: it costs `reward.spin_penalty` and ends the episode (the point).
    Foul,
}

/// Ball start: at rest on the playfield at x ~ N(x_mean, x_std²), y ~ N(y_mean, y_std²),
/// means in the env's `ball_frame` (cm); in a `black_share` of the episodes the drawn
/// point is turned 180 degrees about the playfield's centre (black's kick-off).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StartConfig {
    pub x_mean: f32,
    pub x_std: f32,
    pub y_mean: f32,
    pub y_std: f32,
    /// Share of episodes, in [0, 1], served at the mirror image of the drawn point
    /// (world (x, y) -> (-x, -y)): the ball starts on black's side, black to play it.
    /// Default 0 (the paper's serve, and no extra draw from the episode's stream).
    pub black_share: f32,
    /// Which side serves: drawn by `black_share` (default) or as a match serves.
    #[serde(default, skip_serializing_if = "Serve::is_drawn")]
    pub serve: Serve,
}

/// Which side serves each ball of an env's episodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Serve {
    /// Drawn per serve: black's in a `start.black_share` of them.
    #[default]
    Drawn,
    /// ITSF's rule, as a match serves: after a goal the side scored upon serves, after a
    /// dead ball (or any other end) the side that served it; the first serve after a
    /// seeded reset is yellow's. It holds across an env's episodes (a vector env's
    /// automatic resets) and across the points of a `rules.serve_again` episode.
    Conceded,
}

impl Serve {
    /// The default rule (left out of written configs).
    pub fn is_drawn(&self) -> bool {
        *self == Serve::Drawn
    }
}

impl Default for StartConfig {
    fn default() -> Self {
        Self {
            x_mean: -0.5,
            x_std: 0.5,
            y_mean: -0.1,
            y_std: 0.5,
            black_share: 0.0,
            serve: Serve::Drawn,
        }
    }
}

/// How the ball moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BallModel {
    /// A solid sphere that rolls on the playfield, slowed by `rolling_resistance`, with
    /// `friction` and `restitution` on every contact (this project's first ball).
    Rolling,
    /// The reference model's ball: it slides in the playfield's plane without turning
    /// (two slide joints, no hinge), slowed by dry friction of `axis_deceleration` on x
    /// and on y independently (its `frictionloss`), with no other floor friction; its
    /// contacts use `friction` and `restitution` (calibrated: nearly dead). `planar` and
    /// `rolling_resistance` do not apply.
    #[default]
    Reference,
}

/// Nominal ball and contact properties.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BallConfig {
    /// `rolling` or `reference`.
    pub model: BallModel,
    /// kg (default 0.1).
    pub mass: f32,
    /// Coulomb friction coefficient of ball contacts (rolling: 0.3).
    pub friction: f32,
    /// Restitution of ball contacts with the walls and the floor, and with the men where
    /// `men_restitution` is lower (rolling: 0.6).
    pub restitution: f32,
    /// Restitution of ball contacts with the men where it is the higher (rolling: 0.6;
    /// reference: calibrated on the rebound off a man, which MuJoCo's soft contact against
    /// the rounded foot makes livelier than off a wall).
    pub men_restitution: f32,
    /// Rolling resistance: deceleration of a rolling ball as a fraction of g (rolling:
    /// 0.015, about 15 cm/s²).
    pub rolling_resistance: f32,
    /// Dry friction of the `reference` ball: its deceleration on each axis while it moves
    /// along that axis, cm/s² (200: the reference's `frictionloss = 20` on a 0.1 kg ball).
    pub axis_deceleration: f32,
    /// The ball moves in the playfield's plane only, its centre held at z = its radius
    /// (the reference model's ball has no z joint). False: a kick can lift the ball, and
    /// a ball lifted off the table ends the episode as a physics fault.
    pub planar: bool,
}

impl Default for BallConfig {
    /// The rolling ball of the `*_v1` presets, free in 3-D.
    fn default() -> Self {
        Self {
            model: BallModel::Rolling,
            mass: BALL_MASS,
            friction: 0.3,
            restitution: 0.6,
            men_restitution: 0.6,
            rolling_resistance: 0.015,
            axis_deceleration: REFERENCE_BALL_DECELERATION,
            planar: false,
        }
    }
}

impl BallConfig {
    /// The reference model's ball, with the contact coefficients calibrated against it
    /// (`tests/suite/reference_parity.rs`).
    pub fn reference() -> Self {
        Self {
            model: BallModel::Reference,
            friction: geometry::REFERENCE_BALL_FRICTION,
            restitution: geometry::REFERENCE_BALL_RESTITUTION,
            men_restitution: geometry::REFERENCE_MEN_RESTITUTION,
            planar: true,
            ..Self::default()
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

/// How a physics step is taken: the rods' servo force and integration, their inertia and
/// slide stops, and when contacts are found.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Integrator {
    /// This project's first step: the servo's force evaluated at the end of the step
    /// (backward Euler, "stable PD", [`Servo::implicit_force`](crate::servo::Servo::implicit_force))
    /// over rapier's four substeps, on our colliders' inertia, with the earth's gravity on
    /// the men, a hard stop at the bumpers, and rapier's speculative contacts (found before
    /// the bodies touch). It reaches the reference's end states, but its rods lag MuJoCo's
    /// first steps 2-4x (the `reference_v2` game).
    #[default]
    Rapier,
    /// The reference model's step as MuJoCo 3.3.2's Euler integrator takes it: the position
    /// actuator's force `kp (ctrl - q) - kv q'` taken at the start of each step, `q' += dt a`
    /// then `q += dt q'` (one step, no substeps, turns not capped), on the model's
    /// generalised inertia of each joint ([`crate::geometry::RodSpec::turn_inertia`]), with
    /// the model's 9.81 cm/s² gravity on the men, the bumpers as its soft contacts
    /// ([`crate::soft_stop::SoftStop::REFERENCE`]), and contacts found where the bodies are at
    /// the start of the step (none ahead of touching). Needs `rod_mount = "locked_axes"`.
    MujocoEuler,
}

/// How the ball's contacts with the men are made.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ManContacts {
    /// Rapier's contacts: one hard contact per collider pair, with restitution
    /// `ball.men_restitution` and friction `ball.friction`.
    #[default]
    Rapier,
    /// MuJoCo's soft frictional contacts, as the reference model makes them
    /// ([`crate::soft_contact::SoftContact::REFERENCE`]): critically damped at 4 ms, no
    /// rebound, friction 1 in a pyramidal cone with torsion, solved with the step's other
    /// forces. Needs `integrator = "mujoco_euler"`.
    MujocoSoft,
    /// MuJoCo's soft contacts found as the reference model finds them: its SDF search
    /// ([`crate::sdf_search`], 40 starting points) on the reference man's own distance
    /// field ([`crate::man_field`]), a patch of up to 40 contacts per man where
    /// `mujoco_soft` makes one on the men's colliders; the ball seen at the model's height
    /// (its joints' origin, [`BallFrame::JOINT_ORIGIN`]). Same law and solve. Needs
    /// `integrator = "mujoco_euler"`. The field sampled every 0.1 cm (trilinear between the
    /// samples), whose contacts part from the model's where the plugin's octree changes
    /// leaves or bends within one.
    MujocoSdf,
    /// As `mujoco_sdf`, on the plugin's own octree of the man ([`crate::man_octree`]): the
    /// model's field to float rounding, so the model's contacts exactly. Needs
    /// `integrator = "mujoco_euler"`.
    MujocoOctree,
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
    /// The scripted shooter ([`crate::scripted::Kicker::shooter`]) playing black.
    Shooter,
    /// The scripted dribbler ([`crate::scripted::Kicker::dribbler`]) playing black.
    Dribbler,
}

impl OpponentKind {
    /// Its name in TOML (`static`, `random`, `scripted`, `shooter`, `dribbler`).
    pub fn name(self) -> &'static str {
        match self {
            OpponentKind::Static => "static",
            OpponentKind::Random => "random",
            OpponentKind::Scripted => "scripted",
            OpponentKind::Shooter => "shooter",
            OpponentKind::Dribbler => "dribbler",
        }
    }
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
    /// Multiplier on the sliding friction of the ball's soft contacts with the men
    /// (`man_contacts` `mujoco_soft` or `mujoco_sdf`; under `rapier` the ball's own
    /// friction is the men's too, and `ball_friction_scale` moves it). A fixed value
    /// draws nothing from the RNG, so runs without it replay as before it existed.
    pub men_friction_scale: [f32; 2],
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
            men_friction_scale: [1.0, 1.0],
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

pub(crate) fn non_negative(key: &str, v: f32) -> Result<(), ConfigError> {
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
        if self.integrator == Integrator::MujocoEuler && self.rod_mount != RodMount::LockedAxes {
            return Err(ConfigError::new(
                "rod_mount",
                "integrator = \"mujoco_euler\" sets each rod's inertia about its axis, which only \
                 rod_mount = \"locked_axes\" allows; got \"joint\"",
            ));
        }
        if self.man_contacts != ManContacts::Rapier && self.integrator != Integrator::MujocoEuler {
            let name = match self.man_contacts {
                ManContacts::MujocoSdf => "mujoco_sdf",
                ManContacts::MujocoOctree => "mujoco_octree",
                _ => "mujoco_soft",
            };
            return Err(ConfigError::new(
                "man_contacts",
                format!(
                    "man_contacts = \"{name}\" adds its forces to MuJoCo's explicit Euler step, \
                     which needs integrator = \"mujoco_euler\"; got \"rapier\""
                ),
            ));
        }
        at_least_one("frame_skip", self.frame_skip)?;
        at_least_one("max_episode_steps", self.max_episode_steps)?;
        finite("reward.alpha", self.reward.alpha)?;
        finite("reward.distance_weight", self.reward.distance_weight)?;
        finite("reward.beta", self.reward.beta)?;
        finite("reward.conceded_penalty", self.reward.conceded_penalty)?;
        finite("reward.spin_penalty", self.reward.spin_penalty)?;
        positive("rules.spin_limit_deg", self.rules.spin_limit_deg)?;
        finite("reward.goal[0]", self.reward.goal[0])?;
        finite("reward.goal[1]", self.reward.goal[1])?;
        finite("reward.own_goal_line_y", self.reward.own_goal_line_y)?;
        // Outside the mouth the ball's centre stays short of the end wall by its radius:
        // a line past that is crossed in the mouth only.
        let mouth = geometry::FIELD_HALF_LENGTH - geometry::BALL_RADIUS;
        let deepest = geometry::GOAL_POCKET_BACK - geometry::BALL_RADIUS;
        let line = self.goal_line_world();
        if !(line.is_finite() && line > mouth && line < deepest) {
            return Err(ConfigError::new(
                "reward.goal_line_y",
                format!(
                    "must put the line where only a ball in the goal mouth reaches ({mouth} < world y < {deepest}; {:?} frame), got {}",
                    self.ball_frame, self.reward.goal_line_y,
                ),
            ));
        }
        if self.own_goal_line_world() >= -mouth {
            return Err(ConfigError::new(
                "reward.own_goal_line_y",
                format!(
                    "must put the line where only a ball in yellow's goal mouth reaches (world y < -{mouth}; {:?} frame), got {}",
                    self.ball_frame, self.reward.own_goal_line_y,
                ),
            ));
        }
        non_negative("rules.stagnant_speed", self.rules.stagnant_speed)?;
        at_least_one("rules.stagnant_steps", self.rules.stagnant_steps)?;
        at_least_one("rules.no_progress_steps", self.rules.no_progress_steps)?;
        for limit in self.rules.possession_limit_s {
            positive("rules.possession_limit_s", limit)?;
        }
        finite("start.x_mean", self.start.x_mean)?;
        finite("start.y_mean", self.start.y_mean)?;
        non_negative("start.x_std", self.start.x_std)?;
        non_negative("start.y_std", self.start.y_std)?;
        if !(0.0..=1.0).contains(&self.start.black_share) {
            return Err(ConfigError::new(
                "start.black_share",
                format!("must be a share in [0, 1], got {}", self.start.black_share),
            ));
        }
        if self.start.serve == Serve::Conceded && self.start.black_share != 0.0 {
            return Err(ConfigError::new(
                "start.black_share",
                format!(
                    "{} draws the serving side: leave it at 0 under start.serve = \"conceded\"",
                    self.start.black_share
                ),
            ));
        }
        positive("ball.mass", self.ball.mass)?;
        non_negative("ball.friction", self.ball.friction)?;
        non_negative("ball.restitution", self.ball.restitution)?;
        non_negative("ball.men_restitution", self.ball.men_restitution)?;
        for (key, v) in [
            ("ball.restitution", self.ball.restitution),
            ("ball.men_restitution", self.ball.men_restitution),
        ] {
            if v > 1.0 {
                return Err(ConfigError::new(key, format!("must be <= 1, got {v}")));
            }
        }
        non_negative("ball.rolling_resistance", self.ball.rolling_resistance)?;
        non_negative("ball.axis_deceleration", self.ball.axis_deceleration)?;
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
            "randomization.men_friction_scale",
            r.men_friction_scale,
            true,
        )?;
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
    fn a_ball_frame_point_reaches_the_world_by_the_frame_origin() {
        let mut c = FoosballConfig {
            ball_frame: BallFrame::Joint,
            ..FoosballConfig::default()
        };
        c.reward.goal = [1.0, 65.0];
        assert_eq!(c.to_world([5.0, -52.0]), [5.0, -56.0]);
        assert_eq!(c.goal_world(), [1.0, 61.0]);
        c.ball_frame = BallFrame::World;
        assert_eq!(c.to_world([5.0, -52.0]), [5.0, -52.0]);
        assert_eq!(c.goal_world(), [1.0, 65.0]);
    }

    #[test]
    fn defaults_are_valid() {
        FoosballConfig::default().validate().unwrap();
    }

    #[test]
    fn an_action_translated_between_maps_sets_the_same_servo_targets() {
        use ActionMap::{Linear, Saturating};
        // Inside, at and past each map's saturation, both signs, and a value out of range.
        let actions = [
            [0.0, 0.05, -0.1, 0.125, -0.3, 0.5, 1.0, -1.0],
            [0.02, -0.02, 0.2, -0.7, 0.9, -0.124, 3.0, -2.5],
        ];
        for a in actions {
            for (from, to) in [(Linear, Saturating), (Saturating, Linear), (Linear, Linear)] {
                let b = from.translate(to, a);
                for i in 0..ACTION_DIM {
                    let r = control_range(i);
                    let (want, got) = (from.target(a[i], r), to.target(b[i], r));
                    assert!(
                        (want - got).abs() < 1e-5 * r,
                        "{from:?}->{to:?} [{i}] {want} {got}"
                    );
                }
            }
        }
        // A saturating turn of 0.2 is the whole turn range: linear 1.
        assert_eq!(Saturating.to_linear([0.2; ACTION_DIM])[1], 1.0);
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
        let soft_on_rapier = FoosballConfig {
            man_contacts: ManContacts::MujocoSoft,
            ..FoosballConfig::preset(Preset::ReferenceV2)
        };
        let e = soft_on_rapier.validate().unwrap_err();
        assert_eq!(e.key, "man_contacts");
        assert!(e.to_string().contains("mujoco_euler"), "{e}");
        let sdf_on_rapier = FoosballConfig {
            man_contacts: ManContacts::MujocoSdf,
            ..FoosballConfig::preset(Preset::ReferenceV2)
        };
        let e = sdf_on_rapier.validate().unwrap_err();
        assert!(e.to_string().contains("\"mujoco_sdf\""), "{e}");
        FoosballConfig {
            man_contacts: ManContacts::MujocoSoft,
            ..FoosballConfig::default()
        }
        .validate()
        .unwrap();
    }

    #[test]
    fn another_table_is_named_by_its_first_differing_key() {
        let ours = FoosballConfig::default();
        let mut other = FoosballConfig::preset(Preset::ReferenceV4);
        assert_eq!(
            ours.table_difference(&other),
            Some((
                "man_contacts".into(),
                "\"mujoco_octree\"".into(),
                "\"mujoco_soft\"".into()
            ))
        );
        other.man_contacts = ManContacts::MujocoOctree;
        assert_eq!(ours.table_difference(&other), None);
        // Rules, reward, starts and opponent are not the table.
        other.rules.stagnant_steps = 3;
        other.reward.beta = 1.0;
        other.start.y_mean = 5.0;
        other.opponent = OpponentKind::Shooter;
        assert_eq!(ours.table_difference(&other), None);
        other.ball.friction = 0.5;
        let (key, _, theirs) = ours.table_difference(&other).unwrap();
        assert_eq!((key.as_str(), theirs.as_str()), ("ball.friction", "0.5"));
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
