//! The replay buffer shared by SAC and TD3: a pre-allocated ring of flat rows, its
//! observations as `f32`, or for images as byte planes each stored once (see
//! [`crate::plane_store`]; images arrive as `byte / 255`, so the bytes give back the very
//! same floats).

use crate::plane_store::PlaneStore;
use foosball_nets::{ObsShape, Snapshot, SnapshotError};
use rand::Rng;

/// One uniformly sampled minibatch, row-major: `obs`/`next_obs` `[batch, obs_dim]`,
/// `actions` `[batch, action_dim]`, `rewards` and `dones` `[batch]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReplayBatch {
    /// Observations the actions were taken in.
    pub obs: Vec<f32>,
    /// Actions taken, in `[-1, 1]`.
    pub actions: Vec<f32>,
    /// Rewards received.
    pub rewards: Vec<f32>,
    /// Observations reached (the final observation where an episode ended).
    pub next_obs: Vec<f32>,
    /// 1 where the episode terminated, 0 otherwise; a time-limit truncation counts as 0
    /// so its target bootstraps (SB3's `handle_timeout_termination`).
    pub dones: Vec<f32>,
    /// How many leading rows are demonstrations (`off_policy.demo_share`); 0 without.
    pub demos: usize,
}

impl ReplayBatch {
    /// Appends `other`'s rows after this batch's (its `demos` count is not carried).
    pub fn extend(&mut self, other: ReplayBatch) {
        self.obs.extend(other.obs);
        self.actions.extend(other.actions);
        self.rewards.extend(other.rewards);
        self.next_obs.extend(other.next_obs);
        self.dones.extend(other.dones);
    }
}

/// A ring buffer of transitions with a fixed capacity, allocated once; the oldest row
/// is overwritten when full. It is cleared only by building a new one (between seeds).
#[derive(Clone, Debug, PartialEq)]
pub struct ReplayBuffer {
    obs_dim: usize,
    action_dim: usize,
    capacity: usize,
    observations: Observations,
    actions: Vec<f32>,
    rewards: Vec<f32>,
    terminated: Vec<bool>,
    timeouts: Vec<bool>,
    pos: usize,
    len: usize,
}

impl ReplayBuffer {
    /// An empty buffer of `capacity` rows (zeroed memory is committed by the OS as rows
    /// are written, so a 1e6 buffer costs little until it fills).
    pub fn new(capacity: usize, obs_dim: usize, action_dim: usize) -> Self {
        Self::with_storage(capacity, obs_dim, action_dim, None)
    }

    /// [`ReplayBuffer::new`] for observations of `shape`: images are stored as byte
    /// planes, each distinct plane once.
    pub fn for_obs(capacity: usize, shape: ObsShape, action_dim: usize) -> Self {
        let planes = match shape {
            ObsShape::Image {
                channels,
                height,
                width,
            } => Some(PlaneStore::new(capacity, channels, height * width)),
            ObsShape::Vector(_) => None,
        };
        Self::with_storage(capacity, shape.dim(), action_dim, planes)
    }

    fn with_storage(
        capacity: usize,
        obs_dim: usize,
        action_dim: usize,
        planes: Option<PlaneStore>,
    ) -> Self {
        assert!(capacity > 0, "replay capacity must be positive");
        let observations = match planes {
            Some(store) => Observations::Planes(store),
            None => Observations::Floats {
                obs: vec![0.0; capacity * obs_dim],
                next_obs: vec![0.0; capacity * obs_dim],
            },
        };
        Self {
            obs_dim,
            action_dim,
            capacity,
            observations,
            actions: vec![0.0; capacity * action_dim],
            rewards: vec![0.0; capacity],
            terminated: vec![false; capacity],
            timeouts: vec![false; capacity],
            pos: 0,
            len: 0,
        }
    }

    /// Rows stored (at most the capacity).
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no row is stored.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Maximum rows.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Bytes the observations and next observations hold (for images: the planes
    /// stored so far and the rows' plane ids).
    pub fn observation_bytes(&self) -> usize {
        match &self.observations {
            Observations::Floats { obs, next_obs } => 4 * (obs.len() + next_obs.len()),
            Observations::Planes(store) => store.bytes_held(),
        }
    }

    /// Index the next row will be written at.
    pub fn position(&self) -> usize {
        self.pos
    }

    /// Stores one transition. `timeout` marks a time-limit truncation: the row is then not
    /// terminal for the target even if the env reported it done by time.
    pub fn push(
        &mut self,
        obs: &[f32],
        action: &[f32],
        reward: f32,
        next_obs: &[f32],
        terminated: bool,
        timeout: bool,
    ) {
        let (o, a, i) = (self.obs_dim, self.action_dim, self.pos);
        self.observations.write(i, o, obs, next_obs);
        self.actions[i * a..(i + 1) * a].copy_from_slice(action);
        self.rewards[i] = reward;
        self.terminated[i] = terminated;
        self.timeouts[i] = timeout && !terminated;
        self.pos = (i + 1) % self.capacity;
        self.len = (self.len + 1).min(self.capacity);
    }

    /// Stores the filled rows and the write position under `prefix` (borrowed, not
    /// copied; rows never written are left out).
    pub fn save_state<'a>(&'a self, snap: &mut Snapshot<'a>, prefix: &str) {
        let (o, a, n) = (self.obs_dim, self.action_dim, self.len);
        snap.put_u64(format!("{prefix}.len"), n as u64);
        snap.put_u64(format!("{prefix}.pos"), self.pos as u64);
        self.observations.save(snap, prefix, n, o);
        snap.put_f32(format!("{prefix}.actions"), &self.actions[..n * a]);
        snap.put_f32(format!("{prefix}.rewards"), &self.rewards[..n]);
        snap.put_bools(format!("{prefix}.terminated"), &self.terminated[..n]);
        snap.put_bools(format!("{prefix}.timeouts"), &self.timeouts[..n]);
    }

    /// Restores what [`ReplayBuffer::save_state`] stored under `prefix` into this buffer
    /// (same capacity and widths).
    pub fn load_state(&mut self, snap: &Snapshot<'_>, prefix: &str) -> Result<(), SnapshotError> {
        let (o, a) = (self.obs_dim, self.action_dim);
        let key = |k: &str| format!("{prefix}.{k}");
        let n = snap.u64(&key("len"))? as usize;
        let pos = snap.u64(&key("pos"))? as usize;
        if n > self.capacity || pos >= self.capacity || (n < self.capacity && pos != n) {
            return Err(SnapshotError::Entry {
                name: key("len"),
                message: format!(
                    "{n} rows at position {pos} do not fit a buffer of {} rows",
                    self.capacity
                ),
            });
        }
        let terminated = snap.bools_of_len(&key("terminated"), n)?;
        let timeouts = snap.bools_of_len(&key("timeouts"), n)?;
        self.observations.load(snap, prefix, n, o)?;
        self.actions[..n * a].copy_from_slice(snap.f32s_of_len(&key("actions"), n * a)?);
        self.rewards[..n].copy_from_slice(snap.f32s_of_len(&key("rewards"), n)?);
        self.terminated[..n].copy_from_slice(&terminated);
        self.timeouts[..n].copy_from_slice(&timeouts);
        self.len = n;
        self.pos = pos;
        Ok(())
    }

    /// `batch_size` rows drawn uniformly with replacement from those stored.
    pub fn sample(&self, batch_size: usize, rng: &mut impl Rng) -> ReplayBatch {
        assert!(!self.is_empty(), "sampling an empty replay buffer");
        let (o, a) = (self.obs_dim, self.action_dim);
        let mut batch = ReplayBatch {
            obs: Vec::with_capacity(batch_size * o),
            actions: Vec::with_capacity(batch_size * a),
            rewards: Vec::with_capacity(batch_size),
            next_obs: Vec::with_capacity(batch_size * o),
            dones: Vec::with_capacity(batch_size),
            demos: 0,
        };
        for _ in 0..batch_size {
            let i = rng.random_range(0..self.len);
            self.observations.read(i, o, false, &mut batch.obs);
            batch
                .actions
                .extend_from_slice(&self.actions[i * a..(i + 1) * a]);
            batch.rewards.push(self.rewards[i]);
            self.observations.read(i, o, true, &mut batch.next_obs);
            let done = self.terminated[i] && !self.timeouts[i];
            batch.dones.push(if done { 1.0 } else { 0.0 });
        }
        batch
    }
}

/// Observation and next observation of each row: floats `[row][obs_dim]`, or image
/// planes.
#[derive(Clone, Debug, PartialEq)]
enum Observations {
    Floats { obs: Vec<f32>, next_obs: Vec<f32> },
    Planes(PlaneStore),
}

impl Observations {
    /// Stores row `row`'s pair, each `o` values long.
    fn write(&mut self, row: usize, o: usize, obs: &[f32], next: &[f32]) {
        match self {
            Observations::Floats { obs: all, next_obs } => {
                all[row * o..(row + 1) * o].copy_from_slice(obs);
                next_obs[row * o..(row + 1) * o].copy_from_slice(next);
            }
            Observations::Planes(store) => store.write(row, obs, next),
        }
    }

    /// Appends row `row`'s observation (or, with `next`, its next observation) to `out`.
    fn read(&self, row: usize, o: usize, next: bool, out: &mut Vec<f32>) {
        match self {
            Observations::Floats { obs, next_obs } => {
                let rows = if next { next_obs } else { obs };
                out.extend_from_slice(&rows[row * o..(row + 1) * o]);
            }
            Observations::Planes(store) => store.read(row, next, out),
        }
    }

    fn save<'a>(&'a self, snap: &mut Snapshot<'a>, prefix: &str, rows: usize, o: usize) {
        match self {
            Observations::Floats { obs, next_obs } => {
                snap.put_f32(format!("{prefix}.obs"), &obs[..rows * o]);
                snap.put_f32(format!("{prefix}.next_obs"), &next_obs[..rows * o]);
            }
            Observations::Planes(store) => store.save(snap, prefix, rows),
        }
    }

    fn load(
        &mut self,
        snap: &Snapshot<'_>,
        prefix: &str,
        rows: usize,
        o: usize,
    ) -> Result<(), SnapshotError> {
        match self {
            Observations::Floats { obs, next_obs } => {
                let n = rows * o;
                obs[..n].copy_from_slice(snap.f32s_of_len(&format!("{prefix}.obs"), n)?);
                next_obs[..n].copy_from_slice(snap.f32s_of_len(&format!("{prefix}.next_obs"), n)?);
            }
            Observations::Planes(store) => store.load(snap, prefix, rows)?,
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// Row `row`'s observation, or with `next` its next observation.
    fn stored(buffer: &ReplayBuffer, row: usize, next: bool) -> Vec<f32> {
        let mut out = Vec::new();
        buffer
            .observations
            .read(row, buffer.obs_dim, next, &mut out);
        out
    }

    fn row(buffer: &mut ReplayBuffer, k: usize, terminated: bool, timeout: bool) {
        let x = k as f32;
        buffer.push(
            &[x, -x],
            &[x / 10.0],
            x,
            &[x + 1.0, -x - 1.0],
            terminated,
            timeout,
        );
    }

    #[test]
    fn the_ring_wraps_around_and_keeps_the_newest_rows() {
        let mut buffer = ReplayBuffer::new(3, 2, 1);
        for k in 0..5 {
            row(&mut buffer, k, false, false);
        }
        assert_eq!((buffer.len(), buffer.position()), (3, 2));
        // Rows 3 and 4 overwrote slots 0 and 1; slot 2 still holds row 2.
        assert_eq!(buffer.rewards, vec![3.0, 4.0, 2.0]);
        assert_eq!(stored(&buffer, 0, false), [3.0, -3.0]);
        assert_eq!(stored(&buffer, 2, true), [3.0, -3.0]);
        let batch = buffer.sample(200, &mut ChaCha8Rng::seed_from_u64(0));
        let mut seen: Vec<f32> = batch.rewards.clone();
        seen.sort_by(f32::total_cmp);
        seen.dedup();
        assert_eq!(seen, vec![2.0, 3.0, 4.0]);
        for (k, r) in batch.rewards.iter().enumerate() {
            assert_eq!(batch.obs[2 * k], *r, "rows stay aligned across arrays");
            assert_eq!(batch.actions[k], r / 10.0);
            assert_eq!(batch.next_obs[2 * k], r + 1.0);
        }
    }

    #[test]
    fn a_restored_buffer_samples_and_wraps_like_the_original() {
        for rows in [2, 5] {
            let mut buffer = ReplayBuffer::new(3, 2, 1);
            for k in 0..rows {
                row(&mut buffer, k, k == 1, k == 0);
            }
            let mut snap = Snapshot::new();
            buffer.save_state(&mut snap, "replay");
            let mut restored = ReplayBuffer::new(3, 2, 1);
            restored.load_state(&snap, "replay").unwrap();
            let mut small = ReplayBuffer::new(2, 2, 1);
            let err = small.load_state(&snap, "replay").unwrap_err().to_string();
            assert!(
                err.contains("replay.len") && err.contains("2 rows"),
                "{err}"
            );
            assert_eq!(restored, buffer);
            row(&mut buffer, 9, false, false);
            row(&mut restored, 9, false, false);
            assert_eq!(restored, buffer);
        }
    }

    #[test]
    fn sampling_is_seeded_and_uniform() {
        let mut buffer = ReplayBuffer::new(10, 2, 1);
        for k in 0..10 {
            row(&mut buffer, k, false, false);
        }
        let a = buffer.sample(20_000, &mut ChaCha8Rng::seed_from_u64(1));
        assert_eq!(a, buffer.sample(20_000, &mut ChaCha8Rng::seed_from_u64(1)));
        assert_ne!(a, buffer.sample(20_000, &mut ChaCha8Rng::seed_from_u64(2)));
        let mut counts = [0usize; 10];
        for r in &a.rewards {
            counts[*r as usize] += 1;
        }
        // 2000 expected per row; 5 sigma is about 212.
        assert!(
            counts.iter().all(|&c| (1788..=2212).contains(&c)),
            "{counts:?}"
        );
    }

    #[test]
    fn truncations_bootstrap_and_terminations_do_not() {
        let mut buffer = ReplayBuffer::new(4, 2, 1);
        row(&mut buffer, 0, true, false);
        row(&mut buffer, 1, false, true);
        row(&mut buffer, 2, true, true);
        row(&mut buffer, 3, false, false);
        let batch = buffer.sample(400, &mut ChaCha8Rng::seed_from_u64(3));
        for (r, d) in batch.rewards.iter().zip(&batch.dones) {
            let expected = if *r == 0.0 || *r == 2.0 { 1.0 } else { 0.0 };
            assert_eq!(*d, expected, "row {r}");
        }
    }

    #[test]
    fn image_rows_are_bytes_and_give_back_the_same_floats() {
        let shape = ObsShape::Image {
            channels: 1,
            height: 2,
            width: 2,
        };
        let mut bytes = ReplayBuffer::for_obs(4, shape, 1);
        let mut floats = ReplayBuffer::new(4, 4, 1);
        assert!(matches!(bytes.observations, Observations::Planes(_)));
        for k in 0..6u8 {
            let obs: Vec<f32> = (0..4).map(|j| f32::from(40 * k + j) / 255.0).collect();
            let next: Vec<f32> = (0..4)
                .map(|j| f32::from(250 - 40 * k - j) / 255.0)
                .collect();
            for b in [&mut bytes, &mut floats] {
                b.push(&obs, &[0.5], f32::from(k), &next, k == 3, false);
            }
        }
        let draw = |b: &ReplayBuffer| b.sample(16, &mut ChaCha8Rng::seed_from_u64(5));
        assert_eq!(draw(&bytes), draw(&floats));
        // Saved and restored as bytes; a float buffer cannot take them.
        let mut snap = Snapshot::new();
        bytes.save_state(&mut snap, "r");
        let mut back = ReplayBuffer::for_obs(4, shape, 1);
        back.load_state(&snap, "r").unwrap();
        assert_eq!(back, bytes);
        let e = ReplayBuffer::new(4, 4, 1)
            .load_state(&snap, "r")
            .unwrap_err();
        assert!(e.to_string().contains("`r.obs`: missing"), "{e}");
    }
}
