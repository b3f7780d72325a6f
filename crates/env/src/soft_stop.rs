//! A stop on one joint coordinate as MuJoCo's soft constraints make it: the rods' rubber
//! bumpers meeting the side walls in the reference model.
//!
//! MuJoCo does not forbid penetration: an active constraint pulls the acceleration along
//! its normal towards a reference acceleration, `a_ref = -b v_n - k d r` (`r` the signed
//! distance, negative inside; `v_n` its rate), with `b = 2 / (d_max T)` and
//! `k = 1 / (d_max² T² ζ²)` from `solref = (T, ζ)` and the impedance `d` of `solimp`. For
//! one degree of freedom the solved acceleration is `(1 - d) a_free + d a_ref` whenever
//! that pushes out harder than `a_free` (a contact only pushes). It is computed from the
//! state at the start of the step, as every force of MuJoCo's Euler integrator.

/// A soft stop's constants (MuJoCo's `solref` and a constant `solimp`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoftStop {
    /// Time constant `T` of `solref`, s (raised to `2 dt` at least, as MuJoCo does).
    pub timeconst: f32,
    /// Damping ratio `ζ` of `solref`.
    pub dampratio: f32,
    /// Impedance `d` (the reference's `solimp` is 0.99 at every depth).
    pub impedance: f32,
}

impl SoftStop {
    /// The reference model's contacts: `solref = "0.004 1"`, `solimp = ".99 .99 .00001"`.
    pub const REFERENCE: SoftStop = SoftStop {
        timeconst: 0.004,
        dampratio: 1.0,
        impedance: 0.99,
    };

    /// MuJoCo's reference acceleration along a constraint's normal, `-b v_n - k d r`, at
    /// signed distance `dist` (negative inside) closing at `normal_vel` (its rate, positive
    /// separating), for a step of `dt` seconds.
    pub fn reference_acceleration(&self, dist: f32, normal_vel: f32, dt: f32) -> f32 {
        let t = self.timeconst.max(2.0 * dt);
        let d = self.impedance;
        let b = 2.0 / (d * t);
        let k = 1.0 / (d * d * t * t * self.dampratio * self.dampratio);
        -b * normal_vel - k * d * dist
    }

    /// The acceleration (units of `q` per s²) the stops at `[low, high]` add to a coordinate
    /// at `q` moving at `qdot` whose other forces accelerate it at `free_acc`, for a step
    /// of `dt` seconds; 0 between the stops.
    pub fn acceleration(
        &self,
        [low, high]: [f32; 2],
        q: f32,
        qdot: f32,
        free_acc: f32,
        dt: f32,
    ) -> f32 {
        // Normal pointing back inside, distance negative past the stop.
        let (normal, dist) = if q > high {
            (-1.0, high - q)
        } else if q < low {
            (1.0, q - low)
        } else {
            return 0.0;
        };
        let free_n = normal * free_acc;
        let reference = self.reference_acceleration(dist, normal * qdot, dt);
        let d = self.impedance;
        if reference <= free_n {
            return 0.0; // the other forces already push it out
        }
        normal * d * (reference - free_n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f32 = 0.002;

    #[test]
    fn nothing_between_the_stops_or_when_already_leaving_fast() {
        let s = SoftStop::REFERENCE;
        assert_eq!(s.acceleration([-1.0, 1.0], 0.5, 100.0, 10.0, DT), 0.0);
        // Past the high stop but flung back faster than the stop would push.
        assert_eq!(s.acceleration([-1.0, 1.0], 1.01, -10.0, -1e7, DT), 0.0);
    }

    #[test]
    fn pushes_back_symmetrically_on_both_sides() {
        let s = SoftStop::REFERENCE;
        let hi = s.acceleration([-1.0, 1.0], 1.05, 20.0, 300.0, DT);
        let lo = s.acceleration([-1.0, 1.0], -1.05, -20.0, -300.0, DT);
        assert!(hi < 0.0);
        assert!((hi + lo).abs() < 1e-2 * hi.abs());
    }

    #[test]
    fn the_goalie_bumper_step_of_the_reference_model() {
        // The reference's goalie at 8.7825 cm moving at 148.855 cm/s towards a bumper met at
        // 8.692, its servo pulling to 10 cm (kp 20000, kv 300, 1.52268 kg): MuJoCo's next
        // velocity is -12.177 cm/s (step_response.json, "goalie slide +0.5", step 13 to 14);
        // ours within 1 cm/s (the stop is fitted to the whole trace, not to this step).
        let (q, v, m) = (8.7825_f32, 148.855_f32, 1.52268_f32);
        let free = (20_000.0 * (10.0 - q) - 300.0 * v) / m;
        let a = free + SoftStop::REFERENCE.acceleration([-8.692, 8.692], q, v, free, DT);
        let next = v + DT * a;
        assert!((next - -12.177).abs() < 1.0, "{next}");
    }
}
