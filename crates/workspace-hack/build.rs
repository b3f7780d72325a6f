//! Empty: a crate's `[build-dependencies]` take part in the host build only when it has
//! a build script, and this crate's host dependencies are there for their features.
fn main() {}
