//! Self-imitation learning (Oh, Guo, Singh and Lee, ICML 2018) beside PPO
//! (`[ppo.self_imitation]`): the learner's own episodes are kept with their discounted
//! returns, and after each rollout's PPO update it takes `updates` more gradient steps on
//! minibatches of `batch_size` kept rows, minimising
//!
//! ```text
//! L_sil = coef * mean(-(R - V(s))_+ log pi(a|s)) + value_coef * mean(0.5 (R - V(s))_+^2)
//! R_t   = r_t + gamma r_(t+1) + gamma^2 r_(t+2) + ...   (to the episode's end)
//! ```
//!
//! `(R - V)_+ = max(R - V(s), 0)`, held fixed in the policy term: the policy is pulled
//! toward the actions it once played where they earned more than it now expects from
//! their state, and toward nothing else; the value toward the returns above it. A kick
//! that scored on some starts among many sampled ones is what this repeats: PPO's own
//! update sees that sample once, in one rollout, beside every other row of it.
//!
//! Rewards and observations are the ones the learner saw (normalised under
//! `[normalize]`, with the moments of their time; the actions the unclipped samples); a
//! truncated episode's last reward already holds `gamma V(s_final)` (PPO bootstraps
//! truncations into the reward), so its returns are bootstrapped there.
//!
//! Rows are drawn with probability proportional to `(R - V)^alpha`, `alpha` =
//! `priority_exponent` (the paper's 0.6; 0, the default, draws uniformly), `V` the value
//! predicted when the row was played.
//!
//! Departures from the paper, each to keep the buffer small and its draws cheap: a row is
//! kept only where its return exceeded the value predicted when it was played (the paper
//! keeps every row, under whose priority `(R - V)_+` such a row weighs nothing unless the
//! value later falls), a row's priority stays the one it was kept with (the paper
//! updates the drawn rows' priorities with the current value) and is not corrected for
//! by importance weights (the paper's exponent 0.1 nearly leaves them out), and the
//! buffer holds the newest `capacity` rows.

use crate::config::{ConfigError, ensure};
use crate::tensors::gather_rows;
use foosball_nets::{Snapshot, SnapshotError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// `[ppo.self_imitation]`: off unless `coef` > 0.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SelfImitationConfig {
    /// Weight of the policy term (0: off, the default; the paper's 1 beside A2C).
    pub coef: f32,
    /// Weight of the value term (the paper's 0.01).
    pub value_coef: f32,
    /// Gradient steps on kept rows after each rollout's PPO update.
    pub updates: usize,
    /// Rows per self-imitation minibatch (the paper's 512).
    pub batch_size: usize,
    /// Rows kept, the newest (the paper keeps 100,000 transitions).
    pub capacity: usize,
    /// `alpha` of the draw's priorities `(R - V)^alpha` (0: uniform; the paper's 0.6).
    pub priority_exponent: f32,
}

impl Default for SelfImitationConfig {
    fn default() -> Self {
        Self {
            coef: 0.0,
            value_coef: 0.01,
            updates: 10,
            batch_size: 512,
            capacity: 100_000,
            priority_exponent: 0.0,
        }
    }
}

impl SelfImitationConfig {
    /// Whether the learner imitates itself at all.
    pub fn enabled(&self) -> bool {
        self.coef > 0.0
    }

    /// Rejects invalid settings, naming the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        ensure(
            self.coef.is_finite() && self.coef >= 0.0,
            "coef",
            "must be finite and >= 0",
        )?;
        ensure(
            self.value_coef.is_finite() && self.value_coef >= 0.0,
            "value_coef",
            "must be finite and >= 0",
        )?;
        ensure(self.updates > 0, "updates", "must be positive")?;
        ensure(self.batch_size > 0, "batch_size", "must be positive")?;
        ensure(
            self.priority_exponent.is_finite() && self.priority_exponent >= 0.0,
            "priority_exponent",
            "must be finite and >= 0",
        )?;
        ensure(
            self.capacity >= self.batch_size,
            "capacity",
            "must be at least batch_size",
        )
    }
}

/// `R_t = r_t + gamma R_(t+1)` over one episode's `rewards`, `R` after the last 0.
pub fn discounted_returns(rewards: &[f32], gamma: f32) -> Vec<f32> {
    let mut returns = vec![0.0; rewards.len()];
    let mut running = 0.0;
    for (t, &r) in rewards.iter().enumerate().rev() {
        running = r + gamma * running;
        returns[t] = running;
    }
    returns
}

/// One env's episode so far.
#[derive(Clone, Debug, Default)]
struct Running {
    obs: Vec<f32>,
    actions: Vec<f32>,
    rewards: Vec<f32>,
    values: Vec<f32>,
}

/// Rows: observations, actions, returns.
pub struct Batch {
    /// Observations, `[batch, obs_dim]`.
    pub obs: Vec<f32>,
    /// Actions as sampled (unclipped), `[batch, action_dim]`.
    pub actions: Vec<f32>,
    /// Discounted returns from each row to its episode's end, `[batch]`.
    pub returns: Vec<f32>,
}

/// The episodes being played and the rows kept from finished ones: as many as were kept
/// (at most `capacity`, the oldest overwritten first) and the priority of each, `[rows]`.
pub struct SelfImitation {
    config: SelfImitationConfig,
    gamma: f32,
    dims: (usize, usize),
    running: Vec<Running>,
    kept: Batch,
    priorities: Vec<f32>,
    /// Where the next kept row goes once the buffer is full.
    next: usize,
    rng: ChaCha8Rng,
}

impl SelfImitation {
    /// An empty buffer for `(obs_dim, action_dim)` rows; minibatches drawn from `seed`'s
    /// stream 1 (PPO's own draws stay on stream 0).
    pub fn new(config: SelfImitationConfig, gamma: f32, dims: (usize, usize), seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(1);
        Self {
            config,
            gamma,
            dims,
            running: Vec::new(),
            kept: Batch {
                obs: Vec::new(),
                actions: Vec::new(),
                returns: Vec::new(),
            },
            priorities: Vec::new(),
            next: 0,
            rng,
        }
    }

    /// Rows kept so far.
    pub fn len(&self) -> usize {
        self.kept.returns.len()
    }

    /// Whether no row is kept.
    pub fn is_empty(&self) -> bool {
        self.kept.returns.is_empty()
    }

    /// One vec-env step of `n` envs: observations acted on `[n, obs_dim]`, the sampled
    /// actions `[n, action_dim]`, rewards (truncations bootstrapped), the values
    /// predicted when acting and whether each env's episode ended, all `[n]`. An ended
    /// episode's rows whose return beats their value are kept.
    pub fn record(
        &mut self,
        obs: &[f32],
        actions: &[f32],
        (rewards, values): (&[f32], &[f32]),
        dones: &[f32],
    ) {
        let (o, a) = self.dims;
        let n = rewards.len();
        self.running.resize_with(n, Running::default);
        for i in 0..n {
            let e = &mut self.running[i];
            e.obs.extend_from_slice(&obs[i * o..(i + 1) * o]);
            e.actions.extend_from_slice(&actions[i * a..(i + 1) * a]);
            e.rewards.push(rewards[i]);
            e.values.push(values[i]);
            if dones[i] != 0.0 {
                let episode = std::mem::take(e);
                self.keep(&episode);
            }
        }
    }

    fn keep(&mut self, e: &Running) {
        let (o, a) = self.dims;
        let returns = discounted_returns(&e.rewards, self.gamma);
        for (t, (&ret, &value)) in returns.iter().zip(&e.values).enumerate() {
            if ret <= value {
                continue;
            }
            let (obs, actions) = (&e.obs[t * o..(t + 1) * o], &e.actions[t * a..(t + 1) * a]);
            let priority = (ret - value).powf(self.config.priority_exponent);
            let k = &mut self.kept;
            if k.returns.len() < self.config.capacity {
                k.obs.extend_from_slice(obs);
                k.actions.extend_from_slice(actions);
                k.returns.push(ret);
                self.priorities.push(priority);
            } else {
                let j = self.next;
                k.obs[j * o..(j + 1) * o].copy_from_slice(obs);
                k.actions[j * a..(j + 1) * a].copy_from_slice(actions);
                k.returns[j] = ret;
                self.priorities[j] = priority;
                self.next = (j + 1) % self.config.capacity;
            }
        }
    }

    /// `count` minibatches of `batch_size` kept rows, each drawn with replacement by
    /// priority (the priorities summed once for all of them); none while fewer than
    /// `batch_size` rows are kept.
    pub fn sample(&mut self, count: usize) -> Vec<Batch> {
        let (o, a) = self.dims;
        let (len, b) = (self.len(), self.config.batch_size);
        if len < b {
            return Vec::new();
        }
        let cumulative: Vec<f64> = if self.config.priority_exponent == 0.0 {
            Vec::new()
        } else {
            self.priorities
                .iter()
                .scan(0.0, |sum, &p| {
                    *sum += f64::from(p);
                    Some(*sum)
                })
                .collect()
        };
        (0..count)
            .map(|_| {
                let picks: Vec<usize> = (0..b)
                    .map(|_| match cumulative.last() {
                        None => self.rng.random_range(0..len),
                        Some(&total) => {
                            let u = self.rng.random_range(0.0..total);
                            cumulative.partition_point(|&c| c <= u).min(len - 1)
                        }
                    })
                    .collect();
                let k = &self.kept;
                Batch {
                    obs: gather_rows(&k.obs, o, &picks),
                    actions: gather_rows(&k.actions, a, &picks),
                    returns: gather_rows(&k.returns, 1, &picks),
                }
            })
            .collect()
    }

    /// Writes the running episodes, the kept rows and the draw state under `name`.
    pub fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>, name: &str) {
        let lengths: Vec<u64> = self
            .running
            .iter()
            .map(|e| e.rewards.len() as u64)
            .collect();
        let joined = |f: fn(&Running) -> &Vec<f32>| -> Vec<f32> {
            self.running
                .iter()
                .flat_map(|e| f(e).iter().copied())
                .collect()
        };
        snap.put_u64s(format!("{name}.running_lengths"), lengths);
        snap.put_f32(format!("{name}.running_obs"), joined(|e| &e.obs));
        snap.put_f32(format!("{name}.running_actions"), joined(|e| &e.actions));
        snap.put_f32(format!("{name}.running_rewards"), joined(|e| &e.rewards));
        snap.put_f32(format!("{name}.running_values"), joined(|e| &e.values));
        snap.put_f32(format!("{name}.obs"), &self.kept.obs[..]);
        snap.put_f32(format!("{name}.actions"), &self.kept.actions[..]);
        snap.put_f32(format!("{name}.returns"), &self.kept.returns[..]);
        snap.put_f32(format!("{name}.priorities"), &self.priorities[..]);
        snap.put_u64(format!("{name}.next"), self.next as u64);
        snap.put_rng(&format!("{name}.rng"), &self.rng);
    }

    /// Reads back what [`SelfImitation::save_state`] wrote under `name`.
    pub fn load_state(&mut self, snap: &Snapshot<'_>, name: &str) -> Result<(), SnapshotError> {
        let (o, a) = self.dims;
        let lengths = snap.u64s(&format!("{name}.running_lengths"))?;
        let total: usize = lengths.iter().map(|&l| l as usize).sum();
        let obs = snap.f32s_of_len(&format!("{name}.running_obs"), total * o)?;
        let actions = snap.f32s_of_len(&format!("{name}.running_actions"), total * a)?;
        let rewards = snap.f32s_of_len(&format!("{name}.running_rewards"), total)?;
        let values = snap.f32s_of_len(&format!("{name}.running_values"), total)?;
        let mut at = 0;
        self.running = lengths
            .iter()
            .map(|&l| {
                let (s, e) = (at, at + l as usize);
                at = e;
                Running {
                    obs: obs[s * o..e * o].to_vec(),
                    actions: actions[s * a..e * a].to_vec(),
                    rewards: rewards[s..e].to_vec(),
                    values: values[s..e].to_vec(),
                }
            })
            .collect();
        let returns = snap.f32s(&format!("{name}.returns"))?.to_vec();
        let rows = returns.len();
        self.kept = Batch {
            obs: snap.f32s_of_len(&format!("{name}.obs"), rows * o)?.to_vec(),
            actions: snap
                .f32s_of_len(&format!("{name}.actions"), rows * a)?
                .to_vec(),
            returns,
        };
        self.priorities = snap
            .f32s_of_len(&format!("{name}.priorities"), rows)?
            .to_vec();
        self.next = snap.u64(&format!("{name}.next"))? as usize;
        self.rng = snap.rng(&format!("{name}.rng"))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(capacity: usize, batch_size: usize) -> SelfImitationConfig {
        SelfImitationConfig {
            coef: 1.0,
            capacity,
            batch_size,
            ..SelfImitationConfig::default()
        }
    }

    #[test]
    fn returns_are_discounted_to_the_episodes_end() {
        let r = discounted_returns(&[1.0, 0.0, 2.0], 0.5);
        assert_eq!(r, vec![1.5, 1.0, 2.0]);
        assert!(discounted_returns(&[], 0.9).is_empty());
    }

    /// Two envs (obs 1 value, action 1 value): env 0's episode of three steps ends at
    /// the third, env 1's runs on. Only env 0's rows whose return beats their value are
    /// kept, with that return.
    #[test]
    fn finished_episodes_keep_the_rows_that_beat_their_value() {
        let mut s = SelfImitation::new(config(10, 1), 0.5, (1, 1), 0);
        let steps = [
            ([0.0, 10.0], [0.0, 0.0], [0.5, 9.0], [0.0, 0.0]),
            ([1.0, 11.0], [0.0, 0.0], [2.0, 9.0], [0.0, 0.0]),
            ([2.0, 12.0], [4.0, 0.0], [1.0, 9.0], [1.0, 0.0]),
        ];
        for (obs, rewards, values, dones) in steps {
            let actions = obs.map(|x| -x);
            s.record(&obs, &actions, (&rewards, &values), &dones);
        }
        // Returns of env 0: 1.0, 2.0, 4.0 against values 0.5, 2.0, 1.0: rows 0 and 2.
        assert_eq!(s.kept.obs, vec![0.0, 2.0]);
        assert_eq!(s.kept.actions, vec![-0.0, -2.0]);
        assert_eq!(s.kept.returns, vec![1.0, 4.0]);
        assert_eq!(s.running[1].rewards.len(), 3, "env 1 still plays");
        assert!(s.running[0].rewards.is_empty(), "env 0 starts afresh");
    }

    #[test]
    fn a_full_buffer_overwrites_its_oldest_rows() {
        let mut s = SelfImitation::new(config(3, 2), 0.0, (1, 1), 0);
        assert!(s.sample(1).is_empty());
        for x in 0..5 {
            s.record(&[x as f32], &[0.0], (&[1.0], &[0.0]), &[1.0]);
        }
        assert_eq!(s.kept.obs, vec![3.0, 4.0, 2.0]);
        let b = s.sample(1).remove(0);
        assert_eq!(b.returns.len(), 2);
        assert!(b.obs.iter().all(|x| [2.0, 3.0, 4.0].contains(x)));
    }

    /// Rows kept with gaps 1 and 9 (returns over values), exponent 0.5: drawn about 1 : 3.
    #[test]
    fn draws_follow_the_priorities() {
        let mut c = config(2, 1);
        c.priority_exponent = 0.5;
        let mut s = SelfImitation::new(c, 0.0, (1, 1), 3);
        s.record(&[0.0], &[0.0], (&[1.0], &[0.0]), &[1.0]);
        s.record(&[1.0], &[0.0], (&[10.0], &[1.0]), &[1.0]);
        assert_eq!(s.priorities, vec![1.0, 3.0]);
        let ones = (0..4000).filter(|_| s.sample(1)[0].obs[0] == 1.0).count();
        assert!((ones as f64 / 4000.0 - 0.75).abs() < 0.03, "{ones}");
    }

    #[test]
    fn a_snapshot_resumes_the_episodes_rows_and_draws() {
        let mut c = config(4, 2);
        c.priority_exponent = 0.6;
        let mut s = SelfImitation::new(c.clone(), 0.9, (2, 1), 7);
        let step = |s: &mut SelfImitation, k: usize| {
            let obs = [k as f32, 1.0, -(k as f32), 2.0];
            let done = [if k % 3 == 2 { 1.0 } else { 0.0 }, 0.0];
            s.record(&obs, &[0.1, 0.2], (&[1.0, 0.5], &[0.0, 0.0]), &done);
        };
        for k in 0..7 {
            step(&mut s, k);
        }
        s.sample(1);
        let path = std::env::temp_dir().join(format!("sil-{}.bin", std::process::id()));
        {
            let mut snap = Snapshot::new();
            s.save_state(&mut snap, "sil");
            snap.write(&path).unwrap();
        }
        let read = Snapshot::read(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        let mut resumed = SelfImitation::new(c, 0.9, (2, 1), 0);
        resumed.load_state(&read, "sil").unwrap();
        for k in 7..12 {
            step(&mut s, k);
            step(&mut resumed, k);
        }
        let (a, b) = (s.sample(1).remove(0), resumed.sample(1).remove(0));
        assert_eq!((a.obs, a.actions, a.returns), (b.obs, b.actions, b.returns));
        assert_eq!(s.running[1].rewards, resumed.running[1].rewards);
    }

    #[test]
    fn bad_settings_are_refused_by_key() {
        for (c, key) in [
            (
                SelfImitationConfig {
                    coef: -1.0,
                    ..SelfImitationConfig::default()
                },
                "coef",
            ),
            (
                SelfImitationConfig {
                    updates: 0,
                    ..SelfImitationConfig::default()
                },
                "updates",
            ),
            (
                SelfImitationConfig {
                    priority_exponent: f32::NAN,
                    ..SelfImitationConfig::default()
                },
                "priority_exponent",
            ),
            (
                SelfImitationConfig {
                    capacity: 10,
                    ..SelfImitationConfig::default()
                },
                "capacity",
            ),
        ] {
            let e = c.validate().unwrap_err().to_string();
            assert!(e.contains(key), "{e}");
        }
        assert!(!SelfImitationConfig::default().enabled());
        SelfImitationConfig::default().validate().unwrap();
    }
}
