//! `act`, a run's networks as a line protocol: one action line per observation line, the
//! same observation giving the same action, black's rods hidden where the run hid them,
//! and a malformed line refused by its number.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn act(run: &str, input: &str) -> Output {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut child = Command::new(env!("CARGO_BIN_EXE_act"))
        .args(["--run", root.join(run).to_str().unwrap()])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    child.wait_with_output().unwrap()
}

/// An observation line: 38 values, black's 16 rod values (indices 10..14, 18..22, 26..30,
/// 34..38) set to `black`.
fn observation(black: f32) -> String {
    (0..38)
        .map(|i| {
            let is_black = (6..38).contains(&i) && (i - 6) % 8 >= 4;
            if is_black {
                black.to_string()
            } else {
                format!("{}", 0.1 * i as f32 - 1.0)
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

fn actions(out: &Output) -> Vec<Vec<f32>> {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout.clone())
        .unwrap()
        .lines()
        .map(|l| l.split(' ').map(|v| v.parse().unwrap()).collect())
        .collect()
}

#[test]
fn each_observation_gets_its_action_and_the_same_one_again() {
    let line = observation(0.3);
    let out = actions(&act(
        "results/figure2/ppo-seed0",
        &format!("{line}\n\n{}\n{line}\n", observation(-0.7)),
    ));
    assert_eq!(
        out.len(),
        3,
        "one action per observation, blank lines skipped"
    );
    for a in &out {
        assert_eq!(a.len(), 8);
        assert!(a.iter().all(|v| (-1.0..=1.0).contains(v)), "{a:?}");
    }
    assert_eq!(out[0], out[2]);
    // This run sees black's rods: they change its action.
    assert_ne!(out[0], out[1]);
}

#[test]
fn a_run_that_hid_blacks_rods_does_not_see_them() {
    let out = actions(&act(
        "results/league/self-play-kickoff-hidden-400k-from-recipe1-seed0",
        &format!("{}\n{}\n", observation(0.3), observation(-0.7)),
    ));
    assert_eq!(out[0], out[1]);
}

#[test]
fn a_malformed_line_is_refused_by_its_number() {
    let out = act(
        "results/figure2/ppo-seed0",
        &format!("{}\n1 2 3\n", observation(0.0)),
    );
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("line 2: 3 values, expected 38"), "{err}");
    let nan_first: Vec<String> = std::iter::once("nan".to_string())
        .chain(observation(0.0).split(' ').skip(1).map(String::from))
        .collect();
    let out = act("results/figure2/ppo-seed0", &nan_first.join(" "));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("not a finite number"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
