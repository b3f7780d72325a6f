//! The ITSF Tornado T-3000 table in numbers (cm, kg, s, rad).
//!
//! Every figure here was measured from the paper code's MuJoCo model (see the README's
//! "Table model" section for how). The world frame: x across the table (along the rods),
//! y along the table (yellow attacks +y), z up; the playfield surface is z = 0.

/// Gravity along -z in cm/s².
pub const GRAVITY: f32 = 981.0;
/// The reference model's gravity, cm/s²: MuJoCo's default 9.81 in a model whose lengths
/// are in cm (100 times too weak). Under [`Integrator::MujocoEuler`](crate::config::Integrator)
/// it is what pulls on the men as they turn (the reference's ball has no vertical motion).
pub const REFERENCE_GRAVITY: f32 = 9.81;

/// Ball radius in cm.
pub const BALL_RADIUS: f32 = 1.733_55;
/// Ball mass in kg.
pub const BALL_MASS: f32 = 0.1;

/// Half width of the playfield between the inner side walls (|x| <= this), cm.
pub const FIELD_HALF_WIDTH: f32 = 34.0;
/// Half length of the playfield between the end walls (|y| <= this), cm.
pub const FIELD_HALF_LENGTH: f32 = 60.12;
/// Height of the side and end walls above the playfield, cm.
pub const WALL_HEIGHT: f32 = 11.1;
/// Half width of each goal mouth (|x| <= this), cm (20.32 cm = 8 in wide).
pub const GOAL_HALF_WIDTH: f32 = 10.16;
/// Height of the goal mouth's top above the playfield, cm (the reference's arch top; the
/// mouth is modelled as a rectangle of this height).
pub const GOAL_MOUTH_HEIGHT: f32 = 7.8;
/// |y| of the back of each goal pocket, cm.
pub const GOAL_POCKET_BACK: f32 = 68.12;
/// |y| at which a ball counts as in a goal: the paper's goal centre (0, ±64).
pub const GOAL_LINE_Y: f32 = 64.0;

/// Dry friction of the reference model's ball on each axis, cm/s²: `frictionloss = 20` on
/// each of its slide joints, over its 0.1 kg.
pub const REFERENCE_BALL_DECELERATION: f32 = 200.0;
/// Friction coefficient of the `reference` ball's contacts with men and walls (calibrated
/// against the reference model, see `tests/suite/reference_parity.rs`).
pub const REFERENCE_BALL_FRICTION: f32 = 0.01;
/// Friction coefficient of the reference model's ball contacts as MuJoCo combines them:
/// the larger of the two geoms', the ball's 0.01 against the men's and the table's default
/// 1 (read off the model's contacts in mujoco 3.3.2). The `reference` preset's; the
/// first servo's game (`reference_v2`) kept the ball's own 0.01.
pub const REFERENCE_CONTACT_FRICTION: f32 = 1.0;
/// Restitution of the `reference` ball's contacts (calibrated likewise: MuJoCo's soft
/// contacts with solref 0.004 and damping ratio 1 are nearly dead).
pub const REFERENCE_BALL_RESTITUTION: f32 = 0.09;
/// Restitution of the `reference` ball's contacts with the men (calibrated on the
/// rebound off black's midfield after a kick).
pub const REFERENCE_MEN_RESTITUTION: f32 = 0.3;
/// The reference gym's action bound: its action space is [-20, 20] on every dimension.
pub const REFERENCE_ACTION_BOUND: f32 = 20.0;

/// Height of every rod axis above the playfield, cm.
pub const ROD_HEIGHT: f32 = 7.75;
/// How far along the table (y) from a rod's axis a man of it can reach the ball, cm: the
/// ball's centre lies `ROD_HEIGHT - BALL_RADIUS` below the axis, and a turning man's foot
/// sweeps a circle of radius [`foosman::FOOT_BOTTOM`] about it, so it touches the ball
/// where `dy² + (ROD_HEIGHT - BALL_RADIUS)² <= (FOOT_BOTTOM + BALL_RADIUS)²`.
/// A ball within it is in that rod's possession (ITSF's possession rule).
pub const MAN_REACH_Y: f32 = 6.712;
/// Radius of the steel rods, cm.
pub const ROD_RADIUS: f32 = 0.78;
/// Mass of the rod's bumpers and handle carried with the rod body, kg (2 x 0.05 + 0.01).
pub const ROD_FITTINGS_MASS: f32 = 0.11;

/// One foosman: a torso block around the rod and a narrower leg-and-foot block below it.
/// Extents measured from the reference mesh (after its 0.1 scale).
pub mod foosman {
    /// Mass of one foosman, kg.
    pub const MASS: f32 = 0.07;
    /// Top of the head above the rod axis, cm.
    pub const HEAD_TOP: f32 = 3.52;
    /// Boundary between torso and leg below the rod axis, cm.
    pub const WAIST: f32 = 1.85;
    /// Bottom of the foot below the rod axis, cm (foot 0.47 above the playfield).
    pub const FOOT_BOTTOM: f32 = 7.28;
    /// Torso half extents across (x) and along (y) the table, cm.
    pub const TORSO_HALF_X: f32 = 1.585;
    pub const TORSO_HALF_Y: f32 = 1.75;
    /// Leg-and-foot half extents across (x) and along (y) the table, cm.
    pub const LEG_HALF_X: f32 = 1.12;
    pub const LEG_HALF_Y: f32 = 1.2;
    /// The reference mesh's lower leg and foot along the table, from the rod axis, cm
    /// (`[back, front]`, front being the way the team attacks): its extent where the ball
    /// can touch it (0.5 to 3.5 cm above the playfield), measured on the mesh as placed
    /// in the reference model. The leg box of [`MenShape::Box`](crate::config::MenShape)
    /// is ±`LEG_HALF_Y` about the axis instead: 0.3 cm deeper in front.
    pub const REFERENCE_LEG_Y: [f32; 2] = [-1.3, 0.9];
    /// The reference mesh's lower leg and foot seen along the rod, `[y, z]` from the rod
    /// axis (cm; y the way the team attacks, z up at neutral): the convex outline of the
    /// mesh's vertices more than 3.9 cm from the axis, as the model places the mesh,
    /// simplified to within 0.02 cm. Only this part can meet the ball: the ball's centre
    /// never comes closer to an axis than 6.045 - 1.734 = 4.31 cm. Across the table the
    /// mesh there spans ±[`LEG_HALF_X`] (its convex hull is 2 % smaller than the prism).
    pub const MESH_LEG_PROFILE: [[f32; 2]; 18] = [
        [0.880, -3.894],
        [-1.084, -3.960],
        [-1.290, -4.041],
        [-1.390, -4.155],
        [-1.447, -4.363],
        [-1.426, -4.488],
        [-0.524, -6.662],
        [-0.320, -7.020],
        [-0.175, -7.209],
        [-0.088, -7.265],
        [0.051, -7.276],
        [0.167, -7.217],
        [0.398, -6.918],
        [0.537, -6.658],
        [0.671, -6.259],
        [0.931, -4.800],
        [0.959, -4.204],
        [0.935, -3.917],
    ];
}

/// Which side a rod belongs to. Yellow is the agent and attacks +y; black defends y = +60.12.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Team {
    Yellow,
    Black,
}

impl Team {
    /// +1 for yellow, -1 for black: the sign that turns a team's own frame into the world's
    /// (black's table is yellow's turned 180° about z).
    pub fn sign(self) -> f32 {
        match self {
            Team::Yellow => 1.0,
            Team::Black => -1.0,
        }
    }

    /// The other side.
    pub fn other(self) -> Team {
        match self {
            Team::Yellow => Team::Black,
            Team::Black => Team::Yellow,
        }
    }
}

/// One rod kind (each team has one of each), with its servo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RodSpec {
    /// Short name used in logs: `goalie`, `defence`, `midfield`, `attack`.
    pub name: &'static str,
    /// y of yellow's rod, cm (black's is at -y).
    pub yellow_y: f32,
    /// x offsets of the men from the rod centre at zero slide, cm.
    pub men_x: &'static [f32],
    /// Mass of the steel rod, kg (men and fittings come on top).
    pub rod_mass: f32,
    /// Slide control range: targets lie in [-slide_range, slide_range] cm.
    pub slide_range: f32,
    /// Slide travel allowed by the rod's rubber bumpers, [low, high] cm (measured in the
    /// reference model by commanding each end of the control range).
    pub bumper_travel: [f32; 2],
    /// Slide at which a rubber bumper pad first touches a side wall in the reference model,
    /// cm (either side): where its soft contact starts pushing back. Fitted to the
    /// model's step response (`shared/reference/foosball_cu/step_response.json`), the
    /// defence's (whose stop the fixture never reaches) from its rest at the stop.
    pub bumper_contact: f32,
    /// The reference model's generalised inertia of the rod's turn (MuJoCo's `dof_M` of its
    /// hinge, read from the model), kg cm². Our colliders' inertia is larger (box men);
    /// [`Integrator::MujocoEuler`](crate::config::Integrator) gives the rod this one. The
    /// slide's (kg) is ours already: rod, fittings and men.
    pub turn_inertia: f32,
    /// Slide servo stiffness (kg/s², i.e. force per cm) and damping (kg/s).
    pub slide_kp: f32,
    pub slide_kv: f32,
    /// Turn control range: targets lie in [-turn_range, turn_range] rad.
    pub turn_range: f32,
    /// Turn servo stiffness (kg cm²/s² per rad) and damping (kg cm²/s per rad/s).
    pub turn_kp: f32,
    pub turn_kv: f32,
    /// MuJoCo's `body_invweight0` of this rod's men, translational, 1/kg: the model's
    /// mean inverse mass of a man's body at rest, which with the ball's sets the
    /// regularisation of their soft contacts ([`crate::soft_contact::Regularisation`]).
    pub man_inv_weight: f32,
}

/// The four rod kinds in the order used everywhere: goalie, defence, midfield, attack.
pub const RODS: [RodSpec; 4] = [
    RodSpec {
        name: "goalie",
        yellow_y: -52.5,
        men_x: &[-20.676, 0.0, 20.676],
        rod_mass: 1.202_68,
        slide_range: 10.0,
        bumper_travel: [-8.70, 8.70],
        bumper_contact: 8.692,
        turn_inertia: 2.043_187,
        slide_kp: 20_000.0,
        slide_kv: 300.0,
        turn_range: 2.5,
        turn_kp: 70_000.0,
        turn_kv: 1_000.0,
        man_inv_weight: 0.475_947,
    },
    RodSpec {
        name: "defence",
        yellow_y: -37.5,
        men_x: &[-11.938, 11.938],
        rod_mass: 1.402_07,
        slide_range: 20.0,
        bumper_travel: [-17.43, 17.43],
        bumper_contact: 17.429,
        turn_inertia: 1.384_019,
        slide_kp: 10_000.0,
        slide_kv: 200.0,
        turn_range: 2.5,
        turn_kp: 40_000.0,
        turn_kv: 500.0,
        man_inv_weight: 0.581_220,
    },
    RodSpec {
        name: "midfield",
        yellow_y: -7.5,
        men_x: &[-23.95, -11.975, 0.0, 11.975, 23.95],
        rod_mass: 1.1264,
        slide_range: 7.0,
        bumper_travel: [-5.42, 5.42],
        bumper_contact: 5.414,
        turn_inertia: 3.348_838,
        slide_kp: 40_000.0,
        slide_kv: 500.0,
        turn_range: 2.5,
        turn_kp: 150_000.0,
        turn_kv: 2_000.0,
        man_inv_weight: 0.366_941,
    },
    RodSpec {
        name: "attack",
        yellow_y: 22.5,
        men_x: &[-18.175, 0.0, 18.175],
        rod_mass: 1.257_06,
        slide_range: 12.0,
        bumper_travel: [-11.20, 11.20],
        bumper_contact: 11.194,
        turn_inertia: 2.036_865,
        slide_kp: 20_000.0,
        slide_kv: 300.0,
        turn_range: 2.5,
        turn_kp: 70_000.0,
        turn_kv: 1_000.0,
        man_inv_weight: 0.469_197,
    },
];

/// Number of rods on the table (4 per team).
pub const NUM_RODS: usize = 8;

/// Team and kind of rod `i` in the global rod order: yellow goalie, defence, midfield,
/// attack, then black in the same order.
pub fn rod_of(i: usize) -> (Team, &'static RodSpec) {
    let team = if i < 4 { Team::Yellow } else { Team::Black };
    (team, &RODS[i % 4])
}

/// World y of rod `i`, cm.
pub fn rod_y(i: usize) -> f32 {
    let (team, spec) = rod_of(i);
    team.sign() * spec.yellow_y
}
