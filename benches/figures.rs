//! Benchmark figures as data: the benches (`env_speed`, `update_speed`, `train_speed`)
//! include this file and write `target/bench/<bench>.json`, a flat object of figure name
//! -> number with the unit in the name.

use std::path::{Path, PathBuf};

/// Writes `figures` to `target/bench/<bench>.json` under the workspace (the nearest
/// directory above the bench's package that holds `Cargo.lock`; or
/// `$CARGO_TARGET_DIR/bench`) and returns the path.
pub fn write_figures(bench: &str, figures: &[(String, f64)]) -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(
        || {
            let package = Path::new(env!("CARGO_MANIFEST_DIR"));
            let workspace = package
                .ancestors()
                .find(|d| d.join("Cargo.lock").is_file())
                .unwrap_or(package);
            workspace.join("target")
        },
        PathBuf::from,
    );
    let dir = target.join("bench");
    std::fs::create_dir_all(&dir).expect("target/bench is writable");
    let map: serde_json::Map<String, serde_json::Value> = figures
        .iter()
        .map(|(k, v)| (k.clone(), serde_json::json!(v)))
        .collect();
    let path = dir.join(format!("{bench}.json"));
    let text = serde_json::to_string_pretty(&map).expect("numbers serialise");
    std::fs::write(&path, text).expect("the figures file is writable");
    path
}
