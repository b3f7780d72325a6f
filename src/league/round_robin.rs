//! The round-robin: every pair of agents plays `matches_per_pair` matches, half with each
//! on yellow, round `r` of every pair served from the same seed
//! (`derive_seed(seed, MATCHES, r)`), so pairs meet the same serves and sides swap on
//! each. Results go to `matches.csv` after every batch, rewritten atomically; the same
//! command again plays only the matches that are missing, so an interrupted league
//! loses nothing, new agents join without replaying the old pairs, and more matches per
//! pair add only the new rounds.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use foosball_env::FoosballConfig;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::files::write_atomic;
use crate::play::contestant::Contestant;
use crate::play::matches::{MatchResult, MatchRules, match_table, play_match, round_seed};
use crate::provenance::BUILD_COMMIT;

/// A league's settings and agents (`league.toml`): fixed when it is created, agents
/// added later.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct League {
    /// Seed every match seed derives from.
    pub seed: u64,
    /// Matches per pair, even (half with each side on yellow).
    pub matches_per_pair: u32,
    /// The agent whose rating is pinned at 1000.
    pub anchor: String,
    /// The agents, by the names they are parsed from.
    pub agents: Vec<String>,
    /// How a match is played.
    #[serde(rename = "match")]
    pub rules: MatchRules,
    /// The table, every value pinned (the match rules are laid over it).
    pub table: FoosballConfig,
}

/// One played match.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct MatchRecord {
    /// Agent on yellow.
    pub yellow: String,
    /// Agent on black.
    pub black: String,
    /// Round within the pair (its serve seed).
    pub round: u32,
    /// How it ended.
    pub result: MatchResult,
    /// The table's preset it was played on (empty in rows written before it was
    /// recorded).
    pub preset: String,
    /// The commit of the binary that played it ([`BUILD_COMMIT`]; empty in rows written
    /// before it was recorded).
    pub commit: String,
}

const HEADER: &str = "yellow,black,round,yellow_goals,black_goals,steps,serves,yellow_spins,\
                      black_spins,preset,commit";

impl MatchRecord {
    fn line(&self) -> String {
        let r = &self.result;
        format!(
            "{},{},{},{},{},{},{},{},{},{},{}",
            self.yellow,
            self.black,
            self.round,
            r.yellow_goals,
            r.black_goals,
            r.steps,
            r.serves,
            r.yellow_spins,
            r.black_spins,
            self.preset,
            self.commit
        )
    }

    /// A row of `matches.csv`: eleven fields, or the first nine of a file written before
    /// the preset and the commit were recorded (both then empty).
    fn parse(line: &str) -> Option<Self> {
        let f: Vec<&str> = line.split(',').collect();
        let (fields, preset, commit) = match f.as_slice() {
            [fields @ .., preset, commit] if fields.len() == 9 => (fields, *preset, *commit),
            fields => (fields, "", ""),
        };
        let [yellow, black, round, yg, bg, steps, serves, ys, bs] = fields else {
            return None;
        };
        Some(Self {
            preset: preset.to_string(),
            commit: commit.to_string(),
            yellow: yellow.to_string(),
            black: black.to_string(),
            round: round.parse().ok()?,
            result: MatchResult {
                yellow_goals: yg.parse().ok()?,
                black_goals: bg.parse().ok()?,
                steps: steps.parse().ok()?,
                serves: serves.parse().ok()?,
                yellow_spins: ys.parse().ok()?,
                black_spins: bs.parse().ok()?,
            },
        })
    }
}

/// A league directory: `league.toml` and `matches.csv`.
pub struct LeagueDir {
    /// The directory.
    pub dir: PathBuf,
    /// Its settings.
    pub league: League,
    /// Every match played so far, in schedule order.
    pub records: Vec<MatchRecord>,
}

impl LeagueDir {
    /// Opens `dir`, creating it with `new` when it holds no league. An existing league
    /// keeps its settings: `new`'s agents are added, a larger `matches_per_pair` adds
    /// rounds to every pair (a smaller one is refused), anything else that differs is
    /// refused by key.
    pub fn open(dir: &Path, new: League) -> Result<Self, String> {
        let path = dir.join("league.toml");
        let league = if path.is_file() {
            let text =
                std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            let mut old: League =
                toml::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
            if new.matches_per_pair < old.matches_per_pair {
                return Err(format!(
                    "{}: the league plays {} matches per pair; `matches_per_pair` can grow \
                     (the new rounds are played), not shrink to {}",
                    path.display(),
                    old.matches_per_pair,
                    new.matches_per_pair
                ));
            }
            old.matches_per_pair = new.matches_per_pair;
            for (key, same) in [
                ("seed", old.seed == new.seed),
                ("anchor", old.anchor == new.anchor),
                ("match", old.rules == new.rules),
                ("table", old.table == new.table),
            ] {
                if !same {
                    return Err(format!(
                        "{}: the league was made with another `{key}`; use a new directory \
                         or the same settings",
                        path.display()
                    ));
                }
            }
            for a in new.agents {
                if !old.agents.contains(&a) {
                    old.agents.push(a);
                }
            }
            old
        } else {
            new
        };
        league.validate()?;
        let csv = dir.join("matches.csv");
        let records = match std::fs::read_to_string(&csv) {
            Ok(text) => text
                .lines()
                .skip(1)
                .enumerate()
                .map(|(i, l)| {
                    MatchRecord::parse(l).ok_or_else(|| {
                        format!("{}:{}: not a match record: {l}", csv.display(), i + 2)
                    })
                })
                .collect::<Result<Vec<_>, _>>()?,
            Err(_) => vec![],
        };
        let text = toml::to_string(&league).map_err(|e| e.to_string())?;
        write_atomic(&path, text.as_bytes()).map_err(|e| e.to_string())?;
        Ok(Self {
            dir: dir.to_path_buf(),
            league,
            records,
        })
    }

    /// The matches of the schedule not yet played: `(yellow, black, round)` indices.
    pub fn pending(&self) -> Vec<(usize, usize, u32)> {
        let played: std::collections::BTreeSet<(&str, &str, u32)> = self
            .records
            .iter()
            .map(|r| (r.yellow.as_str(), r.black.as_str(), r.round))
            .collect();
        let agents = &self.league.agents;
        let mut out = vec![];
        for i in 0..agents.len() {
            for j in i + 1..agents.len() {
                for round in 0..self.league.matches_per_pair / 2 {
                    for (y, b) in [(i, j), (j, i)] {
                        if !played.contains(&(agents[y].as_str(), agents[b].as_str(), round)) {
                            out.push((y, b, round));
                        }
                    }
                }
            }
        }
        out
    }

    /// Plays the pending matches on `threads` threads, `batch` at a time, saving after
    /// each batch; `progress(done, total)` after each.
    pub fn play(
        &mut self,
        threads: usize,
        mut progress: impl FnMut(usize, usize),
    ) -> Result<(), String> {
        let contestants: Vec<Contestant> = self
            .league
            .agents
            .iter()
            .map(|a| a.parse())
            .collect::<Result<_, _>>()?;
        let table = match_table(&self.league.table, &self.league.rules);
        // Every agent must fit the table before any match is played.
        for c in &contestants {
            c.policy(&table, 0).map(drop)?;
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.max(1))
            .build()
            .map_err(|e| e.to_string())?;
        let pending = self.pending();
        let total = pending.len();
        let batch = 4 * threads.max(1);
        for (k, chunk) in pending.chunks(batch).enumerate() {
            let played: Vec<Result<MatchRecord, String>> = pool.install(|| {
                chunk
                    .par_iter()
                    .map(|&(y, b, round)| {
                        let seed = round_seed(self.league.seed, round);
                        let (yellow, black) = (&contestants[y], &contestants[b]);
                        let result = play_match(&table, &self.league.rules, yellow, black, seed)
                            .map_err(|e| format!("{} vs {}: {e}", yellow, black))?;
                        Ok(MatchRecord {
                            yellow: self.league.agents[y].clone(),
                            black: self.league.agents[b].clone(),
                            round,
                            result,
                            preset: self.league.table.preset.name().to_string(),
                            commit: BUILD_COMMIT.to_string(),
                        })
                    })
                    .collect()
            });
            for r in played {
                self.records.push(r?);
            }
            self.save()?;
            progress((k * batch + chunk.len()).min(total), total);
        }
        Ok(())
    }

    fn save(&self) -> Result<(), String> {
        let mut text = String::from(HEADER);
        text.push('\n');
        for r in &self.records {
            text.push_str(&r.line());
            text.push('\n');
        }
        write_atomic(&self.dir.join("matches.csv"), text.as_bytes()).map_err(|e| e.to_string())
    }

    /// Every match between agents of the league, by agent index: `(yellow, black,
    /// result)`.
    pub fn games(&self) -> Vec<(usize, usize, MatchResult)> {
        let index: BTreeMap<&str, usize> = self
            .league
            .agents
            .iter()
            .enumerate()
            .map(|(i, a)| (a.as_str(), i))
            .collect();
        self.records
            .iter()
            .filter_map(|r| {
                Some((
                    *index.get(r.yellow.as_str())?,
                    *index.get(r.black.as_str())?,
                    r.result,
                ))
            })
            .collect()
    }
}

impl League {
    /// Checks the settings; errors name the key.
    pub fn validate(&self) -> Result<(), String> {
        self.rules.validate()?;
        if self.matches_per_pair == 0 || self.matches_per_pair % 2 == 1 {
            return Err(format!(
                "matches_per_pair: must be even and at least 2 (sides swap), got {}",
                self.matches_per_pair
            ));
        }
        if self.agents.len() < 2 {
            return Err(format!(
                "agents: a league needs at least 2, got {}",
                self.agents.len()
            ));
        }
        let mut seen = std::collections::BTreeSet::new();
        for a in &self.agents {
            if a.contains(',') {
                return Err(format!("agents: `{a}` has a comma"));
            }
            if !seen.insert(a) {
                return Err(format!("agents: `{a}` is named twice"));
            }
        }
        if !self.agents.contains(&self.anchor) {
            return Err(format!("anchor: `{}` is not among the agents", self.anchor));
        }
        Ok(())
    }
}
