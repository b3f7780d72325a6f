//! Which build wrote a file: the commit the binary was built from (`build.rs`).

/// The commit this binary was built from: 12 hex digits, or `unknown` outside a git
/// checkout. Uncommitted changes are not marked.
pub const BUILD_COMMIT: &str = env!("FOOSBALL_COMMIT");
