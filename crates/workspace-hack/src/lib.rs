//! No code: this crate only names dependencies with features (see its `Cargo.toml`), so
//! that the Python wheel's build (`foosball-py` alone) compiles its shared dependencies
//! with the same features as the whole workspace's build and reuses them.
