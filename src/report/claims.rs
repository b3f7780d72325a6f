//! The paper's Figure-2 claims, each checked against our groups with bootstrap intervals
//! over seeds, with a plain-words verdict.
//!
//! | claim (paper) | reproduced when |
//! | --- | --- |
//! | SAC's score rate is 42.9 % | 0.429 lies in SAC's interval |
//! | SAC scores more than twice PPO and TD3 | the interval of SAC / other (score rate) lies above 2 |
//! | PPO and TD3 score below 21.5 % | the other's interval lies below 0.215 |
//! | SAC's final distance (24.87) is below TD3's (31.92) | SAC's interval lies below TD3's |
//! | TD3's ball speed is about twice SAC's, SAC's about twice PPO's | the ratio's interval holds 2 |
//!
//! "not reproduced" when the interval excludes the claim the other way, "inconclusive"
//! when it straddles, "not measured" when a group is missing, "too few seeds" when a group
//! has a single run (no interval over seeds).

use super::Group;
use super::stats::{self, mean};
use crate::play::metrics::Estimate;
use serde::Serialize;

/// The paper's SAC test score rate (share of 1,000 episodes).
pub const PAPER_SAC_SCORE_RATE: f64 = 0.429;
/// The bound the paper puts PPO's and TD3's score rates under.
pub const PAPER_OTHERS_SCORE_RATE_BELOW: f64 = 0.215;
/// The paper's mean final distances to goal, cm: SAC's and TD3's.
pub const PAPER_FINAL_DISTANCE: [(&str, f64); 2] = [("sac", 24.87), ("td3", 31.92)];

/// Index of each metric in [`crate::play::metrics::TestMetrics::rows`].
const SCORE_RATE: usize = 0;
const BALL_SPEED: usize = 2;
const FINAL_DISTANCE: usize = 4;

/// One claim of the paper checked on one preset.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Verdict {
    /// The table preset of our groups.
    pub preset: String,
    /// The claim in words.
    pub claim: String,
    /// What the paper reports.
    pub paper: String,
    /// What we measured, with the interval.
    pub ours: String,
    /// `reproduced`, `not reproduced`, `inconclusive` or `not measured`.
    pub verdict: &'static str,
}

/// `reproduced` if `lo > bound`, `not reproduced` if `hi < bound`, else `inconclusive`.
fn above(e: &Estimate, bound: f64) -> &'static str {
    if e.ci95[0] > bound {
        "reproduced"
    } else if e.ci95[1] < bound {
        "not reproduced"
    } else {
        "inconclusive"
    }
}

fn below(e: &Estimate, bound: f64) -> &'static str {
    match above(e, bound) {
        "reproduced" => "not reproduced",
        "not reproduced" => "reproduced",
        v => v,
    }
}

fn fmt(e: &Estimate) -> String {
    format!("{:.3} [{:.3}, {:.3}]", e.mean, e.ci95[0], e.ci95[1])
}

/// The claims of the paper checked on every preset that has learner groups.
pub fn verdicts(groups: &[Group]) -> Vec<Verdict> {
    let mut presets: Vec<&str> = Vec::new();
    for g in groups.iter().filter(|g| !g.runs[0].is_baseline()) {
        if !presets.contains(&g.preset.as_str()) {
            presets.push(&g.preset);
        }
    }
    let mut out = Vec::new();
    for preset in presets {
        let find = |algo: &str| {
            groups
                .iter()
                .find(|g| g.preset == preset && g.player == algo)
        };
        let (sac, ppo, td3) = (find("sac"), find("ppo"), find("td3"));
        let mut push = |claim: String, paper: &str, ours: Option<(String, &'static str)>| {
            let (ours, verdict) = ours.unwrap_or_else(|| ("-".into(), "not measured"));
            out.push(Verdict {
                preset: preset.to_string(),
                claim,
                paper: paper.to_string(),
                ours,
                verdict,
            });
        };
        let over = |g: &Group, k: usize| stats::over_seeds(&g.values(k), mean);
        // A verdict needs an interval over seeds: two runs at least in every group.
        let guard = |groups: &[&Group], v: &'static str| {
            if groups.iter().any(|g| g.runs.len() < 2) {
                "too few seeds"
            } else {
                v
            }
        };
        let ratio = |a: &Group, b: &Group, k: usize| {
            stats::ratio_over_seeds(&a.values(k), &b.values(k), mean)
        };
        push(
            "SAC's score rate is 42.9 %".into(),
            "0.429",
            sac.map(|s| {
                let e = over(s, SCORE_RATE);
                let v = if (e.ci95[0]..=e.ci95[1]).contains(&PAPER_SAC_SCORE_RATE) {
                    "reproduced"
                } else {
                    "not reproduced"
                };
                (fmt(&e), guard(&[s], v))
            }),
        );
        for (name, other) in [("PPO", ppo), ("TD3", td3)] {
            push(
                format!("SAC scores more than twice {name} (score-rate ratio > 2)"),
                "> 2",
                sac.zip(other).map(|(s, o)| {
                    let e = ratio(s, o, SCORE_RATE);
                    (fmt(&e), guard(&[s, o], above(&e, 2.0)))
                }),
            );
            push(
                format!("{name}'s score rate is below 21.5 %"),
                "< 0.215",
                other.map(|o| {
                    let e = over(o, SCORE_RATE);
                    (
                        fmt(&e),
                        guard(&[o], below(&e, PAPER_OTHERS_SCORE_RATE_BELOW)),
                    )
                }),
            );
        }
        push(
            "SAC's final distance is below TD3's".into(),
            "24.87 < 31.92 cm",
            sac.zip(td3).map(|(s, t)| {
                let (a, b) = (over(s, FINAL_DISTANCE), over(t, FINAL_DISTANCE));
                let v = if a.ci95[1] < b.ci95[0] {
                    "reproduced"
                } else if a.ci95[0] > b.ci95[1] {
                    "not reproduced"
                } else {
                    "inconclusive"
                };
                (
                    format!("SAC {} vs TD3 {}", fmt(&a), fmt(&b)),
                    guard(&[s, t], v),
                )
            }),
        );
        for (claim, a, b) in [
            ("TD3's ball speed is about twice SAC's", td3, sac),
            ("SAC's ball speed is about twice PPO's", sac, ppo),
        ] {
            push(
                claim.into(),
                "ratio about 2",
                a.zip(b).map(|(a, b)| {
                    let e = ratio(a, b, BALL_SPEED);
                    let v = if (e.ci95[0]..=e.ci95[1]).contains(&2.0) {
                        "reproduced"
                    } else {
                        "not reproduced"
                    };
                    (fmt(&e), guard(&[a, b], v))
                }),
            );
        }
    }
    out
}

/// The verdicts as a markdown table.
pub fn markdown(verdicts: &[Verdict]) -> String {
    let mut out = String::from(
        "# The paper's claims\n\n| preset | claim | paper | ours (mean over seeds [95 % CI]) | verdict |\n| --- | --- | --- | --- | --- |\n",
    );
    for v in verdicts {
        out += &format!(
            "| {} | {} | {} | {} | {} |\n",
            v.preset, v.claim, v.paper, v.ours, v.verdict
        );
    }
    out
}
