//! Comparing runs, like the paper's Figure 2: runs grouped by algorithm, table preset and
//! network; for each of the test metrics the mean and the interquartile mean over seeds
//! with 95 % bootstrap intervals ([`stats`]), per-seed values, scripted baselines
//! beside them, the paper's figures and a verdict per claim of the paper ([`claims`]);
//! PNG charts ([`charts`]) and JSON.
//!
//! A group of one run shows that run's own test interval (over its episodes) instead.

pub mod charts;
pub mod claims;
pub mod stats;

use crate::config::{ConfigFileError, RunConfig};
use crate::files::write_atomic;
use crate::play::metrics::{Estimate, TestMetrics};
use crate::play::scripted::Baseline;
use crate::run::log::EvaluationRow;
use foosball_env::FoosballConfig;
use serde::Serialize;
use stats::{iqm, mean};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A run directory that cannot be reported on, or a report file that could not be
/// written; names the file.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The run's configuration is missing or unreadable.
    #[error(transparent)]
    Config(#[from] ConfigFileError),
    /// Another file could not be read or written.
    #[error("{path}: {message}")]
    File {
        /// The file at fault.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

fn error(path: &Path, message: impl ToString) -> ReportError {
    ReportError::File {
        path: path.to_path_buf(),
        message: message.to_string(),
    }
}

/// One evaluation row: `(env_step, mean_return, score_rate)`.
pub type EvalPoint = (u64, f64, f64);

/// A finished run's or a baseline's results.
#[derive(Clone, Debug)]
pub struct RunResults {
    /// The directory's name.
    pub name: String,
    /// The directory.
    pub dir: PathBuf,
    /// What played: `ppo`, `sac`, `td3`, or a scripted policy's name.
    pub player: String,
    /// The table's rule preset, marked `*` where the configuration changes any of its
    /// values.
    pub preset: String,
    /// Hidden widths of the networks (empty for a scripted policy).
    pub hidden: Vec<usize>,
    /// The rules' goal line (`reward.goal_line_y`), cm.
    pub goal_line_y: f32,
    /// The test metrics (`test/metrics.json`, or `metrics.json` of a baseline).
    pub metrics: TestMetrics,
    /// `evaluations.csv` (empty for a baseline).
    pub evaluations: Vec<EvalPoint>,
    /// The run's configuration by dotted key (`sac.off_policy.n_step` -> `3`), without the
    /// keys that do not change its numbers (seed, thread count); empty for a baseline.
    pub settings: BTreeMap<String, String>,
}

/// Keys of a run's configuration that differ between seeds of one experiment or do not
/// change its numbers.
const NOT_SETTINGS: [&str; 2] = ["protocol.seed", "protocol.threads"];

/// A config number as its file would write it: a float that an `f32` holds exactly (the
/// config's `f32` keys reach JSON widened to `f64`) in the `f32`'s shortest form, `0.005`
/// rather than `0.004999999888241291`.
fn number_text(n: &serde_json::Number) -> String {
    match n.as_f64() {
        Some(x) if n.is_f64() && f64::from(x as f32) == x => (x as f32).to_string(),
        _ => n.to_string(),
    }
}

/// `config` flattened to dotted keys, minus [`NOT_SETTINGS`].
fn settings(config: &RunConfig) -> BTreeMap<String, String> {
    fn flatten(prefix: &str, value: &serde_json::Value, out: &mut BTreeMap<String, String>) {
        match value {
            serde_json::Value::Object(map) => {
                for (k, v) in map {
                    let key = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    flatten(&key, v, out);
                }
            }
            serde_json::Value::String(v) => {
                out.insert(prefix.to_string(), v.clone());
            }
            serde_json::Value::Number(n) => {
                out.insert(prefix.to_string(), number_text(n));
            }
            v => {
                out.insert(prefix.to_string(), v.to_string());
            }
        }
    }
    let mut out = BTreeMap::new();
    let value = serde_json::to_value(config).expect("a run config always serialises");
    flatten("", &value, &mut out);
    for key in NOT_SETTINGS {
        out.remove(key);
    }
    out
}

fn read_metrics(path: &Path) -> Result<TestMetrics, ReportError> {
    TestMetrics::read(path).map_err(|e| error(path, e))
}

/// `(env_step, mean_return, score_rate)` of every evaluation in `path`.
fn read_evaluations(path: &Path) -> Result<Vec<EvalPoint>, ReportError> {
    let rows = EvaluationRow::read(path).map_err(|e| error(path, e))?;
    Ok(rows
        .iter()
        .map(|r| {
            let v = |name| r.get(name).expect("a metric of the schema");
            (r.env_step, v("mean_return"), v("score_rate"))
        })
        .collect())
}

/// The preset's name, with `*` where `env` differs from the preset's values.
fn preset_label(env: &FoosballConfig) -> String {
    let name = env.preset.name();
    if *env == FoosballConfig::preset(env.preset) {
        name.to_string()
    } else {
        format!("{name}*")
    }
}

fn dir_name(dir: &Path) -> String {
    dir.canonicalize()
        .ok()
        .and_then(|d| d.file_name().map(|n| n.to_string_lossy().to_string()))
        .unwrap_or_else(|| dir.display().to_string())
}

impl RunResults {
    /// Reads the run in `dir` (it must have finished its test).
    pub fn read(dir: &Path) -> Result<Self, ReportError> {
        let config = RunConfig::load_run(dir)?;
        Ok(Self {
            name: dir_name(dir),
            dir: dir.to_path_buf(),
            player: config.algo().to_string(),
            preset: preset_label(&config.env),
            hidden: config.hidden().to_vec(),
            goal_line_y: config.env.reward.goal_line_y,
            metrics: read_metrics(&dir.join("test/metrics.json"))?,
            evaluations: read_evaluations(&dir.join("evaluations.csv"))?,
            settings: settings(&config),
        })
    }

    /// Reads the baseline written by `evaluate --policy` in `dir`.
    pub fn read_baseline(dir: &Path) -> Result<Self, ReportError> {
        let b = Baseline::read(dir).map_err(|e| error(&dir.join("baseline.toml"), e))?;
        Ok(Self {
            name: dir_name(dir),
            dir: dir.to_path_buf(),
            player: b.policy.name().to_string(),
            preset: preset_label(&b.env),
            hidden: Vec::new(),
            goal_line_y: b.env.reward.goal_line_y,
            metrics: read_metrics(&dir.join("metrics.json"))?,
            evaluations: Vec::new(),
            settings: BTreeMap::new(),
        })
    }

    /// Whether a scripted policy played (not a trained agent).
    pub fn is_baseline(&self) -> bool {
        self.hidden.is_empty()
    }
}

/// Every result under `paths`: a run directory (`config.toml`), a baseline directory
/// (`baseline.toml`), or a directory of those (a sweep), searched one level down. Runs
/// of a sweep that have not finished their test are skipped and named in the second
/// list; a run named directly must have finished.
pub fn collect(paths: &[PathBuf]) -> Result<(Vec<RunResults>, Vec<String>), ReportError> {
    let mut found = Vec::new();
    let mut unfinished = Vec::new();
    for path in paths {
        if path.join("baseline.toml").is_file() {
            found.push(RunResults::read_baseline(path)?);
        } else if path.join("config.toml").is_file() || !path.is_dir() {
            found.push(RunResults::read(path)?);
        } else {
            let mut dirs: Vec<PathBuf> = std::fs::read_dir(path)
                .map_err(|e| error(path, e))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_dir())
                .collect();
            dirs.sort();
            for dir in dirs {
                if dir.join("baseline.toml").is_file() {
                    found.push(RunResults::read_baseline(&dir)?);
                } else if dir.join("test/metrics.json").is_file() {
                    found.push(RunResults::read(&dir)?);
                } else if dir.join("config.toml").is_file() {
                    unfinished.push(dir.display().to_string());
                }
            }
        }
    }
    if found.is_empty() {
        let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
        return Err(error(
            Path::new(&names.join(" ")),
            "no finished run or baseline here",
        ));
    }
    Ok((found, unfinished))
}

/// Runs of one algorithm (or one scripted policy) on one preset with one network shape.
#[derive(Clone, Debug)]
pub struct Group {
    /// E.g. `sac paper 64x64` or `shooter paper`.
    pub label: String,
    /// Algorithm or scripted policy name.
    pub player: String,
    /// Table preset.
    pub preset: String,
    /// Its runs (seeds), in the order given.
    pub runs: Vec<RunResults>,
}

/// The value most of `values` take, an absent key counting as a value of its own (the
/// first seen on a tie); `None` for no values or when absence is the most common.
fn common_value<'a>(values: impl Iterator<Item = Option<&'a String>>) -> Option<&'a String> {
    let mut counts: Vec<(Option<&String>, usize)> = Vec::new();
    for v in values {
        match counts.iter_mut().find(|(c, _)| *c == v) {
            Some((_, n)) => *n += 1,
            None => counts.push((v, 1)),
        }
    }
    let most = counts.iter().map(|(_, n)| *n).max().unwrap_or(0);
    counts
        .into_iter()
        .find(|(_, n)| *n == most)
        .and_then(|(v, _)| v)
}

/// Groups runs by player, preset and network, in order of first appearance (baselines
/// after the learners). Runs of one player, preset and network whose configurations
/// differ in other keys (an ablation) are kept apart: a group is labelled with the keys
/// where it departs from the value most of those runs share (the first seen on a tie),
/// e.g. `sac reference 64x64` beside `sac reference 64x64 sac.off_policy.n_step=3`.
pub fn group(runs: Vec<RunResults>) -> Vec<Group> {
    let (learners, baselines): (Vec<_>, Vec<_>) = runs.into_iter().partition(|r| !r.is_baseline());
    let runs: Vec<RunResults> = learners.into_iter().chain(baselines).collect();
    let base = |r: &RunResults| {
        let widths: Vec<String> = r.hidden.iter().map(ToString::to_string).collect();
        if r.is_baseline() {
            format!("{} {}", r.player, r.preset)
        } else {
            format!("{} {} {}", r.player, r.preset, widths.join("x"))
        }
    };
    let labels: Vec<String> = runs
        .iter()
        .map(|r| {
            let peers: Vec<&RunResults> = runs.iter().filter(|o| base(o) == base(r)).collect();
            let keys: BTreeSet<&String> = peers.iter().flat_map(|o| o.settings.keys()).collect();
            let departs: Vec<(&String, Option<&String>)> = keys
                .into_iter()
                .map(|key| (key, r.settings.get(key)))
                .filter(|&(key, own)| {
                    common_value(peers.iter().map(|o| o.settings.get(key))) != own
                })
                .collect();
            std::iter::once(base(r))
                .chain(departure_words(&departs, &r.settings))
                .collect::<Vec<_>>()
                .join(" ")
        })
        .collect();
    let mut groups: Vec<Group> = Vec::new();
    for (r, label) in runs.into_iter().zip(labels) {
        match groups.iter_mut().find(|g| g.label == label) {
            Some(g) => g.runs.push(r),
            None => groups.push(Group {
                label,
                player: r.player.clone(),
                preset: r.preset.clone(),
                runs: vec![r],
            }),
        }
    }
    groups
}

/// The words of a group's label for the keys where a run of `settings` departs
/// (`key=value`, in key order): the keys of a table the run has none of (`[curriculum]`
/// absent, say) as one `table=none`, not one `table.key=none` per key.
fn departure_words(
    departs: &[(&String, Option<&String>)],
    settings: &BTreeMap<String, String>,
) -> Vec<String> {
    fn absent_table<'a>(key: &'a str, settings: &BTreeMap<String, String>) -> Option<&'a str> {
        let (table, _) = key.rsplit_once('.')?;
        let prefix = format!("{table}.");
        (!settings.keys().any(|k| k.starts_with(&prefix))).then_some(table)
    }
    let mut words: Vec<String> = Vec::new();
    for &(key, own) in departs {
        let word = match (own, absent_table(key, settings)) {
            (None, Some(table)) => format!("{table}=none"),
            _ => format!("{key}={}", own.map_or("none", String::as_str)),
        };
        if !words.contains(&word) {
            words.push(word);
        }
    }
    words
}

/// One metric of one group.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MetricSummary {
    /// The metric's name.
    pub metric: &'static str,
    /// Each run's test value, in run order.
    pub per_seed: Vec<f64>,
    /// Mean over seeds with its interval (a lone run: its own test interval).
    pub mean: Estimate,
    /// Interquartile mean over seeds with its interval (a lone run: as `mean`).
    pub iqm: Estimate,
}

impl Group {
    /// The per-seed values of metric `k` (in [`TestMetrics::rows`] order).
    pub fn values(&self, k: usize) -> Vec<f64> {
        self.runs
            .iter()
            .map(|r| r.metrics.rows()[k].1.mean)
            .collect()
    }

    /// Every metric's summary over the group's seeds.
    pub fn summaries(&self) -> Vec<MetricSummary> {
        self.runs[0]
            .metrics
            .rows()
            .iter()
            .enumerate()
            .map(|(k, (metric, own))| {
                let per_seed = self.values(k);
                let (m, q) = if per_seed.len() == 1 {
                    (*own, *own)
                } else {
                    (
                        stats::over_seeds(&per_seed, mean),
                        stats::over_seeds(&per_seed, iqm),
                    )
                };
                MetricSummary {
                    metric,
                    per_seed,
                    mean: m,
                    iqm: q,
                }
            })
            .collect()
    }
}

fn cell(e: &Estimate) -> String {
    format!("{:.3} [{:.3}, {:.3}]", e.mean, e.ci95[0], e.ci95[1])
}

/// Markdown tables: the mean and the IQM over seeds of each metric per group, then the
/// per-seed values.
pub fn markdown_tables(groups: &[Group]) -> String {
    let summaries: Vec<Vec<MetricSummary>> = groups.iter().map(Group::summaries).collect();
    let header = |what: &str| {
        let mut out = format!("| {what} |");
        for g in groups {
            out += &format!(
                " {} ({} run{}) |",
                g.label,
                g.runs.len(),
                if g.runs.len() == 1 { "" } else { "s" }
            );
        }
        out += "\n| --- |";
        out += &" --- |".repeat(groups.len());
        out + "\n"
    };
    let mut out = String::new();
    for (title, pick) in [
        (
            "mean over seeds [95 % CI]",
            (|s: &MetricSummary| s.mean) as fn(&MetricSummary) -> Estimate,
        ),
        ("IQM over seeds [95 % CI]", |s: &MetricSummary| s.iqm),
    ] {
        out += &header(title);
        for (k, s) in summaries[0].iter().enumerate() {
            out += &format!("| {} |", s.metric);
            for g in &summaries {
                out += &format!(" {} |", cell(&pick(&g[k])));
            }
            out.push('\n');
        }
        out.push('\n');
    }
    out += &header("per seed (run order)");
    for (k, s) in summaries[0].iter().enumerate() {
        out += &format!("| {} |", s.metric);
        for g in &summaries {
            let v: Vec<String> = g[k].per_seed.iter().map(|v| format!("{v:.3}")).collect();
            out += &format!(" {} |", v.join(", "));
        }
        out.push('\n');
    }
    out
}

/// A file-name stem for a group's label: characters a path cannot hold replaced, and a
/// label longer than 100 bytes (an ablation's many departing keys) cut to its first 80
/// characters and a hash of the whole (file names hold at most 255 bytes).
fn file_stem(label: &str) -> String {
    let stem = label.replace(['*', ' ', '/', '"'], "_");
    if stem.len() <= 100 {
        return stem;
    }
    // FNV-1a: the same label names the same file in every run of the report.
    let hash = label.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    let cut: String = stem.chars().take(80).collect();
    format!("{cut}-{hash:016x}")
}

/// For each learner group whose first run kept its test trajectories, GIFs of that run's
/// best and worst test episode (by return) in `out`, as markdown; nothing where no run
/// has them (`trajectories.bin` is not committed with results).
fn episode_gifs(groups: &[Group], out: &Path) -> Result<String, ReportError> {
    let mut md = String::new();
    for g in groups.iter().filter(|g| !g.runs[0].is_baseline()) {
        let run = &g.runs[0];
        let path = run.dir.join("test/trajectories.bin");
        if !path.is_file() {
            continue;
        }
        let episodes =
            crate::play::trajectories::read_trajectories(&path).map_err(|e| error(&path, e))?;
        let order = crate::play::trajectories::by_return(&episodes);
        let (Some(&best), Some(&worst)) = (order.first(), order.last()) else {
            continue;
        };
        let animation = crate::play::animation::Animation {
            renderer: foosball_env::render::Renderer::new(2.0),
            every: 10,
            delay_cs: 4,
            caption: true,
            goal_line_y: run.goal_line_y,
        };
        let stem = file_stem(&g.label);
        md += &format!("### {} ({})\n\n", g.label, run.name);
        for (what, k) in [("best", best), ("worst", worst)] {
            let file = format!("{stem}-{what}.gif");
            animation
                .write(&out.join(&file), &episodes[k].trajectory)
                .map_err(|e| error(&out.join(&file), e))?;
            md += &format!(
                "{what} test episode {k} (return {:.0}, {} steps): ![{what}]({file})\n\n",
                episodes[k].ret(),
                episodes[k].trajectory.rewards.len()
            );
        }
    }
    Ok(if md.is_empty() {
        md
    } else {
        format!("# Test episodes\n\n{md}")
    })
}

/// Writes `report.md`, `report.json`, `metrics.png` and `curves.png` into `out` for the
/// results of `paths` (see [`collect`]); returns the markdown.
pub fn write_report(paths: &[PathBuf], out: &Path) -> Result<String, ReportError> {
    let (runs, unfinished) = collect(paths)?;
    let groups = group(runs);
    std::fs::create_dir_all(out).map_err(|e| error(out, e))?;
    charts::metrics_chart(&groups, &out.join("metrics.png"))?;
    charts::learning_curves(&groups, &out.join("curves.png"))?;
    let verdicts = claims::verdicts(&groups);
    let mut md = String::from("# Test metrics over seeds\n\n");
    md += &markdown_tables(&groups);
    md += &format!(
        "\nIntervals: percentile bootstrap over seeds ({} resamples); a group of one run \
         shows its test interval over episodes.\n",
        stats::RESAMPLES
    );
    md += "\n![test metrics](metrics.png)\n\nBars in column order, dots are seeds. ";
    md += "\n\n![learning curves](curves.png)\n\n";
    md += &episode_gifs(&groups, out)?;
    md += &claims::markdown(&verdicts);
    if !unfinished.is_empty() {
        md += &format!("\nNot finished (left out): {}\n", unfinished.join(", "));
    }
    let json = serde_json::json!({
        "groups": groups.iter().map(|g| serde_json::json!({
            "label": g.label,
            "player": g.player,
            "preset": g.preset,
            "runs": g.runs.iter().map(|r| &r.name).collect::<Vec<_>>(),
            "metrics": g.summaries(),
        })).collect::<Vec<_>>(),
        "claims": verdicts,
        "unfinished": unfinished,
    });
    let json = serde_json::to_string_pretty(&json).expect("metrics serialise");
    write_atomic(&out.join("report.json"), json.as_bytes())
        .map_err(|e| error(&e.path, e.source))?;
    write_atomic(&out.join("report.md"), md.as_bytes()).map_err(|e| error(&e.path, e.source))?;
    Ok(md)
}

#[cfg(test)]
mod tests {
    use super::{common_value, departure_words, file_stem, number_text};
    use std::collections::BTreeMap;

    #[test]
    fn a_table_the_run_lacks_is_one_word_of_its_label() {
        let keys = [
            "curriculum.share",
            "curriculum.window",
            "protocol.demonstrations",
        ]
        .map(String::from);
        let settings: BTreeMap<String, String> = [("protocol.epochs", "2"), ("sac.gamma", "0.99")]
            .into_iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        let departs: Vec<_> = keys.iter().map(|k| (k, None)).collect();
        assert_eq!(
            departure_words(&departs, &settings),
            ["curriculum=none", "protocol.demonstrations=none"]
        );
        let five = "5".to_string();
        let own = [(&keys[1], Some(&five))];
        assert_eq!(departure_words(&own, &settings), ["curriculum.window=5"]);
    }

    #[test]
    fn a_long_group_label_names_a_short_file_of_its_own() {
        assert_eq!(file_stem("sac reference 64x64"), "sac_reference_64x64");
        let long = |v: &str| {
            format!(
                "sac reference 64x64 {}",
                format!("key.{v}=none ").repeat(20)
            )
        };
        let (a, b) = (file_stem(&long("a")), file_stem(&long("b")));
        assert!(a.len() <= 100 && b.len() <= 100, "{a}");
        assert_ne!(a, b, "two labels, two files");
        assert_eq!(file_stem(&long("a")), a, "the same label, the same file");
    }

    #[test]
    fn config_numbers_read_as_their_file_writes_them() {
        let text = |x: f64| number_text(&serde_json::Number::from_f64(x).unwrap());
        assert_eq!(text(f64::from(0.005f32)), "0.005");
        assert_eq!(text(f64::from(0.99f32)), "0.99");
        assert_eq!(text(0.99), "0.99", "an f64 key keeps its own digits");
        assert_eq!(number_text(&serde_json::Number::from(3)), "3");
    }

    #[test]
    fn an_absent_key_counts_as_a_value_of_its_own() {
        let (a, b) = ("0.005".to_string(), "0.01".to_string());
        assert_eq!(common_value([None, None, Some(&a)].into_iter()), None);
        assert_eq!(
            common_value([Some(&a), None, Some(&a)].into_iter()),
            Some(&a)
        );
        assert_eq!(
            common_value([Some(&b), Some(&a)].into_iter()),
            Some(&b),
            "the first seen on a tie"
        );
    }
}
