//! The opponent pool of a self-play run: the fixed anchors and the learner's snapshots,
//! each with the learner's record against it, and the draw of an episode's opponent.

use std::sync::{Arc, Mutex, PoisonError, RwLock};

use foosball_nets::{Snapshot, SnapshotError};
use serde::Serialize;

use crate::config::SelfPlayConfig;
use crate::play::matches::PolicyOpponent;

/// The learner's results against one opponent, from its training episodes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Record {
    /// Episodes played.
    pub games: u64,
    /// Episodes in which the learner scored and did not concede.
    pub wins: u64,
    /// Episodes in which it did both or neither.
    pub draws: u64,
}

impl Record {
    /// The learner's points share: `(wins + draws / 2 + 1/2) / (games + 1)` (one virtual
    /// draw as prior, so an opponent never met counts as even).
    pub fn points_share(&self) -> f64 {
        (self.wins as f64 + 0.5 * self.draws as f64 + 0.5) / (self.games as f64 + 1.0)
    }

    /// Adds one episode by its goals, `[learner's, opponent's]` (the info's `goals`):
    /// more is a win, as many a draw.
    pub fn add(&mut self, goals: [u32; 2]) {
        self.games += 1;
        match goals[0].cmp(&goals[1]) {
            std::cmp::Ordering::Greater => self.wins += 1,
            std::cmp::Ordering::Equal => self.draws += 1,
            std::cmp::Ordering::Less => {}
        }
    }
}

/// Who an entry of the pool is.
#[derive(Clone)]
pub enum Member {
    /// A fixed opponent by its name: a built-in black policy (`anchors`) or a rival
    /// (`rivals`). Each environment plays its own copy: the fixed opponents are the pool's
    /// first entries, `anchors` then `rivals` in their order, as
    /// [`super::SelfPlay::envs`] hands every [`super::opponent::PoolOpponent`] its copies.
    Anchor(String),
    /// The learner's networks at env step `step`, shared by the environments (a
    /// deterministic policy, so who calls it first changes nothing).
    Snapshot {
        /// Env step it was taken at.
        step: u64,
        /// Its policy as black; `None` once it fell out of the newest `pool_size`.
        policy: Option<Arc<Mutex<PolicyOpponent>>>,
    },
}

/// One opponent and the learner's record against it.
#[derive(Clone)]
pub struct Entry {
    /// Who.
    pub member: Member,
    /// The learner's results against it.
    pub record: Record,
}

impl Entry {
    /// Its name: the anchor's (`static`, ...), the rival's as configured, or `step-N` for
    /// a snapshot.
    pub fn name(&self) -> String {
        match &self.member {
            Member::Anchor(name) => name.clone(),
            Member::Snapshot { step, .. } => snapshot_name(*step),
        }
    }
}

/// The directory name of the snapshot taken at env step `step`.
pub fn snapshot_name(step: u64) -> String {
    format!("step-{step:09}")
}

/// The pool one run's environments draw from. Entries change only between vec-env steps
/// (the training loop adds snapshots and records results), so what an environment reads
/// during a step is the same whatever the thread count.
pub struct Pool {
    config: SelfPlayConfig,
    entries: RwLock<Vec<Entry>>,
    slots: Vec<Mutex<Slot>>,
}

/// Who an environment's episodes play: the one in progress, and the one that ended last
/// (until the loop has recorded it).
#[derive(Clone, Copy, Debug, Default)]
struct Slot {
    playing: Option<usize>,
    ended: Option<usize>,
}

impl Pool {
    /// The anchors and rivals of `config`, no snapshot yet, for `envs` environments.
    pub fn new(config: &SelfPlayConfig, envs: usize) -> Self {
        let names = config.anchors.iter().map(|kind| kind.name().to_string());
        let entries = names
            .chain(config.rivals.iter().cloned())
            .map(|name| Entry {
                member: Member::Anchor(name),
                record: Record::default(),
            })
            .collect();
        Self {
            config: config.clone(),
            entries: RwLock::new(entries),
            slots: (0..envs).map(|_| Mutex::new(Slot::default())).collect(),
        }
    }

    /// The settings.
    pub fn config(&self) -> &SelfPlayConfig {
        &self.config
    }

    /// A copy of the entries, in the order they joined (anchors first).
    pub fn entries(&self) -> Vec<Entry> {
        self.entries
            .read()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    /// Adds the snapshot taken at `step` with its policy; the snapshot `pool_size` places
    /// back leaves play (its record stays).
    pub fn add_snapshot(&self, step: u64, policy: PolicyOpponent) {
        let mut entries = self.entries.write().unwrap_or_else(PoisonError::into_inner);
        entries.push(Entry {
            member: Member::Snapshot {
                step,
                policy: Some(Arc::new(Mutex::new(policy))),
            },
            record: Record::default(),
        });
        let live: Vec<usize> = live_snapshots(&entries);
        if live.len() > self.config.pool_size
            && let Member::Snapshot { policy, .. } = &mut entries[live[0]].member
        {
            *policy = None;
        }
    }

    /// The opponent of an episode from two uniform draws in [0, 1): the newest snapshot
    /// when `u < latest_share`, a fixed opponent (an anchor or a rival, picked by `v`)
    /// when `u < latest_share + anchor_share`, else a live snapshot by prioritised
    /// fictitious self-play (picked by `v` over the weights `(1 - p)^pfsp_power`). Falls
    /// back to the fixed opponents while there is no snapshot and to the snapshots where
    /// there is no fixed opponent.
    pub fn choose(&self, u: f64, v: f64) -> usize {
        let entries = self.entries.read().unwrap_or_else(PoisonError::into_inner);
        let live = live_snapshots(&entries);
        let fixed = self.config.fixed_opponents();
        let c = &self.config;
        let pick = |n: usize| ((v * n as f64) as usize).min(n.saturating_sub(1));
        if live.is_empty()
            || (fixed > 0 && (c.latest_share..c.latest_share + c.anchor_share).contains(&u))
        {
            return pick(fixed);
        }
        if u < c.latest_share {
            return live[live.len() - 1];
        }
        let weights: Vec<f64> = live
            .iter()
            .map(|&i| (1.0 - entries[i].record.points_share()).powf(c.pfsp_power))
            .collect();
        let total: f64 = weights.iter().sum();
        if total <= 0.0 {
            return live[pick(live.len())];
        }
        let mut at = v * total;
        for (&i, w) in live.iter().zip(&weights) {
            if at < *w {
                return i;
            }
            at -= w;
        }
        live[live.len() - 1]
    }

    /// The member at `index`.
    pub fn member(&self, index: usize) -> Member {
        self.entries.read().unwrap_or_else(PoisonError::into_inner)[index]
            .member
            .clone()
    }

    /// Environment `env` reset: the opponent it was playing, if any, becomes the one whose
    /// episode ended; the next is not yet chosen.
    pub fn reset_slot(&self, env: usize) {
        let mut slot = self.slots[env]
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        if let Some(p) = slot.playing.take() {
            slot.ended = Some(p);
        }
    }

    /// Environment `env` now plays `index`.
    pub fn play(&self, env: usize, index: usize) {
        self.slots[env]
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .playing = Some(index);
    }

    /// Records the episode environment `env` just ended (`goals` from its info: the
    /// learner's, the opponent's) against the opponent it played; returns that
    /// opponent's index.
    pub fn record(&self, env: usize, goals: [u32; 2]) -> Option<usize> {
        let index = self.slots[env]
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .ended
            .take()?;
        self.entries.write().unwrap_or_else(PoisonError::into_inner)[index]
            .record
            .add(goals);
        Some(index)
    }

    /// Forgets who the environments were playing (they all restart from a checkpoint).
    pub fn clear_slots(&self) {
        for slot in &self.slots {
            *slot.lock().unwrap_or_else(PoisonError::into_inner) = Slot::default();
        }
    }

    /// The snapshot steps and every entry's record, for a checkpoint.
    pub fn state(&self) -> PoolState {
        let entries = self.entries();
        PoolState {
            snapshots: entries
                .iter()
                .filter_map(|e| match e.member {
                    Member::Snapshot { step, .. } => Some(step),
                    Member::Anchor(_) => None,
                })
                .collect(),
            records: entries.iter().map(|e| e.record).collect(),
        }
    }

    /// Puts a checkpoint's records back on the entries (the same anchors and snapshots).
    pub fn restore_records(&self, records: &[Record]) {
        let mut entries = self.entries.write().unwrap_or_else(PoisonError::into_inner);
        for (e, r) in entries.iter_mut().zip(records) {
            e.record = *r;
        }
    }
}

/// What a checkpoint holds of a pool: the snapshot steps, and the records of the anchors
/// then the snapshots.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PoolState {
    /// Env steps of the snapshots, oldest first.
    pub snapshots: Vec<u64>,
    /// One per entry, anchors first.
    pub records: Vec<Record>,
}

impl PoolState {
    /// Writes it into a checkpoint's state.
    pub fn save(&self, snap: &mut Snapshot<'_>) {
        snap.put_u64s(SNAPSHOTS_KEY, self.snapshots.clone());
        let column = |f: fn(&Record) -> u64| self.records.iter().map(f).collect::<Vec<_>>();
        snap.put_u64s("self_play.games", column(|r| r.games));
        snap.put_u64s("self_play.wins", column(|r| r.wins));
        snap.put_u64s("self_play.draws", column(|r| r.draws));
    }

    /// Reads what [`PoolState::save`] wrote; `None` for a run without self-play.
    pub fn load(snap: &Snapshot<'_>) -> Result<Option<Self>, SnapshotError> {
        if !snap.contains(SNAPSHOTS_KEY) {
            return Ok(None);
        }
        let snapshots = snap.u64s(SNAPSHOTS_KEY)?.to_vec();
        let games = snap.u64s("self_play.games")?;
        let wins = snap.u64s("self_play.wins")?;
        let draws = snap.u64s("self_play.draws")?;
        let records = games
            .iter()
            .zip(wins)
            .zip(draws)
            .map(|((&games, &wins), &draws)| Record { games, wins, draws })
            .collect();
        Ok(Some(Self { snapshots, records }))
    }
}

const SNAPSHOTS_KEY: &str = "self_play.snapshots";

/// Indices of the snapshots still in play, oldest first.
fn live_snapshots(entries: &[Entry]) -> Vec<usize> {
    entries
        .iter()
        .enumerate()
        .filter(|(_, e)| {
            matches!(
                e.member,
                Member::Snapshot {
                    policy: Some(_),
                    ..
                }
            )
        })
        .map(|(i, _)| i)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use foosball_env::OpponentKind;

    fn pool(config: SelfPlayConfig) -> Pool {
        Pool::new(&config, 1)
    }

    #[test]
    fn records_count_wins_draws_and_losses() {
        let mut r = Record::default();
        assert_eq!(r.points_share(), 0.5);
        r.add([1, 0]);
        r.add([0, 1]);
        r.add([1, 1]);
        r.add([0, 0]);
        r.add([3, 2]);
        r.add([2, 3]);
        assert_eq!((r.games, r.wins, r.draws), (6, 2, 2));
        assert_eq!(r.points_share(), (2.0 + 1.0 + 0.5) / 7.0);
    }

    #[test]
    fn without_snapshots_every_draw_is_an_anchor() {
        let p = pool(SelfPlayConfig::default());
        let anchors = SelfPlayConfig::default().anchors.len();
        for (u, v) in [(0.0, 0.0), (0.3, 0.99), (0.9, 0.5)] {
            assert!(p.choose(u, v) < anchors);
        }
        assert_eq!(p.choose(0.9, 0.99), anchors - 1);
    }

    fn idle() -> PolicyOpponent {
        PolicyOpponent::new(
            Box::new(|_: &[f32]| Ok(vec![0.0; 8])),
            foosball_env::config::BallFrame::default(),
        )
    }

    #[test]
    fn draws_split_into_latest_anchors_and_pfsp_by_the_shares() {
        let config = SelfPlayConfig {
            latest_share: 0.5,
            anchor_share: 0.2,
            anchors: vec![OpponentKind::Static],
            rivals: vec!["blocker".into()],
            pfsp_power: 2.0,
            pool_size: 3,
            ..SelfPlayConfig::default()
        };
        let p = pool(config);
        let names: Vec<String> = p.entries().iter().map(Entry::name).collect();
        assert_eq!(names, ["static", "blocker"], "anchors, then rivals");
        for step in [0, 10, 20, 30] {
            p.add_snapshot(step, idle());
        }
        // pool_size 3: step 0 (entry 2) is out of play; 3, 4, 5 are live, 5 the newest.
        let mut records = vec![Record::default(); 6];
        records[3] = Record {
            games: 9,
            wins: 9,
            draws: 0,
        }; // beaten: p = 0.95
        records[4] = Record {
            games: 9,
            wins: 0,
            draws: 0,
        }; // beats the learner: p = 0.05
        p.restore_records(&records);
        let n = 10_000;
        let mut counts = [0usize; 6];
        for k in 0..n {
            let (u, v) = ((k % 100) as f64 / 100.0, (k / 100) as f64 / 100.0);
            counts[p.choose(u, v)] += 1;
        }
        assert_eq!(counts[2], 0, "a snapshot out of play was drawn");
        assert_eq!(counts[0] + counts[1], n / 5, "anchors and rivals");
        assert_eq!(counts[0], counts[1], "an anchor and a rival drawn alike");
        // PFSP over the last 30 %: weights 0.05^2, 0.95^2, 0.5^2 (newest, never met).
        let w = [0.0025, 0.9025, 0.25];
        let pfsp = 0.3 * n as f64;
        let expect = |i: usize| pfsp * w[i] / w.iter().sum::<f64>();
        assert!((counts[3] as f64 - expect(0)).abs() < 40.0, "{counts:?}");
        assert!((counts[4] as f64 - expect(1)).abs() < 40.0, "{counts:?}");
        assert!(
            (counts[5] as f64 - n as f64 / 2.0 - expect(2)).abs() < 40.0,
            "{counts:?}"
        );
    }

    #[test]
    fn slots_hand_the_ended_opponent_to_the_record() {
        let p = pool(SelfPlayConfig::default());
        p.reset_slot(0);
        p.play(0, 2);
        // An auto-reset then a restart in the same step keep the ended opponent.
        p.reset_slot(0);
        p.reset_slot(0);
        assert_eq!(p.record(0, [1, 0]), Some(2));
        assert_eq!(p.record(0, [1, 0]), None);
        assert_eq!(p.entries()[2].record.wins, 1);
    }
}
