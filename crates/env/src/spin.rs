//! Spinning. ITSF rules forbid spinning a rod: turning a man more than 360 degrees before
//! or after striking the ball. [`SpinMeter`] counts it from the rods' unwrapped angles:
//! a rod spins when it turns further than the limit in one direction without turning
//! back; each further limit's worth of turning in that direction is another spin.

use crate::geometry::NUM_RODS;

/// Rotation of each rod in its current direction since it last turned back, rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpinMeter {
    angles: [f32; NUM_RODS],
    run: [f32; NUM_RODS],
}

impl SpinMeter {
    /// A meter starting from the rods' angles `angles` (rad, unwrapped).
    pub fn new(angles: &[f32]) -> Self {
        Self {
            angles: std::array::from_fn(|i| angles[i]),
            run: [0.0; NUM_RODS],
        }
    }

    /// Takes the rods' new angles (rad, unwrapped); returns, per rod, whether it completed
    /// a spin of more than `limit` rad in one direction on this step.
    pub fn update(&mut self, angles: &[f32], limit: f32) -> [bool; NUM_RODS] {
        std::array::from_fn(|i| {
            let d = angles[i] - self.angles[i];
            self.angles[i] = angles[i];
            let run = &mut self.run[i];
            *run = if *run * d < 0.0 { d } else { *run + d };
            if run.abs() > limit {
                *run -= limit.copysign(*run);
                true
            } else {
                false
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::TAU;

    fn turn(meter: &mut SpinMeter, from: f32, to: f32, steps: usize) -> usize {
        (1..=steps)
            .filter(|&k| {
                let a = from + (to - from) * k as f32 / steps as f32;
                meter.update(&[a; NUM_RODS], TAU)[0]
            })
            .count()
    }

    #[test]
    fn a_full_turn_and_more_in_one_direction_is_a_spin() {
        let mut m = SpinMeter::new(&[0.0; NUM_RODS]);
        assert_eq!(turn(&mut m, 0.0, 0.99 * TAU, 50), 0);
        assert_eq!(turn(&mut m, 0.99 * TAU, 1.01 * TAU, 2), 1);
        // Two more turns the same way: two more spins.
        assert_eq!(turn(&mut m, 1.01 * TAU, 3.02 * TAU, 100), 2);
    }

    #[test]
    fn swinging_back_and_forth_never_spins() {
        let mut m = SpinMeter::new(&[0.0; NUM_RODS]);
        for _ in 0..20 {
            assert_eq!(turn(&mut m, 0.0, 0.9 * TAU, 30), 0);
            assert_eq!(turn(&mut m, 0.9 * TAU, 0.0, 30), 0);
        }
        // Going on in the direction of the last swing back: 0.9 + 1.5 turns, two spins.
        assert_eq!(turn(&mut m, 0.0, -1.5 * TAU, 60), 2);
    }
}
