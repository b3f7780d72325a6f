//! Benchmark figures as data: both benches (`env_speed`, `update_speed`) include this
//! file and write `target/bench/<bench>.json`, a flat object of figure name -> number
//! with the unit in the name.

use std::path::{Path, PathBuf};

/// Writes `figures` to `target/bench/<bench>.json` under the workspace (or
/// `$CARGO_TARGET_DIR/bench`) and returns the path.
pub fn write_figures(bench: &str, figures: &[(String, f64)]) -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target"),
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
