//! A TOML configuration file and the files it extends: `extends = "base.toml"` at the
//! top of a file lays its keys over the base's (keys override, tables merge, arrays and
//! other values replace, as [`overlay`] does); a base may extend another. The path is
//! relative to the extending file's folder. A missing file, a cycle or an `extends` that
//! is not a string is refused naming the file at fault.
//!
//! What a file means is its merged table ([`Layers::merged`]); a run saves that merged
//! configuration, so a run directory never depends on the files it came from.

use crate::config::overlay;
use std::path::{Path, PathBuf};

/// The key that names a file's base.
pub const EXTENDS: &str = "extends";

/// A file of the chain: where it is, what it says, and its own table (without `extends`).
#[derive(Clone, Debug)]
pub struct Layer {
    /// The file, as reached from the first file's path.
    pub path: PathBuf,
    /// Its text as written.
    pub text: String,
    /// Its keys, `extends` removed.
    pub table: toml::Table,
}

/// A file that extends others and its chain of bases.
#[derive(Clone, Debug)]
pub struct Layers {
    /// The chain, the extending file first and the last base last.
    pub files: Vec<Layer>,
    /// Every file's keys laid over its base's, the first file's last (it wins).
    pub merged: toml::Table,
}

impl Layers {
    /// The first file of the chain that writes the dotted `key` itself (`a.b.c`, a part
    /// `name[i]` reading the `i`-th table of the array `name`), else the first file.
    pub fn writer_of(&self, key: &str) -> &Layer {
        self.files
            .iter()
            .find(|layer| writes(&layer.table, key))
            .unwrap_or(&self.files[0])
    }
}

/// Whether `table` holds the dotted `key` (an array of tables without an index holds a
/// key that any of its tables holds).
fn writes(table: &toml::Table, key: &str) -> bool {
    let (part, rest) = match key.split_once('.') {
        Some((part, rest)) => (part, Some(rest)),
        None => (key, None),
    };
    let (name, index) = match part.strip_suffix(']').and_then(|p| p.split_once('[')) {
        Some((name, i)) => (name, i.parse::<usize>().ok()),
        None => (part, None),
    };
    let value = match (table.get(name), index) {
        (None, _) => return false,
        (Some(toml::Value::Array(items)), Some(i)) => match items.get(i) {
            Some(item) => item,
            None => return false,
        },
        (Some(value), _) => value,
    };
    let Some(rest) = rest else {
        return true;
    };
    match value {
        toml::Value::Table(t) => writes(t, rest),
        toml::Value::Array(items) => items
            .iter()
            .any(|item| item.as_table().is_some_and(|t| writes(t, rest))),
        _ => false,
    }
}

/// Why a chain of files could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ExtendsError {
    /// A base could not be read (missing, unreadable).
    #[error("{by}: extends = \"{named}\": cannot read {}: {source}", path.display(), by = by.display())]
    Read {
        /// The file that names the base.
        by: PathBuf,
        /// The base as written in `extends`.
        named: String,
        /// The base's path.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A base is not valid TOML.
    #[error("{}:{line}: {message}", path.display())]
    Parse {
        /// The base.
        path: PathBuf,
        /// 1-based line of the offending text.
        line: usize,
        /// The parser's message.
        message: String,
    },
    /// `extends` is not a string.
    #[error("{}: extends: must be a string, the path of the base file", path.display())]
    NotAPath {
        /// The file.
        path: PathBuf,
    },
    /// The chain comes back to a file already in it.
    #[error("{}: extends makes a cycle: {}", chain[0].display(), chain.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(" -> "))]
    Cycle {
        /// The files in the order they extend each other, the repeated one last.
        chain: Vec<PathBuf>,
    },
}

/// The chain that `text` (the file at `path`) starts, or `None` when the text writes no
/// top-level `extends` or is not valid TOML (the caller's own parser then says where).
pub fn layers(text: &str, path: &Path) -> Result<Option<Layers>, ExtendsError> {
    let Ok(table) = text.parse::<toml::Table>() else {
        return Ok(None);
    };
    if !table.contains_key(EXTENDS) {
        return Ok(None);
    }
    let mut files: Vec<Layer> = Vec::new();
    let (mut path, mut text, mut table) = (path.to_path_buf(), text.to_string(), table);
    loop {
        let named = match table.remove(EXTENDS) {
            None => None,
            Some(toml::Value::String(named)) => Some(named),
            Some(_) => return Err(ExtendsError::NotAPath { path }),
        };
        let base = named
            .as_ref()
            .map(|n| path.parent().unwrap_or(Path::new("")).join(n));
        files.push(Layer { path, text, table });
        let (Some(named), Some(base)) = (named, base) else {
            break;
        };
        if let Some(at) = files.iter().position(|l| same_file(&l.path, &base)) {
            let mut chain: Vec<PathBuf> = files[at..].iter().map(|l| l.path.clone()).collect();
            chain.push(base);
            return Err(ExtendsError::Cycle { chain });
        }
        text = std::fs::read_to_string(&base).map_err(|source| ExtendsError::Read {
            by: files[files.len() - 1].path.clone(),
            named: named.clone(),
            path: base.clone(),
            source,
        })?;
        table = text
            .parse::<toml::Table>()
            .map_err(|e| ExtendsError::Parse {
                path: base.clone(),
                line: e.span().map_or(1, |s| line_at(&text, s.start)),
                message: e.message().trim().to_string(),
            })?;
        path = base;
    }
    let mut merged = toml::Table::new();
    for layer in files.iter().rev() {
        overlay(&mut merged, layer.table.clone());
    }
    Ok(Some(Layers { files, merged }))
}

/// 1-based line of byte offset `at` of `text` (its end where `at` is past it).
pub fn line_at(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}

/// Whether two paths name the same file (compared canonically where both exist).
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> toml::Table {
        text.parse().unwrap()
    }

    #[test]
    fn a_dotted_key_is_found_where_it_is_written() {
        let t = table("a = 1\n[b]\nc = 2\n[[d]]\ne = 3\n[[d]]\nf = 4\n");
        assert!(writes(&t, "a") && writes(&t, "b.c") && writes(&t, "d[1].f"));
        assert!(!writes(&t, "b.x") && !writes(&t, "d[0].f") && !writes(&t, "a.b"));
        assert!(!writes(&t, "d[2].e"));
        assert!(writes(&t, "d.f") && !writes(&t, "d.g"));
    }

    #[test]
    fn a_file_without_extends_has_no_layers() {
        let path = Path::new("x.toml");
        assert!(layers("a = 1\n", path).unwrap().is_none());
        assert!(layers("a = [\n", path).unwrap().is_none());
    }

    #[test]
    fn extends_must_name_a_path() {
        let e = layers("extends = 3\n", Path::new("x.toml")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "x.toml: extends: must be a string, the path of the base file"
        );
    }
}
