//! Helpers shared by the integration tests.

use std::path::PathBuf;

/// The reference data folder `../shared/reference/<name>` beside the checkout, or `None`
/// (with a note) where it is absent outside CI. Under `CI=true` it must exist.
pub fn reference_file(name: &str) -> Option<PathBuf> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference")
        .join(name);
    if path.exists() {
        return Some(path);
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "reference file {} is missing",
        path.display()
    );
    eprintln!("skipping: reference file {} is not here", path.display());
    None
}
