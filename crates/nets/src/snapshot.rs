//! Training state that is not a network (optimiser moments, buffers, RNG positions,
//! counters) as named arrays in one binary file, so a run can stop and go on exactly.
//!
//! File layout (little-endian): the magic `FRLSNAP1`, a `u64` entry count, then per
//! entry a `u16` name length, the UTF-8 name, a `u8` kind (0 `f32`, 1 `u64`, 2 `u8`), a
//! `u64` element count and the elements. Files are written through a temporary file
//! renamed into place.

use rand_chacha::ChaCha8Rng;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"FRLSNAP1";

/// One named array.
#[derive(Clone, Debug, PartialEq)]
enum Entry<'a> {
    F32(Cow<'a, [f32]>),
    U64(Cow<'a, [u64]>),
    U8(Cow<'a, [u8]>),
}

impl Entry<'_> {
    fn kind(&self) -> (u8, &'static str) {
        match self {
            Entry::F32(_) => (0, "f32"),
            Entry::U64(_) => (1, "u64"),
            Entry::U8(_) => (2, "u8"),
        }
    }
}

/// A snapshot that could not be written or read, or lacks what was asked of it; names
/// the file (or the entry).
#[derive(Debug, thiserror::Error)]
pub enum SnapshotError {
    /// The file could not be written or read, or is not a snapshot.
    #[error("{path}: {message}")]
    File {
        /// The file at fault.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// An entry is missing or has another type or length than expected.
    #[error("training state entry `{name}`: {message}")]
    Entry {
        /// The entry at fault.
        name: String,
        /// What went wrong.
        message: String,
    },
}

/// Named arrays of training state; borrowed while saving, owned once read.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Snapshot<'a> {
    entries: BTreeMap<String, Entry<'a>>,
}

impl<'a> Snapshot<'a> {
    /// An empty snapshot.
    pub fn new() -> Self {
        Self::default()
    }

    /// Stores `values` under `name` (replacing any entry of that name).
    pub fn put_f32(&mut self, name: impl Into<String>, values: impl Into<Cow<'a, [f32]>>) {
        self.entries.insert(name.into(), Entry::F32(values.into()));
    }

    /// Stores `values` under `name`.
    pub fn put_u64s(&mut self, name: impl Into<String>, values: impl Into<Cow<'a, [u64]>>) {
        self.entries.insert(name.into(), Entry::U64(values.into()));
    }

    /// Stores one counter under `name`.
    pub fn put_u64(&mut self, name: impl Into<String>, value: u64) {
        self.put_u64s(name, vec![value]);
    }

    /// Stores a float as its bit pattern (exact, NaN and infinities included).
    pub fn put_f64(&mut self, name: impl Into<String>, value: f64) {
        self.put_u64(name, value.to_bits());
    }

    /// Stores bytes under `name` (borrowed while saving).
    pub fn put_u8s(&mut self, name: impl Into<String>, values: impl Into<Cow<'a, [u8]>>) {
        self.entries.insert(name.into(), Entry::U8(values.into()));
    }

    /// Stores flags under `name`.
    pub fn put_bools(&mut self, name: impl Into<String>, values: &[bool]) {
        let bytes: Vec<u8> = values.iter().map(|&b| u8::from(b)).collect();
        self.entries
            .insert(name.into(), Entry::U8(Cow::Owned(bytes)));
    }

    /// Stores `rng`'s seed, stream and position, so it continues where it stands.
    pub fn put_rng(&mut self, name: &str, rng: &ChaCha8Rng) {
        let seed = rng.get_seed();
        let pos = rng.get_word_pos();
        let mut words: Vec<u64> = seed
            .chunks(8)
            .map(|c| u64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect();
        words.extend([rng.get_stream(), pos as u64, (pos >> 64) as u64]);
        self.put_u64s(name, words);
    }

    fn entry(&self, name: &str) -> Result<&Entry<'a>, SnapshotError> {
        self.entries.get(name).ok_or_else(|| SnapshotError::Entry {
            name: name.to_string(),
            message: "missing".into(),
        })
    }

    fn wrong(name: &str, expected: &str, entry: &Entry<'_>) -> SnapshotError {
        SnapshotError::Entry {
            name: name.to_string(),
            message: format!("holds {} values, expected {expected}", entry.kind().1),
        }
    }

    /// Whether an entry named `name` exists.
    pub fn contains(&self, name: &str) -> bool {
        self.entries.contains_key(name)
    }

    /// The floats stored under `name`.
    pub fn f32s(&self, name: &str) -> Result<&[f32], SnapshotError> {
        match self.entry(name)? {
            Entry::F32(v) => Ok(v),
            e => Err(Self::wrong(name, "f32", e)),
        }
    }

    /// The floats under `name`, which must number `len`.
    pub fn f32s_of_len(&self, name: &str, len: usize) -> Result<&[f32], SnapshotError> {
        self.f32s(name).and_then(|v| of_len(name, v, len))
    }

    /// The integers stored under `name`.
    pub fn u64s(&self, name: &str) -> Result<&[u64], SnapshotError> {
        match self.entry(name)? {
            Entry::U64(v) => Ok(v),
            e => Err(Self::wrong(name, "u64", e)),
        }
    }

    /// The counter stored under `name`.
    pub fn u64(&self, name: &str) -> Result<u64, SnapshotError> {
        self.u64s(name)
            .and_then(|v| of_len(name, v, 1))
            .map(|v| v[0])
    }

    /// The float stored under `name` by [`Snapshot::put_f64`].
    pub fn f64(&self, name: &str) -> Result<f64, SnapshotError> {
        self.u64(name).map(f64::from_bits)
    }

    /// The bytes stored under `name`.
    pub fn u8s(&self, name: &str) -> Result<&[u8], SnapshotError> {
        match self.entry(name)? {
            Entry::U8(v) => Ok(v),
            e => Err(Self::wrong(name, "u8", e)),
        }
    }

    /// The bytes under `name`, which must number `len`.
    pub fn u8s_of_len(&self, name: &str, len: usize) -> Result<&[u8], SnapshotError> {
        self.u8s(name).and_then(|v| of_len(name, v, len))
    }

    /// The flags stored under `name`.
    pub fn bools(&self, name: &str) -> Result<Vec<bool>, SnapshotError> {
        match self.entry(name)? {
            Entry::U8(v) => Ok(v.iter().map(|&b| b != 0).collect()),
            e => Err(Self::wrong(name, "u8", e)),
        }
    }

    /// The flags under `name`, which must number `len`.
    pub fn bools_of_len(&self, name: &str, len: usize) -> Result<Vec<bool>, SnapshotError> {
        let v = self.bools(name)?;
        of_len(name, &v, len)?;
        Ok(v)
    }

    /// The generator stored under `name` by [`Snapshot::put_rng`], at the same position.
    pub fn rng(&self, name: &str) -> Result<ChaCha8Rng, SnapshotError> {
        use rand::SeedableRng;
        let words = self.u64s(name).and_then(|v| of_len(name, v, 7))?;
        let mut seed = [0u8; 32];
        for (chunk, w) in seed.chunks_mut(8).zip(&words[..4]) {
            chunk.copy_from_slice(&w.to_le_bytes());
        }
        let mut rng = ChaCha8Rng::from_seed(seed);
        rng.set_stream(words[4]);
        rng.set_word_pos(u128::from(words[5]) | (u128::from(words[6]) << 64));
        Ok(rng)
    }

    /// Writes the snapshot to `path` atomically ([`crate::atomic_file`]), so an interrupted
    /// write leaves any previous file intact.
    pub fn write(&self, path: &Path) -> Result<(), SnapshotError> {
        crate::atomic_file::replace_file(path, |tmp| {
            let file = std::fs::File::create(tmp)?;
            let mut out = std::io::BufWriter::with_capacity(1 << 20, file);
            out.write_all(MAGIC)?;
            out.write_all(&(self.entries.len() as u64).to_le_bytes())?;
            for (name, entry) in &self.entries {
                let name_len = u16::try_from(name.len()).expect("entry names are short");
                out.write_all(&name_len.to_le_bytes())?;
                out.write_all(name.as_bytes())?;
                out.write_all(&[entry.kind().0])?;
                match entry {
                    Entry::F32(v) => write_words(&mut out, v, |x| x.to_le_bytes()),
                    Entry::U64(v) => write_words(&mut out, v, |x| x.to_le_bytes()),
                    Entry::U8(v) => write_words(&mut out, v, |x| [x]),
                }?;
            }
            out.into_inner().map_err(|e| e.into_error())?;
            Ok(())
        })
        .map_err(|e| SnapshotError::File {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    }

    /// Reads a snapshot written by [`Snapshot::write`].
    pub fn read(path: &Path) -> Result<Snapshot<'static>, SnapshotError> {
        let error = |message: String| SnapshotError::File {
            path: path.to_path_buf(),
            message,
        };
        let bytes = std::fs::read(path).map_err(|e| error(e.to_string()))?;
        let mut input = bytes.as_slice();
        let mut take = |n: usize| -> Result<&[u8], SnapshotError> {
            if input.len() < n {
                return Err(error("truncated training state file".into()));
            }
            let (head, rest) = input.split_at(n);
            input = rest;
            Ok(head)
        };
        if take(8)? != MAGIC {
            return Err(error("not a foosball-rl training state file".into()));
        }
        let count = u64::from_le_bytes(take(8)?.try_into().expect("8 bytes"));
        let mut entries = BTreeMap::new();
        for _ in 0..count {
            let name_len = u16::from_le_bytes(take(2)?.try_into().expect("2 bytes"));
            let name = String::from_utf8(take(usize::from(name_len))?.to_vec())
                .map_err(|_| error("entry name is not UTF-8".into()))?;
            let kind = take(1)?[0];
            let len = u64::from_le_bytes(take(8)?.try_into().expect("8 bytes")) as usize;
            let entry = match kind {
                0 => Entry::F32(Cow::Owned(
                    take(len * 4)?
                        .chunks_exact(4)
                        .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
                        .collect(),
                )),
                1 => Entry::U64(Cow::Owned(
                    take(len * 8)?
                        .chunks_exact(8)
                        .map(|c| u64::from_le_bytes(c.try_into().expect("8 bytes")))
                        .collect(),
                )),
                2 => Entry::U8(Cow::Owned(take(len)?.to_vec())),
                k => return Err(error(format!("entry `{name}` has unknown kind {k}"))),
            };
            entries.insert(name, entry);
        }
        Ok(Snapshot { entries })
    }
}

/// `values` if they number `len`, else an error naming the entry `name`.
fn of_len<'v, T>(name: &str, values: &'v [T], len: usize) -> Result<&'v [T], SnapshotError> {
    if values.len() != len {
        return Err(SnapshotError::Entry {
            name: name.to_string(),
            message: format!("holds {} values, expected {len}", values.len()),
        });
    }
    Ok(values)
}

/// Writes the element count, then each element's little-endian bytes.
fn write_words<T: Copy, const N: usize>(
    out: &mut impl Write,
    values: &[T],
    bytes: impl Fn(T) -> [u8; N],
) -> std::io::Result<()> {
    out.write_all(&(values.len() as u64).to_le_bytes())?;
    let mut buf = Vec::with_capacity(8192 * N);
    for chunk in values.chunks(8192) {
        buf.clear();
        buf.extend(chunk.iter().flat_map(|&v| bytes(v)));
        out.write_all(&buf)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn every_kind_round_trips_exactly_and_the_rng_goes_on_where_it_stood() {
        let dir = std::env::temp_dir().join(format!("snap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("state.bin");
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        rng.set_stream(3);
        let _: [u64; 5] = std::array::from_fn(|_| rng.random());
        let floats = [1.5f32, -0.0, f32::NAN, f32::INFINITY, 1e-40];
        let mut snap = Snapshot::new();
        snap.put_f32("a.floats", &floats[..]);
        snap.put_u64("a.count", 42);
        snap.put_f64("best", -1.25e300);
        snap.put_bools("flags", &[true, false, true]);
        snap.put_rng("rng", &rng);
        snap.write(&path).unwrap();
        let back = Snapshot::read(&path).unwrap();
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(back.f32s("a.floats").unwrap()), bits(&floats));
        assert_eq!(back.u64("a.count").unwrap(), 42);
        assert_eq!(back.f64("best").unwrap(), -1.25e300);
        assert_eq!(back.bools("flags").unwrap(), [true, false, true]);
        let mut restored = back.rng("rng").unwrap();
        let next: u64 = rng.random();
        assert_eq!(restored.random::<u64>(), next);
        let err = back.u64("a.floats").unwrap_err().to_string();
        assert!(err.contains("`a.floats`") && err.contains("f32"), "{err}");
        let err = back.f32s_of_len("a.floats", 4).unwrap_err().to_string();
        assert!(err.contains("expected 4"), "{err}");
        assert!(
            back.u64("nope")
                .unwrap_err()
                .to_string()
                .contains("missing")
        );
        std::fs::write(&path, b"FRLSNAP1\x05").unwrap();
        let err = Snapshot::read(&path).unwrap_err().to_string();
        assert!(
            err.contains("state.bin") && err.contains("truncated"),
            "{err}"
        );
        std::fs::remove_dir_all(dir).unwrap();
    }
}
