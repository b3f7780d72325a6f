//! `configs/**/*.toml` load, the algorithms' files hold the paper's protocol, and bad
//! files are refused with the file, the line and the key at fault.

use foosball_rl::config::{Algo, AlgoConfig, ConfigFileError, RunConfig};
use std::path::{Path, PathBuf};

fn config_path(algo: Algo) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("configs/{algo}.toml"))
}

#[test]
fn the_shipped_configs_hold_the_papers_protocol() {
    for algo in [Algo::Ppo, Algo::Sac, Algo::Td3] {
        let c = RunConfig::load(&config_path(algo)).unwrap();
        assert_eq!(c.algo(), algo);
        assert_eq!(c.hidden(), &[3000; 7]);
        let p = &c.protocol;
        assert_eq!(
            (p.epochs, p.steps_per_epoch, p.eval_every),
            (15, 100_000, 3_000)
        );
        assert_eq!((p.eval_episodes, p.test_episodes), (10, 1_000));
        let (net, gamma) = match &c.algorithm {
            AlgoConfig::Ppo(p) => (&p.net, p.gamma),
            AlgoConfig::Sac(s) => {
                assert_eq!(s.off_policy.buffer_size, 1_000_000);
                (&s.net, s.gamma)
            }
            AlgoConfig::Td3(t) => {
                assert_eq!(t.off_policy.buffer_size, 1_000_000);
                (&t.net, t.gamma)
            }
        };
        assert_eq!(net.lr.at(1.0), 3e-4);
        assert_eq!(net.adam.eps, 1e-8);
        // The paper's text clipped all three; its code trains SAC with SB3's defaults,
        // which clip nothing. SAC follows the code, PPO (SB3's own 0.5) and TD3 the text.
        let clip = match &c.algorithm {
            AlgoConfig::Sac(_) => None,
            _ => Some(0.5),
        };
        assert_eq!(net.adam.max_grad_norm, clip, "{algo:?}");
        assert_eq!(gamma, 0.99);
        // What a run saves reads back the same.
        let again = RunConfig::from_toml(&c.to_toml(), Path::new("saved.toml")).unwrap();
        assert_eq!(again, c);
    }
}

/// Every file under `configs/` (the ablation's included) loads as a run configuration:
/// a renamed key or a bad value in a shipped file fails here, not hours into a study.
#[test]
fn every_shipped_config_loads() {
    let files = crate::common::files_under(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("configs"),
        "toml",
        &[],
    );
    assert!(files.len() >= 12, "{files:?}");
    for file in files {
        // The error names the file, the line and the key.
        if let Err(e) = RunConfig::load(&file) {
            panic!("{e}");
        }
    }
}

/// `configs/self_play.toml` is SAC as in `sac.toml` on 64 x 64 networks with the
/// defaults of `[self_play]` spelled out, and reads back as saved.
#[test]
fn the_shipped_self_play_config_is_sac_with_the_default_pool() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/self_play.toml");
    let c = RunConfig::load(&path).unwrap();
    let sac = RunConfig::load(&config_path(Algo::Sac)).unwrap();
    assert_eq!(c.algo(), Algo::Sac);
    assert_eq!(c.hidden(), &[64, 64]);
    let (AlgoConfig::Sac(a), AlgoConfig::Sac(b)) = (&c.algorithm, &sac.algorithm) else {
        panic!("not SAC");
    };
    assert_eq!(a.off_policy, b.off_policy);
    assert_eq!((a.gamma, a.net.adam.clone()), (b.gamma, b.net.adam.clone()));
    let sp = c.self_play.as_ref().expect("a [self_play] section");
    let defaults = foosball_rl::config::SelfPlayConfig::default();
    assert_eq!(
        (
            sp.pool_size,
            sp.latest_share,
            sp.anchor_share,
            &sp.anchors,
            sp.pfsp_power
        ),
        (
            defaults.pool_size,
            defaults.latest_share,
            defaults.anchor_share,
            &defaults.anchors,
            defaults.pfsp_power
        )
    );
    let again = RunConfig::from_toml(&c.to_toml(), Path::new("saved.toml")).unwrap();
    assert_eq!(again, c);
}

fn error(text: &str) -> String {
    let e = RunConfig::from_toml(text, Path::new("bad.toml")).unwrap_err();
    e.to_string()
}

#[test]
fn an_unknown_key_names_the_file_the_line_and_the_key() {
    let e = error("algo = \"sac\"\n\n[sac.net]\nhiden = [64]\n");
    assert!(e.starts_with("bad.toml:4: sac.net.hiden: "), "{e}");
}

#[test]
fn an_invalid_value_names_the_file_the_line_and_the_key() {
    let e = error("algo = \"td3\"\n[td3.net]\nactivation = \"relu\"\nhidden = [64, 0]\n");
    assert_eq!(e, "bad.toml:4: td3.net.hidden: widths must be positive");
    let e = error("algo = \"sac\"\n[protocol]\nepochs = 0\n");
    assert_eq!(e, "bad.toml:3: protocol.epochs: must be positive");
    let e = error("algo = \"sac\"\n[env]\nframe_skip = 0\n");
    assert!(e.starts_with("bad.toml:3: env.frame_skip:"), "{e}");
    let e = error("algo = \"td3\"\n[td3]\naction_l2 = -1.0\n");
    assert_eq!(e, "bad.toml:3: td3.action_l2: must be finite and >= 0");
}

#[test]
fn malformed_files_and_wrong_sections_are_refused() {
    assert!(error("algo = \"dqn\"\n").contains("dqn"));
    assert!(error("algo = \"sac\"\n[protocol]\nepochs = -1\n").starts_with("bad.toml:3:"));
    assert!(error("algo = [\n").starts_with("bad.toml:"));
    let e = error("algo = \"sac\"\n[env]\nrod_mount = \"hinge\"\n");
    assert!(
        e.starts_with("bad.toml:2:") && e.contains("`hinge`, expected `joint` or `locked_axes`"),
        "{e}"
    );
    let e = error("algo = \"sac\"\n[protocol]\ntest_actions = \"greedy\"\n");
    assert!(
        e.starts_with("bad.toml:3: protocol.test_actions: ")
            && e.contains("`greedy`, expected `deterministic` or `stochastic`"),
        "{e}"
    );
    let e = error(
        "algo = \"ppo\"\n[protocol]\nbackend = \"host\"\n[env.observation]\nkind = \"image\"\n",
    );
    assert!(
        e.starts_with("bad.toml:") && e.contains("protocol.backend: `host` computes vector"),
        "{e}"
    );
    for algo in ["sac", "td3"] {
        let e = error(&format!(
            "algo = \"{algo}\"\n[protocol]\nbackend = \"host\"\n[{algo}.net]\ncritic_layer_norm = true\n",
        ));
        assert!(
            e.contains(&format!(
                "does not compute layer normalisation: set {algo}.net"
            )),
            "{e}"
        );
    }
    let e = error("algo = \"ppo\"\n[ppo.kickstart]\nteacher = \"random\"\n");
    assert!(
        e.contains("ppo.kickstart.teacher: ") && e.contains("`random` draws its actions"),
        "{e}"
    );
    let e = error("algo = \"ppo\"\n[ppo.kickstart]\nteacher = \"shooter\"\ncoef_end = -1\n");
    assert!(e.contains("ppo.kickstart.coef_end"), "{e}");
    let e = error("algo = \"sac\"\n[ppo]\nn_steps = 8\n");
    assert!(e.contains("ppo: section for another algorithm"), "{e}");
    let missing = RunConfig::load(Path::new("no/such.toml")).unwrap_err();
    assert!(matches!(missing, ConfigFileError::Read { .. }));
    assert!(missing.to_string().contains("no/such.toml"));
}

#[test]
fn earlier_files_with_gamma_under_off_policy_still_read() {
    for (algo, other) in [("sac", 0.95), ("td3", 0.9)] {
        let text = format!("algo = \"{algo}\"\n[{algo}.off_policy]\ngamma = {other}\ntau = 0.01\n");
        let c = RunConfig::from_toml(&text, Path::new("old.toml")).unwrap();
        let (gamma, tau) = match &c.algorithm {
            AlgoConfig::Sac(s) => (s.gamma, s.off_policy.tau),
            AlgoConfig::Td3(t) => (t.gamma, t.off_policy.tau),
            AlgoConfig::Ppo(_) => unreachable!("{algo}"),
        };
        assert_eq!((gamma, tau), (other as f32, 0.01));
        // Saved again, the discount sits in the algorithm's own section.
        let saved = c.to_toml();
        assert!(
            saved.contains(&format!("[{algo}]\ngamma = {other}")),
            "{saved}"
        );
        assert_eq!(
            RunConfig::from_toml(&saved, Path::new("new.toml")).unwrap(),
            c
        );
    }
    // A file of today's shape with the key in both places is refused at the old one.
    let e = error("algo = \"sac\"\n[sac]\ngamma = 0.9\n[sac.off_policy]\ngamma = 0.9\n");
    assert!(e.contains("bad.toml:5") && e.contains("gamma"), "{e}");
}

/// `backend = "auto"` (the shipped algorithm files'): the host path for networks it
/// computes up to `AUTO_HOST_WIDTH` wide, the default CPU backend for the paper's 7 x 3000
/// networks, images and the critics' layer normalisation.
#[test]
fn auto_puts_small_vector_networks_on_the_host_path() {
    use foosball_rl::config::{AUTO_HOST_WIDTH, Overrides};
    for algo in [Algo::Ppo, Algo::Sac, Algo::Td3] {
        let path = config_path(algo);
        let paper = RunConfig::load(&path).unwrap();
        assert_eq!(paper.protocol.backend.map(|b| b.name()), Some("auto"));
        assert!(!paper.computes_on_host(), "{algo}: 7 x 3000 stays on flex");
        let small = |widths: Vec<usize>| {
            let o = Overrides {
                hidden: Some(widths),
                ..Overrides::default()
            };
            RunConfig::load_with(&path, Some(algo), &o).unwrap()
        };
        assert!(small(vec![64, 64]).computes_on_host(), "{algo}");
        assert!(small(vec![AUTO_HOST_WIDTH; 2]).computes_on_host(), "{algo}");
        assert!(
            !small(vec![AUTO_HOST_WIDTH + 1, 64]).computes_on_host(),
            "{algo}"
        );
        let mut image = small(vec![64, 64]);
        image.env.observation.kind = foosball_rl::env::ObservationKind::Image;
        assert!(!image.computes_on_host(), "{algo}");
        if algo != Algo::Ppo {
            let mut norm = small(vec![64, 64]);
            norm.algorithm.net_mut().critic_layer_norm = true;
            assert!(!norm.computes_on_host(), "{algo}");
        }
    }
}

/// Writes `files` (name, text) into a scratch folder named after `test`.
fn chain(test: &str, files: &[(&str, &str)]) -> crate::common::Scratch {
    let dir = crate::common::scratch(test);
    for (name, text) in files {
        let path = dir.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }
    dir
}

/// `extends`: the file's keys over its base's, tables merged, the base's own base first;
/// the path is relative to the extending file, and the run saves the merged config.
#[test]
fn a_config_extends_its_base_keys_override_and_tables_merge() {
    let dir = chain(
        "extends-merge",
        &[
            (
                "root.toml",
                "algo = \"ppo\"\n[protocol]\nepochs = 3\nenvs = 2\n[ppo]\nn_epochs = 4\n\
                 [ppo.net]\nhidden = [32, 32]\n[[drills]]\nshare = 0.5\nx_mean = 1.0\nx_std = 0.0\ny_mean = 0.0\ny_std = 0.0\n",
            ),
            (
                "study/mid.toml",
                "extends = \"../root.toml\"\n[ppo.net]\nhidden = [128, 128]\n[normalize]\n",
            ),
            (
                "study/leaf.toml",
                "extends = \"mid.toml\"\n[protocol]\nepochs = 5\n[ppo]\nbatch_size = 128\n",
            ),
        ],
    );
    let c = RunConfig::load(&dir.join("study/leaf.toml")).unwrap();
    let AlgoConfig::Ppo(ppo) = &c.algorithm else {
        panic!("not PPO")
    };
    // Overridden by the leaf, kept from the root, merged into [ppo] and [ppo.net].
    assert_eq!((c.protocol.epochs, c.protocol.envs), (5, 2));
    assert_eq!((ppo.n_epochs, ppo.batch_size), (4, 128));
    assert_eq!(c.hidden(), &[128, 128]);
    assert!(c.normalize.is_some());
    assert_eq!(c.drills.len(), 1);
    // The same configuration written out whole reads back equal: what a run saves.
    let again = RunConfig::from_toml(&c.to_toml(), Path::new("saved.toml")).unwrap();
    assert_eq!(again, c);
    assert!(!c.to_toml().contains("extends"));
}

#[test]
fn a_missing_base_is_refused_naming_the_file_that_names_it() {
    let dir = chain(
        "extends-missing",
        &[("a.toml", "extends = \"nowhere.toml\"\nalgo = \"sac\"\n")],
    );
    let e = RunConfig::load(&dir.join("a.toml"))
        .unwrap_err()
        .to_string();
    let a = dir.join("a.toml");
    assert!(
        e.starts_with(&format!(
            "{}: extends = \"nowhere.toml\": cannot read {}",
            a.display(),
            dir.join("nowhere.toml").display()
        )),
        "{e}"
    );
}

#[test]
fn a_cycle_of_extends_is_refused_naming_the_chain() {
    let dir = chain(
        "extends-cycle",
        &[
            ("a.toml", "extends = \"b.toml\"\nalgo = \"sac\"\n"),
            ("b.toml", "extends = \"c.toml\"\n"),
            ("c.toml", "extends = \"b.toml\"\n"),
            ("self.toml", "extends = \"self.toml\"\nalgo = \"sac\"\n"),
        ],
    );
    let (a, b, c) = (dir.join("a.toml"), dir.join("b.toml"), dir.join("c.toml"));
    let e = RunConfig::load(&a).unwrap_err().to_string();
    let cycle = format!("{} -> {} -> {}", b.display(), c.display(), b.display());
    assert_eq!(
        e,
        format!("{}: extends makes a cycle: {cycle}", b.display())
    );
    let e = RunConfig::load(&dir.join("self.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("extends makes a cycle"), "{e}");
}

/// A bad key or value names the file of the chain that writes it and its line there.
#[test]
fn an_error_in_a_chain_names_the_file_that_writes_the_key() {
    let dir = chain(
        "extends-errors",
        &[
            (
                "base.toml",
                "algo = \"sac\"\n\n[sac.off_policy]\ntau = 2.0\n",
            ),
            (
                "leaf.toml",
                "extends = \"base.toml\"\n[protocol]\nepochs = 2\n",
            ),
            (
                "fixed.toml",
                "extends = \"base.toml\"\n[sac.off_policy]\ntau = 0.5\n",
            ),
            (
                "bad.toml",
                "extends = \"fixed.toml\"\n[protocol]\n\nepochs = 0\n",
            ),
            (
                "unknown.toml",
                "algo = \"sac\"\n[sac.net]\n\nhiden = [64]\n",
            ),
            (
                "typo.toml",
                "extends = \"unknown.toml\"\n[protocol]\nepochs = 2\n",
            ),
            ("broken.toml", "extends = \"fixed.toml\"\n[protocol\n"),
            ("number.toml", "extends = 3\nalgo = \"sac\"\n"),
            (
                "drill.toml",
                "algo = \"sac\"\n[[drills]]\nshare = 0.5\nspread = 1.0\n",
            ),
            ("drill_leaf.toml", "extends = \"drill.toml\"\n"),
        ],
    );
    let load = |name: &str| RunConfig::load(&dir.join(name)).map(|_| ());
    let shown = |name: &str| dir.join(name).display().to_string();
    // The base's bad value, reached from a file that does not override it.
    let e = load("leaf.toml").unwrap_err().to_string();
    assert_eq!(
        e,
        format!(
            "{}:4: sac.off_policy.tau: must be in (0, 1]",
            shown("base.toml")
        )
    );
    // Overridden further down the chain: fine; the leaf's own bad value names the leaf.
    load("fixed.toml").unwrap();
    let e = load("bad.toml").unwrap_err().to_string();
    assert_eq!(
        e,
        format!("{}:4: protocol.epochs: must be positive", shown("bad.toml"))
    );
    let e = RunConfig::load(&dir.join("typo.toml")).unwrap_err();
    assert!(matches!(e, ConfigFileError::Parse { .. }), "{e}");
    let e = e.to_string();
    assert!(
        e.starts_with(&format!("{}:4: sac.net.hiden: ", shown("unknown.toml"))),
        "{e}"
    );
    // A file that is not TOML says so with its own line, as without `extends`.
    let e = load("broken.toml").unwrap_err().to_string();
    assert!(e.starts_with(&format!("{}:2", shown("broken.toml"))), "{e}");
    let e = load("number.toml").unwrap_err().to_string();
    assert!(e.contains("extends: must be a string"), "{e}");
    // A key of an array of tables (`[[drills]]`) is found in the file that writes it.
    let e = load("drill_leaf.toml").unwrap_err().to_string();
    assert!(
        e.starts_with(&format!("{}:", shown("drill.toml"))) && e.contains("drills.spread"),
        "{e}"
    );
}

/// The study's configs are bases plus their differences: three in four extend another
/// file; the paper's three are the roots.
#[test]
fn the_shipped_configs_are_written_as_bases_and_differences() {
    let files = crate::common::files_under(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("configs"),
        "toml",
        &[],
    );
    let extending = files
        .iter()
        .filter(|f| {
            std::fs::read_to_string(f)
                .unwrap()
                .lines()
                .any(|l| l.starts_with("extends = "))
        })
        .count();
    assert!(
        extending * 4 >= files.len() * 3,
        "{extending} of {} configs extend a base",
        files.len()
    );
    for algo in [Algo::Ppo, Algo::Sac, Algo::Td3] {
        let text = std::fs::read_to_string(config_path(algo)).unwrap();
        assert!(!text.contains("extends"), "configs/{algo}.toml is a root");
    }
}
