//! Ratings from match results: a Bradley-Terry maximum-likelihood fit on the Elo scale,
//! with bootstrap intervals over matches.
//!
//! Agent `i` beats `j` with probability `p_i / (p_i + p_j)`; a draw counts half a win to
//! each. The fit is Hunter's MM iteration (2004) with a weak prior, one virtual draw of
//! every agent against a player of strength 1, which keeps the ratings finite for an
//! agent that never wins (or never loses) and barely moves the others. Ratings are
//! `400 log10(p_i / p_anchor) + 1000`: the anchor is at 1000, and 400 points mean 10:1
//! odds, as in Elo. Intervals: the matches of every pair resampled with replacement,
//! the fit repeated, the 2.5 and 97.5 percentiles of each rating, and the share of the
//! resamples in which each agent is rated first (how sure the board is of its top).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One match between agents `a` and `b` (indices), scored from `a`'s side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Game {
    /// First agent.
    pub a: usize,
    /// Second agent.
    pub b: usize,
    /// `a`'s points: 1 win, 0.5 draw, 0 loss.
    pub a_points: f64,
}

/// Rating of the anchor.
pub const ANCHOR_RATING: f64 = 1000.0;

/// Bradley-Terry ratings (Elo scale, anchor at [`ANCHOR_RATING`]) of `n` agents.
pub fn fit(n: usize, games: &[Game], anchor: usize) -> Vec<f64> {
    // wins[i]: points of i (prior: half a point); pairs[i][j]: games between i and j.
    let mut wins = vec![0.5; n];
    let mut pairs = vec![vec![0.0; n]; n];
    for g in games {
        wins[g.a] += g.a_points;
        wins[g.b] += 1.0 - g.a_points;
        pairs[g.a][g.b] += 1.0;
        pairs[g.b][g.a] += 1.0;
    }
    let mut p = vec![1.0; n];
    for _ in 0..10_000 {
        let next: Vec<f64> = (0..n)
            .map(|i| {
                // The prior's virtual game against strength 1.
                let mut denom = 1.0 / (p[i] + 1.0);
                for j in 0..n {
                    if pairs[i][j] > 0.0 {
                        denom += pairs[i][j] / (p[i] + p[j]);
                    }
                }
                wins[i] / denom
            })
            .collect();
        let change = next
            .iter()
            .zip(&p)
            .map(|(a, b)| (a.ln() - b.ln()).abs())
            .fold(0.0, f64::max);
        p = next;
        if change < 1e-12 {
            break;
        }
    }
    p.iter()
        .map(|pi| ANCHOR_RATING + 400.0 * (pi / p[anchor]).log10())
        .collect()
}

/// What the bootstrap of [`fit`] gives, one entry per agent.
#[derive(Clone, Debug, PartialEq)]
pub struct Bootstrap {
    /// The 95 % interval of each rating: the 2.5 and 97.5 percentiles over the resamples.
    pub ci95: Vec<[f64; 2]>,
    /// The share of the resamples in which each agent is rated first (the lowest index
    /// among equals), in [0, 1]; the shares sum to 1.
    pub first: Vec<f64>,
}

/// The bootstrap of [`fit`]'s ratings: `resamples` redraws of every pair's games with
/// replacement (the pair's count kept), from `seed`.
pub fn bootstrap(
    n: usize,
    games: &[Game],
    anchor: usize,
    resamples: usize,
    seed: u64,
) -> Bootstrap {
    let mut groups: std::collections::BTreeMap<(usize, usize), Vec<Game>> = Default::default();
    for g in games {
        groups
            .entry((g.a.min(g.b), g.a.max(g.b)))
            .or_default()
            .push(*g);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut draws: Vec<Vec<f64>> = vec![Vec::with_capacity(resamples); n];
    let mut firsts = vec![0usize; n];
    for _ in 0..resamples {
        let sample: Vec<Game> = groups
            .values()
            .flat_map(|g| {
                (0..g.len())
                    .map(|_| g[rng.random_range(0..g.len())])
                    .collect::<Vec<_>>()
            })
            .collect();
        let ratings = fit(n, &sample, anchor);
        let top = (0..n).fold(
            0,
            |best, i| {
                if ratings[i] > ratings[best] { i } else { best }
            },
        );
        if n > 0 {
            firsts[top] += 1;
        }
        for (i, r) in ratings.into_iter().enumerate() {
            draws[i].push(r);
        }
    }
    let ci95 = draws
        .into_iter()
        .map(|mut d| {
            d.sort_by(f64::total_cmp);
            let at = |q: f64| d[((q * (d.len() - 1) as f64).round() as usize).min(d.len() - 1)];
            [at(0.025), at(0.975)]
        })
        .collect();
    let first = firsts
        .iter()
        .map(|&k| k as f64 / resamples.max(1) as f64)
        .collect();
    Bootstrap { ci95, first }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Games drawn from known strengths.
    fn games(strengths: &[f64], per_pair: usize, seed: u64) -> Vec<Game> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut out = vec![];
        for a in 0..strengths.len() {
            for b in a + 1..strengths.len() {
                for _ in 0..per_pair {
                    let pa = strengths[a] / (strengths[a] + strengths[b]);
                    let a_points = if rng.random::<f64>() < pa { 1.0 } else { 0.0 };
                    out.push(Game { a, b, a_points });
                }
            }
        }
        out
    }

    #[test]
    fn the_fit_recovers_known_strengths_on_the_elo_scale() {
        // Strengths 1, 10, 100: 400 and 800 Elo above the anchor.
        let g = games(&[1.0, 10.0, 100.0], 2000, 1);
        let r = fit(3, &g, 0);
        assert_eq!(r[0], ANCHOR_RATING);
        assert!((r[1] - 1400.0).abs() < 40.0, "{r:?}");
        assert!((r[2] - 1800.0).abs() < 80.0, "{r:?}");
        let b = bootstrap(3, &g, 0, 200, 2);
        let ci = &b.ci95;
        assert!(ci[1][0] < r[1] && r[1] < ci[1][1], "{ci:?}");
        assert_eq!(ci[0], [ANCHOR_RATING, ANCHOR_RATING]);
        // 400 Elo apart over 2,000 games: the strongest is first in every resample.
        assert_eq!(b.first, [0.0, 0.0, 1.0]);
    }

    #[test]
    fn two_equal_leaders_share_the_first_place_of_the_resamples() {
        // Agents 1 and 2 with the same record: 80 of 100 against agent 0, 50 of 100
        // against each other.
        let mut g = vec![];
        for k in 0..100 {
            for leader in [1, 2] {
                let a_points = if k < 80 { 1.0 } else { 0.0 };
                g.push(Game {
                    a: leader,
                    b: 0,
                    a_points,
                });
            }
            let a_points = if k < 50 { 1.0 } else { 0.0 };
            g.push(Game {
                a: 1,
                b: 2,
                a_points,
            });
        }
        let b = bootstrap(3, &g, 0, 400, 4);
        assert_eq!(b.first[0], 0.0, "{:?}", b.first);
        assert!((b.first.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        for leader in [1, 2] {
            assert!((0.35..0.65).contains(&b.first[leader]), "{:?}", b.first);
        }
    }

    #[test]
    fn an_agent_that_never_wins_gets_a_finite_low_rating() {
        let g: Vec<Game> = (0..20)
            .map(|_| Game {
                a: 0,
                b: 1,
                a_points: 1.0,
            })
            .collect();
        let r = fit(2, &g, 0);
        assert!(r[1].is_finite() && r[1] < 600.0, "{r:?}");
        // Draws only: equal ratings.
        let d: Vec<Game> = (0..20)
            .map(|_| Game {
                a: 0,
                b: 1,
                a_points: 0.5,
            })
            .collect();
        let r = fit(2, &d, 0);
        assert!((r[1] - r[0]).abs() < 1e-6, "{r:?}");
    }
}
