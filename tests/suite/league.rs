//! Leagues: the same seeds give the same matches whatever the thread count, an
//! interrupted or extended league plays only what is missing, the leaderboard files are
//! written, bad settings are refused by name.

use crate::common;

use common::scratch;
use foosball_rl::env::FoosballConfig;
use foosball_rl::league::leaderboard::Leaderboard;
use foosball_rl::league::round_robin::{League, LeagueDir};
use foosball_rl::play::matches::MatchRules;

fn league(agents: &[&str]) -> League {
    League {
        seed: 4,
        matches_per_pair: 2,
        anchor: "zero".into(),
        agents: agents.iter().map(|a| a.to_string()).collect(),
        rules: MatchRules {
            time_limit_s: 4.0,
            ..MatchRules::default()
        },
        table: FoosballConfig::default(),
    }
}

fn matches_csv(name: &str, threads: usize) -> String {
    let dir = scratch(name);
    let mut l = LeagueDir::open(&dir, league(&["shooter", "zero", "random"])).unwrap();
    l.play(threads, |_, _| {}).unwrap();
    std::fs::read_to_string(dir.join("matches.csv")).unwrap()
}

#[test]
fn matches_do_not_depend_on_the_thread_count() {
    let one = matches_csv("league-1-thread", 1);
    let two = matches_csv("league-2-threads", 2);
    assert_eq!(one, two);
    // 3 pairs x 2 matches, sides swapped.
    assert_eq!(one.lines().count(), 1 + 6);
    assert!(one.contains("shooter,zero,0,") && one.contains("zero,shooter,0,"));
}

#[test]
fn a_league_resumes_and_grows_without_replaying() {
    let dir = scratch("league-grow");
    let mut l = LeagueDir::open(&dir, league(&["shooter", "zero"])).unwrap();
    l.play(2, |_, _| {}).unwrap();
    let before = std::fs::read_to_string(dir.join("matches.csv")).unwrap();
    // Opened again: nothing to play.
    let l = LeagueDir::open(&dir, league(&[])).unwrap();
    assert!(l.pending().is_empty());
    // A new agent: only its two pairs.
    let mut l = LeagueDir::open(&dir, league(&["random"])).unwrap();
    assert_eq!(l.league.agents, ["shooter", "zero", "random"]);
    assert_eq!(l.pending().len(), 4);
    l.play(2, |_, _| {}).unwrap();
    let after = std::fs::read_to_string(dir.join("matches.csv")).unwrap();
    assert!(after.starts_with(&before), "old matches kept as they were");
    assert_eq!(after.lines().count(), 1 + 6);
    // The same matches as a league made with all three at once.
    let sorted = |s: &str| {
        let mut v: Vec<String> = s.lines().skip(1).map(String::from).collect();
        v.sort();
        v
    };
    assert_eq!(
        sorted(&after),
        sorted(&matches_csv("league-all-at-once", 2))
    );

    let board = Leaderboard::of(&l);
    board.write(&dir).unwrap();
    assert_eq!(board.standings.len(), 3);
    let zero = board.standings.iter().find(|s| s.agent == "zero").unwrap();
    assert_eq!(zero.rating, 1000.0);
    assert!(board.standings.iter().all(|s| s.matches == 4));
    for file in [
        "leaderboard.json",
        "leaderboard.md",
        "heatmap.png",
        "index.html",
    ] {
        assert!(
            std::fs::metadata(dir.join(file)).unwrap().len() > 100,
            "{file}"
        );
    }
    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    assert_eq!(html.matches("<tr><td>").count(), 3);

    // More matches per pair: only the new round of each pair is played, the old matches
    // stay, and the whole is what a league of 4 per pair plays from the start.
    let mut more = league(&[]);
    more.matches_per_pair = 4;
    let mut l = LeagueDir::open(&dir, more.clone()).unwrap();
    assert_eq!(l.league.matches_per_pair, 4);
    assert_eq!(l.pending().len(), 6);
    assert!(l.pending().iter().all(|&(_, _, round)| round == 1));
    l.play(2, |_, _| {}).unwrap();
    let grown = std::fs::read_to_string(dir.join("matches.csv")).unwrap();
    assert!(grown.starts_with(&after), "old matches kept as they were");
    let at_once = scratch("league-four-at-once");
    let mut all = more;
    all.agents = ["shooter", "zero", "random"].map(String::from).to_vec();
    LeagueDir::open(&at_once, all)
        .unwrap()
        .play(2, |_, _| {})
        .unwrap();
    let four = std::fs::read_to_string(at_once.join("matches.csv")).unwrap();
    assert_eq!(sorted(&grown), sorted(&four));
    assert!(Leaderboard::of(&l).standings.iter().all(|s| s.matches == 8));
    // Fewer: refused, naming the key.
    let e = LeagueDir::open(&dir, league(&[])).err().unwrap();
    assert!(e.contains("`matches_per_pair` can grow"), "{e}");
}

#[test]
fn bad_leagues_are_refused_by_name() {
    let dir = scratch("league-bad");
    let mut odd = league(&["shooter", "zero"]);
    odd.matches_per_pair = 3;
    let e = LeagueDir::open(&dir, odd).err().unwrap();
    assert!(e.starts_with("matches_per_pair"), "{e}");
    let mut no_anchor = league(&["shooter", "random"]);
    no_anchor.anchor = "zero".into();
    let e = LeagueDir::open(&scratch("league-bad-anchor"), no_anchor)
        .err()
        .unwrap();
    assert!(e.starts_with("anchor"), "{e}");
    let e = LeagueDir::open(&scratch("league-bad-twice"), league(&["zero", "zero"]))
        .err()
        .unwrap();
    assert!(e.contains("twice"), "{e}");
    let mut l = LeagueDir::open(&scratch("league-bad-agent"), league(&["zero", "nobody"])).unwrap();
    let e = l.play(1, |_, _| {}).unwrap_err();
    assert!(e.contains("nobody"), "{e}");
    // Reopened with other settings: refused by key.
    let dir = scratch("league-settings");
    LeagueDir::open(&dir, league(&["zero", "random"])).unwrap();
    let mut other = league(&[]);
    other.seed = 5;
    let e = LeagueDir::open(&dir, other).err().unwrap();
    assert!(e.contains("`seed`"), "{e}");
}

/// A run that started from another's networks counts the whole chain's env steps:
/// `more7` trained 3 M env steps itself, 22.5 M from the paper's starts on.
#[test]
fn a_runs_about_line_counts_the_stages_it_started_from() {
    let more7: foosball_rl::play::contestant::Contestant =
        "results/against-shooter/fourier-ball-128-kickstart-defence-more7/ppo-seed0"
            .parse()
            .unwrap();
    let about = more7.about();
    assert!(
        about.starts_with(
            "ppo 128x128 networks trained 22500000 env steps (3000000 in its last stage)"
        ),
        "{about}"
    );
    let first: foosball_rl::play::contestant::Contestant =
        "results/figure2-v6/ppo-seed2".parse().unwrap();
    assert!(
        first.about().contains("trained 1500000 env steps on"),
        "{}",
        first.about()
    );
}

/// Each match row names the table's preset and the commit of the binary that played it;
/// a file written before those columns reads on, its rows' columns empty, and a grown
/// league keeps them as they were.
#[test]
fn a_match_row_records_the_preset_and_the_commit() {
    let commit = foosball_rl::provenance::BUILD_COMMIT;
    assert!(!commit.is_empty() && !commit.contains(','), "{commit}");
    let csv = matches_csv("league-provenance", 1);
    assert!(csv.lines().next().unwrap().ends_with(",preset,commit"));
    for row in csv.lines().skip(1) {
        assert!(row.ends_with(&format!(",reference,{commit}")), "{row}");
    }
    // The same matches in the old nine-column shape: they read, and only new ones play.
    let dir = scratch("league-old-rows");
    let old: String = csv
        .lines()
        .map(|l| l.splitn(10, ',').take(9).collect::<Vec<_>>().join(",") + "\n")
        .collect();
    std::fs::write(dir.join("matches.csv"), &old).unwrap();
    let l = LeagueDir::open(&dir, league(&["shooter", "zero", "random"])).unwrap();
    assert!(l.pending().is_empty());
    assert!(
        l.records
            .iter()
            .all(|r| r.preset.is_empty() && r.commit.is_empty())
    );
}
