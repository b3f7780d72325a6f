//! The built-in opponents, by the name a configuration gives them (`opponent = "..."`).

use crate::config::OpponentKind;
use crate::opponent::{Opponent, RandomOpponent, ScriptedOpponent, StaticOpponent};
use crate::scripted::Kicker;

/// A fresh built-in opponent of `kind` (each environment owns its own: the kickers keep
/// state between steps, the random one draws from the environment's stream).
pub fn opponent_for(kind: OpponentKind) -> Box<dyn Opponent> {
    match kind {
        OpponentKind::Static => Box::new(StaticOpponent),
        OpponentKind::Random => Box::new(RandomOpponent),
        OpponentKind::Scripted => Box::new(ScriptedOpponent),
        OpponentKind::Shooter => Box::new(Kicker::shooter()),
        OpponentKind::Dribbler => Box::new(Kicker::dribbler()),
    }
}
