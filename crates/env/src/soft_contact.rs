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
//! regularisation `R_e` ([`Regularisation`]: `(1 - d) / d A_ee`, or MuJoCo's own rule),
//! and the forces solve MuJoCo's dual problem
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
    /// MuJoCo's `body_invweight0` of the touched man, translational, 1/kg
    /// ([`Regularisation::MujocoPyramid`]).
    pub inv_weight: f32,
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
    /// MuJoCo's `body_invweight0`, translational, 1/kg (its inverse mass).
    pub inv_weight: f32,
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

/// How each cone edge's regularisation `R_e` is set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Regularisation {
    /// `R_e = (1 - d) / d A_ee` from each edge's exact `A_ee = J_e M^-1 J_e'` (the fourth
    /// `reference`'s, kept for its committed runs).
    EdgeDiagonal,
    /// MuJoCo's (`mj_diagApprox`, `mj_makeImpedance`, `impratio` 1): one `R` for all six
    /// edges of a contact, `2 mu² (1 + mu²) (1 - d) / d (w_ball + w_man)` with `mu` the
    /// sliding friction and `w` the bodies' `body_invweight0`. It does not grow and
    /// shrink with each edge's row: an edge whose row nearly vanishes (the normal and a
    /// tangent nearly cancelling) stays as soft as the others, where `EdgeDiagonal`
    /// makes it almost hard and its force unbounded.
    MujocoPyramid,
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
    /// How each edge is regularised.
    pub regularisation: Regularisation,
}

impl SoftContact {
    /// The reference model's ball-man contacts: the default `solref = "0.004 1"`,
    /// `solimp = ".99 .99 .00001"`, `condim = 4`, and the larger of the two geoms'
    /// frictions (MuJoCo's rule): the men's default sliding 1, the ball's torsional 0.1.
    pub const REFERENCE: SoftContact = SoftContact {
        law: SoftStop::REFERENCE,
        friction: 1.0,
        torsional_friction: 0.1,
        regularisation: Regularisation::EdgeDiagonal,
    };

    /// The contact forces of a step of `dt` seconds.
    pub fn solve(
        &self,
        ball: &BallDofs,
        rods: &[RodDofs],
        contacts: &[ManContact],
        dt: f32,
    ) -> ContactForces {
        let problem = self.problem(ball, rods, contacts, dt);
        let generalised = if problem.rows.len() <= DUAL_ROWS_MAX {
            problem.dual()
        } else {
            problem.primal()
        };
        ContactForces {
            ball: [generalised[0], generalised[1]],
            rods: (0..rods.len())
                .map(|k| [generalised[2 + 2 * k], generalised[3 + 2 * k]])
                .collect(),
        }
    }

    /// The step's constraint rows: six cone edges per contact.
    fn problem(
        &self,
        ball: &BallDofs,
        rods: &[RodDofs],
        contacts: &[ManContact],
        dt: f32,
    ) -> Problem {
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

        let d = f64::from(self.law.impedance);
        let ratio = (1.0 - d) / d;
        let regularisation = match self.regularisation {
            Regularisation::EdgeDiagonal => EdgeRegularisation::OfDiagonal(ratio),
            Regularisation::MujocoPyramid => {
                let mu2 = f64::from(self.friction * self.friction).max(1e-12);
                EdgeRegularisation::Given(
                    contacts
                        .iter()
                        .flat_map(|c| {
                            let weight = f64::from(ball.inv_weight + rods[c.rod].inv_weight);
                            [2.0 * mu2 * (1.0 + mu2) * ratio * weight; 6]
                        })
                        .collect(),
                )
            }
        };
        Problem {
            inv_mass,
            free,
            rows,
            reference,
            regularisation,
        }
    }
}

/// Above this many constraint rows (four contacts' cones: the exact single contacts of
/// [`crate::config::ManContacts::MujocoSoft`]) the forces are found by the primal
/// Newton method, below it by the dual's active set: the same optimum (unique), the dual's
/// cost growing as rows cubed and more, the primal's as rows times degrees of freedom
/// squared (a patch of MuJoCo's SDF search has up to 240 rows per man).
const DUAL_ROWS_MAX: usize = 24;

/// One step's soft contact problem: `M^-1` (diagonal), the accelerations `a_0` of the
/// other forces, the cone edges' rows `J_e` and reference accelerations, and their
/// regularisation.
struct Problem {
    inv_mass: Vec<f32>,
    free: Vec<f32>,
    rows: Vec<Vec<f32>>,
    reference: Vec<f32>,
    regularisation: EdgeRegularisation,
}

/// Each edge's `R_e`: `(1 - d) / d` times its `A_ee`, or given.
enum EdgeRegularisation {
    OfDiagonal(f64),
    Given(Vec<f64>),
}

impl Problem {
    /// The generalised contact forces `J' f` from MuJoCo's dual problem, solved by the
    /// active-set method ([`nonnegative_qp`]) in f64 on the f32 problem.
    fn dual(&self) -> Vec<f32> {
        let m = self.rows.len();
        let mut h = vec![0.0_f64; m * m];
        for i in 0..m {
            for j in 0..m {
                h[i * m + j] = self.rows[i]
                    .iter()
                    .zip(&self.rows[j])
                    .zip(&self.inv_mass)
                    .map(|((a, b), w)| f64::from(a * b * w))
                    .sum();
            }
            match &self.regularisation {
                EdgeRegularisation::OfDiagonal(ratio) => h[i * m + i] *= 1.0 + ratio,
                EdgeRegularisation::Given(r) => h[i * m + i] += r[i],
            }
        }
        let linear: Vec<f64> = self
            .rows
            .iter()
            .zip(&self.reference)
            .map(|(r, aref)| f64::from(dot(r, &self.free) - aref))
            .collect();
        let f = nonnegative_qp(&h, &linear);
        let mut generalised = vec![0.0_f32; self.free.len()];
        for (row, fi) in self.rows.iter().zip(&f) {
            for (g, r) in generalised.iter_mut().zip(row) {
                *g += r * *fi as f32;
            }
        }
        generalised
    }

    /// The generalised contact forces `M (a - a_0)` from the primal problem, as MuJoCo's
    /// Newton solver poses it: the accelerations `a` minimising
    ///
    /// ```text
    /// 1/2 (a - a_0)' M (a - a_0) + sum_e [J_e a < a_ref,e] (J_e a - a_ref,e)² / (2 R_e)
    /// ```
    ///
    /// (each edge's force `f_e = max(0, -(J_e a - a_ref,e) / R_e)`: the dual's optimum).
    /// Newton steps on the active edges' quadratic, each followed by an exact line search
    /// along the piecewise-quadratic cost; finite for a convex piecewise quadratic.
    fn primal(&self) -> Vec<f32> {
        let wide = |v: &[f32]| -> Vec<f64> { v.iter().map(|&x| f64::from(x)).collect() };
        let n = self.free.len();
        let free = wide(&self.free);
        let rows: Vec<Vec<f64>> = self.rows.iter().map(|r| wide(r)).collect();
        let mass: Vec<f64> = self.inv_mass.iter().map(|&w| 1.0 / f64::from(w)).collect();
        let product = |row: &[f64], v: &[f64]| row.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
        // 1 / R_e (for `OfDiagonal`, R_e = (1 - d) / d A_ee, A_ee = J_e M^-1 J_e').
        let weight: Vec<f64> = rows
            .iter()
            .enumerate()
            .map(|(e, r)| {
                let regularisation = match &self.regularisation {
                    EdgeRegularisation::OfDiagonal(ratio) => {
                        ratio * r.iter().zip(&mass).map(|(j, m)| j * j / m).sum::<f64>()
                    }
                    EdgeRegularisation::Given(given) => given[e],
                };
                1.0 / regularisation.max(1e-300)
            })
            .collect();
        let reference = wide(&self.reference);
        let all: Vec<usize> = (0..n).collect();
        let mut a = free.clone();
        for _ in 0..100 {
            let residual: Vec<f64> = rows
                .iter()
                .zip(&reference)
                .map(|(r, aref)| product(r, &a) - aref)
                .collect();
            let mut gradient: Vec<f64> = (0..n).map(|k| mass[k] * (a[k] - free[k])).collect();
            let mut hessian = vec![0.0; n * n];
            for k in 0..n {
                hessian[k * n + k] = mass[k];
            }
            for (e, row) in rows.iter().enumerate() {
                if residual[e] < 0.0 {
                    for i in 0..n {
                        gradient[i] += weight[e] * residual[e] * row[i];
                        for j in 0..n {
                            hessian[i * n + j] += weight[e] * row[i] * row[j];
                        }
                    }
                }
            }
            let step = solve_free(&hessian, &gradient, &all);
            let slopes: Vec<f64> = rows.iter().map(|r| product(r, &step)).collect();
            let curvature: f64 = (0..n).map(|k| mass[k] * step[k] * step[k]).sum();
            let scale: f64 = (0..n).map(|k| mass[k] * a[k] * a[k]).sum();
            if curvature <= 1e-24 * (1.0 + scale) {
                break;
            }
            let t = exact_line_search(
                (0..n).map(|k| mass[k] * (a[k] - free[k]) * step[k]).sum(),
                curvature,
                &residual,
                &slopes,
                &weight,
            );
            for k in 0..n {
                a[k] += t * step[k];
            }
        }
        (0..n)
            .map(|k| (mass[k] * (a[k] - free[k])) as f32)
            .collect()
    }
}

/// The minimiser `t >= 0` of `phi(t) = start t + curvature t² / 2 + sum_e weight_e
/// min(r_e + t q_e, 0)² / 2` (convex; its slope piecewise linear and increasing), walked
/// from breakpoint to breakpoint.
fn exact_line_search(
    start: f64,
    curvature: f64,
    residual: &[f64],
    slopes: &[f64],
    weight: &[f64],
) -> f64 {
    // An edge with r >= 0 and q >= 0 is never active for t >= 0 and has no crossing
    // after 0: left out of the walk, which then adds the same terms in the same order.
    let live = || {
        (0..residual.len())
            .map(|e| (residual[e], slopes[e], weight[e]))
            .filter(|&(r, q, _)| !(r >= 0.0 && q >= 0.0))
    };
    let mut t = 0.0_f64;
    loop {
        // The edges active just after t, and phi'(s) = c0 + c1 s on that segment.
        let (mut c0, mut c1, mut next) = (start, curvature, f64::INFINITY);
        for (r, q, w) in live() {
            let at = r + t * q;
            if at < 0.0 || (at == 0.0 && q < 0.0) {
                c0 += w * r * q;
                c1 += w * q * q;
            }
            if q != 0.0 {
                let crossing = -r / q;
                if crossing > t && crossing < next {
                    next = crossing;
                }
            }
        }
        let root = -c0 / c1;
        if root <= next || !next.is_finite() {
            return root.max(t);
        }
        t = next;
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
            inv_weight: 0.367,
        }
    }

    fn ball(vel: [f32; 2]) -> BallDofs {
        BallDofs {
            mass: 0.1,
            vel,
            free_acc: [0.0, 0.0],
            inv_weight: 10.0,
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
    fn the_primal_and_the_dual_find_the_same_forces() {
        // Patches of 1 to 12 contacts spread over a man's shin and sole, the ball and the
        // rod moving every way: the primal Newton method and the dual active set agree.
        let mut seed = 12345_u64;
        let mut uniform = move |lo: f32, hi: f32| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((seed >> 40) as f32 / (1u64 << 24) as f32)
        };
        for case in 0..40 {
            let b = BallDofs {
                free_acc: [uniform(-500.0, 500.0), uniform(-500.0, 500.0)],
                ..ball([uniform(-300.0, 300.0), uniform(-300.0, 300.0)])
            };
            let r = RodDofs {
                free_acc: [uniform(-3e3, 3e3), uniform(-300.0, 300.0)],
                ..rod([uniform(-100.0, 100.0), uniform(-40.0, 40.0)])
            };
            let contacts: Vec<ManContact> = (0..1 + case % 12)
                .map(|_| {
                    let normal =
                        Vector::new(uniform(-0.3, 0.3), uniform(0.5, 1.0), uniform(-0.5, 0.5));
                    ManContact {
                        rod: 0,
                        point: Vector::new(uniform(-1.0, 1.0), -5.5, uniform(1.0, 3.0)),
                        normal: normal.normalize(),
                        dist: uniform(-0.2, 0.0),
                    }
                })
                .collect();
            let problem = SoftContact::REFERENCE.problem(&b, &[r], &contacts, DT);
            let (dual, primal) = (problem.dual(), problem.primal());
            let scale = dual.iter().fold(1.0_f32, |m, v| m.max(v.abs()));
            for (d, p) in dual.iter().zip(&primal) {
                assert!(
                    (d - p).abs() < 1e-4 * scale,
                    "case {case}: {dual:?} {primal:?}"
                );
            }
        }
    }

    #[test]
    fn mujocos_regularisation_is_the_models() {
        // MuJoCo 3.3.2 on the reference model, the ball on yellow's centre midfielder:
        // every edge of a contact gets efc_R = 0.41887 (w_ball 10, w_man 0.366941).
        let law = SoftContact {
            regularisation: Regularisation::MujocoPyramid,
            ..SoftContact::REFERENCE
        };
        let problem = law.problem(&ball([0.0, -200.0]), &[rod([0.0, 0.0])], &[shin(-0.1)], DT);
        let EdgeRegularisation::Given(r) = &problem.regularisation else {
            panic!("MuJoCo's regularisation is given per edge");
        };
        assert_eq!(r.len(), 6);
        for v in r {
            assert!((v - 0.41887).abs() < 1e-4, "{r:?}");
        }
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
