//! The ball's contacts with the men as MuJoCo makes them: soft frictional constraints,
//! solved together with every other force of the step (the reference model's contacts;
//! rapier's are hard, single and bouncy).
//!
//! For a contact at signed distance `r` (negative inside) with normal `n` (from the man to
//! the ball), MuJoCo's pyramidal friction cone (`condim = 4`: sliding friction `mu` on two
//! tangents `t1`, `t2` and torsional friction `mu_t` about `n`) makes six constraint rows,
//! the cone's edges `J_e = J_n ± mu J_t1`, `J_n ± mu J_t2`, `J_n ± mu_t J_spin`, each
//! pushing only (`f_e >= 0`). Each edge is pulled towards its reference acceleration
//! `a_ref,e = -b (J_e v) - k d r` ([`SoftStop::reference_acceleration`]) with the
//! regularisation `R_e = (1 - d) / d A_ee`, and the forces solve MuJoCo's dual problem
//!
//! ```text
//! min_{f >= 0}  1/2 f' (A + R) f + f' (J a_0 - a_ref),    A = J M^-1 J'
//! ```
//!
//! (`a_0` the accelerations of every other force), whose solution is unique for `R > 0`;
//! here exactly, by an active-set method (Lawson and Hanson's, for a quadratic cost) in
//! f64: the cone's edges are nearly parallel, which leaves Gauss-Seidel far from the
//! solution after hundreds of sweeps. The generalised forces
//! `J' f` are added to the step's other forces, so the explicit Euler step of the
//! reference ([`crate::config::Integrator::MujocoEuler`]) takes them as MuJoCo does.
//!
//! The degrees of freedom are the ball's two slides (the reference's ball has no vertical
//! or rotational freedom: a man pressing down on it is held) and each touched rod's slide
//! and turn.

use rapier3d::prelude::Vector;

use crate::soft_stop::SoftStop;

/// One contact between the ball and a man, where the bodies are at the start of the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ManContact {
    /// Index of the touched rod in the problem's `rods`.
    pub rod: usize,
    /// Midpoint between the two surfaces, world, cm.
    pub point: Vector,
    /// Unit normal from the man towards the ball, world.
    pub normal: Vector,
    /// Signed distance between the surfaces, cm (negative: they overlap).
    pub dist: f32,
}

/// A touched rod's two degrees of freedom.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RodDofs {
    /// The rod's axis, unit, world.
    pub axis: Vector,
    /// A point on the axis, world, cm.
    pub on_axis: Vector,
    /// Slide mass, kg.
    pub slide_mass: f32,
    /// Turn inertia about the axis, kg cm².
    pub turn_inertia: f32,
    /// Slide velocity (cm/s) and angular velocity about `axis` (rad/s) at the step's start.
    pub vel: [f32; 2],
    /// Slide (cm/s²) and angular (rad/s²) accelerations of the step's other forces.
    pub free_acc: [f32; 2],
}

/// The ball's two slides (x, y).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallDofs {
    /// Mass, kg.
    pub mass: f32,
    /// Velocity at the step's start, cm/s.
    pub vel: [f32; 2],
    /// Acceleration of the step's other forces, cm/s².
    pub free_acc: [f32; 2],
}

/// The contact forces of one step: generalised forces to add to the others.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactForces {
    /// On the ball's x and y, kg cm/s².
    pub ball: [f32; 2],
    /// On each rod of the problem: slide force (kg cm/s²) and torque about its axis
    /// (kg cm²/s²).
    pub rods: Vec<[f32; 2]>,
}

/// The soft contact's constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoftContact {
    /// `solref` and `solimp` of the contacts.
    pub law: SoftStop,
    /// Sliding friction coefficient `mu`.
    pub friction: f32,
    /// Torsional friction `mu_t`, cm (torque per unit of normal force).
    pub torsional_friction: f32,
}

impl SoftContact {
    /// The reference model's ball-man contacts: the default `solref = "0.004 1"`,
    /// `solimp = ".99 .99 .00001"`, `condim = 4`, and the larger of the two geoms'
    /// frictions (MuJoCo's rule): the men's default sliding 1, the ball's torsional 0.1.
    pub const REFERENCE: SoftContact = SoftContact {
        law: SoftStop::REFERENCE,
        friction: 1.0,
        torsional_friction: 0.1,
    };

    /// The contact forces of a step of `dt` seconds.
    pub fn solve(
        &self,
        ball: &BallDofs,
        rods: &[RodDofs],
        contacts: &[ManContact],
        dt: f32,
    ) -> ContactForces {
        let dofs = 2 + 2 * rods.len();
        let inv_mass: Vec<f32> = [1.0 / ball.mass, 1.0 / ball.mass]
            .into_iter()
            .chain(
                rods.iter()
                    .flat_map(|r| [1.0 / r.slide_mass, 1.0 / r.turn_inertia]),
            )
            .collect();
        let vel: Vec<f32> = ball
            .vel
            .into_iter()
            .chain(rods.iter().flat_map(|r| r.vel))
            .collect();
        let free: Vec<f32> = ball
            .free_acc
            .into_iter()
            .chain(rods.iter().flat_map(|r| r.free_acc))
            .collect();

        // The cone's edges: Jacobian rows and reference accelerations.
        let mut rows: Vec<Vec<f32>> = Vec::with_capacity(6 * contacts.len());
        let mut reference = Vec::with_capacity(6 * contacts.len());
        for c in contacts {
            let rod = &rods[c.rod];
            let [n, t1, t2] = contact_frame(c.normal);
            let arm = c.point - rod.on_axis;
            // The ball's velocity relative to the man's surface point along `d`.
            let linear = |d: Vector| {
                let mut row = vec![0.0; dofs];
                row[0] = d.x;
                row[1] = d.y;
                row[2 + 2 * c.rod] = -d.dot(rod.axis);
                row[3 + 2 * c.rod] = -rod.axis.dot(arm.cross(d));
                row
            };
            // The ball's spin relative to the man's about `n` (the ball cannot turn).
            let mut spin = vec![0.0; dofs];
            spin[3 + 2 * c.rod] = -rod.axis.dot(n);
            let normal = linear(n);
            for (tangent, mu) in [
                (linear(t1), self.friction),
                (linear(t2), self.friction),
                (spin, self.torsional_friction),
            ] {
                for sign in [1.0, -1.0] {
                    let edge: Vec<f32> = normal
                        .iter()
                        .zip(&tangent)
                        .map(|(a, b)| a + sign * mu * b)
                        .collect();
                    reference.push(
                        self.law
                            .reference_acceleration(c.dist, dot(&edge, &vel), dt),
                    );
                    rows.push(edge);
                }
            }
        }

        // A + R and the dual's linear term.
        let m = rows.len();
        let d = f64::from(self.law.impedance);
        let mut h = vec![0.0_f64; m * m];
        for i in 0..m {
            for j in 0..m {
                h[i * m + j] = rows[i]
                    .iter()
                    .zip(&rows[j])
                    .zip(&inv_mass)
                    .map(|((a, b), w)| f64::from(a * b * w))
                    .sum();
            }
            h[i * m + i] *= 1.0 + (1.0 - d) / d;
        }
        let linear: Vec<f64> = rows
            .iter()
            .zip(&reference)
            .map(|(r, aref)| f64::from(dot(r, &free) - aref))
            .collect();
        let f = nonnegative_qp(&h, &linear);

        let mut generalised = vec![0.0_f32; dofs];
        for (row, fi) in rows.iter().zip(&f) {
            for (g, r) in generalised.iter_mut().zip(row) {
                *g += r * *fi as f32;
            }
        }
        ContactForces {
            ball: [generalised[0], generalised[1]],
            rods: (0..rods.len())
                .map(|k| [generalised[2 + 2 * k], generalised[3 + 2 * k]])
                .collect(),
        }
    }
}

/// `argmin_{f >= 0} 1/2 f' H f + c' f` for a symmetric positive definite `H` (row-major,
/// `c.len()` square): Lawson and Hanson's active-set method. Each outer step frees the
/// variable whose gradient is most negative; each inner step solves the free variables'
/// system and, where that would make some negative, moves only as far as the first one
/// reaching zero and fixes it there. Finite, exact up to rounding.
fn nonnegative_qp(h: &[f64], c: &[f64]) -> Vec<f64> {
    let m = c.len();
    let mut f = vec![0.0; m];
    let mut free = vec![false; m];
    for _ in 0..3 * m + 3 {
        let gradient = |f: &[f64], i: usize| -> f64 {
            (0..m).map(|j| h[i * m + j] * f[j]).sum::<f64>() + c[i]
        };
        let scale = c.iter().fold(1e-30_f64, |a, v| a.max(v.abs()));
        let entering = (0..m)
            .filter(|&i| !free[i])
            .map(|i| (i, gradient(&f, i)))
            .filter(|&(_, g)| g < -1e-12 * scale)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let Some((i, _)) = entering else {
            break;
        };
        free[i] = true;
        loop {
            let chosen: Vec<usize> = (0..m).filter(|&i| free[i]).collect();
            let z = solve_free(h, c, &chosen);
            if z.iter().all(|&v| v > 0.0) {
                for (&i, &v) in chosen.iter().zip(&z) {
                    f[i] = v;
                }
                break;
            }
            // Step from f towards z until the first free variable reaches zero.
            let (mut step, mut blocking) = (1.0_f64, chosen[0]);
            for (&i, &v) in chosen.iter().zip(&z) {
                if v <= 0.0 {
                    let t = f[i] / (f[i] - v);
                    if t < step {
                        (step, blocking) = (t, i);
                    }
                }
            }
            for (&i, &v) in chosen.iter().zip(&z) {
                f[i] += step * (v - f[i]);
            }
            f[blocking] = 0.0;
            free[blocking] = false;
            for &i in &chosen {
                if f[i] <= 0.0 {
                    f[i] = 0.0;
                    free[i] = false;
                }
            }
        }
    }
    f
}

/// The free variables' solution of `H_FF z = -c_F` (Cholesky; `H` positive definite).
fn solve_free(h: &[f64], c: &[f64], chosen: &[usize]) -> Vec<f64> {
    let m = c.len();
    let k = chosen.len();
    let mut l = vec![0.0_f64; k * k];
    for a in 0..k {
        for b in 0..=a {
            let mut sum = h[chosen[a] * m + chosen[b]];
            for j in 0..b {
                sum -= l[a * k + j] * l[b * k + j];
            }
            l[a * k + b] = if a == b {
                sum.max(1e-300).sqrt()
            } else {
                sum / l[b * k + b]
            };
        }
    }
    let mut y: Vec<f64> = chosen.iter().map(|&i| -c[i]).collect();
    for a in 0..k {
        for j in 0..a {
            y[a] -= l[a * k + j] * y[j];
        }
        y[a] /= l[a * k + a];
    }
    for a in (0..k).rev() {
        for j in a + 1..k {
            y[a] -= l[j * k + a] * y[j];
        }
        y[a] /= l[a * k + a];
    }
    y
}

fn dot(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// MuJoCo's contact frame for a normal (`mju_makeFrame`): the first tangent is world y
/// (or z, where the normal is within 60° of y) made orthogonal to the normal, the second
/// their cross product.
fn contact_frame(normal: Vector) -> [Vector; 3] {
    let n = normal.normalize();
    let seed = if n.y.abs() < 0.5 {
        Vector::Y
    } else {
        Vector::Z
    };
    let t1 = (seed - n * n.dot(seed)).normalize();
    [n, t1, n.cross(t1)]
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f32 = 0.002;

    fn rod(vel: [f32; 2]) -> RodDofs {
        RodDofs {
            axis: Vector::X,
            on_axis: Vector::new(0.0, -7.5, 7.75),
            slide_mass: 1.586,
            turn_inertia: 3.35,
            vel,
            free_acc: [0.0, 0.0],
        }
    }

    fn ball(vel: [f32; 2]) -> BallDofs {
        BallDofs {
            mass: 0.1,
            vel,
            free_acc: [0.0, 0.0],
        }
    }

    /// The ball's velocity after the step under `forces`.
    fn ball_after(b: &BallDofs, forces: &ContactForces) -> [f32; 2] {
        core::array::from_fn(|i| b.vel[i] + DT * (b.free_acc[i] + forces.ball[i] / b.mass))
    }

    /// The velocity after the step of the man's surface at `point` (cm/s, world).
    fn man_after(r: &RodDofs, forces: &ContactForces, point: Vector) -> Vector {
        let slide = r.vel[0] + DT * (r.free_acc[0] + forces.rods[0][0] / r.slide_mass);
        let turn = r.vel[1] + DT * (r.free_acc[1] + forces.rods[0][1] / r.turn_inertia);
        r.axis * slide + r.axis.cross(point - r.on_axis) * turn
    }

    /// A contact on the front of a man's shin, 2 cm ahead of the axis and 6 cm below it.
    fn shin(dist: f32) -> ManContact {
        ManContact {
            rod: 0,
            point: Vector::new(0.0, -5.5, 1.73),
            normal: Vector::Y,
            dist,
        }
    }

    #[test]
    fn a_ball_driven_into_a_man_stops_closing_in_one_step() {
        // MuJoCo's contact is critically damped at T = 2 dt (b dt = 1.01): after one step
        // the ball and the man's surface no longer close. Without friction they part at
        // the penetration's push-out, d k d r dt = 12.5 cm/s per mm, and 1 % of the
        // closing speed: no rebound. With the reference's friction in a pyramidal cone
        // they may part faster (a slipping edge pushes along the normal too: the
        // pyramid's known artefact, which the reference has). The man, 0.09 kg at the
        // contact through its turn, is swung back.
        let b = ball([0.0, -200.0]);
        let r = rod([0.0, 0.0]);
        let c = shin(-0.1);
        let frictionless = SoftContact {
            friction: 0.0,
            torsional_friction: 0.0,
            ..SoftContact::REFERENCE
        };
        for (law, parting_at_most) in [(frictionless, 16.0), (SoftContact::REFERENCE, 100.0)] {
            let forces = law.solve(&b, &[r], &[c], DT);
            let [vx, vy] = ball_after(&b, &forces);
            let man = man_after(&r, &forces, c.point);
            let parting = vy - man.y;
            assert!(parting > 12.0 && parting < parting_at_most, "{parting}");
            assert!(vx.abs() < 1e-3, "{vx}");
            assert!(vy < -50.0 && man.y < -50.0, "{vy} {man:?}");
        }
    }

    #[test]
    fn separating_bodies_exert_nothing() {
        let b = ball([0.0, 300.0]);
        let forces = SoftContact::REFERENCE.solve(&b, &[rod([0.0, 0.0])], &[shin(-0.01)], DT);
        assert_eq!(forces.ball, [0.0, 0.0]);
        assert_eq!(forces.rods, vec![[0.0, 0.0]]);
    }

    #[test]
    fn friction_carries_the_ball_or_slips_at_the_cone() {
        // A man sliding along x while pressing the ball level with the axis (so that the
        // push does not turn it): slowly, the ball is carried at the man's speed; fast, it
        // slips, pushed sideways by mu times the normal force.
        let b = ball([0.0, 0.0]);
        let c = ManContact {
            point: Vector::new(0.0, -5.5, 7.75),
            ..shin(-0.2)
        };
        let slow = rod([5.0, 0.0]);
        let carried = SoftContact::REFERENCE.solve(&b, &[slow], &[c], DT);
        let [vx, _] = ball_after(&b, &carried);
        let man = man_after(&slow, &carried, c.point);
        assert!((vx - man.x).abs() < 0.05 * man.x, "{vx} {man:?}");
        for mu in [1.0, 0.05] {
            let law = SoftContact {
                friction: mu,
                ..SoftContact::REFERENCE
            };
            let fast = law.solve(&b, &[rod([150.0, 0.0])], &[c], DT);
            let [fx, fy] = fast.ball;
            assert!(fy > 0.0, "{fy}");
            assert!((fx - mu * fy).abs() < 1e-3 * fy, "mu {mu}: {fx} {fy}");
        }
    }

    #[test]
    fn a_man_pressing_down_on_the_ball_is_held() {
        // A foot behind the axis swinging down onto the ball's top: the ball cannot move
        // vertically, so the turn is what stops (MuJoCo's man holds there; a ball free in
        // z would be pushed down instead).
        let b = ball([0.0, 0.0]);
        let r = rod([0.0, 100.0]);
        let point = Vector::new(0.0, -9.0, 3.47);
        let surface_vel = r.axis.cross(point - r.on_axis) * r.vel[1];
        assert!(surface_vel.z < -100.0, "{surface_vel:?}");
        let c = ManContact {
            rod: 0,
            point,
            normal: -Vector::Z,
            dist: -0.02,
        };
        let forces = SoftContact::REFERENCE.solve(&b, &[r], &[c], DT);
        let turn_after = r.vel[1] + DT * forces.rods[0][1] / r.turn_inertia;
        assert!(turn_after.abs() < 3.0, "{turn_after}");
    }

    #[test]
    fn the_frame_is_orthonormal_and_mujocos() {
        for n in [Vector::Y, Vector::X, Vector::new(0.683, -0.724, 0.098)] {
            let [a, b, c] = contact_frame(n);
            for (u, v) in [(a, b), (a, c), (b, c)] {
                assert!(u.dot(v).abs() < 1e-6);
            }
            assert!((a.cross(b) - c).length() < 1e-6);
        }
        assert_eq!(contact_frame(Vector::X)[1], Vector::Y);
    }
}
