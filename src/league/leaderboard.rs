//! The leaderboard of a league: standings sorted by rating, the win-rate matrix, and the
//! files that show them: `leaderboard.json`, `leaderboard.md`, `heatmap.png` (row
//! agent's points share against each column agent) and `index.html` (a sortable table
//! and the heatmap, opening from disk with no server).

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use serde::Serialize;

use super::ratings::{Game, fit, intervals};
use super::round_robin::LeagueDir;
use crate::files::write_atomic;
use crate::play::matches::{MatchRules, Tally};
use crate::play::metrics::wilson_points;
use crate::png::png;

/// Bootstrap resamples of the rating intervals.
pub const RESAMPLES: usize = 500;

/// One agent's line.
#[derive(Clone, Debug, Serialize)]
pub struct Standing {
    /// The agent, by the name it is parsed from.
    pub agent: String,
    /// Bradley-Terry rating, Elo scale (the anchor at 1000).
    pub rating: f64,
    /// Its 95 % bootstrap interval.
    pub ci95: [f64; 2],
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
        let ci = intervals(n, &games, anchor, RESAMPLES, league.league.seed);
        // Each agent's matches, and each ordered pair's (row agent's side).
        let mut tallies = vec![Tally::default(); n];
        let mut pairs = vec![vec![Tally::default(); n]; n];
        for &(y, b, r) in &played {
            for (me, other, yellow) in [(y, b, true), (b, y, false)] {
                tallies[me].add(r.side(yellow));
                pairs[me][other].add(r.side(yellow));
            }
        }
        let standings: Vec<Standing> = (0..n)
            .map(|i| {
                let t = &tallies[i];
                Standing {
                    agent: names[i].clone(),
                    rating: ratings[i],
                    ci95: ci[i],
                    matches: t.matches,
                    wins: t.wins,
                    draws: t.draws,
                    losses: t.losses,
                    goal_difference: t.goal_difference(),
                    spins_per_minute: t.spins_per_minute(league.league.table.agent_dt()),
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
            agents: order.iter().map(|&i| names[i].clone()).collect(),
            standings: order.iter().map(|&i| standings[i].clone()).collect(),
            matrix,
        }
    }

    /// The standings and the matrix as markdown.
    pub fn to_markdown(&self) -> String {
        let mut s = format!(
            "| rank | agent | rating (Elo scale, {} = 1000) | 95 % CI | matches | W-D-L | goal difference | spins per minute |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n",
            self.anchor
        );
        for (k, st) in self.standings.iter().enumerate() {
            s += &format!(
                "| {} | {} | {:.0} | [{:.0}, {:.0}] | {} | {}-{}-{} | {:+} | {:.2} |\n",
                k + 1,
                st.agent,
                st.rating,
                st.ci95[0],
                st.ci95[1],
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
        write_atomic(&dir.join("index.html"), self.html().as_bytes()).map_err(|e| e.to_string())
    }

    fn heatmap(&self, path: &Path) -> Result<(), String> {
        let n = self.agents.len();
        let cell = 64i32;
        let longest = self
            .agents
            .iter()
            .map(|a| a.chars().count().min(46))
            .max()
            .unwrap_or(0);
        let label_w = 40 + 8 * longest as i32;
        let size = (
            (label_w + cell * n as i32 + 20) as u32,
            (60 + cell * n as i32 + 40) as u32,
        );
        png(path, size, |root| {
            let title = ("sans-serif", 20).into_font();
            root.draw(&Text::new(
                "row agent's points share against the column agent (win 1, draw 0.5)",
                (10, 12),
                title,
            ))?;
            let font = TextStyle::from(("sans-serif", 14).into_font());
            for (i, row) in self.matrix.iter().enumerate() {
                let y = 60 + cell * i as i32;
                root.draw(&Text::new(
                    format!("{} {}", i + 1, shorten(&self.agents[i], 46)),
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
                        font.clone().pos(Pos::new(HPos::Center, VPos::Center)),
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

    fn html(&self) -> String {
        let rows: String = self
            .standings
            .iter()
            .enumerate()
            .map(|(k, s)| {
                format!(
                    "<tr><td>{}</td><td>{}</td><td>{:.0}</td><td>{:.0} – {:.0}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:+}</td><td>{:.2}</td></tr>\n",
                    k + 1,
                    escape(&s.agent),
                    s.rating,
                    s.ci95[0],
                    s.ci95[1],
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
th {{ background: #eee; cursor: pointer; user-select: none; }}
th.sorted::after {{ content: " ▾"; }}
</style></head>
<body>
<h1>foosball-rl leaderboard</h1>
<p>Bradley–Terry ratings on the Elo scale ({anchor} pinned at 1000), 95 % bootstrap intervals over matches;
{rules} Click a heading to sort.</p>
<table id="board"><thead><tr><th>rank</th><th>agent</th><th>rating</th><th>95 % CI</th><th>matches</th><th>wins</th><th>draws</th><th>losses</th><th>goal difference</th><th>spins per minute</th></tr></thead>
<tbody>
{rows}</tbody></table>
<h2>Head to head</h2>
<p><img src="heatmap.png" alt="win-rate matrix"></p>
<script>
document.querySelectorAll("#board th").forEach((th, col) => th.addEventListener("click", () => {{
  const body = document.querySelector("#board tbody");
  const key = r => {{ const t = r.children[col].textContent; const v = parseFloat(t); return isNaN(v) ? t : v; }};
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
        )
    }

    /// How the matches were played, in one sentence.
    fn rules_line(&self) -> String {
        let r = &self.rules;
        format!(
            "{} matches per pair, sides swapped; first to {} goals or {} s of play; kick-off {}: {}.",
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

/// `s` cut to `n` characters from the end (paths keep their run name).
fn shorten(s: &str, n: usize) -> String {
    let count = s.chars().count();
    if count <= n {
        s.to_string()
    } else {
        format!("…{}", s.chars().skip(count - n + 1).collect::<String>())
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
