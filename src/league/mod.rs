//! Leagues: round-robins of two-sided matches among any agents (run networks, scripted
//! policies), Bradley-Terry ratings with bootstrap intervals, and the leaderboard.
//!
//! - [`round_robin`]: the league directory (`league.toml`, `matches.csv`), its schedule,
//!   resumable play on several threads;
//! - [`ratings`]: the Bradley-Terry fit on the Elo scale, bootstrap intervals;
//! - [`domains`]: each agent's standard test on `reference`, on the randomised table and
//!   (where measured) on the MuJoCo model, kept in `domains.csv`;
//! - [`leaderboard`]: standings, the win-rate matrix (Wilson intervals,
//!   [`crate::play::metrics::wilson_points`]), and their files
//!   (`leaderboard.json`, `leaderboard.md`, `heatmap.png`, `index.html`).
//!
//! Imports run one way: `league` reads [`crate::play`] (contestants, matches) and the
//! layer-1 modules, nothing of [`crate::run`], [`crate::sweep`] or [`crate::report`].

pub mod domains;
pub mod leaderboard;
pub mod ratings;
pub mod round_robin;
