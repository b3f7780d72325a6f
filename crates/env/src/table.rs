//! The table as a rapier3d world: playfield, walls, goal pockets, eight servo-driven rods
//! with their men, and the ball. Units cm, kg, s, rad.
//!
//! Each rod is a dynamic rigid body with two degrees of freedom left free: slide along the
//! rod axis (limited to the servo's range by a joint limit) and turn about it. The other
//! four are held by a generic joint ([`RodMount::Joint`]) or locked on the body
//! ([`RodMount::LockedAxes`]). Two [`Servo`]s drive the free coordinates, applied as a
//! force and a torque before every physics step. Only the ball touches anything: men and
//! rods collide with the ball alone, and the table collides with the ball alone.

use core::f32::consts::PI;
use std::sync::OnceLock;

use rapier3d::prelude::*;

use crate::carried_shape::CarriedShape;
use crate::config::{
    BallFrame, BallModel, FoosballConfig, Integrator, ManContacts, MenShape, RodMount, SlideStops,
};
use crate::geometry::{self, NUM_RODS, RodSpec, Team, foosman};
use crate::man_field::{FieldForm, ManField};
use crate::sdf_search::{DQuat, DVec3, SdfSearch};
use crate::servo::Servo;
use crate::soft_contact::{BallDofs, ManContact, Regularisation, RodDofs, SoftContact};
use crate::soft_stop::SoftStop;

const TABLE_GROUP: Group = Group::GROUP_1;
const BALL_GROUP: Group = Group::GROUP_2;
const ROD_GROUP: Group = Group::GROUP_3;

/// Ratio of the force on a rolling solid sphere's centre to the deceleration it yields:
/// `m + I / r² = 7/5 m`.
const ROLLING_INERTIA_FACTOR: f32 = 1.4;

/// The physical settings a table is built with (nominal values, or one episode's
/// randomised draw).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhysicsParams {
    /// Physics step, s.
    pub dt: f32,
    /// Ball mass, kg.
    pub ball_mass: f32,
    /// Friction coefficient of every ball contact.
    pub ball_friction: f32,
    /// Restitution of the ball's contacts with the table (and with the men, where the men's
    /// is lower: rapier keeps the larger of the two).
    pub ball_restitution: f32,
    /// Restitution of the men's contacts (with the ball).
    pub men_restitution: f32,
    /// The men's colliders.
    pub men_shape: MenShape,
    /// Deceleration of a freely rolling ball, as a fraction of g.
    pub rolling_resistance: f32,
    /// How the ball moves.
    pub ball_model: BallModel,
    /// Dry friction of the `reference` ball on each axis, cm/s².
    pub axis_deceleration: f32,
    /// What stops the rods' slides.
    pub slide_stops: SlideStops,
    /// Rapier's contact recycling (see [`FoosballConfig::contact_recycling`]).
    pub contact_recycling: bool,
    /// Multiplier on every servo's kp and kv.
    pub servo_gain_scale: f32,
    /// Multiplier on the sliding friction of the ball's soft contacts with the men.
    pub men_friction_scale: f32,
    /// The ball's centre stays at z = its radius (no vertical motion).
    pub ball_planar: bool,
    /// How the rods are held.
    pub rod_mount: RodMount,
    /// How a physics step is taken.
    pub integrator: Integrator,
    /// How the ball's contacts with the men are made.
    pub man_contacts: ManContacts,
}

impl PhysicsParams {
    /// The nominal (not randomised) settings of `config`.
    pub fn nominal(config: &FoosballConfig) -> Self {
        Self {
            dt: config.physics_dt,
            ball_mass: config.ball.mass,
            ball_friction: config.ball.friction,
            ball_restitution: config.ball.restitution,
            men_restitution: config.ball.men_restitution,
            men_shape: config.men_shape,
            rolling_resistance: config.ball.rolling_resistance,
            ball_model: config.ball.model,
            axis_deceleration: config.ball.axis_deceleration,
            slide_stops: config.slide_stops,
            contact_recycling: config.contact_recycling,
            servo_gain_scale: 1.0,
            men_friction_scale: 1.0,
            ball_planar: config.ball.planar,
            rod_mount: config.rod_mount,
            integrator: config.integrator,
            man_contacts: config.man_contacts,
        }
    }
}

/// One rod's joint coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RodState {
    /// Slide along the rod's axis from neutral, cm.
    pub slide: f32,
    /// Slide velocity, cm/s.
    pub slide_vel: f32,
    /// Turn angle from hanging straight down, rad, unwrapped (may leave (-π, π]).
    pub angle: f32,
    /// Angular velocity, rad/s.
    pub angle_vel: f32,
}

/// A rod in the world.
#[derive(Debug, Clone)]
struct Rod {
    body: RigidBodyHandle,
    /// The rod's neutral pose in the world; its local x axis is the rod axis.
    frame: Pose,
    /// The rod axis in world coordinates (±x).
    axis: Vector,
    /// Generalised inertia of the slide (kg) and of the turn about the axis (kg cm²).
    slide_mass: f32,
    turn_inertia: f32,
    slide_servo: Servo,
    turn_servo: Servo,
    /// Under [`RodMount::LockedAxes`], `m g` times the centre of mass's offset from the
    /// axis at neutral (rod frame y and z), kg cm²/s²: gravity's torque about the axis
    /// at angle `q` is `-(w[0] cos q - w[1] sin q)`. `None` when the body carries its
    /// own centre of mass (the joint mount).
    hanging_weight: Option<[f32; 2]>,
    /// Unwrapped turn angle after the last step, rad.
    angle: f32,
    /// Under [`Integrator::MujocoEuler`] with bumpers: the slides at which the bumpers'
    /// soft contacts start, cm.
    soft_stops: Option<[f32; 2]>,
    /// The men's colliders with their bounding spheres in the rod's frame (centre, radius;
    /// cm), for [`ManContacts::MujocoSoft`]'s own contact search (empty under rapier's).
    men: Vec<(ColliderHandle, Vector, f32)>,
}

/// A copy of `world` in its state: bodies, colliders, joints, islands, the broad and
/// narrow phases (contacts with their warm-start impulses); the pipelines and the CCD
/// solver, workspaces only (rapier's `PhysicsWorld` docs), start empty. A copy steps on as
/// the original does, to the bit (`crate::foosball`'s tests).
fn copy_world(w: &PhysicsWorld) -> PhysicsWorld {
    PhysicsWorld {
        gravity: w.gravity,
        integration_parameters: w.integration_parameters,
        physics_pipeline: PhysicsPipeline::new(),
        collision_pipeline: CollisionPipeline::new(),
        islands: w.islands.clone(),
        broad_phase: w.broad_phase.clone(),
        narrow_phase: w.narrow_phase.clone(),
        bodies: w.bodies.clone(),
        colliders: w.colliders.clone(),
        impulse_joints: w.impulse_joints.clone(),
        multibody_joints: w.multibody_joints.clone(),
        soft_bodies: w.soft_bodies.clone(),
        ccd_solver: CCDSolver::new(),
    }
}

impl Clone for Table {
    /// The table in its current state (`copy_world`).
    fn clone(&self) -> Self {
        Self {
            world: copy_world(&self.world),
            ball: self.ball,
            rods: self.rods.clone(),
            targets: self.targets,
            ball_drag: self.ball_drag,
            integrator: self.integrator,
            soft_contact: self.soft_contact,
            sdf_search: self.sdf_search,
        }
    }
}

/// The simulated table.
pub struct Table {
    world: PhysicsWorld,
    ball: RigidBodyHandle,
    rods: Vec<Rod>,
    /// Servo targets per rod: `[slide cm, angle rad]`.
    targets: [[f32; 2]; NUM_RODS],
    ball_drag: BallDrag,
    integrator: Integrator,
    /// Under [`ManContacts::MujocoSoft`], the ball-man contacts this table computes itself
    /// (rapier's are then off).
    soft_contact: Option<SoftContact>,
    /// Under [`ManContacts::MujocoSdf`] and [`ManContacts::MujocoOctree`], how those
    /// contacts are found: MuJoCo's search on the reference man's field in that form, not
    /// one exact contact per man collider.
    sdf_search: Option<(SdfSearch, FieldForm)>,
}

/// The floor's pull on the moving ball.
#[derive(Debug, Clone, Copy)]
enum BallDrag {
    /// A rolling ball: this force (kg cm/s²) against its horizontal velocity while it
    /// touches the floor.
    Rolling(f32),
    /// The reference's sliding ball: dry friction of this deceleration (cm/s²) on x and
    /// on y independently.
    PerAxis(f32),
}

fn groups(member: Group, filter: Group) -> InteractionGroups {
    InteractionGroups::new(member, filter, InteractionTestMode::And)
}

/// A box spanning `[lo, hi]` on each axis, as a table collider.
fn block(lo: [f32; 3], hi: [f32; 3]) -> Collider {
    let half = |i: usize| 0.5 * (hi[i] - lo[i]);
    let mid = |i: usize| 0.5 * (hi[i] + lo[i]);
    ColliderBuilder::cuboid(half(0), half(1), half(2))
        .translation(Vector::new(mid(0), mid(1), mid(2)))
        .collision_groups(groups(TABLE_GROUP, BALL_GROUP))
        .friction(0.0)
        .restitution(0.0)
        .build()
}

/// The fixed colliders: playfield, side walls, end walls with goal mouths, goal pockets.
fn table_colliders() -> Vec<Collider> {
    use geometry::{
        FIELD_HALF_LENGTH as L, FIELD_HALF_WIDTH as W, GOAL_HALF_WIDTH as G,
        GOAL_MOUTH_HEIGHT as M, GOAL_POCKET_BACK as B, WALL_HEIGHT as H,
    };
    const T: f32 = 4.0; // wall thickness, outside the playing volume
    let mut out = vec![
        // Playfield and the floors of both goal pockets.
        block([-W - T, -B - T, -T], [W + T, B + T, 0.0]),
        // Side walls.
        block([-W - T, -L - T, 0.0], [-W, L + T, H]),
        block([W, -L - T, 0.0], [W + T, L + T, H]),
    ];
    for s in [-1.0_f32, 1.0] {
        // y range of something lying beyond |y| = from .. to on this end.
        let span = |from: f32, to: f32| if s > 0.0 { (from, to) } else { (-to, -from) };
        let (y0, y1) = span(L, L + T);
        // End wall either side of the mouth, and the crossbar above it.
        out.push(block([-W, y0, 0.0], [-G, y1, H]));
        out.push(block([G, y0, 0.0], [W, y1, H]));
        out.push(block([-G, y0, M], [G, y1, H]));
        // Goal pocket: side walls, back wall, roof.
        let (p0, p1) = span(L, B);
        out.push(block([-G - T, p0, 0.0], [-G, p1, H]));
        out.push(block([G, p0, 0.0], [G + T, p1, H]));
        let (b0, b1) = span(B, B + T);
        out.push(block([-G - T, b0, 0.0], [G + T, b1, H]));
        out.push(block([-G, p0, M], [G, p1, M + T]));
    }
    out
}

/// The slide limits of a rod kind, cm.
fn slide_limits(spec: &RodSpec, stops: SlideStops) -> [f32; 2] {
    match stops {
        SlideStops::ControlRange => [-spec.slide_range, spec.slide_range],
        SlideStops::Bumpers => spec.bumper_travel,
    }
}

/// Half the steel rod's length, cm: it spans the playfield at any slide.
fn shaft_half_len() -> f32 {
    geometry::FIELD_HALF_WIDTH + geometry::RODS[1].slide_range
}

/// The colliders of one rod in its own frame (x along the rod, z up at neutral): the steel
/// rod and each man's torso and leg blocks.
///
/// With `capsule_shaft` the steel rod is a capsule of the rod's radius carrying the
/// cylinder's mass properties (the same numbers, so the body's mass and inertia are the
/// same bit for bit): the same surface wherever the ball can reach (the caps lie beyond
/// the walls), and an analytic bounding box, where the cylinder's is found by
/// support-point queries (12 % of a locked-axes env step in `perf`, for the AABB updates
/// and the CCD sweeps). The joint mount keeps the cylinder, so that its runs stay the same
/// bit for bit: with the capsule, a trained TD3's test changed at rounding level (the
/// bounding boxes differ, so contact pairs can be ordered differently).
fn rod_colliders(
    spec: &RodSpec,
    capsule_shaft: bool,
    men: MenShape,
    men_restitution: f32,
) -> Vec<Collider> {
    let rod_groups = groups(ROD_GROUP, BALL_GROUP);
    let cylinder = ColliderBuilder::cylinder(shaft_half_len(), geometry::ROD_RADIUS)
        .rotation(Vector::new(0.0, 0.0, PI / 2.0))
        .mass(spec.rod_mass + geometry::ROD_FITTINGS_MASS);
    let shaft = if capsule_shaft {
        let c = cylinder.build();
        // Not attached yet, the collider's position is its pose in the rod's frame.
        let in_rod_frame = c.mass_properties().transform_by(c.position());
        ColliderBuilder::capsule_x(shaft_half_len(), geometry::ROD_RADIUS)
            .mass_properties(in_rod_frame)
    } else {
        cylinder
    };
    let mut out = vec![
        shaft
            .collision_groups(rod_groups)
            .friction(0.0)
            .restitution(0.0)
            .build(),
    ];
    let torso_half_z = 0.5 * (foosman::HEAD_TOP + foosman::WAIST);
    let leg_half_z = 0.5 * (foosman::FOOT_BOTTOM - foosman::WAIST);
    let torso_vol = foosman::TORSO_HALF_X * foosman::TORSO_HALF_Y * torso_half_z;
    let leg_vol = foosman::LEG_HALF_X * foosman::LEG_HALF_Y * leg_half_z;
    let torso_mass = foosman::MASS * torso_vol / (torso_vol + leg_vol);
    let torso_z = 0.5 * (foosman::HEAD_TOP - foosman::WAIST);
    let leg_z = -0.5 * (foosman::WAIST + foosman::FOOT_BOTTOM);
    // A leg block from `back` to `front` along the table in the rod's frame (+y: the way
    // the team attacks), under the man at `x`.
    let leg_block = |x: f32, [back, front]: [f32; 2]| {
        ColliderBuilder::cuboid(foosman::LEG_HALF_X, 0.5 * (front - back), leg_half_z)
            .translation(Vector::new(x, 0.5 * (front + back), leg_z))
    };
    let man_collider = |shape: ColliderBuilder, m: f32| {
        shape
            .mass(m)
            .collision_groups(rod_groups)
            .friction(0.0)
            .restitution(men_restitution)
            .build()
    };
    for &x in spec.men_x {
        out.push(man_collider(
            ColliderBuilder::cuboid(foosman::TORSO_HALF_X, foosman::TORSO_HALF_Y, torso_half_z)
                .translation(Vector::new(x, 0.0, torso_z)),
            torso_mass,
        ));
        let leg = match men {
            MenShape::Box => leg_block(x, [-foosman::LEG_HALF_Y, foosman::LEG_HALF_Y]),
            MenShape::Reference => leg_block(x, foosman::REFERENCE_LEG_Y),
            MenShape::Mesh => mesh_leg().translation(Vector::new(x, 0.0, 0.0)),
        };
        out.push(man_collider(leg, foosman::MASS - torso_mass));
    }
    out
}

/// The mesh's lower leg and foot ([`foosman::MESH_LEG_PROFILE`]) as a convex prism
/// ±[`foosman::LEG_HALF_X`] across, in the man's frame. The hull is computed once and
/// shared by every man of every table (a reset builds 22 of them).
fn mesh_leg() -> ColliderBuilder {
    static LEG: OnceLock<SharedShape> = OnceLock::new();
    let shape = LEG.get_or_init(|| {
        let points: Vec<Vector> = [-foosman::LEG_HALF_X, foosman::LEG_HALF_X]
            .into_iter()
            .flat_map(|x| {
                foosman::MESH_LEG_PROFILE
                    .iter()
                    .map(move |&[y, z]| Vector::new(x, y, z))
            })
            .collect();
        SharedShape::convex_hull(&points).expect("the leg profile spans a volume")
    });
    ColliderBuilder::new(shape.clone())
}

/// `a` wrapped into (-π, π].
fn wrap_angle(a: f32) -> f32 {
    if a > PI {
        a - 2.0 * PI
    } else if a <= -PI {
        a + 2.0 * PI
    } else {
        a
    }
}

/// Turn angle about x of a rotation that is (up to rounding) about x alone, in (-π, π].
fn angle_about_x(q: Rotation) -> f32 {
    wrap_angle(2.0 * q.x.atan2(q.w))
}

impl Table {
    /// Builds the table with every rod at neutral and the ball at rest at `ball_xy`
    /// (cm) on the playfield.
    pub fn new(params: &PhysicsParams, ball_xy: [f32; 2]) -> Self {
        let mut world = PhysicsWorld::new();
        world.gravity = Vector::new(0.0, 0.0, -geometry::GRAVITY);
        world.integration_parameters.dt = params.dt;
        world.integration_parameters.length_unit = 100.0;
        world.integration_parameters.contact_recycling = params.contact_recycling;
        let mujoco = params.integrator == Integrator::MujocoEuler;
        if mujoco {
            // One Euler step per physics step, as MuJoCo takes it.
            world.integration_parameters.num_solver_iterations = 1;
            // Contacts found where the bodies are at the start of the step, as MuJoCo finds
            // them: none ahead of touching, so a man meets the ball a step after it
            // reaches it, not in the step it does (rapier's speculative contacts).
            world.integration_parameters.normalized_prediction_distance = 0.0;
        }

        let soft = params.man_contacts != ManContacts::Rapier;
        let men_contact = SoftContact {
            friction: SoftContact::REFERENCE.friction * params.men_friction_scale,
            ..SoftContact::REFERENCE
        };
        let (soft_contact, sdf_search) = match params.man_contacts {
            ManContacts::Rapier => (None, None),
            ManContacts::MujocoSoft => (Some(men_contact), None),
            // The model's contacts with the model's regularisation.
            ManContacts::MujocoSdf | ManContacts::MujocoOctree => (
                Some(SoftContact {
                    regularisation: Regularisation::MujocoPyramid,
                    ..men_contact
                }),
                Some((
                    SdfSearch::REFERENCE,
                    if params.man_contacts == ManContacts::MujocoSdf {
                        FieldForm::Grid
                    } else {
                        FieldForm::Octree
                    },
                )),
            ),
        };
        // The men's contacts are MuJoCo's search on the man's field: a rod's colliders carry
        // its mass and nothing else ([`CarriedShape`]).
        let field_search = sdf_search.is_some();
        let ground = world.insert_body(RigidBodyBuilder::fixed());
        for c in table_colliders() {
            world
                .colliders
                .insert_with_parent(c, ground, &mut world.bodies);
        }

        let rods = (0..NUM_RODS)
            .map(|i| {
                let (team, spec) = geometry::rod_of(i);
                let locked = params.rod_mount == RodMount::LockedAxes;
                let rotation = match team {
                    Team::Yellow => Rotation::IDENTITY,
                    // Half a turn about z. `from_rotation_z(PI)` is off by ~4e-8 rad, which
                    // the joint absorbs (its frame is the same) but a body turning about the
                    // locked world x does not: its servo then drifts. The joint mount keeps
                    // the rounded frame, so that its runs stay the same bit for bit.
                    Team::Black if locked => Rotation::from_xyzw(0.0, 0.0, 1.0, 0.0),
                    Team::Black => Rotation::from_rotation_z(PI),
                };
                let frame = Pose::from_parts(
                    Vector::new(0.0, geometry::rod_y(i), geometry::ROD_HEIGHT),
                    rotation,
                );
                let body = world.insert_body(
                    RigidBodyBuilder::dynamic()
                        .pose(frame)
                        // Under the soft contacts nothing of rapier's collides with a rod:
                        // its sweeps need not look beyond the fixed colliders.
                        .ccd_enabled(!soft)
                        // MuJoCo's rods turn up to 0.9 rad in a step (the midfield's
                        // reversal); rapier would cap them at 0.25 pi.
                        .allow_fast_rotation(mujoco)
                        .locked_axes(if locked {
                            LockedAxes::TRANSLATION_LOCKED_Y
                                | LockedAxes::TRANSLATION_LOCKED_Z
                                | LockedAxes::ROTATION_LOCKED_Y
                                | LockedAxes::ROTATION_LOCKED_Z
                        } else {
                            LockedAxes::empty()
                        })
                        .can_sleep(false),
                );
                let colliders: Vec<ColliderHandle> =
                    rod_colliders(spec, locked, params.men_shape, params.men_restitution)
                        .into_iter()
                        .map(|mut c| {
                            if field_search {
                                let shape = c.shared_shape().clone();
                                c.set_shape(SharedShape::new(CarriedShape(shape)));
                            }
                            world
                                .colliders
                                .insert_with_parent(c, body, &mut world.bodies)
                        })
                        .collect();
                // Every collider after the shaft is a man's; only the soft contacts search
                // them (a table is built at every reset: no work for the other models).
                let men = if soft {
                    colliders[1..]
                        .iter()
                        .map(|&h| {
                            let c = &world.colliders[h];
                            let local = c.position_wrt_parent().copied().unwrap_or_default();
                            let sphere = c.shape().compute_local_bounding_sphere();
                            (h, local * sphere.center(), sphere.radius())
                        })
                        .collect()
                } else {
                    Vec::new()
                };
                let held = if locked {
                    JointAxesMask::empty()
                } else {
                    JointAxesMask::LIN_Y
                        | JointAxesMask::LIN_Z
                        | JointAxesMask::ANG_Y
                        | JointAxesMask::ANG_Z
                };
                let soft_stops = (mujoco && params.slide_stops == SlideStops::Bumpers)
                    .then_some([-spec.bumper_contact, spec.bumper_contact]);
                let mut joint = GenericJointBuilder::new(held)
                    .local_frame1(frame)
                    .local_frame2(Pose::IDENTITY)
                    .contacts_enabled(false);
                if soft_stops.is_none() {
                    joint = joint.limits(JointAxis::LinX, slide_limits(spec, params.slide_stops));
                }
                world.insert_impulse_joint(ground, body, joint.build());

                let rb = &world.bodies[body];
                let mprops = &rb.mass_properties().local_mprops;
                let com = mprops.local_com;
                let inertia = mprops.reconstruct_inertia_matrix();
                let mass = mprops.mass();
                let turn_inertia = if mujoco {
                    spec.turn_inertia
                } else {
                    inertia.x_axis.x + mass * (com.y * com.y + com.z * com.z)
                };
                let gravity = if mujoco {
                    geometry::REFERENCE_GRAVITY
                } else {
                    geometry::GRAVITY
                };
                let hanging_weight = locked.then(|| {
                    // The body turns about its centre of mass, so that goes on the axis
                    // (with the inertia about the axis) and the colliders carry no mass;
                    // the men's weight below the axis comes back as a torque.
                    let about_axis = AngVector::new(
                        turn_inertia,
                        inertia.y_axis.y + mass * (com.x * com.x + com.z * com.z),
                        inertia.z_axis.z + mass * (com.x * com.x + com.y * com.y),
                    );
                    for &c in &colliders {
                        world.colliders[c].set_density(0.0);
                    }
                    let rb = &mut world.bodies[body];
                    rb.set_additional_mass_properties(
                        MassProperties::new(Vector::ZERO, mass, about_axis),
                        false,
                    );
                    rb.recompute_mass_properties_from_colliders(&world.colliders);
                    [mass * gravity * com.y, mass * gravity * com.z]
                });
                let g = params.servo_gain_scale;
                Rod {
                    body,
                    frame,
                    axis: rotation * Vector::X,
                    slide_mass: mass,
                    turn_inertia,
                    hanging_weight,
                    slide_servo: Servo {
                        kp: g * spec.slide_kp,
                        kv: g * spec.slide_kv,
                    },
                    turn_servo: Servo {
                        kp: g * spec.turn_kp,
                        kv: g * spec.turn_kv,
                    },
                    angle: 0.0,
                    soft_stops,
                    men,
                }
            })
            .collect();

        let sliding = params.ball_model == BallModel::Reference;
        let ball = world.insert_body(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(ball_xy[0], ball_xy[1], geometry::BALL_RADIUS))
                .ccd_enabled(true)
                .locked_axes(if sliding {
                    // Two slide joints and nothing else, as the reference's ball; the
                    // floor then bears no weight, so it adds no friction either.
                    LockedAxes::TRANSLATION_LOCKED_Z | LockedAxes::ROTATION_LOCKED
                } else if params.ball_planar {
                    LockedAxes::TRANSLATION_LOCKED_Z
                } else {
                    LockedAxes::empty()
                })
                .gravity_scale(if sliding { 0.0 } else { 1.0 })
                .can_sleep(false),
        );
        let ball_collider = ColliderBuilder::ball(geometry::BALL_RADIUS)
            .mass(params.ball_mass)
            .friction(params.ball_friction)
            .friction_combine_rule(CoefficientCombineRule::Max)
            .restitution(params.ball_restitution)
            .restitution_combine_rule(CoefficientCombineRule::Max)
            .collision_groups(groups(
                BALL_GROUP,
                if soft {
                    TABLE_GROUP
                } else {
                    TABLE_GROUP | ROD_GROUP
                },
            ))
            .build();
        world
            .colliders
            .insert_with_parent(ball_collider, ball, &mut world.bodies);

        Self {
            world,
            ball,
            rods,
            targets: [[0.0; 2]; NUM_RODS],
            integrator: params.integrator,
            soft_contact,
            sdf_search,
            ball_drag: if sliding {
                BallDrag::PerAxis(params.axis_deceleration)
            } else {
                BallDrag::Rolling(
                    ROLLING_INERTIA_FACTOR
                        * params.rolling_resistance
                        * params.ball_mass
                        * geometry::GRAVITY,
                )
            },
        }
    }

    /// Sets rod `rod`'s servo targets: slide in cm and angle in rad (clamped to the rod's
    /// control ranges).
    pub fn set_target(&mut self, rod: usize, slide: f32, angle: f32) {
        let (_, spec) = geometry::rod_of(rod);
        self.targets[rod] = [
            slide.clamp(-spec.slide_range, spec.slide_range),
            angle.clamp(-spec.turn_range, spec.turn_range),
        ];
    }

    /// Advances the world by one physics step.
    pub fn step(&mut self) {
        let dt = self.world.integration_parameters.dt;
        let before: [RodState; NUM_RODS] = core::array::from_fn(|i| self.rod_state(i));
        let mut rod_forces = [[0.0_f32; 2]; NUM_RODS];
        for (i, rod) in self.rods.iter().enumerate() {
            let s = before[i];
            let [slide_target, angle_target] = self.targets[i];
            let (mut f, mut t) = match self.integrator {
                Integrator::Rapier => (
                    rod.slide_servo.implicit_force(
                        slide_target,
                        s.slide,
                        s.slide_vel,
                        rod.slide_mass,
                        dt,
                    ),
                    rod.turn_servo.implicit_force(
                        angle_target,
                        s.angle,
                        s.angle_vel,
                        rod.turn_inertia,
                        dt,
                    ),
                ),
                Integrator::MujocoEuler => (
                    rod.slide_servo
                        .explicit_force(slide_target, s.slide, s.slide_vel),
                    rod.turn_servo
                        .explicit_force(angle_target, s.angle, s.angle_vel),
                ),
            };
            if let Some([wy, wz]) = rod.hanging_weight {
                t += wz * s.angle.sin() - wy * s.angle.cos();
            }
            if let Some(stops) = rod.soft_stops {
                let free = f / rod.slide_mass;
                f += rod.slide_mass
                    * SoftStop::REFERENCE.acceleration(stops, s.slide, s.slide_vel, free, dt);
            }
            rod_forces[i] = [f, t];
        }
        let mut ball_force = self.ball_drag(dt);
        if let Some(law) = self.soft_contact {
            self.add_contact_forces(&law, &before, &mut rod_forces, &mut ball_force, dt);
        }
        for (rod, [f, t]) in self.rods.iter().zip(rod_forces) {
            let body = &mut self.world.bodies[rod.body];
            body.reset_forces(false);
            body.reset_torques(false);
            body.add_force(rod.axis * f, false);
            body.add_torque(rod.axis * t, false);
        }
        let ball = &mut self.world.bodies[self.ball];
        ball.reset_forces(false);
        ball.add_force(ball_force, false);
        self.world.step();
        match self.integrator {
            Integrator::Rapier => {
                for i in 0..self.rods.len() {
                    let raw = self.raw_angle(i);
                    let rod = &mut self.rods[i];
                    rod.angle += wrap_angle(raw - rod.angle);
                }
            }
            Integrator::MujocoEuler => {
                for (i, s) in before.iter().enumerate() {
                    self.euler_position_update(i, s, dt);
                }
            }
        }
    }

    /// Puts rod `rod` where MuJoCo's Euler step puts it: each coordinate advanced by `dt`
    /// times its velocity at the end of the step (rapier turns a body through
    /// `2 atan(dt w / 2)`, short of `dt w` at the rods' speeds, and its substeps average the
    /// velocity over the step).
    fn euler_position_update(&mut self, rod: usize, before: &RodState, dt: f32) {
        let r = &mut self.rods[rod];
        let body = &mut self.world.bodies[r.body];
        let slide = before.slide + dt * body.linvel().dot(r.axis);
        r.angle = before.angle + dt * body.angvel().dot(r.axis);
        let local = Pose::from_parts(
            Vector::new(slide, 0.0, 0.0),
            Rotation::from_rotation_x(r.angle),
        );
        body.set_position(r.frame * local, false);
    }

    /// The floor's drag on the ball for the coming step (kg cm/s²), as a force at its
    /// centre that never reverses the velocity it opposes: a rolling ball slows at
    /// `rolling_resistance * g` against its horizontal velocity while it touches the
    /// playfield; the reference's sliding ball at `axis_deceleration` on x and on y
    /// independently (MuJoCo's `frictionloss` on each slide joint).
    fn ball_drag(&self, dt: f32) -> Vector {
        let ball = &self.world.bodies[self.ball];
        let v = ball.linvel();
        let m = ball.mass();
        match self.ball_drag {
            BallDrag::Rolling(force) => {
                let on_floor = ball.translation().z < geometry::BALL_RADIUS + 0.05;
                let speed = (v.x * v.x + v.y * v.y).sqrt();
                if on_floor && speed > 0.0 {
                    let stop = ROLLING_INERTIA_FACTOR * m * speed / dt;
                    let f = force.min(stop);
                    Vector::new(-v.x / speed * f, -v.y / speed * f, 0.0)
                } else {
                    Vector::ZERO
                }
            }
            BallDrag::PerAxis(deceleration) => {
                let axis = |v: f32| -v.signum() * (m * deceleration).min(m * v.abs() / dt);
                Vector::new(axis(v.x), axis(v.y), 0.0)
            }
        }
    }

    /// The ball's contacts with the men where the bodies are at the step's start (the
    /// reference's are found so), for [`ManContacts::MujocoSoft`]: rod index and contact.
    fn man_contacts(&self) -> Vec<(usize, ManContact)> {
        if let Some((search, form)) = self.sdf_search {
            return self.sdf_man_contacts(&search, ManField::reference(form));
        }
        let centre = self.world.bodies[self.ball].translation();
        let ball_pose = Pose::from_translation(centre);
        let ball_shape = Ball::new(geometry::BALL_RADIUS);
        let mut out = Vec::new();
        for (i, rod) in self.rods.iter().enumerate() {
            let body_pose = *self.world.bodies[rod.body].position();
            for &(handle, sphere_centre, radius) in &rod.men {
                let gap = (body_pose * sphere_centre).distance(centre);
                if gap > radius + geometry::BALL_RADIUS {
                    continue;
                }
                let collider = &self.world.colliders[handle];
                let pose = body_pose * collider.position_wrt_parent().copied().unwrap_or_default();
                if let Ok(Some(c)) = rapier3d::parry::query::contact(
                    &ball_pose,
                    &ball_shape,
                    &pose,
                    collider.shape(),
                    0.0,
                ) && c.normal1.is_finite()
                {
                    let point = 0.5 * (c.point1 + c.point2);
                    out.push((
                        i,
                        ManContact {
                            rod: 0,
                            point,
                            normal: -c.normal1,
                            dist: c.dist,
                        },
                    ));
                }
            }
        }
        out
    }

    /// The ball's contacts with the men as the reference model finds them, for
    /// [`ManContacts::MujocoSdf`] and [`ManContacts::MujocoOctree`] (`field` in the form
    /// each reads): MuJoCo's SDF search between the ball, seen at the
    /// model's height ([`BallFrame::JOINT_ORIGIN`]), and each man near it (its frame the
    /// rod's moved to the man's x), on the reference man's field: rod index and contact.
    fn sdf_man_contacts(&self, search: &SdfSearch, field: &ManField) -> Vec<(usize, ManContact)> {
        let ball = self.world.bodies[self.ball].translation();
        let centre = DVec3::new(
            f64::from(ball.x),
            f64::from(ball.y),
            f64::from(BallFrame::JOINT_ORIGIN[2]),
        );
        let radius = f64::from(geometry::BALL_RADIUS);
        let vector = |v: DVec3| Vector::new(v.x as f32, v.y as f32, v.z as f32);
        let mut out = Vec::new();
        for (i, rod) in self.rods.iter().enumerate() {
            let pose = *self.world.bodies[rod.body].position();
            let q = pose.rotation;
            let rotation = DQuat::from_xyzw(q.x.into(), q.y.into(), q.z.into(), q.w.into());
            for &x in geometry::rod_of(i).1.men_x {
                let origin = pose * Vector::new(x, 0.0, 0.0);
                let origin = DVec3::new(origin.x.into(), origin.y.into(), origin.z.into());
                if origin.distance(centre) > field.reach + radius {
                    continue;
                }
                for c in search.contacts(field, rotation, origin, centre, radius) {
                    out.push((
                        i,
                        ManContact {
                            rod: 0,
                            point: vector(c.point),
                            normal: vector(c.normal),
                            dist: c.dist as f32,
                        },
                    ));
                }
            }
        }
        out
    }

    /// Adds the soft ball-man contacts' forces to the step's others (`rod_forces`: slide
    /// force and torque per rod; `ball_force`), solved against them
    /// ([`SoftContact::solve`]).
    fn add_contact_forces(
        &self,
        law: &SoftContact,
        before: &[RodState; NUM_RODS],
        rod_forces: &mut [[f32; 2]; NUM_RODS],
        ball_force: &mut Vector,
        dt: f32,
    ) {
        let found = self.man_contacts();
        if found.is_empty() {
            return;
        }
        let mut touched: Vec<usize> = found.iter().map(|&(i, _)| i).collect();
        touched.dedup();
        let rods: Vec<RodDofs> = touched
            .iter()
            .map(|&i| {
                let r = &self.rods[i];
                let s = &before[i];
                RodDofs {
                    axis: r.axis,
                    on_axis: self.world.bodies[r.body].translation(),
                    slide_mass: r.slide_mass,
                    turn_inertia: r.turn_inertia,
                    vel: [s.slide_vel, s.angle_vel],
                    free_acc: [
                        rod_forces[i][0] / r.slide_mass,
                        rod_forces[i][1] / r.turn_inertia,
                    ],
                    inv_weight: geometry::rod_of(i).1.man_inv_weight,
                }
            })
            .collect();
        let contacts: Vec<ManContact> = found
            .iter()
            .map(|&(i, c)| ManContact {
                rod: touched.iter().position(|&t| t == i).unwrap_or_default(),
                ..c
            })
            .collect();
        let ball = &self.world.bodies[self.ball];
        let m = ball.mass();
        let v = ball.linvel();
        let forces = law.solve(
            &BallDofs {
                mass: m,
                vel: [v.x, v.y],
                free_acc: [ball_force.x / m, ball_force.y / m],
                inv_weight: 1.0 / m,
            },
            &rods,
            &contacts,
            dt,
        );
        // A degenerate contact never poisons the state: the step goes on without it.
        if !forces
            .ball
            .iter()
            .chain(forces.rods.iter().flatten())
            .all(|f| f.is_finite())
        {
            return;
        }
        *ball_force += Vector::new(forces.ball[0], forces.ball[1], 0.0);
        for (&i, [f, t]) in touched.iter().zip(forces.rods) {
            rod_forces[i][0] += f;
            rod_forces[i][1] += t;
        }
    }

    fn raw_angle(&self, rod: usize) -> f32 {
        let r = &self.rods[rod];
        let rel = r.frame.inv_mul(self.world.bodies[r.body].position());
        angle_about_x(rel.rotation)
    }

    /// Joint coordinates of rod `rod` (global rod order, see [`crate::layout`]).
    pub fn rod_state(&self, rod: usize) -> RodState {
        let r = &self.rods[rod];
        let body = &self.world.bodies[r.body];
        let rel = r.frame.inv_mul(body.position());
        RodState {
            slide: rel.translation.x,
            slide_vel: body.linvel().dot(r.axis),
            angle: r.angle,
            angle_vel: body.angvel().dot(r.axis),
        }
    }

    /// Puts rod `rod` (global rod order) at `state`: its slide (cm) and angle (rad, kept
    /// unwrapped) and their velocities (cm/s, rad/s); its servo targets are left as they
    /// are. With [`Table::set_ball`], a recorded state of the game to step on from.
    pub fn set_rod(&mut self, rod: usize, state: RodState) {
        let r = &mut self.rods[rod];
        r.angle = state.angle;
        let local = Pose::from_parts(
            Vector::new(state.slide, 0.0, 0.0),
            Rotation::from_rotation_x(state.angle),
        );
        let body = &mut self.world.bodies[r.body];
        body.set_position(r.frame * local, true);
        body.set_linvel(r.axis * state.slide_vel, true);
        body.set_angvel(r.axis * state.angle_vel, true);
    }

    /// Ball centre, cm.
    pub fn ball_position(&self) -> [f32; 3] {
        self.world.bodies[self.ball].translation().to_array()
    }

    /// Ball velocity, cm/s.
    pub fn ball_velocity(&self) -> [f32; 3] {
        self.world.bodies[self.ball].linvel().to_array()
    }

    /// Places the ball at `position` (cm) moving at `velocity` (cm/s), without spin.
    pub fn set_ball(&mut self, position: [f32; 3], velocity: [f32; 3]) {
        let ball = &mut self.world.bodies[self.ball];
        ball.set_translation(Vector::from_array(position), true);
        ball.set_linvel(Vector::from_array(velocity), true);
        ball.set_angvel(Vector::ZERO, true);
    }

    /// Physics step length, s.
    pub fn dt(&self) -> f32 {
        self.world.integration_parameters.dt
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angle_about_x_round_trips() {
        for a in [-3.0_f32, -1.0, 0.0, 0.5, 2.9] {
            assert!((angle_about_x(Rotation::from_rotation_x(a)) - a).abs() < 1e-5);
        }
    }

    #[test]
    fn rod_inertia_includes_the_men() {
        let t = Table::new(
            &PhysicsParams::nominal(&FoosballConfig::default()),
            [0.0, 0.0],
        );
        let goalie = &t.rods[0];
        // rod + fittings + 3 men
        assert!((goalie.slide_mass - (1.20268 + 0.11 + 0.21)).abs() < 1e-4);
        // three men of ~10.8 cm hanging ~1.9 cm below the axis: ~0.9 kg cm² each
        assert!(
            goalie.turn_inertia > 2.0 && goalie.turn_inertia < 4.0,
            "{}",
            goalie.turn_inertia
        );
    }

    #[test]
    fn soft_contacts_push_an_overlapping_ball_out_and_leave_a_free_one_alone() {
        let soft = PhysicsParams::nominal(&FoosballConfig {
            man_contacts: ManContacts::MujocoSoft,
            ..FoosballConfig::default()
        });
        let hard = PhysicsParams::nominal(&FoosballConfig {
            man_contacts: ManContacts::Rapier,
            ..FoosballConfig::default()
        });
        // 0.2 cm into the front of yellow's resting centre midfielder's foot (rod at
        // y = -7.5, the foot's front about 0.6 cm ahead of the axis at the ball's height).
        let mut table = Table::new(&soft, [0.0, -7.5 + 0.6 + geometry::BALL_RADIUS - 0.2]);
        for _ in 0..5 {
            table.step();
        }
        let v = table.ball_velocity();
        assert!(v.iter().all(|x| x.is_finite()));
        assert!(v[1] > 1.0 && v[1] < 100.0, "{v:?}");
        // Away from every man the two contact models step the same table bit for bit.
        let [mut a, mut b] = [&soft, &hard].map(|p| Table::new(p, [10.0, 15.0]));
        for t in [&mut a, &mut b] {
            t.set_ball([10.0, 15.0, geometry::BALL_RADIUS], [40.0, 0.0, 0.0]);
            for _ in 0..20 {
                t.step();
            }
        }
        assert_eq!(a.ball_position(), b.ball_position());
        assert_eq!(a.ball_velocity(), b.ball_velocity());
    }

    #[test]
    fn the_capsule_shaft_carries_the_cylinders_mass_properties_bit_for_bit() {
        let mut world = PhysicsWorld::new();
        for spec in &geometry::RODS {
            let [cylinder, capsule] = [false, true].map(|capsule_shaft| {
                let body = world.insert_body(RigidBodyBuilder::dynamic());
                for c in rod_colliders(spec, capsule_shaft, MenShape::Box, 0.0) {
                    world
                        .colliders
                        .insert_with_parent(c, body, &mut world.bodies);
                }
                world.bodies[body].mass_properties().local_mprops
            });
            assert_eq!(cylinder, capsule);
            assert!(cylinder.mass() > spec.rod_mass);
        }
    }
}
