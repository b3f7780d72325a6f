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

/// The board's domain columns: each agent's standard test on `reference` is `evaluate`'s
/// (the same episodes from the same seeds), the randomised table's is another game,
/// the tests are kept (opened again, nothing is played) and an agent added is tested
/// alone; a MuJoCo measurement in `mujoco/` fills its column, "not measured" elsewhere.
#[test]
fn the_domain_tests_are_evaluates_and_are_kept() {
    use foosball_rl::env::Preset;
    use foosball_rl::league::domains::{DomainTests, MUJOCO};
    use foosball_rl::play::contestant::Contestant;
    use foosball_rl::play::player::{Player, PlayerArgs};
    use foosball_rl::play::scripted::ScriptedPolicy;

    let dir = scratch("league-domains");
    let mut l = LeagueDir::open(&dir, league(&["shooter", "zero"])).unwrap();
    l.play(2, |_, _| {}).unwrap();
    let mut tests = DomainTests::open(&dir).unwrap();
    let mut played = vec![];
    tests
        .play_missing(&l.league.agents, 40, |a, d, _| {
            played.push(format!("{a} {d}"))
        })
        .unwrap();
    assert_eq!(
        played,
        [
            "shooter reference",
            "shooter reference_randomized",
            "zero reference",
            "zero reference_randomized"
        ]
    );
    let evaluate = Player::from_args(&PlayerArgs {
        policy: Some(ScriptedPolicy::Shooter),
        ..PlayerArgs::default()
    })
    .unwrap();
    let summaries: Vec<_> = evaluate.play(40, false).unwrap();
    let scored = summaries.iter().filter(|e| e.summary.scored).count();
    let shooter = tests.score("shooter", "reference").unwrap().clone();
    assert_eq!(shooter.score_rate, scored as f64 / 40.0);
    assert_eq!(shooter.episodes, 40);
    // The same episodes, not only the same rate.
    let standard = Player::standard_test(
        &Contestant::Scripted(ScriptedPolicy::Shooter),
        Preset::Reference,
    )
    .unwrap()
    .play(40, false)
    .unwrap();
    let returns = |e: &[foosball_rl::play::evaluation::PlayedEpisode]| -> Vec<f64> {
        e.iter().map(|e| e.summary.ret).collect()
    };
    assert_eq!(returns(&standard), returns(&summaries));
    let randomized = Player::standard_test(
        &Contestant::Scripted(ScriptedPolicy::Shooter),
        Preset::ReferenceRandomized,
    )
    .unwrap();
    assert_ne!(randomized.env().randomization, evaluate.env().randomization);

    // Kept: opened again, nothing left to play; a new agent plays its two tests alone.
    let mut again = DomainTests::open(&dir).unwrap();
    assert_eq!(again.score("shooter", "reference"), Some(&shooter));
    let mut played = vec![];
    let agents = ["shooter".to_string(), "zero".into(), "random".into()];
    again
        .play_missing(&agents, 40, |a, d, _| played.push(format!("{a} {d}")))
        .unwrap();
    assert_eq!(played, ["random reference", "random reference_randomized"]);

    // A MuJoCo measurement (tools/transfer.py's --out) fills its column.
    std::fs::create_dir_all(dir.join("mujoco")).unwrap();
    std::fs::write(
        dir.join("mujoco/zero.json"),
        r#"{"agent": "zero", "mujoco": {"episodes": 100, "score_rate": [0.0, 0.0, 0.037]}}"#,
    )
    .unwrap();
    let tests = DomainTests::open(&dir).unwrap();
    assert_eq!(tests.score("zero", MUJOCO).unwrap().episodes, 100);
    let board = Leaderboard::of(&l).with_tests(&tests);
    let md = board.to_markdown();
    assert!(md.contains("| test on reference (score rate) |"), "{md}");
    let zero = board.standings.iter().find(|s| s.agent == "zero").unwrap();
    assert_eq!(zero.tests.len(), 3);
    assert!(zero.tests.iter().all(Option::is_some));
    let shooter_row = md.lines().find(|r| r.contains("| shooter |")).unwrap();
    assert!(shooter_row.ends_with("| not measured |"), "{shooter_row}");

    // A broken row is named with its file and line.
    std::fs::write(dir.join("domains.csv"), "agent,domain\nzero,reference,x\n").unwrap();
    let err = DomainTests::open(&dir).unwrap_err();
    assert!(err.contains("domains.csv:2"), "{err}");
}
