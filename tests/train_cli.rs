//! `train` end to end with a tiny protocol: each algorithm writes its metrics, the same
//! seed gives the same metrics on 1 and 2 threads, and bad input is refused.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn tiny_config(dir: &Path, algo: &str) -> PathBuf {
    let section = match algo {
        "ppo" => "[ppo]\nn_steps = 64\nbatch_size = 32\nn_epochs = 2\n[ppo.net]\nhidden = [16]\n",
        _ => "[ALGO.net]\nhidden = [16]\n[ALGO.off_policy]\nbuffer_size = 1000\nlearning_starts = 50\nbatch_size = 32\n",
    }
    .replace("ALGO", algo);
    let text = format!(
        "algo = \"{algo}\"\n[protocol]\nseed = 3\nepochs = 2\nsteps_per_epoch = 150\neval_every = 100\n\
         eval_episodes = 2\ntest_episodes = 3\nenvs = 2\n[env]\nmax_episode_steps = 30\n{section}"
    );
    let path = dir.join(format!("{algo}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

fn train(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_train"))
        .args(args)
        .output()
        .unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("foosball-train-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn run(config: &Path, out: &Path, threads: &str) -> String {
    let o = train(&[
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threads",
        threads,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::read_to_string(out.join("test/metrics.json")).unwrap()
}

#[test]
fn each_algorithm_trains_evaluates_and_tests_reproducibly() {
    let dir = scratch("e2e");
    for algo in ["ppo", "sac", "td3"] {
        let config = tiny_config(&dir, algo);
        let a = run(&config, &dir.join(format!("{algo}-a")), "1");
        let b = run(&config, &dir.join(format!("{algo}-b")), "2");
        assert_eq!(a, b, "{algo}: metrics differ between 1 and 2 threads");
        if algo == "sac" {
            let c = run(&config, &dir.join(format!("{algo}-c")), "0");
            assert_eq!(a, c, "{algo}: metrics differ with one thread per core");
        }
        let metrics: serde_json::Value = serde_json::from_str(&a).unwrap();
        assert_eq!(metrics["episodes"], 3);
        let run_dir = dir.join(format!("{algo}-a"));
        for file in [
            "config.toml",
            "episodes.csv",
            "evaluations.csv",
            "test/metrics.md",
            "test/trajectories.bin",
        ] {
            assert!(run_dir.join(file).exists(), "{algo}: {file} missing");
        }
        assert!(run_dir.join("last").read_dir().unwrap().count() > 0);
        assert!(run_dir.join("best").read_dir().unwrap().count() > 0);
        // Evaluations every 100 of 300 env steps.
        let evals = std::fs::read_to_string(run_dir.join("evaluations.csv")).unwrap();
        assert_eq!(evals.lines().count(), 1 + 3, "{evals}");
        let traj = std::fs::read(run_dir.join("test/trajectories.bin")).unwrap();
        assert_eq!(&traj[..4], b"FSBT");
        assert_eq!(u64::from_le_bytes(traj[16..24].try_into().unwrap()), 3);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

fn refused(args: &[&str]) -> String {
    let o = train(args);
    assert_eq!(o.status.code(), Some(2), "{args:?} should fail");
    let stderr = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(
        stderr.starts_with("error: ") || stderr.contains("error:"),
        "{stderr}"
    );
    stderr
}

#[test]
fn bad_input_is_refused_with_the_culprit_named() {
    let dir = scratch("bad");
    let config = tiny_config(&dir, "sac");
    let c = config.to_str().unwrap();
    let o = train(&["--algo", "dqn"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("dqn"));
    assert!(refused(&["--config", "no/such.toml"]).contains("no/such.toml"));
    assert!(refused(&["--config", c, "--hidden", "16,0"]).contains("sac.net.hidden"));
    assert!(refused(&["--config", c, "--epochs", "0"]).contains("protocol.epochs"));
    assert!(refused(&["--config", c, "--algo", "td3"]).contains("algo = \"sac\""));
    let out = dir.join("taken");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("config.toml"), "algo = \"sac\"\n").unwrap();
    let e = refused(&["--config", c, "--out", out.to_str().unwrap()]);
    assert!(e.contains("already holds a run"), "{e}");
    assert_eq!(
        std::fs::read_to_string(out.join("config.toml")).unwrap(),
        "algo = \"sac\"\n",
        "nothing overwritten"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

fn evaluate(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_evaluate"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn evaluate_reproduces_the_test_of_the_saved_networks() {
    let dir = scratch("evaluate");
    let config = tiny_config(&dir, "td3");
    let run_dir = dir.join("run");
    let trained = run(&config, &run_dir, "2");
    let r = run_dir.to_str().unwrap();
    let o = evaluate(&["--run", r, "--checkpoint", "last"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Loaded networks play the same test episodes as the trained ones did.
    let again = std::fs::read_to_string(run_dir.join("evaluate-last/metrics.json")).unwrap();
    assert_eq!(again, trained);
    let o = evaluate(&["--run", r, "--episodes", "2"]);
    assert!(o.status.success());
    let best: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(run_dir.join("evaluate-best/metrics.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(best["episodes"], 2);

    let o = evaluate(&["--run", dir.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not a run directory"));
    std::fs::remove_dir_all(&dir).unwrap();
}
