//! Where each quantity sits in the observation and action vectors: the one table of indices.
//!
//! Observation (38 × f32; the reference code's order; rods ordered yellow goalie, defence,
//! midfield, attack, then black goalie, defence, midfield, attack):
//!
//! | indices | quantity | unit |
//! | --- | --- | --- |
//! | 0..3   | ball position x, y, z            | cm    |
//! | 3..6   | ball velocity x, y, z            | cm/s  |
//! | 6..14  | rod slide positions (8 rods)     | cm    |
//! | 14..22 | rod slide velocities             | cm/s  |
//! | 22..30 | rod angles                       | rad   |
//! | 30..38 | rod angular velocities           | rad/s |
//!
//! Rod coordinates are each rod's own joint coordinates: slide along the rod's axis, angle
//! about it, zero at neutral (men hanging straight down). Black's rods are yellow's turned
//! 180° about z, so a positive slide moves a black rod towards world -x and a positive
//! turn swings every rod's feet towards the goal that team attacks.
//!
//! Action (8 × f32 in [-1, 1]): for yellow's goalie, defence, midfield, attack in turn,
//! `[slide, turn]`, each mapped linearly onto the joint's control range
//! ([`crate::geometry::RodSpec::slide_range`], [`crate::geometry::RodSpec::turn_range`]).

use core::ops::Range;

/// Length of the observation vector.
pub const OBS_DIM: usize = 38;
/// Length of the action vector (one team's 4 rods × slide, turn).
pub const ACTION_DIM: usize = 8;

/// Ball position x, y, z (cm).
pub const BALL_POS: Range<usize> = 0..3;
/// Ball velocity x, y, z (cm/s).
pub const BALL_VEL: Range<usize> = 3..6;
/// Rod slide positions (cm), 8 rods.
pub const ROD_SLIDE: Range<usize> = 6..14;
/// Rod slide velocities (cm/s), 8 rods.
pub const ROD_SLIDE_VEL: Range<usize> = 14..22;
/// Rod angles (rad), 8 rods.
pub const ROD_ANGLE: Range<usize> = 22..30;
/// Rod angular velocities (rad/s), 8 rods.
pub const ROD_ANGLE_VEL: Range<usize> = 30..38;

/// Index of rod `rod`'s slide command in an action vector.
pub const fn action_slide(rod: usize) -> usize {
    2 * rod
}

/// Index of rod `rod`'s turn command in an action vector.
pub const fn action_turn(rod: usize) -> usize {
    2 * rod + 1
}

/// Indices of black's 16 rod values in the observation (slides, slide velocities, angles,
/// angular velocities of black's four rods), ascending.
pub fn black_rod_inputs() -> impl Iterator<Item = usize> {
    [ROD_SLIDE, ROD_SLIDE_VEL, ROD_ANGLE, ROD_ANGLE_VEL]
        .into_iter()
        .flat_map(|r| r.start + 4..r.end)
}

/// The observation as black sees it: the table turned 180° about z (x -> -x, y -> -y for
/// the ball) and the two teams' rod blocks swapped, so black's rods come first. Rod
/// coordinates are already in each rod's own frame and stay as they are. A policy trained
/// as yellow plays black through this view.
pub fn mirror_observation(obs: &[f32; OBS_DIM]) -> [f32; OBS_DIM] {
    let mut out = *obs;
    for r in [BALL_POS, BALL_VEL] {
        out[r.start] = -obs[r.start];
        out[r.start + 1] = -obs[r.start + 1];
    }
    for r in [ROD_SLIDE, ROD_SLIDE_VEL, ROD_ANGLE, ROD_ANGLE_VEL] {
        for i in 0..4 {
            out[r.start + i] = obs[r.start + 4 + i];
            out[r.start + 4 + i] = obs[r.start + i];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn black_rod_inputs_are_the_second_half_of_each_rod_group() {
        let inputs: Vec<usize> = black_rod_inputs().collect();
        assert_eq!(inputs.len(), 16);
        assert_eq!(&inputs[..4], &[10, 11, 12, 13]);
        assert_eq!(&inputs[12..], &[34, 35, 36, 37]);
        // Mirroring moves exactly these values into yellow's place.
        let obs: [f32; OBS_DIM] = std::array::from_fn(|i| i as f32);
        let mirrored = mirror_observation(&obs);
        for (k, i) in inputs.iter().enumerate() {
            assert_eq!(mirrored[i - 4], obs[*i], "input {k}");
        }
    }

    #[test]
    fn groups_tile_the_observation_without_gaps() {
        let groups = [
            BALL_POS,
            BALL_VEL,
            ROD_SLIDE,
            ROD_SLIDE_VEL,
            ROD_ANGLE,
            ROD_ANGLE_VEL,
        ];
        let mut next = 0;
        for g in groups {
            assert_eq!(g.start, next);
            next = g.end;
        }
        assert_eq!(next, OBS_DIM);
        assert_eq!(action_turn(3), ACTION_DIM - 1);
    }

    #[test]
    fn mirroring_twice_is_identity() {
        let obs: [f32; OBS_DIM] = core::array::from_fn(|i| i as f32 * 0.5 - 3.0);
        let m = mirror_observation(&obs);
        assert_eq!(m[0], -obs[0]);
        assert_eq!(m[2], obs[2]);
        assert_eq!(m[ROD_SLIDE.start], obs[ROD_SLIDE.start + 4]);
        assert_eq!(mirror_observation(&m), obs);
    }
}
