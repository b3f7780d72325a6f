//! `train` runs end to end on the wgpu backend (`backend = "wgpu"` under `[protocol]`):
//! a tiny run of each algorithm finishes and writes its test metrics. In CI wgpu runs on
//! lavapipe, Mesa's software Vulkan driver; `crates/algos/tests/backend_parity.rs` checks
//! that its updates match the CPU's.
//!
//! `cargo test --release --features wgpu --test suite wgpu_train::`

use std::process::Command;

use crate::common;

#[test]
fn each_algorithm_trains_on_wgpu() {
    let dir = common::scratch("wgpu-train");
    for algo in ["ppo", "sac", "td3"] {
        let config = dir.join(format!("{algo}.toml"));
        let text = common::tiny_config_text(algo, 1, 150)
            .replace("[protocol]\n", "[protocol]\nbackend = \"wgpu\"\n");
        std::fs::write(&config, text).unwrap();
        let out = dir.join(algo);
        let o = Command::new(env!("CARGO_BIN_EXE_train"))
            .args(["--config", config.to_str().unwrap()])
            .args(["--out", out.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{algo} on wgpu: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let saved = std::fs::read_to_string(out.join("config.toml")).unwrap();
        assert!(saved.contains("backend = \"wgpu\""), "{saved}");
        let metrics: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("test/metrics.json")).unwrap())
                .unwrap();
        assert_eq!(metrics["episodes"], 3, "{algo}: {metrics}");
    }
}
