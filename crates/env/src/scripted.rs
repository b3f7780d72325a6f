//! Hand-written controllers for one team's four rods, seen from that team's side (the
//! [`Opponent`] interface, so they play yellow or black): the yardsticks a learner is
//! compared with.
//!
//! [`Kicker`] reads the 38-dim state, picks the straight line from the ball into the
//! attacked goal that passes farthest from every opposing man, lines up the man of the rod
//! just behind the ball so that his foot's edge sends the ball along that line, and
//! swings: a full-power swing is the [`Kicker::shooter`], a gentle one the
//! [`Kicker::dribbler`] (it pushes the ball forward in small steps, which the per-step
//! `alpha` term pays for). Rods in front of the ball lift their feet to let it pass.

use crate::EnvRng;
use crate::geometry::{BALL_RADIUS, FIELD_HALF_LENGTH, GOAL_HALF_WIDTH, RODS, foosman};
use crate::layout::{
    ACTION_DIM, BALL_POS, OBS_DIM, ROD_ANGLE, ROD_ANGLE_VEL, ROD_SLIDE, action_slide, action_turn,
};
use crate::opponent::{Opponent, man_at};

/// Ball centre ahead of a rod's axis (own +y), cm, within which the rod can kick it.
const KICK_ZONE: (f32, f32) = (-1.5, 6.5);
/// Ball centre ahead of a rod's axis, cm, within which a foot at rest reaches it.
const CLOSE: f32 = 4.5;
/// Turn command (of ±1 = ±2.5 rad) that lifts the feet of rods in front of the ball.
const LIFTED: f32 = -0.65;
/// Turn command of the back-swing a rod waits in before kicking.
const WOUND: f32 = -0.25;
/// Rod angle (rad) under which a rod counts as wound up (half the back-swing's).
const WOUND_ANGLE: f32 = WOUND * 2.5 * 0.5;
/// Rod angle (rad) past which a swing counts as done.
const SWUNG: f32 = 1.2;
/// Largest angle (rad from own +y) the foot's edge can give the ball.
const MAX_AIM: f32 = 0.8;
/// How far (cm) the man may be from his aiming position and still kick.
const ALIGNED: f32 = 0.8;

/// A scripted attacker (see the module docs). It keeps no state between steps: where a
/// rod is in its swing is read off its angle and angular velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kicker {
    /// Forward turn command of a kick, in (0, 1].
    power: f32,
}

impl Kicker {
    /// Kicks at full power along the clearest line to goal.
    pub fn shooter() -> Self {
        Self::with_power(1.0)
    }

    /// Taps the ball forward gently along the clearest line to goal.
    pub fn dribbler() -> Self {
        Self::with_power(0.12)
    }

    /// A kicker whose forward swing commands `power` (of the turn range, in (0, 1]).
    pub fn with_power(power: f32) -> Self {
        Self {
            power: power.clamp(0.01, 1.0),
        }
    }
}

/// The opposing men's centres (x, y) in the own frame, from the own-view state.
fn opposing_men(obs: &[f32; OBS_DIM]) -> impl Iterator<Item = (f32, f32)> + '_ {
    (0..4).flat_map(move |r| {
        let spec = &RODS[r];
        let slide = obs[ROD_SLIDE.start + 4 + r];
        // The opposing team's table is ours turned 180° about z.
        spec.men_x
            .iter()
            .map(move |&m| (-(m + slide), -spec.yellow_y))
    })
}

/// Sideways distance by which the straight line from `ball` to `(target_x, goal_y)`
/// clears the nearest opposing man (negative when it hits one).
fn clearance(obs: &[f32; OBS_DIM], ball: (f32, f32), target_x: f32) -> f32 {
    let goal_y = FIELD_HALF_LENGTH;
    let slope = (target_x - ball.0) / (goal_y - ball.1).max(1e-3);
    opposing_men(obs)
        .filter(|&(_, y)| y > ball.1 + 1.0)
        .map(|(x, y)| (ball.0 + slope * (y - ball.1) - x).abs() - foosman::LEG_HALF_X - BALL_RADIUS)
        .fold(f32::INFINITY, f32::min)
}

/// The aiming angle (rad from own +y, positive towards +x) of the clearest line to goal.
fn aim(obs: &[f32; OBS_DIM], ball: (f32, f32)) -> f32 {
    let reach = GOAL_HALF_WIDTH - BALL_RADIUS;
    let best = (0..=40)
        .map(|k| -reach + 2.0 * reach * k as f32 / 40.0)
        .map(|x| (x, clearance(obs, ball, x) - 0.05 * x.abs()))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0.0, |(x, _)| x);
    ((best - ball.0).atan2((FIELD_HALF_LENGTH - ball.1).max(1e-3))).clamp(-MAX_AIM, MAX_AIM)
}

impl Opponent for Kicker {
    fn fork(&self) -> Option<Box<dyn Opponent>> {
        Some(Box::new(*self))
    }

    fn linear_actions(&self) -> bool {
        true
    }

    fn act(&mut self, obs: &[f32; OBS_DIM], _rng: &mut EnvRng) -> [f32; ACTION_DIM] {
        let ball = (obs[BALL_POS.start], obs[BALL_POS.start + 1]);
        let mut action = [0.0; ACTION_DIM];
        let angle = aim(obs, ball);
        for rod in 0..4 {
            let spec = &RODS[rod];
            let ahead = ball.1 - spec.yellow_y;
            let in_zone = (KICK_ZONE.0..=KICK_ZONE.1).contains(&ahead);
            // The foot's edge meets the ball off-centre by this much to send it at `angle`.
            let offset = if angle.abs() < 0.05 {
                0.0
            } else {
                angle.signum() * (foosman::LEG_HALF_X + BALL_RADIUS * angle.abs().sin())
            };
            let (slide, miss) = man_at(rod, if in_zone { ball.0 - offset } else { ball.0 });
            action[action_slide(rod)] = slide / spec.slide_range;
            let turn = obs[ROD_ANGLE.start + rod];
            let swinging = obs[ROD_ANGLE_VEL.start + rod] > 0.5 && turn < SWUNG;
            // Kick from the back-swing (or straight away when the ball is close enough for a
            // foot at rest to reach it), and carry a started swing through.
            let ready = turn < WOUND_ANGLE || (ahead < CLOSE && turn < 0.2);
            let kick = in_zone && ((miss < ALIGNED && ready) || swinging);
            action[action_turn(rod)] = if kick {
                self.power
            } else if ahead < KICK_ZONE.0 - 1.0 {
                LIFTED
            } else {
                WOUND
            };
        }
        action
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clearest_line_avoids_the_men_of_a_static_opponent() {
        // Opposing rods at neutral: a man stands at x = 0 on the goalie, midfield and
        // attack rods, so a ball at (0, 10) must be aimed off-centre.
        let obs = [0.0; OBS_DIM];
        let a = aim(&obs, (0.0, 10.0));
        assert!(a.abs() > 0.02, "aimed straight into the goalie: {a}");
        let x_at_goal = 10.0 * 0.0 + (FIELD_HALF_LENGTH - 10.0) * a.tan();
        assert!(x_at_goal.abs() < GOAL_HALF_WIDTH, "aimed wide: {x_at_goal}");
        assert!(clearance(&obs, (0.0, 10.0), x_at_goal) > 0.0);
    }
}
