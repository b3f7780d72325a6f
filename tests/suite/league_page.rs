//! The leaderboard page in a real browser (Debian's chromium, headless): it loads with
//! no console message, a click on a heading sorts the board (down, then up again), and
//! every link and image resolves from the page's folder. For the committed board and for
//! one written now whose agents include a run and an ONNX export. Under `CI=true` the
//! browser must be installed (`.ci/run` installs it); elsewhere the test says it skipped.

use crate::common::scratch;
use foosball_rl::config::RunConfig;
use foosball_rl::env::FoosballConfig;
use foosball_rl::league::leaderboard::Leaderboard;
use foosball_rl::league::round_robin::{League, LeagueDir};
use foosball_rl::onnx::export::exported_policy;
use foosball_rl::play::matches::MatchRules;
use std::path::{Path, PathBuf};
use std::process::Command;

/// What the test page saw: the rating column before and after one and two clicks on its
/// heading, and every `href`/`src` of the board page.
#[derive(serde::Deserialize, Debug)]
struct Seen {
    before: Vec<String>,
    once: Vec<String>,
    twice: Vec<String>,
    links: Vec<String>,
}

/// The browser, or `None` (with a note) where it is absent outside CI.
fn chromium() -> Option<PathBuf> {
    let found = ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|b| {
            Command::new(b)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        });
    assert!(
        found.is_some() || std::env::var("CI").as_deref() != Ok("true"),
        "no headless browser: install Debian's chromium"
    );
    if found.is_none() {
        eprintln!("skipping: no chromium here");
    }
    found.map(PathBuf::from)
}

/// Opens `page` (an `index.html`) in an iframe of a test page in `work`, clicks the rating
/// heading twice, and returns what it saw and the browser's console lines.
fn browse(browser: &Path, page: &Path, work: &Path) -> (Seen, Vec<String>) {
    let page = page.canonicalize().unwrap();
    let test = work.join("test.html");
    std::fs::write(
        &test,
        format!(
            r##"<!doctype html><html><body><iframe id="f" src="file://{}"></iframe><pre id="out"></pre>
<script>
const f = document.getElementById("f");
f.onload = () => {{
  const d = f.contentDocument;
  const col = c => [...d.querySelectorAll("#board tbody tr")].map(r => r.children[c].firstChild.textContent);
  const before = col(2);
  d.querySelectorAll("#board th")[2].click();
  const once = col(2);
  d.querySelectorAll("#board th")[2].click();
  const twice = col(2);
  const links = [...d.querySelectorAll("a[href], img[src]")].map(a => a.getAttribute("href") || a.getAttribute("src"));
  document.getElementById("out").textContent = JSON.stringify({{before, once, twice, links}});
}};
</script></body></html>"##,
            page.display()
        ),
    )
    .unwrap();
    let out = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            // The test page reads the board page's document (both file://).
            "--disable-web-security",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=5000",
            "--dump-dom",
        ])
        .arg(format!(
            "--user-data-dir={}",
            work.join("profile").display()
        ))
        .arg(format!("file://{}", test.display()))
        .output()
        .unwrap();
    let dom = String::from_utf8_lossy(&out.stdout);
    let json = dom
        .split("<pre id=\"out\">")
        .nth(1)
        .and_then(|rest| rest.split("</pre>").next())
        .unwrap_or_else(|| panic!("the test page did not run: {dom}"));
    let json = json
        .replace("&amp;", "&")
        .replace("&lt;", "<")
        .replace("&gt;", ">");
    let seen: Seen = serde_json::from_str(&json).unwrap_or_else(|e| panic!("{e}: {json}"));
    let console = String::from_utf8_lossy(&out.stderr)
        .lines()
        .filter(|l| l.contains(":CONSOLE"))
        .map(String::from)
        .collect();
    (seen, console)
}

/// Checks one board page in the browser; returns how many links it has.
fn check(browser: &Path, page: &Path, name: &str) -> usize {
    let work = scratch(name);
    let (seen, console) = browse(browser, page, &work);
    assert!(
        console.is_empty(),
        "{}: console: {console:?}",
        page.display()
    );
    let ratings = |col: &[String]| -> Vec<f64> { col.iter().map(|r| r.parse().unwrap()).collect() };
    let (before, once, twice) = (
        ratings(&seen.before),
        ratings(&seen.once),
        ratings(&seen.twice),
    );
    assert!(before.len() >= 3, "{:?}", seen.before);
    assert!(
        once.windows(2).all(|w| w[0] >= w[1]),
        "one click sorts down: {once:?}"
    );
    assert!(
        twice.windows(2).all(|w| w[0] <= w[1]),
        "two sort up: {twice:?}"
    );
    let dir = page.parent().unwrap();
    for link in &seen.links {
        assert!(
            dir.join(link).exists(),
            "{}: `{link}` resolves to nothing",
            page.display()
        );
    }
    seen.links.len()
}

#[test]
fn the_committed_board_loads_sorts_and_links_in_a_browser() {
    let Some(browser) = chromium() else { return };
    let page =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("results/league/leaderboard-v6/index.html");
    // 11 runs and the heatmap.
    assert_eq!(check(&browser, &page, "league-page-v6"), 12);
}

#[test]
fn the_outside_boards_load_sort_and_link_in_a_browser() {
    let Some(browser) = chromium() else { return };
    for board in ["outside-v2", "outside-v3"] {
        let page = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("results/league")
            .join(board)
            .join("index.html");
        // 2 runs, the 3 outside entries' folders and the heatmap.
        assert_eq!(check(&browser, &page, &format!("league-page-{board}")), 6);
    }
}

#[test]
fn a_board_with_a_run_and_an_onnx_entry_loads_sorts_and_links_in_a_browser() {
    let Some(browser) = chromium() else { return };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let run = "results/figure2-v6-sac-td3/td3-seed0";
    let dir = scratch("league-page-fresh");
    let config = RunConfig::load_run(&root.join(run)).unwrap();
    let onnx = dir.join("td3.onnx");
    std::fs::write(
        &onnx,
        exported_policy(&config, &root.join(run).join("last"), run).unwrap(),
    )
    .unwrap();
    let board_dir = dir.join("board");
    let league = League {
        seed: 1,
        matches_per_pair: 2,
        anchor: "zero".into(),
        agents: vec![
            "zero".into(),
            "shooter".into(),
            root.join(run).display().to_string(),
            onnx.display().to_string(),
        ],
        rules: MatchRules {
            time_limit_s: 3.0,
            ..MatchRules::default()
        },
        table: FoosballConfig::default(),
    };
    let mut l = LeagueDir::open(&board_dir, league).unwrap();
    l.play(2, |_, _| {}).unwrap();
    let board = Leaderboard::of(&l);
    board.write(&board_dir).unwrap();
    let onnx_row = board
        .standings
        .iter()
        .find(|s| s.agent.ends_with("td3.onnx"))
        .unwrap();
    assert!(
        onnx_row.about.starts_with("ONNX export of td3"),
        "{}",
        onnx_row.about
    );
    // The run's link, the ONNX file's folder and the heatmap.
    assert_eq!(
        check(
            &browser,
            &board_dir.join("index.html"),
            "league-page-fresh-browse"
        ),
        3
    );
}
