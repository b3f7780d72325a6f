//! `report` on finished runs: the side-by-side table carries each run's test metrics, the
//! charts are PNG images, and a run without a test is refused by name.

use crate::common;

use common::{scratch, tiny_config_text};
use foosball_rl::config::RunConfig;
use foosball_rl::run::train::{Start, train};
use std::path::Path;
use std::process::Command;

/// Width and height from a PNG's IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        path.display()
    );
    let word = |at: usize| u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap());
    (word(16), word(20))
}

#[test]
fn report_tables_and_charts_several_runs() {
    let dir = scratch("report");
    let mut runs = Vec::new();
    for algo in ["ppo", "sac"] {
        let text = tiny_config_text(algo, 2, 150);
        let config = RunConfig::from_toml(&text, Path::new("tiny.toml")).unwrap();
        let run = dir.join(algo);
        std::fs::create_dir_all(&run).unwrap();
        train(&config, &run, Start::Fresh, |_| {}).unwrap();
        runs.push(run);
    }
    let out = dir.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_report"))
        .args(runs.iter().map(|r| r.to_str().unwrap()))
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let header = md
        .lines()
        .find(|l| l.starts_with("| mean over seeds"))
        .unwrap();
    assert!(
        header.contains("ppo reference* 16 (1 run)")
            && header.contains("sac reference* 16 (1 run)"),
        "{header}"
    );
    for (k, run) in runs.iter().enumerate() {
        let m: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(run.join("test/metrics.json")).unwrap())
                .unwrap();
        let reward = m["mean_return"]["mean"].as_f64().unwrap();
        let row = md
            .lines()
            .find(|l| l.starts_with("| mean episode reward"))
            .unwrap();
        let cell = row.split('|').nth(2 + k).unwrap().trim();
        assert!(
            cell.starts_with(&format!("{reward:.3} [")),
            "{cell} vs {reward}"
        );
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(json["groups"].as_array().unwrap().len(), 2);
    assert!(
        md.contains("| reference* | SAC's score rate is 42.9 % | 0.429 |"),
        "{md}"
    );
    assert_eq!(png_size(&out.join("metrics.png")), (1500, 440));
    // The runs kept their test trajectories: each group's best and worst episode as GIFs.
    assert!(md.contains("# Test episodes"), "{md}");
    for gif in ["ppo_reference__16-best.gif", "sac_reference__16-worst.gif"] {
        assert!(md.contains(gif), "{gif} not in\n{md}");
        assert_eq!(&std::fs::read(out.join(gif)).unwrap()[..6], b"GIF89a");
    }
    assert_eq!(png_size(&out.join("curves.png")), (1200, 450));

    let unfinished = dir.join("unfinished");
    std::fs::create_dir_all(&unfinished).unwrap();
    std::fs::copy(runs[0].join("config.toml"), unfinished.join("config.toml")).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_report"))
        .args([unfinished.to_str().unwrap(), "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("unfinished/test/metrics.json"), "{err}");
}

#[test]
fn report_over_seeds_averages_each_metric_and_lists_every_seed() {
    let dir = scratch("report-seeds");
    let mut returns = Vec::new();
    for seed in [3, 4] {
        let text = tiny_config_text("ppo", 1, 150).replace("seed = 3", &format!("seed = {seed}"));
        let config = RunConfig::from_toml(&text, Path::new("tiny.toml")).unwrap();
        let run = dir.join("sweep").join(format!("ppo-seed{seed}"));
        std::fs::create_dir_all(&run).unwrap();
        let m = train(&config, &run, Start::Fresh, |_| {}).unwrap();
        returns.push(m.mean_return.mean);
    }
    let out = dir.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_report"))
        .arg(dir.join("sweep"))
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("ppo reference* 16 (2 runs)"), "{md}");
    let rows: Vec<&str> = md
        .lines()
        .filter(|l| l.starts_with("| mean episode reward"))
        .collect();
    // Mean table, IQM table (2 seeds: nothing trimmed), per-seed table.
    let mean = (returns[0] + returns[1]) / 2.0;
    assert!(
        rows[0].contains(&format!("| {mean:.3} [")),
        "{} vs {mean}",
        rows[0]
    );
    assert!(rows[1].contains(&format!("| {mean:.3} [")), "{}", rows[1]);
    assert!(
        rows[2].contains(&format!("{:.3}, {:.3}", returns[0], returns[1])),
        "{}",
        rows[2]
    );

    // An ablation: a run that departs from the others in one key is its own group, named
    // by that key, and the two seeds stay pooled.
    let text = tiny_config_text("ppo", 1, 150).replace("n_epochs = 2", "n_epochs = 3");
    let config = RunConfig::from_toml(&text, Path::new("tiny.toml")).unwrap();
    let variant = dir.join("ablation").join("ppo-seed3");
    std::fs::create_dir_all(&variant).unwrap();
    train(&config, &variant, Start::Fresh, |_| {}).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_report"))
        .args([dir.join("sweep"), dir.join("ablation")])
        .args(["--out", dir.join("out2").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(dir.join("out2/report.md")).unwrap();
    let header = md
        .lines()
        .find(|l| l.starts_with("| mean over seeds"))
        .unwrap();
    assert!(
        header
            .contains("| ppo reference* 16 (2 runs) | ppo reference* 16 ppo.n_epochs=3 (1 run) |"),
        "{header}"
    );

    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_report"))
        .arg(&empty)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no finished run or baseline here"));
}
