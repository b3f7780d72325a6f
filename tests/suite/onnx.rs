//! Policies in and out: a run exported as ONNX acts as its networks (within 1e-5 on
//! 10,000 observations of its table, for PPO with normalisation and Fourier features, SAC
//! with black's rods hidden, TD3) and scores its committed test through `evaluate`; a
//! program speaking `act`'s line protocol plays as a contestant; bad files and failing
//! programs get one-line errors that name them.

use super::common;
use foosball_rl::agents::load_agent;
use foosball_rl::algos::{ActMode, Step};
use foosball_rl::config::RunConfig;
use foosball_rl::env::layout::{ACTION_DIM, OBS_DIM};
use foosball_rl::env::{Env, FoosballConfig, FoosballEnv};
use foosball_rl::nets::{Activation, HostMlp};
use foosball_rl::onnx::export::exported_policy;
use foosball_rl::onnx::graph::policy_model;
use foosball_rl::onnx::runtime::OnnxPolicy;
use foosball_rl::play::contestant::Contestant;
use foosball_rl::play::matches::{MatchRules, match_table, play_match};
use foosball_rl::play::process::ProcessPolicy;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

/// The headline run: PPO 128x128 on normalised observations with Fourier features.
const HEADLINE: &str =
    "results/ppo-study-v6/goal-bonus-10x-linear-actions-target-kl-fourier-ball-128/ppo-seed0";

/// `n` observations of `env`'s table under random commands, episodes from seeds 0, 1, ...
fn observations(env: &FoosballConfig, n: usize) -> Vec<f32> {
    let mut table = FoosballEnv::new(env.clone()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut obs = table.reset(Some(0));
    let mut all = Vec::with_capacity(n * OBS_DIM);
    let mut episodes = 0;
    while all.len() < n * OBS_DIM {
        all.extend_from_slice(&obs);
        let action: Vec<f32> = (0..ACTION_DIM)
            .map(|_| rng.random_range(-1.0..=1.0))
            .collect();
        let (next, t) = table.step(&action).unwrap();
        obs = match t.done() {
            true => {
                episodes += 1;
                table.reset(Some(episodes))
            }
            false => next,
        };
    }
    all
}

/// The largest difference between the run's networks and their export on 10,000
/// observations of the run's table.
fn largest_difference(run: &str) -> f32 {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(run);
    let config = RunConfig::load_run(&dir).unwrap();
    let networks = dir.join("last");
    let scratch = common::scratch(&format!("onnx-{}", run.replace('/', "-")));
    let file = scratch.join("policy.onnx");
    std::fs::write(&file, exported_policy(&config, &networks, run).unwrap()).unwrap();
    let onnx = OnnxPolicy::load(&file, OBS_DIM, ACTION_DIM).unwrap();
    let obs = observations(&config.env, 10_000);
    let mut seen = obs.clone();
    for row in seen.chunks_exact_mut(OBS_DIM) {
        config.env.observation.conceal(row);
    }
    let mut agent = load_agent(&config, &networks).unwrap();
    let ours = agent.act(&seen, ActMode::Deterministic);
    let theirs = onnx.act(&obs).unwrap();
    assert_eq!(ours.len(), 10_000 * ACTION_DIM);
    let d = ours
        .iter()
        .zip(&theirs)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f32::max);
    eprintln!("{run}: largest action difference {d:e} on 10,000 observations");
    d
}

#[test]
fn an_exported_ppo_with_normalisation_and_fourier_features_acts_as_its_networks() {
    let d = largest_difference(HEADLINE);
    assert!(d <= 1e-5, "largest action difference {d}");
}

#[test]
fn an_exported_sac_that_hid_blacks_rods_acts_as_its_networks() {
    let d = largest_difference("results/league/self-play-kickoff-hidden-400k-from-recipe1-seed0");
    assert!(d <= 1e-5, "largest action difference {d}");
}

#[test]
fn an_exported_td3_acts_as_its_networks() {
    let d = largest_difference("results/figure2-v6-sac-td3/td3-seed0");
    assert!(d <= 1e-5, "largest action difference {d}");
}

/// `bin` with `args`; its stdout, or a failure with its stderr.
fn run_bin(bin: &str, args: &[&str]) -> String {
    let out = Command::new(bin).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{bin} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn the_headline_run_exported_scores_its_committed_test_and_answers_act_alike() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let run = root.join(HEADLINE);
    let scratch = common::scratch("onnx-headline");
    let file = scratch.join("headline.onnx");
    let (run_s, file_s) = (run.to_str().unwrap(), file.to_str().unwrap());
    run_bin(
        env!("CARGO_BIN_EXE_export"),
        &["--run", run_s, "--out", file_s],
    );
    let out = scratch.join("test");
    let args = ["--run", file_s, "--out", out.to_str().unwrap()];
    run_bin(env!("CARGO_BIN_EXE_evaluate"), &args);
    let ours = std::fs::read(out.join("metrics.json")).unwrap();
    let committed = std::fs::read(run.join("test/metrics.json")).unwrap();
    assert!(
        ours == committed,
        "the export's 1,000-episode test differs from the run's committed one"
    );

    let lines: String = observations(&FoosballConfig::default(), 50)
        .chunks_exact(OBS_DIM)
        .map(|row| format!("{}\n", foosball_rl::play::process::format_values(row)))
        .collect();
    let answer = |target: &str| {
        let mut child = Command::new(env!("CARGO_BIN_EXE_act"))
            .args(["--run", target])
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        std::io::Write::write_all(&mut child.stdin.take().unwrap(), lines.as_bytes()).unwrap();
        let out = child.wait_with_output().unwrap();
        assert!(out.status.success());
        String::from_utf8(out.stdout)
            .unwrap()
            .split_whitespace()
            .map(|v| v.parse::<f32>().unwrap())
            .collect::<Vec<_>>()
    };
    let (from_run, from_file) = (answer(run_s), answer(file_s));
    assert_eq!(from_run.len(), 50 * ACTION_DIM);
    assert_eq!(from_run.len(), from_file.len());
    for (a, b) in from_run.iter().zip(&from_file) {
        assert!(
            (a - b).abs() <= 1e-5,
            "act: {a} from the run, {b} from its export"
        );
    }
}

/// A one-layer policy `[width_in] -> [width_out]` of fixed weights and biases `b`,
/// written as ONNX into `dir/name`.
fn tiny_model(dir: &Path, name: &str, (width_in, width_out): (usize, usize), b: f32) -> String {
    let params: Vec<f32> = (0..width_in * width_out)
        .map(|k| 0.01 * (k % 7) as f32)
        .chain(std::iter::repeat_n(b, width_out))
        .collect();
    let mlp = HostMlp::new(vec![width_in, width_out], Activation::Relu, params).unwrap();
    // No tanh after it: tract's tanh answers NaN with a finite value.
    let chain = [Step::Mlp(mlp)];
    let bytes = policy_model(width_in, &[], &chain, &[], "test").unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn bad_onnx_files_are_refused_with_a_line_naming_the_file() {
    let scratch = common::scratch("onnx-bad-files");
    let load = |path: &str| OnnxPolicy::load(Path::new(path), OBS_DIM, ACTION_DIM).unwrap_err();
    let text = scratch.join("text.onnx");
    std::fs::write(&text, "not a model").unwrap();
    let e = load(text.to_str().unwrap());
    assert!(
        e.contains("text.onnx") && e.contains("not an ONNX model"),
        "{e}"
    );

    let e = load(&tiny_model(&scratch, "narrow.onnx", (37, 8), 0.0));
    assert!(
        e.contains("narrow.onnx") && e.contains("[batch, 38]"),
        "{e}"
    );
    assert!(!e.contains('\n'), "one line: {e}");

    let e = load(&tiny_model(&scratch, "six.onnx", (38, 6), 0.0));
    assert!(e.contains("six.onnx") && e.contains("[1, 8]"), "{e}");

    let e = load(&tiny_model(&scratch, "nan.onnx", (38, 8), f32::NAN));
    assert!(e.contains("nan.onnx") && e.contains("NaN"), "{e}");

    let fine = tiny_model(&scratch, "fine.onnx", (38, 8), 0.1);
    let policy = OnnxPolicy::load(Path::new(&fine), OBS_DIM, ACTION_DIM).unwrap();
    let mut batch = vec![0.5; 3 * OBS_DIM];
    batch[OBS_DIM + 4] = f32::INFINITY;
    let e = policy.act(&batch).unwrap_err();
    assert!(
        e.contains("observation 1") && e.contains("fine.onnx"),
        "{e}"
    );

    let e = "missing.onnx".parse::<Contestant>().unwrap_err();
    assert!(
        e.contains("missing.onnx") && e.contains("no such ONNX file"),
        "{e}"
    );
}

#[test]
fn a_program_plays_through_the_line_protocol_and_its_failures_are_named() {
    let limit = Duration::from_millis(500);
    let dims = (OBS_DIM, ACTION_DIM);
    let obs = vec![0.25; 2 * OBS_DIM];
    // Echoes each observation's first eight values: the exact numbers crossed both ways.
    let echo = "while read -r a b c d e f g h rest; do echo $a $b $c $d $e $f $g $h; done";
    let mut p = ProcessPolicy::start(echo, dims, limit).unwrap();
    assert_eq!(p.act(&obs).unwrap(), vec![0.25; 2 * ACTION_DIM]);
    assert_eq!(p.act(&obs[..OBS_DIM]).unwrap(), vec![0.25; ACTION_DIM]);

    let e = ProcessPolicy::start("exit 3", dims, limit)
        .unwrap()
        .act(&obs)
        .unwrap_err();
    assert!(
        e.contains("`exit 3`") && e.contains("exit status: 3"),
        "{e}"
    );
    let e = ProcessPolicy::start("sleep 5", dims, limit)
        .unwrap()
        .act(&obs)
        .unwrap_err();
    assert!(e.contains("no answer to observation 1 within 0.5 s"), "{e}");
    let e = ProcessPolicy::start("while read l; do echo 1 nan; done", dims, limit)
        .unwrap()
        .act(&obs)
        .unwrap_err();
    assert!(e.contains("answer 1: 2 values, expected 8"), "{e}");

    // In a match: a program that holds its rods plays; one that dies ends the match with
    // an error naming its side.
    let rules = MatchRules {
        time_limit_s: 2.0,
        ..MatchRules::default()
    };
    let table = match_table(&FoosballConfig::default(), &rules);
    let zeros: Contestant = "process:while read l; do echo 0 0 0 0 0 0 0 0; done"
        .parse()
        .unwrap();
    let shooter: Contestant = "shooter".parse().unwrap();
    let played = play_match(&table, &rules, &shooter, &zeros, 1).unwrap();
    let scripted = play_match(&table, &rules, &shooter, &"zero".parse().unwrap(), 1).unwrap();
    assert_eq!(
        played, scripted,
        "zeros from a program play as the zero policy"
    );
    let dying: Contestant = "process:exit 4".parse().unwrap();
    let e = play_match(&table, &rules, &shooter, &dying, 1).unwrap_err();
    assert!(e.starts_with("black (process:exit 4)"), "{e}");
}
