//! Image observations in the replay buffer, each distinct image plane stored once.
//!
//! A stacked observation `[channels, height, width]` shares all but one frame with the
//! previous step's, and a transition's observation is the previous transition's next
//! observation: storing both stacks whole keeps every frame `2 * frame_stack` times.
//! Here a row holds the ids of its `2 * channels` planes (`height * width` bytes each:
//! one channel of one frame), and a plane's bytes live once in a slot, found again by
//! their hash and confirmed byte for byte; a slot is freed when the last row holding it
//! is overwritten. Nothing is assumed about how frames are stacked: any planes that are
//! not byte-identical are simply stored apart, so rows read back exactly what was
//! written. On foosball (84x84 grey, 4 frames) a row costs about one plane (7 KiB)
//! instead of eight.

use foosball_env::observation::{byte_value, value_byte};
use foosball_nets::{Snapshot, SnapshotError};
use rustc_hash::{FxBuildHasher, FxHasher};
use std::collections::HashMap;
use std::hash::Hasher;

/// A row slot not yet written.
const EMPTY: u32 = u32::MAX;

/// The hash a plane's bytes are found again by.
fn plane_hash(bytes: &[u8]) -> u64 {
    let mut hasher = FxHasher::default();
    hasher.write(bytes);
    hasher.finish()
}

/// Image observation pairs `(obs, next_obs)` of up to `rows` transitions, as
/// content-addressed byte planes (see the module doc).
#[derive(Clone, Debug)]
pub struct PlaneStore {
    /// Bytes per plane, `height * width`.
    plane_len: usize,
    /// Planes per observation, `channels`.
    planes: usize,
    /// `[slot][plane_len]` bytes; grows to the most slots ever live at once.
    bytes: Vec<u8>,
    /// Hash of each slot's bytes.
    hashes: Vec<u64>,
    /// Rows holding each slot (twice where both of a row's observations do); 0: free.
    refs: Vec<u32>,
    /// Free slots, the last freed on top.
    free: Vec<u32>,
    /// A live slot for each hash.
    index: HashMap<u64, u32, FxBuildHasher>,
    /// `[row][2 * planes]` slot ids, the observation's then the next observation's.
    ids: Vec<u32>,
    /// One plane's bytes being stored (working memory, not state).
    scratch: Vec<u8>,
}

impl PartialEq for PlaneStore {
    /// Same planes in the same slots, rows and free list (the scratch plane aside).
    fn eq(&self, other: &Self) -> bool {
        (self.plane_len, self.planes) == (other.plane_len, other.planes)
            && self.bytes == other.bytes
            && self.hashes == other.hashes
            && self.refs == other.refs
            && self.free == other.free
            && self.index == other.index
            && self.ids == other.ids
    }
}

impl PlaneStore {
    /// An empty store for `rows` transitions of observations made of `planes` planes of
    /// `plane_len` bytes.
    pub fn new(rows: usize, planes: usize, plane_len: usize) -> Self {
        assert!(planes > 0 && plane_len > 0, "an image has planes of pixels");
        Self {
            plane_len,
            planes,
            bytes: Vec::new(),
            hashes: Vec::new(),
            refs: Vec::new(),
            free: Vec::new(),
            index: HashMap::default(),
            ids: vec![EMPTY; rows * 2 * planes],
            scratch: vec![0; plane_len],
        }
    }

    /// Slots holding a plane now.
    pub fn live_planes(&self) -> usize {
        self.refs.len() - self.free.len()
    }

    /// Bytes held: every slot ever allocated and the rows' ids.
    pub fn bytes_held(&self) -> usize {
        let rows = self.ids.len() / (2 * self.planes);
        self.refs.len() * Self::slot_bytes(self.plane_len) + rows * Self::row_bytes(self.planes)
    }

    /// Bytes one stored plane of `plane_len` bytes costs: its pixels, hash and row count,
    /// and about 16 bytes of index entry.
    pub fn slot_bytes(plane_len: usize) -> usize {
        plane_len + size_of::<u64>() + size_of::<u32>() + 16
    }

    /// Bytes one row's plane ids take, for observations of `planes` planes (the
    /// observation's and the next observation's).
    pub fn row_bytes(planes: usize) -> usize {
        2 * planes * size_of::<u32>()
    }

    /// Stores row `row`'s observation and next observation (values `byte / 255`, each
    /// `planes * plane_len` long), releasing the planes of what the row held before.
    pub fn write(&mut self, row: usize, obs: &[f32], next_obs: &[f32]) {
        let width = 2 * self.planes;
        let old: Vec<u32> = self.ids[row * width..(row + 1) * width].to_vec();
        let values = obs.chunks_exact(self.plane_len);
        for (k, plane) in values
            .chain(next_obs.chunks_exact(self.plane_len))
            .enumerate()
        {
            let slot = self.acquire(plane);
            self.ids[row * width + k] = slot;
        }
        for slot in old.into_iter().filter(|&s| s != EMPTY) {
            self.release(slot);
        }
    }

    /// Appends row `row`'s observation (`next: false`) or next observation as `byte / 255`.
    pub fn read(&self, row: usize, next: bool, out: &mut Vec<f32>) {
        let start = (2 * row + usize::from(next)) * self.planes;
        for &slot in &self.ids[start..start + self.planes] {
            out.extend(self.plane(slot).iter().map(|&b| byte_value(b)));
        }
    }

    fn plane(&self, slot: u32) -> &[u8] {
        let at = slot as usize * self.plane_len;
        &self.bytes[at..at + self.plane_len]
    }

    /// A slot holding `values` as bytes, one more row counted on it.
    fn acquire(&mut self, values: &[f32]) -> u32 {
        for (b, &v) in self.scratch.iter_mut().zip(values) {
            *b = value_byte(v);
        }
        let hash = plane_hash(&self.scratch);
        if let Some(&slot) = self.index.get(&hash)
            && self.plane(slot) == self.scratch.as_slice()
        {
            self.refs[slot as usize] += 1;
            return slot;
        }
        let slot = match self.free.pop() {
            Some(slot) => slot,
            None => {
                self.bytes.resize(self.bytes.len() + self.plane_len, 0);
                self.hashes.push(0);
                self.refs.push(0);
                u32::try_from(self.refs.len() - 1).expect("fewer than 2^32 planes")
            }
        };
        let at = slot as usize * self.plane_len;
        self.bytes[at..at + self.plane_len].copy_from_slice(&self.scratch);
        self.hashes[slot as usize] = hash;
        self.refs[slot as usize] = 1;
        // On a hash collision the first plane keeps the entry; the new one is just not
        // shared.
        self.index.entry(hash).or_insert(slot);
        slot
    }

    fn release(&mut self, slot: u32) {
        let s = slot as usize;
        self.refs[s] -= 1;
        if self.refs[s] == 0 {
            self.free.push(slot);
            if self.index.get(&self.hashes[s]) == Some(&slot) {
                self.index.remove(&self.hashes[s]);
            }
        }
    }

    /// Stores the first `rows` rows' ids, the slots' bytes and the free list under
    /// `prefix` (the bytes borrowed).
    pub fn save<'a>(&'a self, snap: &mut Snapshot<'a>, prefix: &str, rows: usize) {
        let ids = &self.ids[..rows * 2 * self.planes];
        let wide = |v: &[u32]| v.iter().map(|&x| u64::from(x)).collect::<Vec<u64>>();
        snap.put_u64s(format!("{prefix}.plane_ids"), wide(ids));
        snap.put_u64s(format!("{prefix}.free_planes"), wide(&self.free));
        snap.put_u8s(format!("{prefix}.planes"), &self.bytes[..]);
    }

    /// Restores what [`PlaneStore::save`] stored under `prefix` for `rows` rows into this
    /// (empty or used) store of the same sizes; ids of missing planes are refused.
    pub fn load(
        &mut self,
        snap: &Snapshot<'_>,
        prefix: &str,
        rows: usize,
    ) -> Result<(), SnapshotError> {
        let key = |k: &str| format!("{prefix}.{k}");
        let ids = snap.u64s(&key("plane_ids"))?;
        let free = snap.u64s(&key("free_planes"))?;
        let bytes = snap.u8s(&key("planes"))?;
        let slots = bytes.len() / self.plane_len;
        let bad = |name: String, message: String| SnapshotError::Entry { name, message };
        if bytes.len() % self.plane_len != 0 {
            return Err(bad(
                key("planes"),
                format!("{} bytes are not planes of {}", bytes.len(), self.plane_len),
            ));
        }
        if ids.len() != rows * 2 * self.planes {
            return Err(bad(
                key("plane_ids"),
                format!(
                    "{} ids for {rows} rows of {} planes",
                    ids.len(),
                    2 * self.planes
                ),
            ));
        }
        if let Some(id) = ids.iter().chain(free).find(|&&id| id >= slots as u64) {
            return Err(bad(
                key("plane_ids"),
                format!("plane {id} of a store of {slots} planes"),
            ));
        }
        let mut restored = PlaneStore::new(
            self.ids.len() / (2 * self.planes),
            self.planes,
            self.plane_len,
        );
        restored.bytes = bytes.to_vec();
        restored.hashes = bytes.chunks_exact(self.plane_len).map(plane_hash).collect();
        restored.refs = vec![0; slots];
        for (k, &id) in ids.iter().enumerate() {
            restored.ids[k] = id as u32;
            restored.refs[id as usize] += 1;
        }
        restored.free = free.iter().map(|&id| id as u32).collect();
        for slot in 0..slots as u32 {
            if restored.refs[slot as usize] > 0 {
                restored
                    .index
                    .entry(restored.hashes[slot as usize])
                    .or_insert(slot);
            }
        }
        *self = restored;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frame `t` of a made-up video: `plane_len` bytes no other frame has.
    fn frame(t: usize, plane_len: usize) -> Vec<u8> {
        (0..plane_len)
            .map(|j| ((t * 31 + j * 7 + (t * j) % 13) % 256) as u8)
            .collect()
    }

    /// The stack of the last `depth` frames at step `t` of an episode that began at
    /// frame `start` (a reset repeats its first frame), as `byte / 255`.
    fn stack(start: usize, t: usize, depth: usize, plane_len: usize) -> Vec<f32> {
        (0..depth)
            .flat_map(|k| {
                frame(
                    (start + t).saturating_sub(depth - 1 - k).max(start),
                    plane_len,
                )
            })
            .map(byte_value)
            .collect()
    }

    /// Writes `steps` transitions of episodes `episode` steps long into `store`'s ring of
    /// `rows`, returning what each row should read back.
    fn fill(
        store: &mut PlaneStore,
        rows: usize,
        steps: usize,
        episode: usize,
    ) -> Vec<[Vec<f32>; 2]> {
        let (depth, len) = (store.planes, store.plane_len);
        let mut expected = vec![[Vec::new(), Vec::new()]; rows];
        for step in 0..steps {
            let start = step / episode * (episode + 1);
            let t = step % episode;
            let pair = [stack(start, t, depth, len), stack(start, t + 1, depth, len)];
            store.write(step % rows, &pair[0], &pair[1]);
            expected[step % rows] = pair;
        }
        expected
    }

    fn read(store: &PlaneStore, row: usize, next: bool) -> Vec<f32> {
        let mut out = Vec::new();
        store.read(row, next, &mut out);
        out
    }

    #[test]
    fn stacked_frames_read_back_exactly_and_are_stored_once() {
        let (rows, plane_len) = (50, 12);
        let mut store = PlaneStore::new(rows, 4, plane_len);
        // 40 transitions, episodes of 10 steps: 40 next frames and 4 reset frames.
        let expected = fill(&mut store, rows, 40, 10);
        for (row, pair) in expected.iter().enumerate().take(40) {
            assert_eq!(read(&store, row, false), pair[0], "row {row}");
            assert_eq!(read(&store, row, true), pair[1], "row {row}");
        }
        assert_eq!(store.live_planes(), 44, "whole stacks would be 320 planes");
    }

    #[test]
    fn overwritten_rows_free_their_planes_for_reuse() {
        let (rows, plane_len) = (16, 9);
        let mut store = PlaneStore::new(rows, 4, plane_len);
        let expected = fill(&mut store, rows, 1_000, 7);
        for (row, pair) in expected.iter().enumerate() {
            assert_eq!(read(&store, row, false), pair[0], "row {row}");
            assert_eq!(read(&store, row, true), pair[1], "row {row}");
        }
        // The 16 rows hold 16 next frames, the current frames of the oldest rows' episode
        // starts, and the 3 older frames the first row's stack reaches back to.
        assert!(store.live_planes() <= 16 + 3 + 3, "{}", store.live_planes());
        // Slots are reused, not grown: at most all live planes plus one row's worth.
        assert!(
            store.refs.len() <= store.live_planes() + 8,
            "{}",
            store.refs.len()
        );
        let counted: u32 = store.refs.iter().sum();
        assert_eq!(
            counted as usize,
            rows * 8,
            "every row holds 8 plane references"
        );
    }

    #[test]
    fn identical_planes_in_one_row_share_a_slot() {
        let mut store = PlaneStore::new(2, 3, 4);
        let grey = [0.5_f32; 4].map(|v| byte_value(value_byte(v)));
        let obs: Vec<f32> = grey.iter().cycle().take(12).copied().collect();
        store.write(0, &obs, &obs);
        assert_eq!(store.live_planes(), 1);
        assert_eq!(store.refs[0], 6);
        store.write(0, &[0.0; 12], &[1.0; 12]);
        assert_eq!(store.live_planes(), 2, "the grey plane was freed");
        assert_eq!(read(&store, 0, true), vec![1.0; 12]);
    }

    #[test]
    fn a_restored_store_reads_and_grows_like_the_original() {
        let (rows, plane_len) = (8, 5);
        let mut store = PlaneStore::new(rows, 2, plane_len);
        fill(&mut store, rows, 13, 4);
        let saved = store.clone();
        let mut snap = Snapshot::new();
        saved.save(&mut snap, "replay", rows);
        let mut back = PlaneStore::new(rows, 2, plane_len);
        back.load(&snap, "replay", rows).unwrap();
        assert_eq!(back, store);
        let (obs, next) = (vec![0.25_f32; 10], vec![0.75_f32; 10]);
        store.write(3, &obs, &next);
        back.write(3, &obs, &next);
        assert_eq!(back, store);

        // An id past the stored planes is refused by name.
        let mut ids = snap.u64s("replay.plane_ids").unwrap().to_vec();
        ids[0] = 1_000;
        let mut bad = Snapshot::new();
        saved.save(&mut bad, "replay", rows);
        bad.put_u64s("replay.plane_ids", ids);
        let e = back.load(&bad, "replay", rows).unwrap_err().to_string();
        assert!(
            e.contains("replay.plane_ids") && e.contains("plane 1000"),
            "{e}"
        );
    }
}
