//! The leaderboard of a league: standings sorted by rating, the win-rate matrix, and the
//! files that show them: `leaderboard.json`, `leaderboard.md`, `heatmap.png` (row
//! agent's points share against each column agent, at most [`PAGE_WIDTH`] pixels wide)
//! and `index.html` (a sortable table of short names, whole on hover, each with a line
//! saying what it is and a link to its run, and the heatmap; it opens from disk with no
//! server).

use std::path::{Component, Path, PathBuf};

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use serde::Serialize;

use super::domains::{DomainScore, DomainTests, MUJOCO, TABLES};
use super::ratings::{Game, bootstrap, fit};
use super::round_robin::LeagueDir;
use crate::files::write_atomic;
use crate::play::contestant::Contestant;
use crate::play::matches::{MatchRules, Tally};
use crate::play::metrics::wilson_points;
use crate::png::png;

/// Bootstrap resamples of the rating intervals and the first-place shares.
pub const RESAMPLES: usize = 500;

/// The window width the page's heatmap fits, pixels.
pub const PAGE_WIDTH: i32 = 1280;

/// Characters of a short name at most (longer ones keep their end).
const SHORT_NAME_CHARS: usize = 32;

/// One agent's line.
#[derive(Clone, Debug, Serialize)]
pub struct Standing {
    /// The agent, by the name it is parsed from.
    pub agent: String,
    /// Its short name (a run's directory name; its parent's too where two would read
    /// the same), at most 32 characters.
    pub short: String,
    /// What it is, in one line ([`Contestant::about`]).
    pub about: String,
    /// Its run directory as named, or its ONNX file's folder ([`Contestant::home`]; none
    /// for a scripted policy or a program): where the page links it.
    pub run: Option<PathBuf>,
    /// Bradley-Terry rating, Elo scale (the anchor at 1000).
    pub rating: f64,
    /// Its 95 % bootstrap interval.
    pub ci95: [f64; 2],
    /// The share of the bootstrap resamples in which it is rated first, in [0, 1].
    pub rated_first: f64,
    /// Matches played.
    pub matches: u32,
    /// Wins, draws and losses.
    pub wins: u32,
    /// Draws.
    pub draws: u32,
    /// Losses.
    pub losses: u32,
    /// Goals scored minus goals let in.
    pub goal_difference: i64,
    /// Spins of its rods per minute of play ([`foosball_env::spin`]).
    pub spins_per_minute: f64,
    /// Its standard test in each of the board's [`Leaderboard::domains`] (None: not
    /// measured).
    pub tests: Vec<Option<DomainScore>>,
}

/// Row agent against column agent: points share with its Wilson interval.
#[derive(Clone, Debug, Serialize)]
pub struct Cell {
    /// Matches between the two.
    pub matches: u32,
    /// The row agent's points share (win 1, draw 0.5), in [0, 1].
    pub win_rate: f64,
    /// Its 95 % Wilson interval.
    pub ci95: [f64; 2],
}

/// A league's standings and matrix.
#[derive(Clone, Debug, Serialize)]
pub struct Leaderboard {
    /// The anchor (rating 1000).
    pub anchor: String,
    /// Matches per pair.
    pub matches_per_pair: u32,
    /// How the matches were played.
    pub rules: MatchRules,
    /// The domains of the standings' tests ([`super::domains`]; empty for a board shown
    /// without them).
    pub domains: Vec<String>,
    /// Standings, best first.
    pub standings: Vec<Standing>,
    /// The agents in matrix order (the standings' order).
    pub agents: Vec<String>,
    /// `matrix[i][j]`: agent i against agent j (None on the diagonal or unplayed).
    pub matrix: Vec<Vec<Option<Cell>>>,
}

impl Leaderboard {
    /// The leaderboard of every match played in `league`.
    pub fn of(league: &LeagueDir) -> Self {
        let names = &league.league.agents;
        let n = names.len();
        let anchor = names
            .iter()
            .position(|a| *a == league.league.anchor)
            .unwrap_or(0);
        let played = league.games();
        let games: Vec<Game> = played
            .iter()
            .map(|&(y, b, r)| Game {
                a: y,
                b,
                a_points: r.yellow_points(),
            })
            .collect();
        let ratings = fit(n, &games, anchor);
        let boot = bootstrap(n, &games, anchor, RESAMPLES, league.league.seed);
        // Each agent's matches, and each ordered pair's (row agent's side).
        let mut tallies = vec![Tally::default(); n];
        let mut pairs = vec![vec![Tally::default(); n]; n];
        for &(y, b, r) in &played {
            for (me, other, yellow) in [(y, b, true), (b, y, false)] {
                tallies[me].add(r.side(yellow));
                pairs[me][other].add(r.side(yellow));
            }
        }
        let contestants: Vec<Option<Contestant>> = names.iter().map(|a| a.parse().ok()).collect();
        let shorts = short_names(names, &contestants);
        let standings: Vec<Standing> = (0..n)
            .map(|i| {
                let t = &tallies[i];
                let c = contestants[i].as_ref();
                Standing {
                    agent: names[i].clone(),
                    short: shorts[i].clone(),
                    about: c.map_or_else(|| "?".into(), Contestant::about),
                    run: c.and_then(Contestant::home).map(Path::to_path_buf),
                    rating: ratings[i],
                    ci95: boot.ci95[i],
                    rated_first: boot.first[i],
                    matches: t.matches,
                    wins: t.wins,
                    draws: t.draws,
                    losses: t.losses,
                    goal_difference: t.goal_difference(),
                    spins_per_minute: t.spins_per_minute(league.league.table.agent_dt()),
                    tests: vec![],
                }
            })
            .collect();
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| ratings[b].total_cmp(&ratings[a]).then(a.cmp(&b)));
        let matrix = order
            .iter()
            .map(|&i| {
                order
                    .iter()
                    .map(|&j| {
                        let t = &pairs[i][j];
                        let m = f64::from(t.matches);
                        (i != j && t.matches > 0).then(|| Cell {
                            matches: t.matches,
                            win_rate: t.points / m,
                            ci95: wilson_points(t.points, m).ci95,
                        })
                    })
                    .collect()
            })
            .collect();
        Self {
            anchor: names[anchor].clone(),
            matches_per_pair: league.league.matches_per_pair,
            rules: league.league.rules.clone(),
            domains: vec![],
            agents: order.iter().map(|&i| names[i].clone()).collect(),
            standings: order.iter().map(|&i| standings[i].clone()).collect(),
            matrix,
        }
    }

    /// The board with each agent's standard test in every domain of `tests` (our tables,
    /// then the MuJoCo model).
    pub fn with_tests(mut self, tests: &DomainTests) -> Self {
        self.domains = TABLES.iter().map(|p| p.name().to_string()).collect();
        self.domains.push(MUJOCO.into());
        for st in &mut self.standings {
            st.tests = self
                .domains
                .iter()
                .map(|d| tests.score(&st.agent, d).cloned())
                .collect();
        }
        self
    }

    /// A domain's column heading.
    fn domain_heading(domain: &str) -> String {
        if domain == MUJOCO {
            "test on the MuJoCo model".into()
        } else {
            format!("test on {domain}")
        }
    }

    /// A standing's test cells.
    fn test_cells(st: &Standing) -> Vec<String> {
        st.tests
            .iter()
            .map(|t| {
                t.as_ref()
                    .map_or_else(|| "not measured".into(), DomainScore::label)
            })
            .collect()
    }

    /// The standings and the matrix as markdown.
    pub fn to_markdown(&self) -> String {
        let headings: String = self
            .domains
            .iter()
            .map(|d| format!(" {} (score rate) |", Self::domain_heading(d)))
            .collect();
        let mut s = format!(
            "| rank | agent | rating (Elo scale, {} = 1000) | 95 % CI | rated first (resamples) | matches | W-D-L | goal difference | spins per minute |{headings}\n| --- | --- | --- | --- | --- | --- | --- | --- | --- |{}\n",
            self.anchor,
            " --- |".repeat(self.domains.len())
        );
        for (k, st) in self.standings.iter().enumerate() {
            let tests: String = Self::test_cells(st)
                .iter()
                .map(|c| format!(" {c} |"))
                .collect();
            s += &format!(
                "| {} | {} | {:.0} | [{:.0}, {:.0}] | {:.0} % | {} | {}-{}-{} | {:+} | {:.2} |{tests}\n",
                k + 1,
                st.agent,
                st.rating,
                st.ci95[0],
                st.ci95[1],
                100.0 * st.rated_first,
                st.matches,
                st.wins,
                st.draws,
                st.losses,
                st.goal_difference,
                st.spins_per_minute
            );
        }
        s += &format!("\n{}\n", self.rules_line());
        s += "\nRow against column: the row agent's points share (win 1, draw 0.5) [95 % Wilson interval].\n\n| | ";
        s += &(1..=self.agents.len())
            .map(|k| k.to_string())
            .collect::<Vec<_>>()
            .join(" | ");
        s += " |\n|";
        s += &" --- |".repeat(self.agents.len() + 1);
        s += "\n";
        for (i, row) in self.matrix.iter().enumerate() {
            s += &format!("| {} {} |", i + 1, self.agents[i]);
            for cell in row {
                s += &match cell {
                    Some(c) => format!(
                        " {:.0} % [{:.0}, {:.0}] |",
                        100.0 * c.win_rate,
                        100.0 * c.ci95[0],
                        100.0 * c.ci95[1]
                    ),
                    None => " |".into(),
                };
            }
            s += "\n";
        }
        s
    }

    /// Writes `leaderboard.json`, `leaderboard.md`, `heatmap.png` and `index.html` into
    /// `dir`.
    pub fn write(&self, dir: &Path) -> Result<(), String> {
        let json = serde_json::to_string_pretty(self).expect("a leaderboard serialises");
        write_atomic(&dir.join("leaderboard.json"), json.as_bytes()).map_err(|e| e.to_string())?;
        write_atomic(&dir.join("leaderboard.md"), self.to_markdown().as_bytes())
            .map_err(|e| e.to_string())?;
        self.heatmap(&dir.join("heatmap.png"))?;
        write_atomic(&dir.join("index.html"), self.html(dir).as_bytes()).map_err(|e| e.to_string())
    }

    fn heatmap(&self, path: &Path) -> Result<(), String> {
        let n = self.agents.len();
        let shorts: Vec<&str> = self.standings.iter().map(|s| s.short.as_str()).collect();
        let HeatmapLayout {
            label_w,
            cell,
            size,
        } = HeatmapLayout::of(&shorts);
        png(path, size, |root| {
            let title = ("sans-serif", 20).into_font();
            root.draw(&Text::new(
                "row agent's points share against the column agent (win 1, draw 0.5)",
                (10, 12),
                title,
            ))?;
            let font = TextStyle::from(("sans-serif", 14).into_font());
            let numbers =
                TextStyle::from(("sans-serif", if cell < 40 { 11 } else { 14 }).into_font());
            for (i, row) in self.matrix.iter().enumerate() {
                let y = 60 + cell * i as i32;
                root.draw(&Text::new(
                    format!("{} {}", i + 1, shorts[i]),
                    (label_w - 8, y + cell / 2),
                    font.clone().pos(Pos::new(HPos::Right, VPos::Center)),
                ))?;
                for (j, c) in row.iter().enumerate() {
                    let x = label_w + cell * j as i32;
                    let (fill, text) = match c {
                        Some(c) => (diverging(c.win_rate), format!("{:.0}", 100.0 * c.win_rate)),
                        None => (RGBColor(235, 235, 235), String::new()),
                    };
                    root.draw(&Rectangle::new(
                        [(x, y), (x + cell - 2, y + cell - 2)],
                        fill.filled(),
                    ))?;
                    root.draw(&Text::new(
                        text,
                        (x + cell / 2, y + cell / 2),
                        numbers.clone().pos(Pos::new(HPos::Center, VPos::Center)),
                    ))?;
                }
            }
            for j in 0..n {
                root.draw(&Text::new(
                    (j + 1).to_string(),
                    (label_w + cell * j as i32 + cell / 2, 46),
                    font.clone().pos(Pos::new(HPos::Center, VPos::Center)),
                ))?;
            }
            Ok(())
        })
        .map_err(|e| format!("{}: {e}", path.display()))
    }

    /// The page written into `dir` (its links to the runs relative to it).
    fn html(&self, dir: &Path) -> String {
        let rows: String = self
            .standings
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let name = match &s.run {
                    Some(run) => format!(
                        "<a href=\"{}\">{}</a>",
                        escape(&relative(run, dir)),
                        escape(&s.short)
                    ),
                    None => escape(&s.short),
                };
                let tests: String = Self::test_cells(s)
                    .iter()
                    .map(|c| format!("<td>{}</td>", escape(c)))
                    .collect();
                format!(
                    "<tr><td>{}</td><td title=\"{}\">{name}<div class=\"about\">{}</div></td><td>{:.0}</td><td>{:.0} – {:.0}</td><td>{:.0} %</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:+}</td><td>{:.2}</td>{tests}</tr>\n",
                    k + 1,
                    escape(&s.agent),
                    escape(&s.about),
                    s.rating,
                    s.ci95[0],
                    s.ci95[1],
                    100.0 * s.rated_first,
                    s.matches,
                    s.wins,
                    s.draws,
                    s.losses,
                    s.goal_difference,
                    s.spins_per_minute
                )
            })
            .collect();
        format!(
            r##"<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>foosball-rl leaderboard</title>
<style>
body {{ font-family: sans-serif; margin: 2em; color: #222; }}
table {{ border-collapse: collapse; }}
th, td {{ border: 1px solid #ccc; padding: 4px 10px; text-align: right; }}
td:nth-child(2), th:nth-child(2) {{ text-align: left; }}
td .about {{ font-size: 80%; color: #666; max-width: 36em; }}
img {{ max-width: 100%; }}
th {{ background: #eee; cursor: pointer; user-select: none; }}
th.sorted::after {{ content: " ▾"; }}
</style></head>
<body>
<h1>foosball-rl leaderboard</h1>
<p>Bradley–Terry ratings on the Elo scale ({anchor} pinned at 1000), 95 % bootstrap intervals over matches and the share of those resamples in which each agent is rated first;
{rules}{tests_line} Click a heading to sort.</p>
<table id="board"><thead><tr><th>rank</th><th>agent</th><th>rating</th><th>95 % CI</th><th>rated first</th><th>matches</th><th>wins</th><th>draws</th><th>losses</th><th>goal difference</th><th>spins per minute</th>{test_headings}</tr></thead>
<tbody>
{rows}</tbody></table>
<h2>Head to head</h2>
<p><img src="heatmap.png" alt="win-rate matrix"></p>
<script>
document.querySelectorAll("#board th").forEach((th, col) => th.addEventListener("click", () => {{
  const body = document.querySelector("#board tbody");
  const key = r => {{ const t = r.children[col].firstChild.textContent; const v = parseFloat(t); return isNaN(v) ? t : v; }};
  const down = !th.classList.contains("sorted");
  document.querySelectorAll("#board th").forEach(h => h.classList.remove("sorted"));
  if (down) th.classList.add("sorted");
  [...body.rows].sort((a, b) => {{ const x = key(a), y = key(b); const c = x < y ? -1 : x > y ? 1 : 0; return down ? -c : c; }})
    .forEach(r => body.appendChild(r));
}}));
</script>
</body></html>
"##,
            anchor = escape(&self.anchor),
            rules = escape(&self.rules_line()),
            tests_line = if self.domains.is_empty() {
                String::new()
            } else {
                " The test columns: each agent's standard test (score rate and its 95 % Wilson \
                 interval) on the reference table, on the randomised table and on the paper \
                 code's MuJoCo model where tools/transfer.py measured it."
                    .into()
            },
            test_headings = self
                .domains
                .iter()
                .map(|d| format!("<th>{}</th>", escape(&Self::domain_heading(d))))
                .collect::<String>(),
        )
    }

    /// How the matches were played, in one sentence.
    fn rules_line(&self) -> String {
        let r = &self.rules;
        let possession = if r.possession {
            let [five_man, other] = r.possession_limit_s;
            format!(
                "; possession limits (ITSF): {five_man} s on a five-man rod, {other} s elsewhere"
            )
        } else {
            String::new()
        };
        format!(
            "{} matches per pair, sides swapped; first to {} goals or {} s of play; kick-off {}: {}{possession}.",
            self.matches_per_pair,
            r.goals_to_win,
            r.time_limit_s,
            r.kickoff,
            r.kickoff.meaning()
        )
    }
}

/// Red (0) through white (0.5) to green (1).
fn diverging(v: f64) -> RGBColor {
    let v = v.clamp(0.0, 1.0);
    let mix = |a: f64, b: f64, t: f64| (a + (b - a) * t).round() as u8;
    if v < 0.5 {
        let t = v / 0.5;
        RGBColor(
            mix(215.0, 255.0, t),
            mix(48.0, 255.0, t),
            mix(39.0, 255.0, t),
        )
    } else {
        let t = (v - 0.5) / 0.5;
        RGBColor(
            mix(255.0, 26.0, t),
            mix(255.0, 152.0, t),
            mix(255.0, 80.0, t),
        )
    }
}

/// Where the heatmap's labels and cells go: the label column's width, the cell's side and
/// the image's size, pixels. Cells are 64 pixels where the agents fit [`PAGE_WIDTH`], as
/// small as 24 where they do not.
#[derive(Debug, PartialEq)]
struct HeatmapLayout {
    label_w: i32,
    cell: i32,
    size: (u32, u32),
}

impl HeatmapLayout {
    fn of(labels: &[&str]) -> Self {
        let n = labels.len().max(1) as i32;
        let longest = labels.iter().map(|a| a.chars().count()).max().unwrap_or(0);
        // "NN " before each label, about 8 pixels a character at 14 points.
        let label_w = 40 + 8 * longest as i32;
        let cell = ((PAGE_WIDTH - 20 - label_w) / n).clamp(24, 64);
        Self {
            label_w,
            cell,
            size: (
                (label_w + cell * n + 20) as u32,
                (60 + cell * n + 40) as u32,
            ),
        }
    }
}

/// The agents' short names ([`Contestant::short_name`]), cut to [`SHORT_NAME_CHARS`]: a
/// run by its directory's name, by its parent's and its own where two would read the same,
/// by its whole name where even those do; an agent that does not parse by its name.
fn short_names(names: &[String], contestants: &[Option<Contestant>]) -> Vec<String> {
    let at = |depth: usize| -> Vec<String> {
        names
            .iter()
            .zip(contestants)
            .map(|(name, c)| {
                c.as_ref()
                    .map_or_else(|| name.clone(), |c| c.short_name(depth))
            })
            .collect()
    };
    let (one, two) = (at(1), at(2));
    let cut = |v: &[String], f: fn(&str, usize) -> String| -> Vec<String> {
        v.iter().map(|s| f(s, SHORT_NAME_CHARS)).collect()
    };
    // Shortened forms, tried in order: the first that no other agent shares is taken.
    let levels = [
        cut(&one, shorten),
        cut(&two, shorten),
        cut(&two, keep_end),
        cut(names, shorten),
        cut(names, keep_end),
    ];
    let unique = |v: &[String], i: usize| v.iter().filter(|s| **s == v[i]).count() == 1;
    (0..names.len())
        .map(|i| {
            levels
                .iter()
                .find(|v| unique(v, i))
                .unwrap_or(&levels[levels.len() - 1])[i]
                .clone()
        })
        .collect()
}

/// `target` as a link from a page in `base`: `..` for each of `base`'s components past
/// their common start, both taken as the real paths they name where they exist (links
/// resolved), else from the working directory, so a page links within the tree it sits
/// in however the two were named.
fn relative(target: &Path, base: &Path) -> String {
    fn parts(p: &Path) -> Vec<Component<'_>> {
        p.components().filter(|c| *c != Component::CurDir).collect()
    }
    let absolute = |p: &Path| {
        p.canonicalize()
            .unwrap_or_else(|_| match std::env::current_dir() {
                Ok(cwd) if !p.is_absolute() => cwd.join(p),
                _ => p.to_path_buf(),
            })
    };
    let (target, base) = (absolute(target), absolute(base));
    let (t, b) = (parts(&target), parts(&base));
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut link: PathBuf = b[common..].iter().map(|_| "..").collect();
    link.extend(&t[common..]);
    format!("{}/", link.display())
}

/// `s` cut to `n` characters (n >= 2) at its start: `…` and its last `n - 1` (where two
/// names cut in the middle read the same).
fn keep_end(s: &str, n: usize) -> String {
    let chars: Vec<char> = s.chars().collect();
    if chars.len() <= n {
        return s.to_string();
    }
    let end: String = chars[chars.len() - (n - 1)..].iter().collect();
    format!("…{end}")
}

/// `s` cut to `n` characters (n >= 2) in its middle: the start and the end (a run's kind
/// and its seed) kept, `…` between.
fn shorten(s: &str, n: usize) -> String {
    let chars: Vec<char> = s.chars().collect();
    if chars.len() <= n {
        return s.to_string();
    }
    let head = (n - 1) / 2;
    let tail = n - 1 - head;
    let start: String = chars[..head].iter().collect();
    let end: String = chars[chars.len() - tail..].iter().collect();
    format!("{start}…{end}")
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_heatmap_of_fifteen_long_names_fits_the_page() {
        let label = "x".repeat(SHORT_NAME_CHARS);
        let layout = HeatmapLayout::of(&vec![label.as_str(); 15]);
        assert!(layout.size.0 <= PAGE_WIDTH as u32, "{layout:?}");
        // Twenty take smaller cells to fit.
        let layout = HeatmapLayout::of(&vec![label.as_str(); 20]);
        assert!(layout.size.0 <= PAGE_WIDTH as u32, "{layout:?}");
        assert!(layout.cell >= 24 && layout.cell < 64, "{layout:?}");
        // A few short names keep the full cell.
        assert_eq!(HeatmapLayout::of(&["shooter", "zero", "random"]).cell, 64);
    }

    /// Run directories `runs` under the temporary folder `scratch`, each with a
    /// `config.toml` of algorithm `algo` only; their paths.
    fn run_dirs(scratch: &str, runs: &[&str], algo: &str) -> Vec<String> {
        let dir = std::env::temp_dir().join(scratch);
        runs.iter()
            .map(|run| {
                std::fs::create_dir_all(dir.join(run)).unwrap();
                let config = format!("algo = \"{algo}\"\n");
                std::fs::write(dir.join(run).join("config.toml"), config).unwrap();
                dir.join(run).display().to_string()
            })
            .collect()
    }

    #[test]
    fn short_names_are_run_names_with_their_parent_where_two_would_read_the_same() {
        let mut names = run_dirs(
            "foosball-short-names",
            &[
                "a/figure2/sac-seed0",
                "a/figure2-v3/sac-seed0",
                "a/league/ppo-seed1",
            ],
            "sac",
        );
        names[2] += "@best";
        names.push("shooter".into());
        names.push("no-such-agent".into());
        let contestants: Vec<Option<Contestant>> = names.iter().map(|a| a.parse().ok()).collect();
        assert_eq!(
            short_names(&names, &contestants),
            [
                "figure2/sac-seed0",
                "figure2-v3/sac-seed0",
                "ppo-seed1@best",
                "shooter",
                "no-such-agent"
            ]
        );
        let about = contestants[0].as_ref().unwrap().about();
        assert!(about.starts_with("sac 256x256 networks trained"), "{about}");
        assert!(
            contestants[3]
                .as_ref()
                .unwrap()
                .about()
                .starts_with("scripted: Lines the man")
        );
    }

    /// Two runs whose directory names cut in the middle read the same keep their ends.
    #[test]
    fn names_that_cut_alike_keep_their_ends() {
        let names = run_dirs(
            "foosball-cut-names",
            &[
                "r/fourier-ball-128-kickstart-defence-more7/ppo-seed0",
                "r/fourier-ball-128-kickstart-defence-mixed-from-more7/ppo-seed0",
            ],
            "ppo",
        );
        let contestants: Vec<Option<Contestant>> = names.iter().map(|a| a.parse().ok()).collect();
        let shorts = short_names(&names, &contestants);
        assert_eq!(
            shorts,
            [
                "…ckstart-defence-more7/ppo-seed0",
                "…ence-mixed-from-more7/ppo-seed0"
            ]
        );
        assert!(shorts.iter().all(|s| s.chars().count() <= SHORT_NAME_CHARS));
    }

    #[test]
    fn a_run_is_linked_relative_to_the_page() {
        let link = relative(
            Path::new("results/figure2/sac-seed0"),
            Path::new("results/league/leaderboard"),
        );
        assert_eq!(link, "../../figure2/sac-seed0/");
        assert_eq!(
            relative(Path::new("./runs/x"), Path::new("out")),
            "../runs/x/"
        );
        let cwd = std::env::current_dir().unwrap();
        assert_eq!(
            relative(Path::new("runs/x"), &cwd.join("out")),
            "../runs/x/"
        );
        // Existing folders named both ways (absolute, relative, through `..`) link alike.
        let (run, page) = (Path::new("results/figure2"), Path::new("results/league"));
        let expected = "../figure2/";
        assert_eq!(relative(run, page), expected);
        assert_eq!(relative(&cwd.join(run), page), expected);
        assert_eq!(relative(run, &cwd.join(page)), expected);
        assert_eq!(
            relative(&cwd.join("docs/../results/figure2"), page),
            expected
        );
    }

    #[test]
    fn a_long_name_keeps_its_start_and_end() {
        assert_eq!(
            shorten("self-play-kickoff-hidden-seed1", 16),
            "self-pl…en-seed1"
        );
        assert_eq!(shorten("sac-seed0", 16), "sac-seed0");
    }
}
