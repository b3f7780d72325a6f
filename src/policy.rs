//! Scripted policies for yellow, played through the same evaluation as trained agents:
//! the yardsticks of the report (`evaluate --policy shooter|dribbler|zero|random`).

use crate::evaluation::BatchPolicy;
use foosball_env::layout::OBS_DIM;
use foosball_env::opponent::{RandomOpponent, StaticOpponent};
use foosball_env::scripted::Kicker;
use foosball_env::{EnvRng, Opponent};
use rand::SeedableRng;
use serde::{Deserialize, Serialize};

/// A hand-written controller of yellow's four rods.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ScriptedPolicy {
    /// Lines the man behind the ball up with the clearest line to goal and kicks hard.
    Shooter,
    /// The same aim with gentle taps: walks the ball up the table.
    Dribbler,
    /// Every command 0: rods hold neutral, feet down.
    Zero,
    /// Every command uniform in [-1, 1] each step.
    Random,
}

impl ScriptedPolicy {
    /// Every policy, in documentation order.
    pub const ALL: [ScriptedPolicy; 4] = [
        ScriptedPolicy::Shooter,
        ScriptedPolicy::Dribbler,
        ScriptedPolicy::Zero,
        ScriptedPolicy::Random,
    ];

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            ScriptedPolicy::Shooter => "shooter",
            ScriptedPolicy::Dribbler => "dribbler",
            ScriptedPolicy::Zero => "zero",
            ScriptedPolicy::Random => "random",
        }
    }

    /// The policy over batches of observations; `seed` fixes the random policy's draws
    /// (one stream, rows in batch order, so a fixed batch layout replays exactly).
    pub fn batch_policy(self, seed: u64) -> Box<BatchPolicy<'static>> {
        let mut controller: Box<dyn Opponent> = match self {
            ScriptedPolicy::Shooter => Box::new(Kicker::shooter()),
            ScriptedPolicy::Dribbler => Box::new(Kicker::dribbler()),
            ScriptedPolicy::Zero => Box::new(StaticOpponent),
            ScriptedPolicy::Random => Box::new(RandomOpponent),
        };
        let mut rng = EnvRng::seed_from_u64(seed);
        Box::new(move |obs: &[f32]| {
            obs.chunks_exact(OBS_DIM)
                .flat_map(|row| {
                    let row: &[f32; OBS_DIM] = row.try_into().expect("chunks of OBS_DIM");
                    controller.act(row, &mut rng)
                })
                .collect::<Vec<f32>>()
        })
    }
}
