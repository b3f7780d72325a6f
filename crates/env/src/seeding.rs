//! How every random stream derives from one run seed.
//!
//! `derive_seed(run_seed, stream, index)` mixes the three with SplitMix64, so streams are
//! independent and a seed never depends on thread count or call order. Fixed stream ids:
//!
//! | stream | used for |
//! | --- | --- |
//! | [`TRAIN_ENVS`] | training environments: worker `i` of `n` starts epoch `e` (0-based) from `index = e * n + i` |
//! | [`EVAL_ENVS`]  | evaluation episode `index` (held out from training) |
//! | [`TEST_ENVS`]  | final-test episode `index` (held out from both) |
//! | [`LEARNER`]    | the learner's own stream (`index` 0: network init, sampling, noise) |
//! | [`ACTION_SAMPLING`] | sampled (stochastic) evaluation actions; `index` is the episodes' stream ([`EVAL_ENVS`] or [`TEST_ENVS`]) |
//! | [`MATCHES`] | two-sided matches of a league: `index` = the match's number among a pair's |
//! | [`PLANNER`] | the planner's search for episode `index` of the stream it is tested on |
//! | [`CURRICULUM`] | which training episodes begin along a teacher's: `run_seed` is the training env's reset seed, `index` 0 |
//! | [`RIVALS`] | a self-play run's rivals: training environment `index`'s own copies (random players, sampled actions) |
//! | [`DAGGER`] | an interactive teacher's round `index`: `derive_seed(run_seed, DAGGER, index)` is the round's own seed, from which its episodes' starts (stream [`DAGGER`]), queried steps and searches derive |

/// Stream of the training environments.
pub const TRAIN_ENVS: u64 = 1;
/// Stream of the periodic evaluation episodes.
pub const EVAL_ENVS: u64 = 2;
/// Stream of the final test episodes.
pub const TEST_ENVS: u64 = 3;
/// Stream of the learning algorithm's components.
pub const LEARNER: u64 = 4;
/// Stream of the noise of stochastic evaluations and tests.
pub const ACTION_SAMPLING: u64 = 5;
/// Stream of the matches of a league (serves, sampled actions, random players).
pub const MATCHES: u64 = 6;
/// Stream of the planner's searches (one per episode).
pub const PLANNER: u64 = 7;
/// Stream of a reverse curriculum's choices of starts (`crate::starts`).
pub const CURRICULUM: u64 = 8;
/// Stream of an interactive teacher's rounds (the learner's episodes it relabels).
pub const DAGGER: u64 = 9;
/// Stream of a self-play run's rivals (one per training environment).
pub const RIVALS: u64 = 10;

/// One SplitMix64 output step.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of item `index` of stream `stream` under run seed `run_seed`.
pub fn derive_seed(run_seed: u64, stream: u64, index: u64) -> u64 {
    splitmix64(splitmix64(splitmix64(run_seed) ^ stream) ^ index)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_and_indices_give_distinct_seeds() {
        let mut seen = std::collections::HashSet::new();
        for stream in [
            TRAIN_ENVS,
            EVAL_ENVS,
            TEST_ENVS,
            LEARNER,
            ACTION_SAMPLING,
            MATCHES,
            PLANNER,
            CURRICULUM,
            DAGGER,
            RIVALS,
        ] {
            for index in 0..1000 {
                assert!(seen.insert(derive_seed(7, stream, index)));
            }
        }
        assert_eq!(derive_seed(7, 1, 3), derive_seed(7, 1, 3));
        assert_ne!(derive_seed(7, 1, 3), derive_seed(8, 1, 3));
    }
}
