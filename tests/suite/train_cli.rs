//! `train` end to end with a tiny protocol: each algorithm writes its metrics, the same
//! seed gives the same metrics on 1 and 2 threads, and bad input is refused.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common;

fn tiny_config(dir: &Path, algo: &str) -> PathBuf {
    let path = dir.join(format!("{algo}.toml"));
    std::fs::write(&path, common::tiny_config_text(algo, 2, 150)).unwrap();
    path
}

fn train(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_train"))
        .args(args)
        .output()
        .unwrap()
}

use common::scratch;

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
        let tags = tensorboard_tags(&run_dir.join("tensorboard"));
        for tag in [
            "eval/mean_return",
            "rollout/ep_return_mean",
            "time/updates_per_second",
        ] {
            assert!(
                tags.iter().any(|t| t == tag),
                "{algo}: no {tag} in {tags:?}"
            );
        }
        let scalars = std::fs::read_to_string(run_dir.join("scalars.csv")).unwrap();
        for tag in &tags {
            assert!(
                scalars.contains(&format!(",{tag},")),
                "{algo}: {tag} not in scalars.csv"
            );
        }
        let traj = std::fs::read(run_dir.join("test/trajectories.bin")).unwrap();
        assert_eq!(&traj[..4], b"FSBT");
        assert_eq!(u64::from_le_bytes(traj[16..24].try_into().unwrap()), 3);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn each_algorithm_on_the_host_path_trains_and_tests_reproducibly() {
    for algo in ["ppo", "sac", "td3"] {
        let dir = scratch(&format!("e2e-host-{algo}"));
        let config = dir.join("host.toml");
        let text = common::tiny_config_text(algo, 2, 150);
        std::fs::write(
            &config,
            text.replace("seed = 3\n", "seed = 3\nbackend = \"host\"\n"),
        )
        .unwrap();
        let a = run(&config, &dir.join("a"), "1");
        let b = run(&config, &dir.join("b"), "2");
        assert_eq!(
            a, b,
            "{algo} on the host path: metrics differ between 1 and 2 threads"
        );
        let metrics: serde_json::Value = serde_json::from_str(&a).unwrap();
        assert_eq!(metrics["episodes"], 3);
        let saved = std::fs::read_to_string(dir.join("a/config.toml")).unwrap();
        assert!(saved.contains("backend = \"host\""), "{saved}");
    }
}

/// The length-delimited fields of a protobuf message as `(field number, bytes)`.
fn proto_fields(mut data: &[u8]) -> Vec<(u64, &[u8])> {
    fn varint(data: &mut &[u8]) -> u64 {
        let mut v = 0;
        for shift in (0..64).step_by(7) {
            let b = data[0];
            *data = &data[1..];
            v |= u64::from(b & 0x7f) << shift;
            if b < 0x80 {
                break;
            }
        }
        v
    }
    let mut out = Vec::new();
    while !data.is_empty() {
        let key = varint(&mut data);
        match key & 7 {
            0 => drop(varint(&mut data)),
            1 => data = &data[8..],
            5 => data = &data[4..],
            2 => {
                let n = varint(&mut data) as usize;
                out.push((key >> 3, &data[..n]));
                data = &data[n..];
            }
            t => panic!("wire type {t}"),
        }
    }
    out
}

/// The scalar tags in the TensorBoard event files of `dir`, read through their record
/// framing (`u64` length, `u32` CRC, data, `u32` CRC) and `Event.summary.value.tag`.
fn tensorboard_tags(dir: &Path) -> Vec<String> {
    let mut tags = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let bytes = std::fs::read(entry.unwrap().path()).unwrap();
        let mut rest = bytes.as_slice();
        while !rest.is_empty() {
            let len = u64::from_le_bytes(rest[..8].try_into().unwrap()) as usize;
            let event = &rest[12..12 + len];
            rest = &rest[12 + len + 4..];
            for (_, summary) in proto_fields(event).into_iter().filter(|f| f.0 == 5) {
                for (_, value) in proto_fields(summary) {
                    for (_, tag) in proto_fields(value).into_iter().filter(|f| f.0 == 1) {
                        let tag = String::from_utf8(tag.to_vec()).unwrap();
                        if !tags.contains(&tag) {
                            tags.push(tag);
                        }
                    }
                }
            }
        }
    }
    tags
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
    // A size no machine holds is refused before anything is allocated or written.
    let huge = dir.join("huge");
    let e = refused(&[
        "--config",
        c,
        "--hidden",
        "100000000,100000000",
        "--out",
        huge.to_str().unwrap(),
    ]);
    assert!(
        e.contains("sac.net.hidden = [100000000, 100000000]") && e.contains("GiB"),
        "{e}"
    );
    assert!(!huge.exists());
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

    // On another game: the same networks, that game's table, its own output directory.
    let o = evaluate(&["--run", r, "--preset", "reference_v3", "--episodes", "2"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("actions) on reference_v3"));
    let other = std::fs::read_to_string(run_dir.join("evaluate-best-on-reference_v3/metrics.json"));
    assert!(other.is_ok());
    // A game whose observations mean something else is refused, naming the key.
    let o = evaluate(&["--run", r, "--preset", "reference_v1"]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("--preset reference_v1") && e.contains("ball_frame"),
        "{e}"
    );

    // A configuration's `[env]` instead of a preset: the run's own gives its own test
    // back, on the run's test seeds; one whose actions mean something else is refused.
    let c = config.to_str().unwrap();
    let o = evaluate(&["--run", r, "--checkpoint", "last", "--config", c]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let own = std::fs::read_to_string(run_dir.join("evaluate-last-on-td3/metrics.json")).unwrap();
    assert_eq!(own, trained);
    let linear = dir.join("linear.toml");
    std::fs::write(&linear, "algo = \"td3\"\n[env]\naction_map = \"linear\"\n").unwrap();
    let o = evaluate(&["--run", r, "--config", linear.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("--config") && e.contains("action_map"), "{e}");

    let o = evaluate(&["--run", dir.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not a run directory"));

    // `--force` replaces the run and `evaluate`'s outputs of the old one.
    let o = train(&["--config", config.to_str().unwrap(), "--out", r, "--force"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!run_dir.join("evaluate-last").exists() && !run_dir.join("evaluate-best").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A run under `[normalize]` saves its observation moments beside its networks; loaded,
/// they play the test's episodes again, and a run without them is refused by name.
#[test]
fn a_normalised_run_saves_its_moments_and_evaluate_reproduces_its_test() {
    let dir = scratch("normalize");
    let path = dir.join("ppo.toml");
    std::fs::write(
        &path,
        common::tiny_config_text("ppo", 2, 150) + "[normalize]\n",
    )
    .unwrap();
    let run_dir = dir.join("run");
    let trained = run(&path, &run_dir, "1");
    let moments = foosball_rl::nets::Snapshot::read(&run_dir.join("last/normalize.bin")).unwrap();
    assert_eq!(moments.u64s("obs.mean").unwrap().len(), 38);
    assert!(moments.f64("obs.count").unwrap() > 100.0);
    let r = run_dir.to_str().unwrap();
    let o = evaluate(&["--run", r, "--checkpoint", "last"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let again = std::fs::read_to_string(run_dir.join("evaluate-last/metrics.json")).unwrap();
    assert_eq!(again, trained);

    std::fs::remove_file(run_dir.join("last/normalize.bin")).unwrap();
    let o = evaluate(&["--run", r, "--checkpoint", "last"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("normalize.bin"));
    // Networks that read raw observations do not start a normalised run.
    let raw = dir.join("raw");
    let raw_text = common::tiny_config_text("ppo", 1, 150);
    std::fs::write(dir.join("raw.toml"), &raw_text).unwrap();
    run(&dir.join("raw.toml"), &raw, "1");
    let o = train(&[
        "--config",
        path.to_str().unwrap(),
        "--out",
        dir.join("fine").to_str().unwrap(),
        "--init-from",
        &format!("{}@last", raw.display()),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("normalize.obs"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A run whose networks read Fourier features plays its test again from its saved
/// networks (the features rebuilt from its configuration); networks that read other
/// features do not start it, and settings out of range are refused by key.
#[test]
fn a_fourier_run_replays_its_test_and_refuses_networks_of_other_features() {
    let dir = scratch("fourier");
    let text = |features: &str| {
        common::tiny_config_text("td3", 1, 150) + "[normalize]\n[fourier]\n" + features
    };
    let write = |name: &str, body: String| {
        let path = dir.join(name);
        std::fs::write(&path, body).unwrap();
        path
    };
    let path = write("td3.toml", text("frequencies = 3\n"));
    let run_dir = dir.join("run");
    let trained = run(&path, &run_dir, "1");
    let r = run_dir.to_str().unwrap();
    let o = evaluate(&["--run", r, "--checkpoint", "last"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let again = std::fs::read_to_string(run_dir.join("evaluate-last/metrics.json")).unwrap();
    assert_eq!(again, trained);

    let other = write("other.toml", text("frequencies = 2\n"));
    let o = train(&[
        "--config",
        other.to_str().unwrap(),
        "--out",
        dir.join("fine").to_str().unwrap(),
        "--init-from",
        &format!("{r}@last"),
    ]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("[fourier]") && e.contains("3 frequencies"),
        "{e}"
    );

    for (features, key) in [
        ("frequencies = 0\n", "fourier.frequencies"),
        ("scale = -1.0\n", "fourier.scale"),
        ("inputs = [38]\n", "fourier.inputs"),
    ] {
        let bad = write("bad.toml", text(features));
        let o = train(&[
            "--config",
            bad.to_str().unwrap(),
            "--out",
            dir.join("bad").to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2));
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains(key), "{e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_paper_codes_test_plays_the_best_networks_sampled_and_evaluate_repeats_it() {
    let dir = scratch("code-test");
    let text = common::tiny_config_text("sac", 2, 150).replace(
        "test_episodes = 3\n",
        "test_episodes = 3\ntest_networks = \"best\"\ntest_actions = \"stochastic\"\n",
    );
    let config = dir.join("sac.toml");
    std::fs::write(&config, text).unwrap();
    let run_dir = dir.join("run");
    let trained = run(&config, &run_dir, "1");
    let r = run_dir.to_str().unwrap();
    // evaluate's defaults for this run: the best networks (always), sampled actions (the run's).
    let o = evaluate(&["--run", r]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let again =
        std::fs::read_to_string(run_dir.join("evaluate-best-stochastic/metrics.json")).unwrap();
    assert_eq!(again, trained);
    // The last networks acting deterministically play other episodes.
    let o = evaluate(&[
        "--run",
        r,
        "--checkpoint",
        "last",
        "--actions",
        "deterministic",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let last = std::fs::read_to_string(run_dir.join("evaluate-last/metrics.json")).unwrap();
    assert_ne!(last, trained);
    // `best` without an evaluation is refused by key.
    let never = common::tiny_config_text("sac", 1, 50).replace(
        "eval_every = 100",
        "eval_every = 100\ntest_networks = \"best\"",
    );
    std::fs::write(&config, never).unwrap();
    let e = refused(&["--config", config.to_str().unwrap(), "--out", r, "--force"]);
    assert!(e.contains("protocol.test_networks"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn train_prints_its_budget_before_training() {
    let dir = scratch("budget");
    let config = tiny_config(&dir, "td3");
    let out = dir.join("run");
    let o = train(&[
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    let line = text
        .lines()
        .find(|l| l.starts_with("# budget: memory about"))
        .unwrap_or_else(|| panic!("no budget line in\n{text}"));
    // TD3 trains once per vec-env step of 2 envs: half a gradient step per env step.
    assert!(line.contains("+ 0.50 gradient steps of"), "{line}");
    assert!(line.contains("for the run's 300 env steps"), "{line}");
    assert!(!text.contains("more than a day"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn recipe_options_train_save_reload_and_are_refused_where_they_do_not_apply() {
    let dir = scratch("recipe");
    let text = common::tiny_config_text("sac", 2, 150)
        .replace(
            "[sac.net]\n",
            "[sac]\nactor_average_tau = 0.01\n[sac.net]\ncritic_layer_norm = true\n",
        )
        .replace(
            "[sac.off_policy]\n",
            "[sac.off_policy]\nreward_scale = 0.01\nn_step = 3\n",
        )
        .replace("[protocol]\n", "[protocol]\nbest_by = \"score_rate\"\n");
    let config = dir.join("sac.toml");
    std::fs::write(&config, text).unwrap();
    let run_dir = dir.join("run");
    let trained = run(&config, &run_dir, "1");
    let saved = std::fs::read_to_string(run_dir.join("config.toml")).unwrap();
    assert!(saved.contains("critic_layer_norm = true") && saved.contains("reward_scale = 0.01"));
    assert!(saved.contains("best_by = \"score_rate\"") && run_dir.join("best").is_dir());
    assert!(saved.contains("actor_average_tau = 0.01") && saved.contains("n_step = 3"));
    assert!(run_dir.join("last/actor_average.bpk").is_file());
    // The normalised critics (gain and bias of each hidden layer) are saved and reloaded.
    let plain_dir = dir.join("plain");
    run(&tiny_config(&dir, "sac"), &plain_dir, "1");
    let size = |d: &Path| std::fs::metadata(d.join("last/critic.bpk")).unwrap().len();
    assert!(size(&run_dir) > size(&plain_dir));
    let o = evaluate(&["--run", run_dir.to_str().unwrap(), "--checkpoint", "last"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let again = std::fs::read_to_string(run_dir.join("evaluate-last/metrics.json")).unwrap();
    assert_eq!(again, trained);
    let ppo = dir.join("ppo.toml");
    let text = common::tiny_config_text("ppo", 1, 150)
        .replace("[ppo.net]\n", "[ppo.net]\ncritic_layer_norm = true\n");
    std::fs::write(&ppo, text).unwrap();
    let e = refused(&["--config", ppo.to_str().unwrap()]);
    assert!(e.contains("ppo.net.critic_layer_norm"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}
