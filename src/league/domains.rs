//! The leaderboard's columns beside the matches: each agent's standard test (the
//! 1,000-episode test of `evaluate`, its score rate with a Wilson interval) in every
//! domain of the board:
//!
//! - `reference`, the paper code's game;
//! - `reference_randomized`, that game on a table whose ball and servos are drawn anew
//!   each episode ([`Preset::ReferenceRandomized`]);
//! - the paper code's own MuJoCo model, where `tools/transfer.py` has measured the agent
//!   (its `--out` JSON in `LEAGUE/mujoco/`, with `"agent"` naming the league's agent):
//!   MuJoCo is a measuring instrument, never a dependency, so elsewhere the column says
//!   "not measured".
//!
//! The tests on our tables are played once per agent and domain and kept in
//! `LEAGUE/domains.csv` (`agent,domain,episodes,score_rate,low,high,commit`, the commit
//! of the binary that played them), so adding an agent tests only it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::files::write_atomic;
use crate::play::contestant::Contestant;
use crate::play::metrics::TestMetrics;
use crate::play::player::Player;
use crate::provenance::BUILD_COMMIT;
use foosball_env::Preset;

/// The tables every agent is tested on, in column order (the MuJoCo model comes after).
pub const TABLES: [Preset; 2] = [Preset::Reference, Preset::ReferenceRandomized];

/// The MuJoCo column's name.
pub const MUJOCO: &str = "mujoco";

const HEADER: &str = "agent,domain,episodes,score_rate,low,high,commit";

/// One agent's test in one domain.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DomainScore {
    /// Episodes played.
    pub episodes: u32,
    /// Share of episodes that scored, in [0, 1].
    pub score_rate: f64,
    /// Its 95 % interval (Wilson).
    pub ci95: [f64; 2],
    /// The commit of the binary that played it (empty for the MuJoCo model's).
    pub commit: String,
}

impl DomainScore {
    /// `22.6 % [20.1, 25.3]`.
    pub fn label(&self) -> String {
        format!(
            "{:.1} % [{:.1}, {:.1}]",
            100.0 * self.score_rate,
            100.0 * self.ci95[0],
            100.0 * self.ci95[1]
        )
    }
}

/// The domain tests of a league directory: per agent and domain name
/// ([`Preset::name`] or [`MUJOCO`]), its score.
#[derive(Clone, Debug, Default)]
pub struct DomainTests {
    dir: PathBuf,
    scores: BTreeMap<(String, String), DomainScore>,
}

impl DomainTests {
    /// The tests kept in `dir` (`domains.csv` and `mujoco/*.json`; none where absent).
    /// Errors name the file and line at fault.
    pub fn open(dir: &Path) -> Result<Self, String> {
        let mut tests = Self {
            dir: dir.to_path_buf(),
            scores: BTreeMap::new(),
        };
        let csv = dir.join("domains.csv");
        if let Ok(text) = std::fs::read_to_string(&csv) {
            for (i, line) in text.lines().enumerate().skip(1) {
                let (key, score) = parse_row(line).ok_or_else(|| {
                    format!("{}:{}: not a test row: {line}", csv.display(), i + 1)
                })?;
                tests.scores.insert(key, score);
            }
        }
        let mujoco = dir.join("mujoco");
        if let Ok(entries) = std::fs::read_dir(&mujoco) {
            let mut files: Vec<PathBuf> = entries
                .filter_map(|e| Some(e.ok()?.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "json"))
                .collect();
            files.sort();
            for file in files {
                let (agent, score) = read_transfer(&file)?;
                tests.scores.insert((agent, MUJOCO.into()), score);
            }
        }
        Ok(tests)
    }

    /// `agent`'s score in `domain` ([`Preset::name`] or [`MUJOCO`]), if measured.
    pub fn score(&self, agent: &str, domain: &str) -> Option<&DomainScore> {
        self.scores.get(&(agent.to_string(), domain.to_string()))
    }

    /// Plays the standard test of `episodes` episodes on every table of [`TABLES`] for
    /// each of `agents` not yet tested there (a contestant with held rods has no test
    /// and is left out), writing `domains.csv` after each, with `progress(agent, domain,
    /// score)` after each.
    pub fn play_missing(
        &mut self,
        agents: &[String],
        episodes: u32,
        mut progress: impl FnMut(&str, &str, &DomainScore),
    ) -> Result<(), String> {
        for agent in agents {
            let contestant: Contestant = agent.parse()?;
            if matches!(contestant, Contestant::Held { .. }) {
                continue;
            }
            for table in TABLES {
                let key = (agent.clone(), table.name().to_string());
                if self.scores.contains_key(&key) {
                    continue;
                }
                let player = Player::standard_test(&contestant, table)
                    .map_err(|why| format!("{agent} on {}: {why}", table.name()))?;
                let played = player.play(episodes, false)?;
                let summaries: Vec<_> = played.iter().map(|e| e.summary).collect();
                let m = TestMetrics::from_episodes(&summaries);
                let score = DomainScore {
                    episodes,
                    score_rate: m.score_rate.mean,
                    ci95: m.score_rate.ci95,
                    commit: BUILD_COMMIT.into(),
                };
                progress(agent, table.name(), &score);
                self.scores.insert(key, score);
                self.write()?;
            }
        }
        Ok(())
    }

    /// Writes `domains.csv` (the tests on our tables; the MuJoCo model's stay in their
    /// files).
    fn write(&self) -> Result<(), String> {
        let mut text = format!("{HEADER}\n");
        for ((agent, domain), s) in &self.scores {
            if domain != MUJOCO {
                text += &format!(
                    "{agent},{domain},{},{},{},{},{}\n",
                    s.episodes, s.score_rate, s.ci95[0], s.ci95[1], s.commit
                );
            }
        }
        write_atomic(&self.dir.join("domains.csv"), text.as_bytes()).map_err(|e| e.to_string())
    }
}

/// A row of `domains.csv`: the agent is everything before the last six fields.
fn parse_row(line: &str) -> Option<((String, String), DomainScore)> {
    let mut fields = line.rsplitn(7, ',');
    let commit = fields.next()?.to_string();
    let high = fields.next()?.parse().ok()?;
    let low = fields.next()?.parse().ok()?;
    let score_rate = fields.next()?.parse().ok()?;
    let episodes = fields.next()?.parse().ok()?;
    let domain = fields.next()?.to_string();
    let agent = fields.next()?.to_string();
    Some((
        (agent, domain),
        DomainScore {
            episodes,
            score_rate,
            ci95: [low, high],
            commit,
        },
    ))
}

/// What `tools/transfer.py --out` wrote: the agent (`"agent"`, else `"run"`) and its
/// score on the MuJoCo model (`"mujoco"`'s `"episodes"` and `"score_rate"`: value, low,
/// high).
fn read_transfer(file: &Path) -> Result<(String, DomainScore), String> {
    #[derive(Deserialize)]
    struct Transfer {
        agent: Option<String>,
        run: Option<String>,
        mujoco: Measured,
    }
    #[derive(Deserialize)]
    struct Measured {
        episodes: u32,
        score_rate: [f64; 3],
    }
    let at = |why: String| format!("{}: {why}", file.display());
    let text = std::fs::read_to_string(file).map_err(|e| at(e.to_string()))?;
    let t: Transfer = serde_json::from_str(&text).map_err(|e| at(e.to_string()))?;
    let agent = t
        .agent
        .or(t.run)
        .ok_or_else(|| at("neither `agent` nor `run` names the agent".into()))?;
    let [score_rate, low, high] = t.mujoco.score_rate;
    Ok((
        agent,
        DomainScore {
            episodes: t.mujoco.episodes,
            score_rate,
            ci95: [low, high],
            commit: String::new(),
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_reads_back_with_commas_in_the_agent() {
        let line = "process:python p.py --a 1,2,reference,1000,0.25,0.2,0.3,abc123";
        let ((agent, domain), s) = parse_row(line).expect("a row");
        assert_eq!(agent, "process:python p.py --a 1,2");
        assert_eq!(domain, "reference");
        assert_eq!((s.episodes, s.score_rate, s.ci95), (1000, 0.25, [0.2, 0.3]));
        assert_eq!(s.commit, "abc123");
        assert!(parse_row("shooter,reference,many,0.1,0,0.2,x").is_none());
    }
}
