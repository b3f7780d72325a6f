//! Demonstrations (`protocol.demonstrations` + `off_policy.demo_share`): a run learns
//! from a `trajectories.bin` that `evaluate` recorded, the same numbers twice and other
//! numbers than without them, several files as one buffer, normalised under
//! `[normalize]`; files recorded on the run's
//! own evaluation or test starts or on another table, an image observation, a missing
//! file, an empty list and half-set keys are refused by key.

use crate::common;

use common::{scratch, tiny_config_text};
use foosball_rl::config::RunConfig;
use foosball_rl::play::scripted::{Baseline, ScriptedPolicy};
use foosball_rl::run::train::{Start, train};
use std::path::{Path, PathBuf};

/// The shooter's `episodes` recorded on the tiny table from seed `seed`'s test starts.
fn record(dir: &Path, seed: u64) -> PathBuf {
    let c = RunConfig::from_toml(&tiny_config_text("sac", 1, 200), Path::new("t.toml")).unwrap();
    let shooter = Baseline {
        policy: ScriptedPolicy::Shooter,
        seed,
        env: c.env,
        planner: None,
    };
    let out = dir.join(format!("shooter-{seed}"));
    shooter.test(6, &out, true).unwrap();
    out.join("trajectories.bin")
}

fn with_demos(file: &Path, extra: &str) -> String {
    tiny_config_text("sac", 1, 200)
        .replace(
            "[protocol]\n",
            &format!("[protocol]\ndemonstrations = \"{}\"\n", file.display()),
        )
        .replace(
            "[sac.off_policy]\n",
            &format!("[sac.off_policy]\ndemo_share = 0.5\n{extra}"),
        )
}

fn run(dir: &Path, name: &str, text: &str) -> Result<Vec<u8>, String> {
    let out = dir.join(name);
    std::fs::create_dir_all(&out).unwrap();
    let c = RunConfig::from_toml(text, Path::new("t.toml")).map_err(|e| e.to_string())?;
    train(&c, &out, Start::Fresh, |_| {}).map_err(|e| e.to_string())?;
    Ok(std::fs::read(out.join("test/metrics.json")).unwrap())
}

/// The networks a run of `dir/name` saved last, every file's bytes in name order: what it
/// learnt, where a tiny run's test may end alike either way.
fn learnt(dir: &Path, name: &str) -> Vec<u8> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join(name).join("last"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    files
        .iter()
        .flat_map(|f| std::fs::read(f).unwrap())
        .collect()
}

#[test]
fn a_run_learns_from_recorded_episodes_reproducibly() {
    let dir = scratch("demonstrations");
    let file = record(&dir, 1000);
    let cloning = with_demos(&file, "").replace("[sac.net]", "[sac]\nbc_weight = 0.4\n[sac.net]");
    let first = run(&dir, "a", &cloning).unwrap();
    assert_eq!(first, run(&dir, "b", &cloning).unwrap(), "not reproducible");
    let alone = run(&dir, "alone", &tiny_config_text("sac", 1, 200)).unwrap();
    assert_ne!(first, alone, "the demonstrations changed nothing");
    let rl_only = run(&dir, "rl-only", &with_demos(&file, "")).unwrap();
    assert_ne!(first, rl_only, "behaviour cloning changed nothing");
}

/// Under `[normalize]` the demonstrations seed the moments and are learned from
/// normalised: other numbers than the normalised run without them, the same twice; a run stopped and resumed ends as the uninterrupted one (the rows handed again at the
/// resume are those of the start); beside `[dagger]` too (the files handed before the
/// checkpoint's moments replace the fresh ones, the labels after: neither is merged into
/// the moments twice).
#[test]
fn a_normalised_run_learns_from_demonstrations_and_resumes_exactly() {
    let dir = scratch("demonstrations-normalised");
    let file = record(&dir, 1000);
    let normalised = with_demos(&file, "") + "[normalize]\n";
    let first = run(&dir, "a", &normalised).unwrap();
    assert_eq!(
        first,
        run(&dir, "b", &normalised).unwrap(),
        "not reproducible"
    );
    let alone = tiny_config_text("sac", 1, 200) + "[normalize]\n";
    run(&dir, "alone", &alone).unwrap();
    assert_ne!(
        learnt(&dir, "a"),
        learnt(&dir, "alone"),
        "the demonstrations changed nothing"
    );
    let (one, three) = (
        "epochs = 1\nsteps_per_epoch = 200",
        "epochs = 3\nsteps_per_epoch = 150",
    );
    assert!(normalised.contains(one));
    let longer = normalised.replace(one, three);
    crate::resume::stopped_and_resumed("normalised-demos", &longer, None);
    let teacher = "[dagger]\nevery = 75\nepisodes = 2\n[dagger.planner]\npopulation = 16\n\
                   elites = 4\niterations = 4\nmax_rollout_steps = 30\n";
    crate::resume::stopped_and_resumed("normalised-demos-dagger", &(longer + teacher), None);
}

#[test]
fn several_files_fill_one_buffer_in_order() {
    let dir = scratch("demonstrations-files");
    let (a, b) = (record(&dir, 1000), record(&dir, 2000));
    let list = |files: &[&Path]| {
        let names: Vec<String> = files
            .iter()
            .map(|f| format!("\"{}\"", f.display()))
            .collect();
        with_demos(a.as_path(), "").replace(
            &format!("demonstrations = \"{}\"", a.display()),
            &format!("demonstrations = [{}]", names.join(", ")),
        )
    };
    // A list of one is the file itself.
    assert_eq!(
        run(&dir, "one", &with_demos(&a, "")).unwrap(),
        run(&dir, "list-of-one", &list(&[&a])).unwrap()
    );
    let both = run(&dir, "both", &list(&[&a, &b])).unwrap();
    assert_eq!(both, run(&dir, "both-again", &list(&[&a, &b])).unwrap());
    assert_ne!(
        both,
        run(&dir, "a-only", &list(&[&a])).unwrap(),
        "file b changed nothing"
    );
    // A bad file in a list is named; an empty list is refused.
    let own = record(&dir, 3);
    let err = run(&dir, "with-own", &list(&[&a, &own])).unwrap_err();
    assert!(
        err.contains("protocol.demonstrations") && err.contains("shooter-3"),
        "{err}"
    );
    let err = run(&dir, "empty", &list(&[])).unwrap_err();
    assert!(
        err.contains("protocol.demonstrations") && err.contains("empty list"),
        "{err}"
    );
}

#[test]
fn demonstrations_that_do_not_fit_the_run_are_refused_by_key() {
    let dir = scratch("demonstrations-refused");
    // Seed 3 is the tiny run's own: its test starts would be learnt from.
    let own = record(&dir, 3);
    let err = run(&dir, "own", &with_demos(&own, "")).unwrap_err();
    assert!(
        err.contains("protocol.demonstrations") && err.contains("evaluation or test starts"),
        "{err}"
    );
    let missing = dir.join("none.bin");
    let err = run(&dir, "missing", &with_demos(&missing, "")).unwrap_err();
    assert!(err.contains("none.bin"), "{err}");
    let file = record(&dir, 1000);
    let half = with_demos(&file, "").replace("demo_share = 0.5\n", "");
    let err = run(&dir, "half", &half).unwrap_err();
    assert!(
        err.contains("protocol.demonstrations") && err.contains("demo_share"),
        "{err}"
    );
    let other_half = tiny_config_text("sac", 1, 200)
        .replace("[sac.off_policy]\n", "[sac.off_policy]\ndemo_share = 0.5\n");
    let err = run(&dir, "other-half", &other_half).unwrap_err();
    assert!(err.contains("sac.off_policy.demo_share"), "{err}");
    let bc_alone =
        tiny_config_text("sac", 1, 200).replace("[sac.net]", "[sac]\nbc_weight = 0.4\n[sac.net]");
    let err = run(&dir, "bc", &bc_alone).unwrap_err();
    assert!(err.contains("bc_weight"), "{err}");
    let ppo = tiny_config_text("ppo", 1, 200).replace(
        "[protocol]\n",
        &format!("[protocol]\ndemonstrations = \"{}\"\n", file.display()),
    );
    let err = run(&dir, "ppo", &ppo).unwrap_err();
    assert!(err.contains("protocol.demonstrations"), "{err}");
    let images = with_demos(&file, "") + "[env.observation]\nkind = \"image\"\n";
    let err = run(&dir, "images", &images).unwrap_err();
    assert!(err.contains("this run observes images"), "{err}");
    // Recorded on the fourth reference's contacts, learnt on the default's: another game.
    let other_table =
        with_demos(&file, "").replace("[env]\n", "[env]\nman_contacts = \"mujoco_soft\"\n");
    let err = run(&dir, "other-table", &other_table).unwrap_err();
    assert!(
        err.contains("protocol.demonstrations")
            && err.contains("recorded on another table")
            && err.contains("man_contacts = \"mujoco_octree\""),
        "{err}"
    );
    // Other rules on the same table are fine.
    let other_rules =
        with_demos(&file, "").replace("[env]\n", "[env]\nrules.stagnant_steps = 12\n");
    run(&dir, "other-rules", &other_rules).unwrap();
}
