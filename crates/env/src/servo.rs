//! The rods' position servos: MuJoCo's `position` actuator, `force = kp (target - q) - kv q'`,
//! taken explicitly as MuJoCo's Euler integrator takes it ([`Servo::explicit_force`]), or
//! implicitly ([`Servo::implicit_force`], this project's first servo) so that the stiff
//! gains of the reference stay stable at any `physics_dt`.

/// A PD position servo on one joint coordinate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Servo {
    /// Stiffness: generalised force per unit of position error.
    pub kp: f32,
    /// Damping: generalised force per unit of velocity.
    pub kv: f32,
}

impl Servo {
    /// Generalised force (units as [`Servo::implicit_force`]) at position `q` moving at
    /// `qdot`: `kp (target - q) - kv qdot`, the actuator's force at the start of the step,
    /// as MuJoCo's Euler integrator applies it for the whole step.
    pub fn explicit_force(&self, target: f32, q: f32, qdot: f32) -> f32 {
        self.kp * (target - q) - self.kv * qdot
    }

    /// Generalised force (N·100 = kg cm/s² for slides, kg cm²/s² for turns) to apply for one
    /// physics step of `dt` seconds on a joint of generalised inertia `inertia` at position
    /// `q` moving at `qdot`.
    ///
    /// It is the force of the servo evaluated at the *end* of the step (backward Euler,
    /// "stable PD"): solving `v' = v + dt/m (kp (target - q - dt v') - kv v')` for `v'` and
    /// returning `m (v' - v) / dt`. As `dt -> 0` it tends to the explicit law
    /// `kp (target - q) - kv qdot`; unlike it, it never overshoots into instability when
    /// `dt * sqrt(kp / m)` is large.
    pub fn implicit_force(&self, target: f32, q: f32, qdot: f32, inertia: f32, dt: f32) -> f32 {
        let explicit = self.kp * (target - q - dt * qdot) - self.kv * qdot;
        explicit / (1.0 + dt * self.kv / inertia + dt * dt * self.kp / inertia)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Integrate a unit-mass servo with semi-implicit Euler, as the physics engine does.
    fn settle(servo: Servo, inertia: f32, dt: f32, steps: usize) -> (f32, f32) {
        let (mut q, mut v) = (0.0_f32, 0.0_f32);
        for _ in 0..steps {
            let f = servo.implicit_force(1.0, q, v, inertia, dt);
            v += dt * f / inertia;
            q += dt * v;
        }
        (q, v)
    }

    #[test]
    fn tends_to_the_explicit_law_for_small_steps() {
        let s = Servo {
            kp: 100.0,
            kv: 10.0,
        };
        let f = s.implicit_force(2.0, 0.5, 0.3, 1.0, 1e-7);
        assert!((f - s.explicit_force(2.0, 0.5, 0.3)).abs() < 1e-3);
        assert_eq!(s.explicit_force(2.0, 0.5, 0.3), 100.0 * 1.5 - 10.0 * 0.3);
    }

    #[test]
    fn stays_stable_where_the_explicit_law_diverges() {
        // The midfield turn servo on a light rod: dt * sqrt(kp / I) = 10, far past the
        // explicit limit of 2.
        let s = Servo {
            kp: 150_000.0,
            kv: 2_000.0,
        };
        let (q, v) = settle(s, 0.06, 0.002, 500);
        assert!((q - 1.0).abs() < 1e-3, "q = {q}");
        assert!(v.abs() < 1e-2, "v = {v}");
    }

    #[test]
    fn reaches_the_target_with_the_reference_gains() {
        // Goalie slide servo on its 1.52 kg rod, 2 ms steps: within 2 % by 60 ms.
        let s = Servo {
            kp: 20_000.0,
            kv: 300.0,
        };
        let (q, _) = settle(s, 1.52, 0.002, 30);
        assert!((q - 1.0).abs() < 0.02, "q = {q}");
    }
}
