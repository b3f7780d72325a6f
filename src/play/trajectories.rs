//! Recorded episodes and their file, `trajectories.bin`: little-endian, magic `FSBT`,
//! `u32` version 1, `u32` obs_dim, `u32` action_dim, `u64` episodes; then per episode
//! `u64` seed, `u32` steps T, `f32` observations `[T, obs_dim]`, `f32` actions
//! `[T, action_dim]`, `f32` rewards `[T]`.

use std::path::Path;

/// One episode's steps: the table's states acted on `[T, 38]` (noise-free, whatever the
/// agent observes), actions `[T, action_dim]`, rewards `[T]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectory {
    /// States, row-major (foosball's 38-dim layout).
    pub obs: Vec<f32>,
    /// Actions, row-major, in `[-1, 1]`.
    pub actions: Vec<f32>,
    /// Rewards.
    pub rewards: Vec<f32>,
}

/// The `trajectories.bin` bytes of `episodes`, each its reset seed and its steps.
pub fn trajectories_bytes(
    episodes: &[(u64, &Trajectory)],
    obs_dim: usize,
    action_dim: usize,
) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(b"FSBT");
    out.extend_from_slice(&1u32.to_le_bytes());
    out.extend_from_slice(&(obs_dim as u32).to_le_bytes());
    out.extend_from_slice(&(action_dim as u32).to_le_bytes());
    out.extend_from_slice(&(episodes.len() as u64).to_le_bytes());
    for (seed, t) in episodes {
        out.extend_from_slice(&seed.to_le_bytes());
        out.extend_from_slice(&(t.rewards.len() as u32).to_le_bytes());
        for x in t.obs.iter().chain(&t.actions).chain(&t.rewards) {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    out
}

/// One episode read back from `trajectories.bin`.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedEpisode {
    /// The seed it was reset with.
    pub seed: u64,
    /// Its steps.
    pub trajectory: Trajectory,
}

impl RecordedEpisode {
    /// Its undiscounted return.
    pub fn ret(&self) -> f64 {
        self.trajectory.rewards.iter().map(|&r| f64::from(r)).sum()
    }

    /// Whether the ball was seen in black's goal: some observed ball y at or past
    /// `goal_line_y`, cm (the rules' `reward.goal_line_y`; foosball's 38-dim layout).
    pub fn scored(&self, goal_line_y: f32) -> bool {
        use foosball_env::layout;
        self.trajectory
            .obs
            .chunks_exact(layout::OBS_DIM)
            .any(|o| o[layout::BALL_POS.start + 1] >= goal_line_y)
    }
}

/// Indices of `episodes` from the highest return to the lowest (ties in index order).
pub fn by_return(episodes: &[RecordedEpisode]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..episodes.len()).collect();
    order.sort_by(|&a, &b| episodes[b].ret().total_cmp(&episodes[a].ret()));
    order
}

/// Reads a `trajectories.bin` written by [`trajectories_bytes`] (any observation and action
/// widths); the error says what is wrong with the file (another format or version, cut
/// short).
pub fn read_trajectories(path: &Path) -> Result<Vec<RecordedEpisode>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let fail = |what: String| format!("{}: {what}", path.display());
    let mut cursor = Cursor {
        bytes: &bytes,
        at: 0,
    };
    if cursor.take(4).map_err(&fail)? != b"FSBT" {
        return Err(fail("not a trajectories file (no FSBT magic)".into()));
    }
    let version = cursor.u32().map_err(&fail)?;
    if version != 1 {
        return Err(fail(format!(
            "format version {version}; this build reads version 1"
        )));
    }
    let obs_dim = cursor.u32().map_err(&fail)? as usize;
    let action_dim = cursor.u32().map_err(&fail)? as usize;
    let n = cursor.u64().map_err(&fail)?;
    (0..n)
        .map(|_| {
            let seed = cursor.u64()?;
            let steps = cursor.u32()? as usize;
            Ok(RecordedEpisode {
                seed,
                trajectory: Trajectory {
                    obs: cursor.f32s(steps * obs_dim)?,
                    actions: cursor.f32s(steps * action_dim)?,
                    rewards: cursor.f32s(steps)?,
                },
            })
        })
        .collect::<Result<_, String>>()
        .map_err(fail)
}

/// Little-endian reads from a byte slice; running out is an error naming the offset.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Cursor<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        let chunk = self.bytes.get(self.at..self.at + n).ok_or_else(|| {
            format!(
                "truncated at byte {} (file of {} bytes)",
                self.at,
                self.bytes.len()
            )
        })?;
        self.at += n;
        Ok(chunk)
    }

    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }

    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }

    fn f32s(&mut self, n: usize) -> Result<Vec<f32>, String> {
        Ok(self
            .take(4 * n)?
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect())
    }
}
