//! Who plays black. An [`Opponent`] sees the table from black's side
//! ([`crate::layout::mirror_observation`]) and answers with an action in black's own
//! frame, so a policy trained as yellow can be plugged in unchanged (self-play).

use rand::Rng;

use crate::EnvRng;
use crate::config::OpponentKind;
use crate::geometry::RODS;
use crate::layout::{ACTION_DIM, BALL_POS, OBS_DIM, action_slide, action_turn};

/// A controller for black's four rods.
pub trait Opponent: Send {
    /// Black's action (8 values in [-1, 1], layout as yellow's) for black's view `obs`.
    /// `rng` is the environment's own stream, so random opponents stay reproducible.
    fn act(&mut self, obs: &[f32; OBS_DIM], rng: &mut EnvRng) -> [f32; ACTION_DIM];

    /// Called at every environment reset.
    fn reset(&mut self) {}
}

/// Holds every rod at neutral: feet down, centred (the paper's opponent).
#[derive(Debug, Clone, Copy, Default)]
pub struct StaticOpponent;

impl Opponent for StaticOpponent {
    fn act(&mut self, _obs: &[f32; OBS_DIM], _rng: &mut EnvRng) -> [f32; ACTION_DIM] {
        [0.0; ACTION_DIM]
    }
}

/// Draws every command uniformly from [-1, 1] each step.
#[derive(Debug, Clone, Copy, Default)]
pub struct RandomOpponent;

impl Opponent for RandomOpponent {
    fn act(&mut self, _obs: &[f32; OBS_DIM], rng: &mut EnvRng) -> [f32; ACTION_DIM] {
        core::array::from_fn(|_| rng.random_range(-1.0..=1.0))
    }
}

/// Keeps every foot down and slides each rod so that the man best placed to reach the
/// ball's x stands in its path: a goalkeeper-style blocker.
#[derive(Debug, Clone, Copy, Default)]
pub struct ScriptedOpponent;

impl ScriptedOpponent {
    /// Slide command in [-1, 1] that puts a man of `rod` (0..4) at `ball_x` (cm, in the
    /// rod's own frame), or as near as the rod's range allows.
    pub fn tracking_slide(rod: usize, ball_x: f32) -> f32 {
        let spec = &RODS[rod];
        let r = spec.slide_range;
        let best = spec
            .men_x
            .iter()
            .map(|&m| (ball_x - m).clamp(-r, r))
            .min_by(|a, b| {
                let miss = |s: f32| {
                    (spec.men_x.iter().map(|&m| (m + s - ball_x).abs()))
                        .fold(f32::INFINITY, f32::min)
                };
                miss(*a)
                    .total_cmp(&miss(*b))
                    .then(a.abs().total_cmp(&b.abs()))
            })
            .unwrap_or(0.0);
        best / r
    }
}

impl Opponent for ScriptedOpponent {
    fn act(&mut self, obs: &[f32; OBS_DIM], _rng: &mut EnvRng) -> [f32; ACTION_DIM] {
        let mut action = [0.0; ACTION_DIM];
        for rod in 0..4 {
            action[action_slide(rod)] = Self::tracking_slide(rod, obs[BALL_POS.start]);
            action[action_turn(rod)] = 0.0;
        }
        action
    }
}

/// The built-in opponent of a kind.
pub fn opponent_for(kind: OpponentKind) -> Box<dyn Opponent> {
    match kind {
        OpponentKind::Static => Box::new(StaticOpponent),
        OpponentKind::Random => Box::new(RandomOpponent),
        OpponentKind::Scripted => Box::new(ScriptedOpponent),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tracking_puts_a_man_on_the_ball() {
        // Goalie men at -20.676, 0, 20.676 with +-10 of slide: any |x| <= 30.676 is reachable.
        for x in [-25.0_f32, -8.0, 0.0, 3.0, 14.0, 30.0] {
            let s = ScriptedOpponent::tracking_slide(0, x) * RODS[0].slide_range;
            let miss = RODS[0]
                .men_x
                .iter()
                .map(|m| (m + s - x).abs())
                .fold(f32::INFINITY, f32::min);
            assert!(miss < 1e-4, "x = {x}: slide {s} misses by {miss}");
        }
        // Out of reach: the outermost man goes as far as he can.
        let s = ScriptedOpponent::tracking_slide(0, 33.0);
        assert_eq!(s, 1.0);
    }
}
