//! Records the commit this package is built from as `FOOSBALL_COMMIT` (12 hex digits, or
//! `unknown` outside a git checkout), so that files a binary writes can say which build
//! wrote them (the league's `matches.csv`). Uncommitted changes are not marked.

use std::path::Path;
use std::process::Command;

fn main() {
    let commit = Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=FOOSBALL_COMMIT={commit}");
    // A new commit moves HEAD or a branch; name only paths that exist (a missing one
    // would run this script at every build).
    for path in [".git/HEAD", ".git/refs/heads", ".git/packed-refs"] {
        if Path::new(path).exists() {
            println!("cargo:rerun-if-changed={path}");
        }
    }
    println!("cargo:rerun-if-changed=build.rs");
}
