//! Fourier features of the observation around any [`Agent`] (`[fourier]` in a run
//! configuration): each observation value `x` reaches the networks as
//!
//! ```text
//! [x, sin(pi s x), cos(pi s x), sin(2 pi s x), cos(2 pi s x), ..., sin(2^(K-1) pi s x), cos(2^(K-1) pi s x)]
//! ```
//!
//! `K` = `frequencies`, `s` = `scale`: a block of `1 + 2 K` inputs for each value listed in
//! `inputs` (all of them when it is empty), the others passed on alone, in the
//! observation's order. This is NeRF's positional encoding (Mildenhall et al.
//! 2020; Tancik et al. 2020 on why it lets a small network resolve fine differences of
//! its input) applied per observation value, as Brellmann et al. (2023) use Fourier
//! features in deep RL. The map is fixed (nothing learned, nothing saved: the run's
//! configuration rebuilds it), so every player of a run reads the table as the learner
//! did. Under `[normalize]` it reads the normalised values (the wrapper sits inside
//! [`crate::Normalized`]), whose unit is one running standard deviation: with `s` = 1 and
//! `K` = 5 the highest pair turns through `16 pi` a standard deviation, a full period
//! per 0.125 of one.

use crate::agent::{ActMode, Agent, AgentError, Experience, Metrics};
use crate::config::{ConfigError, ensure};
use crate::demonstrations::Demonstration;
use crate::policy_chain::Step;
use foosball_nets::{Snapshot, SnapshotError};
use serde::{Deserialize, Serialize};
use std::f32::consts::PI;
use std::path::Path;

/// Most frequencies a value may get (`2^15 pi s` is already past an `f32`'s resolution of
/// `sin` at the observation's scale).
pub const MAX_FREQUENCIES: u32 = 16;

/// `[fourier]`: which observation values are encoded, how many frequencies each gets and
/// the lowest one's scale.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FourierConfig {
    /// `K`: the sin/cos pairs per value, frequencies `pi s 2^k` for `k` = 0..K.
    pub frequencies: u32,
    /// `s`: the lowest frequency in units of `pi` per unit of the value.
    pub scale: f32,
    /// Indices of the observation values to encode, increasing (empty: every value).
    pub inputs: Vec<usize>,
}

impl Default for FourierConfig {
    fn default() -> Self {
        Self {
            frequencies: 5,
            scale: 1.0,
            inputs: Vec::new(),
        }
    }
}

impl FourierConfig {
    /// Rejects invalid settings for observations of `width` values, naming the key.
    pub fn validate(&self, width: usize) -> Result<(), ConfigError> {
        ensure(
            (1..=MAX_FREQUENCIES).contains(&self.frequencies),
            "frequencies",
            &format!("must be in 1..={MAX_FREQUENCIES}"),
        )?;
        ensure(
            self.scale > 0.0 && self.scale.is_finite(),
            "scale",
            "must be finite and positive",
        )?;
        ensure(
            self.inputs.windows(2).all(|w| w[0] < w[1]),
            "inputs",
            "must increase (each value once)",
        )?;
        ensure(
            self.inputs.iter().all(|&j| j < width),
            "inputs",
            &format!("must be below the observation's {width} values"),
        )
    }

    /// The sin/cos features of one value, `2 K` of them, appended to `out`.
    fn encode(&self, x: f32, out: &mut Vec<f32>) {
        for f in self.angular_frequencies() {
            let (sin, cos) = (f * x).sin_cos();
            out.push(sin);
            out.push(cos);
        }
    }

    /// `pi s 2^k` for `k` = 0..K, radians per unit of the value (each the one before
    /// doubled, in f32).
    fn angular_frequencies(&self) -> impl Iterator<Item = f32> {
        std::iter::successors(Some(PI * self.scale), |f| Some(f * 2.0))
            .take(self.frequencies as usize)
    }

    /// Whether each of `width` values is encoded.
    fn encoded(&self, width: usize) -> Vec<bool> {
        (0..width)
            .map(|j| self.inputs.is_empty() || self.inputs.binary_search(&j).is_ok())
            .collect()
    }

    /// The networks' input width for observations of `width` values.
    pub fn width(&self, width: usize) -> usize {
        let encoded = self.encoded(width).iter().filter(|&&e| e).count();
        width + 2 * self.frequencies as usize * encoded
    }
}

/// An agent that reads the Fourier features of its observations (module docs); it takes
/// and reports `width`-wide observations, its inner agent
/// [`FourierConfig::width`]`(width)`-wide ones.
pub struct FourierFeatures {
    inner: Box<dyn Agent + Send>,
    config: FourierConfig,
    /// Whether each observation value is encoded.
    encoded: Vec<bool>,
}

impl FourierFeatures {
    /// Wraps `inner`, whose observations are `config.width(width)` wide.
    ///
    /// # Panics
    /// If they are not: the caller built the inner agent for another width.
    pub fn new(inner: Box<dyn Agent + Send>, config: FourierConfig, width: usize) -> Self {
        assert_eq!(
            inner.obs_dim(),
            config.width(width),
            "the inner agent reads {} inputs, the features of {width} values are {}",
            inner.obs_dim(),
            config.width(width)
        );
        Self {
            inner,
            encoded: config.encoded(width),
            config,
        }
    }

    /// `obs` (`[n, width]`) as the networks read it, `[n, config.width(width)]`; a
    /// non-finite value stays non-finite in its whole block (the learners' guards see it).
    pub fn features(&self, obs: &[f32]) -> Vec<f32> {
        let n = obs.len() / self.encoded.len();
        let mut out = Vec::with_capacity(n * self.inner.obs_dim());
        for (&x, &encoded) in obs.iter().zip(self.encoded.iter().cycle()) {
            out.push(x);
            if encoded {
                self.config.encode(x, &mut out);
            }
        }
        out
    }

    /// The networks' inputs that value `j` reaches.
    fn block(&self, j: usize) -> std::ops::Range<usize> {
        let pair = 2 * self.config.frequencies as usize;
        let start = j + pair * self.encoded[..j].iter().filter(|&&e| e).count();
        start..start + 1 + if self.encoded[j] { pair } else { 0 }
    }
}

impl Agent for FourierFeatures {
    fn obs_dim(&self) -> usize {
        self.encoded.len()
    }

    fn action_dim(&self) -> usize {
        self.inner.action_dim()
    }

    fn act(&mut self, obs: &[f32], mode: ActMode) -> Vec<f32> {
        self.inner.act(&self.features(obs), mode)
    }

    fn seed_sampling(&mut self, seed: u64) {
        self.inner.seed_sampling(seed);
    }

    /// [`Step::Fourier`] ahead of the inner agent's chain.
    fn policy_chain(&self) -> Result<Vec<Step>, String> {
        let frequencies = self.config.angular_frequencies().collect();
        let mut chain = self.inner.policy_chain()?;
        chain.insert(
            0,
            Step::Fourier {
                encoded: self.encoded.clone(),
                frequencies,
            },
        );
        Ok(chain)
    }

    fn observe(&mut self, step: &Experience<'_>) {
        let seen = step.map_obs(|o| self.features(o));
        self.inner.observe(&seen.with(step, step.rewards));
    }

    fn update(&mut self, progress_remaining: f64) -> Option<Metrics> {
        self.inner.update(progress_remaining)
    }

    fn env_steps(&self) -> u64 {
        self.inner.env_steps()
    }

    fn gradient_steps(&self) -> u64 {
        self.inner.gradient_steps()
    }

    fn save(&self, dir: &Path) -> Result<(), AgentError> {
        self.inner.save(dir)
    }

    fn load(&mut self, dir: &Path) -> Result<(), AgentError> {
        self.inner.load(dir)
    }

    /// Zeroes every input that a value at `inputs` reaches.
    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        let width = self.obs_dim();
        if let Some(&j) = inputs.iter().find(|&&j| j >= width) {
            return Err(format!(
                "input {j} is past the observation's {width} values"
            ));
        }
        let blocks: Vec<usize> = inputs.iter().flat_map(|&j| self.block(j)).collect();
        self.inner.zero_obs_inputs(&blocks)
    }

    fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>) {
        self.inner.save_state(snap);
    }

    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError> {
        self.inner.load_state(snap)
    }

    /// The demonstrations with their observations' features.
    fn set_demonstrations(&mut self, episodes: &[Demonstration<'_>]) -> Result<usize, String> {
        let w = self.obs_dim();
        if let Some(k) = episodes
            .iter()
            .position(|e| e.obs.len() != e.rewards.len() * w)
        {
            return Err(format!(
                "demonstration {k}: {} observation values for {} steps; the learner takes {w} \
                 per step",
                episodes[k].obs.len(),
                episodes[k].rewards.len()
            ));
        }
        let featured: Vec<Vec<f32>> = episodes.iter().map(|e| self.features(e.obs)).collect();
        let handed: Vec<Demonstration<'_>> = episodes
            .iter()
            .zip(&featured)
            .map(|(e, obs)| Demonstration { obs, ..*e })
            .collect();
        self.inner.set_demonstrations(&handed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{Log, Recorder};
    use std::sync::{Arc, Mutex};

    type Zeroed = Arc<Mutex<Vec<usize>>>;

    fn two_frequencies(inputs: Vec<usize>) -> FourierConfig {
        FourierConfig {
            frequencies: 2,
            scale: 0.5,
            inputs,
        }
    }

    /// The wrapper, what its inner agent observed and the inputs it was asked to zero.
    fn wrapped(config: FourierConfig, width: usize) -> (FourierFeatures, Log, Zeroed) {
        let log = Log::default();
        let inner = Recorder::new(config.width(width), log.clone());
        let zeroed = inner.zeroed.clone();
        (
            FourierFeatures::new(Box::new(inner), config, width),
            log,
            zeroed,
        )
    }

    #[test]
    fn each_value_becomes_itself_and_its_sines_and_cosines() {
        let (agent, _, _) = wrapped(two_frequencies(vec![]), 2);
        // x = 1: pi/2 then pi; x = -0.5: -pi/4 then -pi/2.
        let f = agent.features(&[1.0, -0.5]);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let want = [1.0, 1.0, 0.0, 0.0, -1.0, -0.5, -h, h, -1.0, 0.0];
        assert_eq!(f.len(), 10);
        for (got, want) in f.iter().zip(want) {
            assert!((got - want).abs() < 1e-6, "{f:?}");
        }
        assert_eq!(two_frequencies(vec![]).width(38), 190);
        let bad = agent.features(&[f32::NAN, 0.0]);
        assert!(bad[..5].iter().all(|x| !x.is_finite()), "{bad:?}");
    }

    #[test]
    fn only_the_listed_values_are_encoded_row_by_row() {
        let c = two_frequencies(vec![1]);
        assert_eq!(c.width(3), 7);
        let (agent, _, _) = wrapped(c, 3);
        let f = agent.features(&[5.0, 1.0, 6.0, 7.0, -0.5, 8.0]);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let want = [5.0, 1.0, 1.0, 0.0, 0.0, -1.0, 6.0];
        let want2 = [7.0, -0.5, -h, h, -1.0, 0.0, 8.0];
        assert_eq!(f.len(), 14);
        for (got, want) in f.iter().zip(want.iter().chain(&want2)) {
            assert!((got - want).abs() < 1e-6, "{f:?}");
        }
    }

    #[test]
    fn the_inner_agent_acts_and_learns_on_the_features() {
        let (mut agent, log, _) = wrapped(two_frequencies(vec![]), 2);
        assert_eq!(agent.obs_dim(), 2);
        let (obs, next) = ([0.25, 1.0, -2.0, 0.5], [1.0, 1.0, 3.0, 3.0]);
        // The recorder acts with its first input: each row's first value.
        assert_eq!(agent.act(&obs, ActMode::Explore), vec![0.25, -2.0]);
        agent.observe(&Experience {
            obs: &obs,
            actions: &[0.0, 0.0],
            rewards: &[1.0, 2.0],
            next_obs: &next,
            final_obs: vec![None, Some(&[9.0, 9.0])],
            terminated: &[false, true],
            truncated: &[false, false],
            absorbing: vec![false, false],
            teacher: None,
        });
        let seen = log.lock().unwrap();
        assert_eq!(seen[0].0, agent.features(&obs));
        assert_eq!(seen[0].1, vec![1.0, 2.0], "rewards untouched");
    }

    #[test]
    fn demonstrations_and_blinded_inputs_map_to_whole_blocks() {
        let (mut agent, log, zeroed) = wrapped(two_frequencies(vec![]), 3);
        let obs = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
        let demo = Demonstration {
            obs: &obs,
            actions: &[0.0, 0.0],
            rewards: &[1.0, 1.0],
            terminated: true,
            absorbing: false,
        };
        assert_eq!(agent.set_demonstrations(&[demo]), Ok(2));
        assert_eq!(log.lock().unwrap()[0].0, agent.features(&obs));
        let short = Demonstration {
            obs: &obs[..5],
            ..demo
        };
        let err = agent.set_demonstrations(&[demo, short]).unwrap_err();
        assert!(err.contains("demonstration 1"), "{err}");

        agent.zero_obs_inputs(&[2, 0]).unwrap();
        assert_eq!(
            *zeroed.lock().unwrap(),
            vec![10, 11, 12, 13, 14, 0, 1, 2, 3, 4]
        );
        let err = agent.zero_obs_inputs(&[3]).unwrap_err();
        assert!(err.contains("input 3"), "{err}");

        // Value 1 encoded alone: inputs 0 | 1..6 | 6.
        let (mut agent, _, zeroed) = wrapped(two_frequencies(vec![1]), 3);
        agent.zero_obs_inputs(&[2, 1]).unwrap();
        assert_eq!(*zeroed.lock().unwrap(), vec![6, 1, 2, 3, 4, 5]);
    }

    #[test]
    fn settings_out_of_range_are_refused_by_key() {
        assert!(FourierConfig::default().validate(38).is_ok());
        let key = |c: FourierConfig| c.validate(38).unwrap_err().to_string();
        let none = FourierConfig {
            frequencies: 0,
            ..FourierConfig::default()
        };
        assert!(key(none).contains("frequencies"));
        let flat = FourierConfig {
            scale: 0.0,
            ..FourierConfig::default()
        };
        assert!(key(flat).contains("scale"));
        for inputs in [vec![1, 1], vec![2, 1], vec![38]] {
            let c = FourierConfig {
                inputs,
                ..FourierConfig::default()
            };
            assert!(key(c).contains("inputs"));
        }
    }
}
