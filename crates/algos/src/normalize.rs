//! Running normalisation of observations and rewards around any [`Agent`], as
//! Stable-Baselines3's `VecNormalize` computes it (`[normalize]` in a run configuration).
//!
//! - Observations: `clip((o - mean) / sqrt(var + epsilon), -clip_obs, clip_obs)` per value,
//!   `mean` and `var` the running moments of every observation acted on in training
//!   (`act(.., Explore)`; the first of each episode included, an episode's last one not:
//!   `VecNormalize` counts the reset observation that replaces it). Evaluation, test and
//!   play read the moments as they stand, frozen.
//! - Rewards: `clip(r / sqrt(var_R + epsilon), -clip_reward, clip_reward)` with `var_R`
//!   the running variance of the discounted return `R <- gamma * R + r` of each env (reset
//!   to 0 where its episode ends). The mean is not taken off: the sign of a reward stays.
//! - Demonstrations (`protocol.demonstrations`) seed both moments before the first step:
//!   their observations and the discounted returns of their steps are merged, and they
//!   reach the inner agent normalised and scaled with those moments.
//! - Moments merge batches exactly (Chan et al.'s parallel update, `f64`), starting from
//!   mean 0, variance 1 and count `1e-4`, as SB3's `RunningMeanStd`.
//!
//! The inner agent learns and acts on normalised values only: its value function is in
//! normalised reward units, its replay (SAC, TD3) holds observations normalised with the
//! moments of their time (SB3 keeps the raw ones and normalises at sampling; the
//! moments settle within a few thousand steps). The observation moments are saved beside
//! the networks (`normalize.bin`, exact `f64`s), so every player of the run (evaluate, league, act)
//! reads the table as the learner did; all moments and the running returns go into the
//! checkpoint, so a resumed run continues exactly.

use crate::agent::{ActMode, Agent, AgentError, Experience, Metrics};
use crate::config::{ConfigError, ensure};
use crate::demonstrations::Demonstration;
use crate::policy_chain::Step;
use foosball_nets::{Snapshot, SnapshotError};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The file beside a run's networks that holds the observation moments.
pub const FILE: &str = "normalize.bin";

/// `[normalize]`: what is normalised and how (defaults `VecNormalize`'s).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NormalizeConfig {
    /// Normalise observations (the state vector only).
    pub obs: bool,
    /// Scale rewards by the running standard deviation of the discounted return.
    pub reward: bool,
    /// Bound of a normalised observation value (standard deviations).
    pub clip_obs: f32,
    /// Bound of a scaled reward.
    pub clip_reward: f32,
    /// Discount of the return whose variance scales rewards (the learner's gamma, as a
    /// rule).
    pub gamma: f64,
    /// Added to every variance before its square root.
    pub epsilon: f64,
}

impl Default for NormalizeConfig {
    fn default() -> Self {
        Self {
            obs: true,
            reward: true,
            clip_obs: 10.0,
            clip_reward: 10.0,
            gamma: 0.99,
            epsilon: 1e-8,
        }
    }
}

impl NormalizeConfig {
    /// Rejects invalid settings, naming the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        ensure(
            self.obs || self.reward,
            "obs",
            "obs and reward both off: drop [normalize]",
        )?;
        ensure(self.clip_obs > 0.0, "clip_obs", "must be positive")?;
        ensure(self.clip_reward > 0.0, "clip_reward", "must be positive")?;
        ensure(
            (0.0..=1.0).contains(&self.gamma),
            "gamma",
            "must be in [0, 1]",
        )?;
        ensure(
            self.epsilon > 0.0 && self.epsilon.is_finite(),
            "epsilon",
            "must be positive",
        )
    }
}

/// Running mean and variance of vectors of a fixed width (SB3's `RunningMeanStd`).
#[derive(Clone, Debug, PartialEq)]
pub struct RunningMoments {
    /// Mean per value.
    pub mean: Vec<f64>,
    /// Population variance per value.
    pub var: Vec<f64>,
    /// Vectors seen, plus the initial `1e-4`.
    pub count: f64,
}

impl RunningMoments {
    /// Mean 0, variance 1, count `1e-4`, for vectors of `width` values.
    pub fn new(width: usize) -> Self {
        Self {
            mean: vec![0.0; width],
            var: vec![1.0; width],
            count: 1e-4,
        }
    }

    /// Merges the rows of `batch` (`[n, width]`) that are finite throughout.
    pub fn update(&mut self, batch: &[f32]) {
        let w = self.mean.len();
        let rows: Vec<&[f32]> = batch
            .chunks(w)
            .filter(|r| r.iter().all(|x| x.is_finite()))
            .collect();
        if rows.is_empty() {
            return;
        }
        let n = rows.len() as f64;
        let total = self.count + n;
        for j in 0..w {
            let m = rows.iter().map(|r| f64::from(r[j])).sum::<f64>() / n;
            let v = rows
                .iter()
                .map(|r| (f64::from(r[j]) - m).powi(2))
                .sum::<f64>()
                / n;
            let delta = m - self.mean[j];
            let m2 = self.var[j] * self.count + v * n + delta * delta * self.count * n / total;
            self.mean[j] += delta * n / total;
            self.var[j] = m2 / total;
        }
        self.count = total;
    }

    fn put(&self, snap: &mut Snapshot<'_>, key: &str) {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
        snap.put_u64s(format!("{key}.mean"), bits(&self.mean));
        snap.put_u64s(format!("{key}.var"), bits(&self.var));
        snap.put_f64(format!("{key}.count"), self.count);
    }

    fn take(&mut self, snap: &Snapshot<'_>, key: &str) -> Result<(), SnapshotError> {
        let floats = |name: String, len: usize| -> Result<Vec<f64>, SnapshotError> {
            let bits = snap.u64s(&name)?;
            if bits.len() != len {
                return Err(SnapshotError::Entry {
                    name,
                    message: format!("holds {} values, expected {len}", bits.len()),
                });
            }
            Ok(bits.iter().map(|&b| f64::from_bits(b)).collect())
        };
        self.mean = floats(format!("{key}.mean"), self.mean.len())?;
        self.var = floats(format!("{key}.var"), self.var.len())?;
        self.count = snap.f64(&format!("{key}.count"))?;
        Ok(())
    }
}

/// An agent that sees normalised observations and rewards (module docs).
pub struct Normalized {
    inner: Box<dyn Agent + Send>,
    config: NormalizeConfig,
    obs: RunningMoments,
    returns: RunningMoments,
    /// Discounted return of each training env so far.
    running: Vec<f64>,
    /// The last hand of demonstrations that added episodes: how many the list held (the
    /// moments hold their observations and returns; a list handed again only grows at
    /// its end) and the moments every row was normalised with then.
    handed: Option<Handed>,
}

/// What [`Normalized`] keeps of the demonstrations it handed on.
#[derive(Clone, Debug, PartialEq)]
struct Handed {
    episodes: usize,
    obs: RunningMoments,
    returns: RunningMoments,
}

impl Normalized {
    /// Wraps `inner`, moments fresh.
    pub fn new(inner: Box<dyn Agent + Send>, config: NormalizeConfig) -> Self {
        let width = inner.obs_dim();
        Self {
            inner,
            config,
            obs: RunningMoments::new(width),
            returns: RunningMoments::new(1),
            running: Vec::new(),
            handed: None,
        }
    }

    /// The observation moments as they stand.
    pub fn obs_moments(&self) -> &RunningMoments {
        &self.obs
    }

    /// `obs` (`[n, obs_dim]`) as the inner agent sees it.
    pub fn observation(&self, obs: &[f32]) -> Vec<f32> {
        self.observation_with(&self.obs, obs)
    }

    /// `obs` standardised with `moments`.
    fn observation_with(&self, moments: &RunningMoments, obs: &[f32]) -> Vec<f32> {
        if !self.config.obs {
            return obs.to_vec();
        }
        let (w, c) = (moments.mean.len(), self.config.clip_obs);
        obs.iter()
            .enumerate()
            .map(|(k, &x)| {
                let j = k % w;
                let z = (f64::from(x) - moments.mean[j])
                    / (moments.var[j] + self.config.epsilon).sqrt();
                (z as f32).clamp(-c, c)
            })
            .collect()
    }

    /// `rewards` as the inner agent is paid them, with the return moments as they stand.
    fn scaled(&self, rewards: &[f32]) -> Vec<f32> {
        self.scaled_with(&self.returns, rewards)
    }

    /// `rewards` divided by the return's standard deviation in `returns`.
    fn scaled_with(&self, returns: &RunningMoments, rewards: &[f32]) -> Vec<f32> {
        if !self.config.reward {
            return rewards.to_vec();
        }
        let scale = (returns.var[0] + self.config.epsilon).sqrt();
        let c = self.config.clip_reward;
        rewards
            .iter()
            .map(|&r| ((f64::from(r) / scale) as f32).clamp(-c, c))
            .collect()
    }

    /// Scales `rewards` after merging the returns they extend; resets the returns of the
    /// envs whose episodes ended (`done`).
    fn rewards(&mut self, rewards: &[f32], done: &[bool]) -> Vec<f32> {
        if !self.config.reward {
            return rewards.to_vec();
        }
        if self.running.len() != rewards.len() {
            self.running = vec![0.0; rewards.len()];
        }
        for (ret, &r) in self.running.iter_mut().zip(rewards) {
            *ret = self.config.gamma * *ret + f64::from(r);
        }
        let returns: Vec<f32> = self.running.iter().map(|&x| x as f32).collect();
        self.returns.update(&returns);
        let scaled = self.scaled(rewards);
        for (ret, &d) in self.running.iter_mut().zip(done) {
            if d {
                *ret = 0.0;
            }
        }
        scaled
    }
}

impl Agent for Normalized {
    fn obs_dim(&self) -> usize {
        self.inner.obs_dim()
    }

    fn action_dim(&self) -> usize {
        self.inner.action_dim()
    }

    fn act(&mut self, obs: &[f32], mode: ActMode) -> Vec<f32> {
        if mode == ActMode::Explore && self.config.obs {
            self.obs.update(obs);
        }
        self.inner.act(&self.observation(obs), mode)
    }

    fn seed_sampling(&mut self, seed: u64) {
        self.inner.seed_sampling(seed);
    }

    /// The inner agent's chain behind [`Step::Standardize`] with the moments as they
    /// stand (none where observations are not normalised).
    fn policy_chain(&self) -> Result<Vec<Step>, String> {
        let mut chain = self.inner.policy_chain()?;
        if self.config.obs {
            let eps = self.config.epsilon;
            let standardize = Step::Standardize {
                mean: self.obs.mean.clone(),
                scale: self.obs.var.iter().map(|v| (v + eps).sqrt()).collect(),
                clip: self.config.clip_obs,
            };
            chain.insert(0, standardize);
        }
        Ok(chain)
    }

    /// The observations acted on are normalised again with the moments `act` used (only
    /// `act(.., Explore)` moves them), so the learner stores what it acted on.
    fn observe(&mut self, step: &Experience<'_>) {
        let seen = step.map_obs(|o| self.observation(o));
        let done: Vec<bool> = (0..step.len())
            .map(|i| step.terminated[i] || step.truncated[i])
            .collect();
        let rewards = self.rewards(step.rewards, &done);
        self.inner.observe(&seen.with(step, &rewards));
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

    /// The networks, and the observation moments in [`FILE`].
    fn save(&self, dir: &Path) -> Result<(), AgentError> {
        self.inner.save(dir)?;
        let mut snap = Snapshot::new();
        self.obs.put(&mut snap, "obs");
        snap.write(&dir.join(FILE)).map_err(|e| AgentError::File {
            path: dir.join(FILE),
            message: e.to_string(),
        })
    }

    /// The networks, and the observation moments from [`FILE`] (`obs_dim` values each).
    fn load(&mut self, dir: &Path) -> Result<(), AgentError> {
        self.inner.load(dir)?;
        let path = dir.join(FILE);
        let file = |message: String| AgentError::File {
            path: path.clone(),
            message,
        };
        if !path.exists() {
            return Err(file(
                "missing: a run trained with [normalize] saves its observation moments here".into(),
            ));
        }
        let snap = Snapshot::read(&path).map_err(|e| file(e.to_string()))?;
        let mut moments = RunningMoments::new(self.obs_dim());
        moments
            .take(&snap, "obs")
            .map_err(|e| file(e.to_string()))?;
        if !moments
            .var
            .iter()
            .chain(&moments.mean)
            .all(|x| x.is_finite())
        {
            return Err(file("non-finite moments".into()));
        }
        self.obs = moments;
        Ok(())
    }

    fn zero_obs_inputs(&mut self, inputs: &[usize]) -> Result<(), String> {
        self.inner.zero_obs_inputs(inputs)
    }

    fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>) {
        self.inner.save_state(snap);
        self.obs.put(snap, "normalize.obs");
        self.returns.put(snap, "normalize.returns");
        let bits: Vec<u64> = self.running.iter().map(|x| x.to_bits()).collect();
        snap.put_u64s("normalize.running", bits);
        if let Some(h) = &self.handed {
            snap.put_u64("normalize.handed.episodes", h.episodes as u64);
            h.obs.put(snap, "normalize.handed.obs");
            h.returns.put(snap, "normalize.handed.returns");
        }
    }

    fn load_state(&mut self, snap: &Snapshot<'_>) -> Result<(), SnapshotError> {
        self.inner.load_state(snap)?;
        self.obs.take(snap, "normalize.obs")?;
        self.returns.take(snap, "normalize.returns")?;
        let bits = snap.u64s("normalize.running")?;
        self.running = bits.iter().map(|&b| f64::from_bits(b)).collect();
        // A checkpoint of a run handed nothing (or from before the record) keeps what
        // this agent was handed.
        if snap.contains("normalize.handed.episodes") {
            let (mut obs, mut returns) = (self.obs.clone(), self.returns.clone());
            obs.take(snap, "normalize.handed.obs")?;
            returns.take(snap, "normalize.handed.returns")?;
            self.handed = Some(Handed {
                episodes: snap.u64("normalize.handed.episodes")? as usize,
                obs,
                returns,
            });
        }
        Ok(())
    }

    /// The demonstrations as the inner agent learns from them. The episodes not handed
    /// before merge into the moments (their observations into the observation moments,
    /// the discounted return of each of their steps into the return moments: at the start
    /// of a run they seed the moments before any step is played); then every episode's
    /// observations are normalised and rewards scaled with the moments as they stand. A
    /// list handed again (`[dagger]`'s aggregate after each round) must keep the episodes
    /// handed before at its head: they are normalised anew, not merged again. A list
    /// with nothing new is normalised with the moments of the last hand that added
    /// episodes, which are part of the state with their count: a resume that hands the
    /// files to a fresh agent before replacing the moments by the checkpoint's, or hands
    /// the aggregate after, gives the inner agent the rows of the uninterrupted run.
    fn set_demonstrations(&mut self, episodes: &[Demonstration<'_>]) -> Result<usize, String> {
        let w = self.obs_dim();
        if episodes.iter().any(|e| e.obs.len() != e.rewards.len() * w) {
            // Not a table's episodes: the inner agent names the one at fault.
            return self.inner.set_demonstrations(episodes);
        }
        let before = self.handed.as_ref().map_or(0, |h| h.episodes);
        let new = &episodes[before.min(episodes.len())..];
        if self.config.obs {
            for e in new {
                self.obs.update(e.obs);
            }
        }
        if self.config.reward {
            for e in new {
                let mut ret = 0.0;
                let returns: Vec<f32> = e
                    .rewards
                    .iter()
                    .map(|&r| {
                        ret = self.config.gamma * ret + f64::from(r);
                        ret as f32
                    })
                    .collect();
                self.returns.update(&returns);
            }
        }
        if !new.is_empty() || self.handed.is_none() {
            self.handed = Some(Handed {
                episodes: episodes.len(),
                obs: self.obs.clone(),
                returns: self.returns.clone(),
            });
        }
        let h = self.handed.as_ref().expect("set above");
        let seen: Vec<(Vec<f32>, Vec<f32>)> = (episodes.iter())
            .map(|e| {
                let obs = self.observation_with(&h.obs, e.obs);
                (obs, self.scaled_with(&h.returns, e.rewards))
            })
            .collect();
        let normalised: Vec<Demonstration<'_>> = episodes
            .iter()
            .zip(&seen)
            .map(|(e, (obs, rewards))| Demonstration { obs, rewards, ..*e })
            .collect();
        self.inner.set_demonstrations(&normalised)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{Log, Recorder};

    fn wrapped(config: NormalizeConfig) -> (Normalized, Log) {
        let log = Log::default();
        (
            Normalized::new(Box::new(Recorder::new(2, log.clone())), config),
            log,
        )
    }

    /// Two envs, observations `[2, 2]`; env 1's episode ends on every step.
    fn step(n: &mut Normalized, obs: &[f32], rewards: [f32; 2], next_obs: &[f32]) {
        n.act(obs, ActMode::Explore);
        n.observe(&Experience {
            obs,
            actions: &[0.0, 0.0],
            rewards: &rewards,
            next_obs,
            final_obs: vec![None, Some(&[9.0, 9.0])],
            terminated: &[false, true],
            truncated: &[false, false],
            absorbing: vec![false, false],
            teacher: None,
        });
    }

    #[test]
    fn merged_moments_are_those_of_all_rows_at_once() {
        let rows: Vec<f32> = (0..40).map(|i| ((i * 7 % 13) as f32) - 3.5).collect();
        let mut parts = RunningMoments::new(2);
        for chunk in rows.chunks(6) {
            parts.update(chunk);
        }
        let mut once = RunningMoments::new(2);
        once.update(&rows);
        for j in 0..2 {
            let col: Vec<f64> = rows
                .iter()
                .skip(j)
                .step_by(2)
                .map(|&x| f64::from(x))
                .collect();
            let m = col.iter().sum::<f64>() / 20.0;
            let v = col.iter().map(|x| (x - m).powi(2)).sum::<f64>() / 20.0;
            // The prior (mean 0, var 1, count 1e-4) moves the moments by ~1e-5.
            assert!((parts.mean[j] - m).abs() < 1e-4, "{} vs {m}", parts.mean[j]);
            assert!(
                (parts.var[j] - v).abs() < 1e-4 * v,
                "{} vs {v}",
                parts.var[j]
            );
            assert!((parts.mean[j] - once.mean[j]).abs() < 1e-12);
            assert!((parts.var[j] - once.var[j]).abs() < 1e-9);
        }
        let before = parts.clone();
        parts.update(&[f32::NAN, 1.0]);
        assert_eq!(parts, before, "a non-finite row is not merged");
    }

    #[test]
    fn the_inner_agent_sees_standardised_clipped_observations() {
        let (mut n, log) = wrapped(NormalizeConfig {
            clip_obs: 1.5,
            reward: false,
            ..NormalizeConfig::default()
        });
        let obs = [0.0, 100.0, 2.0, 300.0];
        step(&mut n, &obs, [1.0, 1.0], &obs);
        // Moments of the two rows (prior count 1e-4): mean (1, 200), var (1, 10_000).
        let m = n.obs_moments().clone();
        assert!((m.mean[0] - 1.0).abs() < 1e-3 && (m.mean[1] - 200.0).abs() < 0.1);
        assert!((m.var[0] - 1.0).abs() < 1e-3 && (m.var[1] - 10_000.0).abs() < 5.0);
        let seen = log.lock().unwrap()[0].0.clone();
        for (s, want) in seen.iter().zip([-1.0, -1.0, 1.0, 1.0]) {
            assert!((s - want).abs() < 1e-3, "{seen:?}");
        }
        assert_eq!(
            log.lock().unwrap()[0].1,
            vec![1.0, 1.0],
            "rewards untouched"
        );
        assert_eq!(n.observation(&[100.0, 0.0]), vec![1.5, -1.5], "clipped");
        // Acting deterministically reads the moments and leaves them alone.
        assert_eq!(n.act(&[3.0, 0.0], ActMode::Deterministic), vec![1.5]);
        assert_eq!(n.obs_moments(), &m);
    }

    #[test]
    fn rewards_are_scaled_by_the_std_of_the_discounted_return_reset_at_episode_ends() {
        let config = NormalizeConfig {
            obs: false,
            gamma: 0.5,
            ..NormalizeConfig::default()
        };
        let (mut n, log) = wrapped(config.clone());
        let o = [0.0; 4];
        step(&mut n, &o, [2.0, 4.0], &o);
        step(&mut n, &o, [2.0, 4.0], &o);
        // Returns: step 1 (2, 4); step 2 env 0 0.5 * 2 + 2 = 3, env 1 restarted at 4.
        let mut by_hand = RunningMoments::new(1);
        let mut scales = Vec::new();
        for returns in [[2.0, 4.0], [3.0, 4.0]] {
            by_hand.update(&returns);
            scales.push((by_hand.var[0] + config.epsilon).sqrt());
        }
        assert_eq!(n.returns, by_hand);
        let log = log.lock().unwrap();
        for (k, scale) in scales.iter().enumerate() {
            let want = [(2.0 / scale) as f32, (4.0 / scale) as f32];
            assert_eq!(log[k].1, want, "step {k}");
        }
        assert_eq!(log[0].0, o.to_vec(), "observations untouched");
    }

    #[test]
    fn a_resumed_wrapper_continues_exactly() {
        let run = |n: &mut Normalized, k: f32| {
            step(
                n,
                &[k, 2.0 * k, -k, 1.0],
                [k, 1.0 - k],
                &[k + 1.0, 0.0, 1.0, k],
            );
        };
        let (mut a, log_a) = wrapped(NormalizeConfig::default());
        for k in 0..5 {
            run(&mut a, k as f32);
        }
        let mut snap = Snapshot::new();
        a.save_state(&mut snap);
        let (mut b, log_b) = wrapped(NormalizeConfig::default());
        b.load_state(&snap).unwrap();
        for k in 5..9 {
            run(&mut a, k as f32);
            run(&mut b, k as f32);
        }
        assert_eq!(log_a.lock().unwrap()[5..], log_b.lock().unwrap()[..]);
    }

    #[test]
    fn saved_moments_load_back_and_a_missing_file_is_named() {
        let dir = std::env::temp_dir().join(format!("normalize-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (mut a, _) = wrapped(NormalizeConfig::default());
        step(&mut a, &[1.0, 5.0, 3.0, -5.0], [0.0, 0.0], &[0.0; 4]);
        a.save(&dir).unwrap();
        let (mut b, _) = wrapped(NormalizeConfig::default());
        b.load(&dir).unwrap();
        assert_eq!(b.obs_moments(), a.obs_moments());
        std::fs::remove_file(dir.join(FILE)).unwrap();
        let err = b.load(&dir).unwrap_err().to_string();
        assert!(err.contains(FILE), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn demonstrations_seed_the_moments_and_are_handed_on_normalised() {
        let (mut n, log) = wrapped(NormalizeConfig::default());
        let (obs_a, obs_b) = ([1.0, 10.0, 3.0, 30.0], [5.0, 50.0]);
        let demo = |obs, rewards| Demonstration {
            obs,
            actions: &[0.0, 0.0],
            rewards,
            terminated: true,
            absorbing: false,
        };
        let kept = n.set_demonstrations(&[demo(&obs_a, &[1.0, 2.0]), demo(&obs_b, &[4.0])]);
        assert_eq!(kept, Ok(3));
        // Rows (1, 10), (3, 30), (5, 50): means 3 and 30, variances 8/3 and 800/3.
        let m = n.obs_moments();
        assert!((m.mean[0] - 3.0).abs() < 1e-4 && (m.mean[1] - 30.0).abs() < 1e-3);
        assert!((m.var[0] - 8.0 / 3.0).abs() < 1e-3 && (m.var[1] - 800.0 / 3.0).abs() < 1e-1);
        // Discounted returns per step: 1, 0.99 + 2 = 2.99 (first episode), 4 (second).
        let returns = [1.0, 2.99, 4.0];
        let mean = returns.iter().sum::<f64>() / 3.0;
        let var = returns.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / 3.0;
        let log = log.lock().unwrap();
        let (sd0, sd1) = ((8.0f64 / 3.0).sqrt(), (800.0f64 / 3.0).sqrt());
        let want_obs = [(1.0 - 3.0) / sd0, (10.0 - 30.0) / sd1, 0.0, 0.0];
        for (got, want) in log[0].0.iter().zip(want_obs) {
            assert!((f64::from(*got) - want).abs() < 1e-3, "{got} vs {want}");
        }
        for (got, r) in log[0].1.iter().chain(&log[1].1).zip([1.0, 2.0, 4.0]) {
            let want = r / var.sqrt();
            assert!((f64::from(*got) - want).abs() < 1e-3, "{got} vs {want}");
        }
    }

    /// A list handed again with episodes added at its end merges only those: the moments
    /// are those of one hand of the whole list, across a checkpoint too; every row is
    /// handed on normalised with the moments as they stand, and a list with nothing new
    /// as the last hand that added episodes normalised it.
    #[test]
    fn a_list_handed_again_merges_only_its_new_episodes() {
        let demo = |obs| Demonstration {
            obs,
            actions: &[0.0],
            rewards: &[1.0],
            terminated: true,
            absorbing: false,
        };
        let (a, b) = (demo(&[1.0, 10.0]), demo(&[5.0, 50.0]));
        let (mut once, _) = wrapped(NormalizeConfig::default());
        once.set_demonstrations(&[a, b]).unwrap();
        let (mut grown, log) = wrapped(NormalizeConfig::default());
        grown.set_demonstrations(&[a]).unwrap();
        grown.set_demonstrations(&[a, b]).unwrap();
        grown.set_demonstrations(&[a, b]).unwrap();
        assert_eq!(grown.obs_moments(), once.obs_moments());
        assert_eq!(grown.returns, once.returns);
        // The last hand: both rows normalised with the moments of the two (means 3, 30).
        let last = log.lock().unwrap()[3..].to_vec();
        assert!(last[0].0[0] < 0.0 && last[1].0[0] > 0.0, "{last:?}");
        let mut snap = Snapshot::new();
        grown.save_state(&mut snap);
        let (mut resumed, _) = wrapped(NormalizeConfig::default());
        resumed.load_state(&snap).unwrap();
        resumed.set_demonstrations(&[a, b]).unwrap();
        assert_eq!(resumed.obs_moments(), once.obs_moments());
        // Once the moments have moved, the same list again: the rows of that hand.
        grown.act(&[100.0, 100.0], ActMode::Explore);
        assert_ne!(grown.obs_moments(), once.obs_moments());
        grown.set_demonstrations(&[a, b]).unwrap();
        assert_eq!(log.lock().unwrap()[5..], last[..]);
    }

    #[test]
    fn a_config_without_anything_to_normalise_is_refused() {
        let off = NormalizeConfig {
            obs: false,
            reward: false,
            ..NormalizeConfig::default()
        };
        assert_eq!(off.validate().unwrap_err().key, "obs");
        assert!(NormalizeConfig::default().validate().is_ok());
    }
}
