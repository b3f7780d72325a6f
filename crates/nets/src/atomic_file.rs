//! The one way every file of a run is written: through a temporary sibling that is
//! flushed to disk and renamed over the target, then the directory flushed, so a crash
//! at any point leaves either the old file or the new one, never a mix.

use std::io;
use std::path::{Path, PathBuf};

/// The temporary sibling of `path`: `.tmp` put before its extension (`a.png` ->
/// `a.tmp.png`), so writers that go by the extension still recognise it.
fn temporary(path: &Path) -> PathBuf {
    match path.extension() {
        Some(ext) => {
            let mut tmp = std::ffi::OsString::from("tmp.");
            tmp.push(ext);
            path.with_extension(tmp)
        }
        None => path.with_extension("tmp"),
    }
}

/// Lets `write` create the file at the temporary path it is given, then fsyncs it,
/// renames it to `path` and fsyncs `path`'s directory.
pub fn replace_file(path: &Path, write: impl FnOnce(&Path) -> io::Result<()>) -> io::Result<()> {
    let tmp = temporary(path);
    write(&tmp)?;
    std::fs::File::open(&tmp)?.sync_all()?;
    std::fs::rename(&tmp, path)?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    std::fs::File::open(dir)?.sync_all()
}

/// Writes `bytes` to `path` atomically (see the module docs).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    replace_file(path, |tmp| std::fs::write(tmp, bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_leaves_the_old_file() {
        let dir = std::env::temp_dir().join(format!("atomic-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.txt");
        write_atomic(&path, b"old").unwrap();
        let e = replace_file(&path, |tmp| {
            std::fs::write(tmp, b"half")?;
            Err(io::Error::other("interrupted"))
        });
        assert!(e.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        write_atomic(&path, b"new").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        assert!(!temporary(&path).exists());
        assert_eq!(temporary(Path::new("d/m.png")), Path::new("d/m.tmp.png"));
        assert_eq!(temporary(Path::new("d/state")), Path::new("d/state.tmp"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
