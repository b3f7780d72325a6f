//! Self-play training: black is drawn per training episode from a pool of the learner's
//! own snapshots and fixed anchors (`[self_play]` in a run configuration).
//!
//! - Snapshots: every `snapshot_every` env steps (the first at step 0) the learner's
//!   networks are saved as `RUN/pool/step-N/` (a `config.toml` and `last/`, so a snapshot
//!   is a contestant of `league` and `evaluate --opponent` like any run) and join the pool.
//! - Draw per episode ([`pool::Pool::choose`]): the newest snapshot (`latest_share`), a
//!   fixed opponent (`anchor_share`: built-in black policies, `anchors`, and other
//!   contestants, `rivals`: a trained run's networks, `blocker`), else a snapshot among
//!   the newest `pool_size` by prioritised fictitious self-play, weight
//!   `(1 - p)^pfsp_power` with `p` the learner's points share against it so far.
//! - The learner's table: the run's own, with black's goals counted (the own-goal line is
//!   black's goal line mirrored, as in matches), `conceded_penalty` lost per step while
//!   the ball lies in yellow's goal, and no "no progress" end unless `no_progress_end`
//!   (black attacks the other way; with it, an episode ends 15 steps into any attack of
//!   black's and the learner never sees a goal against it), a `black_serve_share` of the
//!   serves turned 180 degrees onto black's side (black's kick-off, which the learner meets
//!   as black in every other match), or under `serve = "conceded"` every ball served as a
//!   match serves it (the side scored upon); under `serve_again` every point's end (a goal, a dead
//!   ball) serves again and the episode runs to `episode_steps`, as a match does;
//!   everything else (reward, other ends) as configured.
//!   Evaluations and the test still play `env.opponent`, so curves stay comparable.
//! - Resumable: the checkpoint holds the snapshot list and the records; reproducible:
//!   the draws come from each environment's own stream and the pool changes only between
//!   vec-env steps. `RUN/pool/pool.json` and `pool.md` give the records at each checkpoint.

pub mod opponent;
pub mod pool;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use foosball_algos::Agent;
use foosball_env::roster::opponent_for;
use foosball_env::seeding::{RIVALS, derive_seed};
use foosball_env::{FoosballConfig, FoosballEnv, FoosballInfo, Opponent};
use serde::Serialize;

use crate::config::{Checkpoint, RunConfig, SelfPlayConfig, TestActions};
use crate::files::{RunFileError, write_atomic};
use crate::play::contestant::Contestant;
use crate::play::matches::{PolicyOpponent, symmetric_goals};
use opponent::PoolOpponent;
use pool::{Member, Pool, PoolState, Record, snapshot_name};

/// The pool folder inside a run directory.
pub const POOL_DIR: &str = "pool";

/// What went wrong in self-play.
#[derive(Debug, thiserror::Error)]
pub enum SelfPlayError {
    /// A snapshot could not be saved.
    #[error("{dir}: cannot save the snapshot: {message}")]
    Save {
        /// The snapshot directory.
        dir: PathBuf,
        /// Why.
        message: String,
    },
    /// A snapshot could not be loaded (e.g. a resumed run whose pool folder is gone).
    #[error("self-play pool: {0}")]
    Load(String),
    /// A run file could not be written.
    #[error(transparent)]
    File(#[from] RunFileError),
    /// The training table was refused.
    #[error("self-play table: env.{0}")]
    Env(String),
    /// A rival is not a contestant, or cannot play on the learner's table.
    #[error("self_play.rivals: {0}")]
    Rival(String),
}

/// A self-play run's pool, its snapshot schedule and where it writes.
pub struct SelfPlay {
    pool: Arc<Pool>,
    rivals: Vec<Contestant>,
    config: RunConfig,
    table: FoosballConfig,
    dir: PathBuf,
    next_snapshot: u64,
}

/// `env` as the learner plays it in self-play (module docs): black's goals count against
/// it; no "no progress" end unless `sp.no_progress_end`; a `sp.black_serve_share` of the
/// serves on black's side, or served as a match under `sp.serve = "conceded"`;
/// `sp.serve_again` and `sp.episode_steps` as the table's.
pub fn self_play_table(env: &FoosballConfig, sp: &SelfPlayConfig) -> FoosballConfig {
    let mut t = symmetric_goals(env);
    t.reward.conceded_penalty = sp.conceded_penalty;
    if !sp.no_progress_end {
        t.rules.no_progress_steps = u32::MAX;
    }
    t.start.black_share = sp.black_serve_share;
    t.start.serve = sp.serve;
    t.rules.serve_again = sp.serve_again;
    if let Some(steps) = sp.episode_steps {
        t.max_episode_steps = steps;
    }
    t
}

impl SelfPlay {
    /// The pool of `config`'s run in `run_dir` for `envs` environments: empty (fresh) or
    /// as a checkpoint left it, its snapshots loaded again from `RUN/pool/`. Each rival
    /// must name a contestant.
    pub fn start(
        config: &RunConfig,
        sp: &SelfPlayConfig,
        run_dir: &Path,
        envs: usize,
        checkpoint: Option<&PoolState>,
    ) -> Result<Self, SelfPlayError> {
        let rivals = sp
            .rivals
            .iter()
            .map(|name| name.parse::<Contestant>().map_err(SelfPlayError::Rival))
            .collect::<Result<_, _>>()?;
        let mut this = Self {
            pool: Arc::new(Pool::new(sp, envs)),
            rivals,
            config: config.clone(),
            table: self_play_table(&config.env, sp),
            dir: run_dir.join(POOL_DIR),
            next_snapshot: 0,
        };
        if let Some(state) = checkpoint {
            for &step in &state.snapshots {
                this.join(step)?;
                this.next_snapshot = step + sp.snapshot_every;
            }
            this.pool.restore_records(&state.records);
        }
        Ok(this)
    }

    /// `n` training environments, black in each drawn from the pool.
    pub fn envs(&self, n: usize) -> Result<Vec<FoosballEnv>, SelfPlayError> {
        (0..n)
            .map(|i| {
                let black = Box::new(PoolOpponent::new(
                    self.pool.clone(),
                    i,
                    self.fixed_opponents(i)?,
                ));
                FoosballEnv::with_opponent(self.table.clone(), black)
                    .map_err(|e| SelfPlayError::Env(e.to_string()))
            })
            .collect()
    }

    /// Environment `env`'s own copies of the anchors, then of the rivals (seeded by
    /// [`RIVALS`] and `env`).
    fn fixed_opponents(&self, env: usize) -> Result<Vec<Box<dyn Opponent>>, SelfPlayError> {
        let anchors = self
            .pool
            .config()
            .anchors
            .iter()
            .map(|&k| Ok(opponent_for(k)));
        let seed = derive_seed(self.config.protocol.seed, RIVALS, env as u64);
        let rivals = self.rivals.iter().map(|rival| {
            let policy = rival
                .policy(&self.table, seed)
                .map_err(|why| SelfPlayError::Rival(format!("`{rival}`: {why}")))?;
            Ok(Box::new(PolicyOpponent::new(policy, self.table.ball_frame)) as Box<dyn Opponent>)
        });
        anchors.chain(rivals).collect()
    }

    /// Takes a snapshot of `agent` if one is due at `env_steps`.
    pub fn after_step(&mut self, env_steps: u64, agent: &dyn Agent) -> Result<(), SelfPlayError> {
        if env_steps < self.next_snapshot {
            return Ok(());
        }
        let step = self.next_snapshot;
        let dir = self.dir.join(snapshot_name(step));
        let networks = dir.join(Checkpoint::Last.name());
        let save_error = |message: String| SelfPlayError::Save {
            dir: dir.clone(),
            message,
        };
        std::fs::create_dir_all(&networks).map_err(|e| save_error(e.to_string()))?;
        agent
            .save(&networks)
            .map_err(|e| save_error(e.to_string()))?;
        let mut snapshot_config = self.config.clone();
        snapshot_config.self_play = None;
        write_atomic(
            &dir.join("config.toml"),
            snapshot_config.to_toml().as_bytes(),
        )?;
        self.join(step)?;
        self.next_snapshot = step + self.pool.config().snapshot_every;
        Ok(())
    }

    /// Loads the snapshot of `step` from the pool folder into the pool.
    fn join(&self, step: u64) -> Result<(), SelfPlayError> {
        let contestant = Contestant::Run {
            dir: self.dir.join(snapshot_name(step)),
            checkpoint: Checkpoint::Last,
            actions: TestActions::Deterministic,
        };
        let policy = contestant
            .policy(&self.table, 0)
            .map_err(SelfPlayError::Load)?;
        self.pool
            .add_snapshot(step, PolicyOpponent::new(policy, self.table.ball_frame));
        Ok(())
    }

    /// Records the training episode environment `env` just ended.
    pub fn on_episode(&self, env: usize, info: &FoosballInfo) {
        self.pool.record(env, info.goals);
    }

    /// The pool's part of a checkpoint.
    pub fn state(&self) -> PoolState {
        self.pool.state()
    }

    /// Writes `RUN/pool/pool.json` and `pool.md`: every opponent with the learner's record
    /// against it, at env step `env_steps`.
    pub fn write_records(&self, env_steps: u64) -> Result<(), SelfPlayError> {
        let rows: Vec<RecordRow> = self
            .pool
            .entries()
            .iter()
            .map(|e| RecordRow {
                opponent: e.name(),
                in_play: match &e.member {
                    Member::Anchor(_) => true,
                    Member::Snapshot { policy, .. } => policy.is_some(),
                },
                record: e.record,
                points_share: e.record.points_share(),
            })
            .collect();
        let json = serde_json::json!({ "env_steps": env_steps, "opponents": rows });
        let text = serde_json::to_string_pretty(&json).expect("records serialise");
        write_atomic(&self.dir.join("pool.json"), text.as_bytes())?;
        let mut md = format!(
            "# Self-play pool at env step {env_steps}\n\n| opponent | in play | episodes | \
             learner wins | draws | losses | learner points share |\n|---|---|---:|---:|---:|---:|---:|\n"
        );
        for r in &rows {
            let Record { games, wins, draws } = r.record;
            md += &format!(
                "| {} | {} | {games} | {wins} | {draws} | {} | {:.3} |\n",
                r.opponent,
                if r.in_play { "yes" } else { "no" },
                games - wins - draws,
                r.points_share
            );
        }
        write_atomic(&self.dir.join("pool.md"), md.as_bytes())?;
        Ok(())
    }
}

#[derive(Serialize)]
struct RecordRow {
    opponent: String,
    in_play: bool,
    #[serde(flatten)]
    record: Record,
    points_share: f64,
}
