//! The run configuration: one TOML file (`configs/<algo>.toml`) holding the protocol, the
//! environment and the algorithm's settings. Unknown keys and invalid values are refused
//! with the file, the line and the dotted key.

use foosball_algos::{PpoConfig, SacConfig, Td3Config};
use foosball_env::{ConfigError, FoosballConfig};
use foosball_nets::Backend;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::{Path, PathBuf};

/// Which algorithm a run trains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Algo {
    /// Proximal Policy Optimization.
    Ppo,
    /// Soft Actor-Critic.
    Sac,
    /// Twin Delayed DDPG.
    Td3,
}

impl Algo {
    /// Lower-case name, as in file names and TOML.
    pub fn name(self) -> &'static str {
        match self {
            Algo::Ppo => "ppo",
            Algo::Sac => "sac",
            Algo::Td3 => "td3",
        }
    }
}

impl fmt::Display for Algo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The training and testing protocol (the paper's by default).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Protocol {
    /// Run seed; every random stream derives from it.
    pub seed: u64,
    /// Epochs (a checkpoint is written at the end of each).
    pub epochs: u32,
    /// Env steps per epoch, counted over all rollout workers.
    pub steps_per_epoch: u64,
    /// Env steps between evaluations.
    pub eval_every: u64,
    /// Deterministic episodes per evaluation, on held-out seeds.
    pub eval_episodes: u32,
    /// Deterministic episodes of the final test, on seeds held out from both.
    pub test_episodes: u32,
    /// Rollout workers (environments stepped together).
    pub envs: usize,
    /// Rayon threads for env workers and the backend; 0 means one per core.
    pub threads: usize,
    /// Network backend; the default CPU backend when absent.
    pub backend: Option<Backend>,
}

impl Protocol {
    /// Env steps of the whole run: `epochs * steps_per_epoch`.
    pub fn total_env_steps(&self) -> u64 {
        u64::from(self.epochs) * self.steps_per_epoch
    }
}

impl Default for Protocol {
    fn default() -> Self {
        Self {
            seed: 0,
            epochs: 15,
            steps_per_epoch: 100_000,
            eval_every: 3_000,
            eval_episodes: 10,
            test_episodes: 1_000,
            envs: 1,
            threads: 0,
            backend: None,
        }
    }
}

/// A whole run's settings: `algo`, `[protocol]`, `[env]` and the algorithm's section.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// The algorithm to train.
    pub algo: Algo,
    /// Epochs, evaluation, test, workers, seed.
    #[serde(default)]
    pub protocol: Protocol,
    /// The foosball environment.
    #[serde(default)]
    pub env: FoosballConfig,
    /// PPO's settings (only with `algo = "ppo"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ppo: Option<PpoConfig>,
    /// SAC's settings (only with `algo = "sac"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sac: Option<SacConfig>,
    /// TD3's settings (only with `algo = "td3"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub td3: Option<Td3Config>,
}

/// Command-line overrides of a run configuration (`None`: keep the file's value).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overrides {
    /// `protocol.seed`.
    pub seed: Option<u64>,
    /// `protocol.epochs`.
    pub epochs: Option<u32>,
    /// `protocol.steps_per_epoch`.
    pub steps_per_epoch: Option<u64>,
    /// `protocol.envs`.
    pub envs: Option<usize>,
    /// `protocol.threads`.
    pub threads: Option<usize>,
    /// `<algo>.net.hidden`.
    pub hidden: Option<Vec<usize>>,
    /// `env`, replaced whole (e.g. by a preset's values).
    pub env: Option<FoosballConfig>,
}

/// A configuration that could not be used; `Display` names the file, line and key.
#[derive(Debug, thiserror::Error)]
pub enum ConfigFileError {
    /// A run directory without its `config.toml`.
    #[error("{dir}: not a run directory (no config.toml)")]
    NotARun {
        /// The directory.
        dir: PathBuf,
    },
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The file is not valid TOML or does not fit the schema (unknown key, wrong type).
    #[error("{path}:{line}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line of the offending text.
        line: usize,
        /// The parser's message.
        message: String,
    },
    /// A value is out of its range.
    #[error("{path}:{line}: {key}: {message}", line = line.map_or("?".into(), |l| l.to_string()))]
    Invalid {
        /// The file.
        path: PathBuf,
        /// 1-based line of the key, where it is written in the file.
        line: Option<usize>,
        /// Dotted key.
        key: String,
        /// What is wrong.
        message: String,
    },
}

impl RunConfig {
    /// Reads and checks a TOML file.
    pub fn load(path: &Path) -> Result<Self, ConfigFileError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigFileError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_toml(&text, path)
    }

    /// Reads `path`, checks it trains `algo` (when given), applies `overrides` and checks
    /// the result; the error names the file and the key.
    pub fn load_with(
        path: &Path,
        algo: Option<Algo>,
        overrides: &Overrides,
    ) -> Result<Self, String> {
        let mut c = Self::load(path).map_err(|e| e.to_string())?;
        if let Some(algo) = algo
            && algo != c.algo
        {
            return Err(format!(
                "--algo {algo} but {} has algo = \"{}\"",
                path.display(),
                c.algo
            ));
        }
        let (o, p) = (overrides, &mut c.protocol);
        p.seed = o.seed.unwrap_or(p.seed);
        p.epochs = o.epochs.unwrap_or(p.epochs);
        p.steps_per_epoch = o.steps_per_epoch.unwrap_or(p.steps_per_epoch);
        p.envs = o.envs.unwrap_or(p.envs);
        p.threads = o.threads.unwrap_or(p.threads);
        if let Some(hidden) = &o.hidden {
            c.set_hidden(hidden.clone());
        }
        if let Some(env) = &o.env {
            c.env = env.clone();
        }
        c.validate().map_err(|e| {
            format!(
                "{} (after command-line overrides): {}: {}",
                path.display(),
                e.key,
                e.message
            )
        })?;
        Ok(c)
    }

    /// The saved configuration of the run in `dir` (its `config.toml`).
    pub fn load_run(dir: &Path) -> Result<Self, ConfigFileError> {
        let path = dir.join("config.toml");
        if !path.is_file() {
            return Err(ConfigFileError::NotARun {
                dir: dir.to_path_buf(),
            });
        }
        Self::load(&path)
    }

    /// Parses and checks TOML `text`; `path` names it in errors.
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, ConfigFileError> {
        let mut config: RunConfig = toml::from_str(text).map_err(|e| ConfigFileError::Parse {
            path: path.to_path_buf(),
            line: e.span().map_or(1, |s| line_at(text, s.start)),
            message: e.message().trim().to_string(),
        })?;
        config.fill_algo_section();
        config.validate().map_err(|e| ConfigFileError::Invalid {
            path: path.to_path_buf(),
            line: line_of_key(text, &e.key),
            key: e.key,
            message: e.message,
        })?;
        Ok(config)
    }

    /// The effective configuration as TOML (what a run saves as `config.toml`), arrays on
    /// one line.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a run config always serialises")
    }

    fn fill_algo_section(&mut self) {
        match self.algo {
            Algo::Ppo => self.ppo = Some(self.ppo.take().unwrap_or_default()),
            Algo::Sac => self.sac = Some(self.sac.take().unwrap_or_default()),
            Algo::Td3 => self.td3 = Some(self.td3.take().unwrap_or_default()),
        }
    }

    /// Rejects out-of-range values and sections of another algorithm.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let p = &self.protocol;
        let positive = |ok: bool, key: &str| {
            if ok {
                Ok(())
            } else {
                Err(ConfigError::new(
                    format!("protocol.{key}"),
                    "must be positive",
                ))
            }
        };
        positive(p.epochs > 0, "epochs")?;
        positive(p.steps_per_epoch > 0, "steps_per_epoch")?;
        positive(p.eval_every > 0, "eval_every")?;
        positive(p.eval_episodes > 0, "eval_episodes")?;
        positive(p.test_episodes > 0, "test_episodes")?;
        positive(p.envs > 0, "envs")?;
        if let Some(b) = p.backend
            && !b.is_compiled()
        {
            return Err(ConfigError::new(
                "protocol.backend",
                format!("`{b}` is not compiled in: rebuild with `--features foosball-nets/{b}`"),
            ));
        }
        self.env.validate().map_err(|e| e.under("env"))?;
        for (name, present) in [
            ("ppo", self.ppo.is_some()),
            ("sac", self.sac.is_some()),
            ("td3", self.td3.is_some()),
        ] {
            if present && name != self.algo.name() {
                return Err(ConfigError::new(
                    name,
                    format!("section for another algorithm (algo = \"{}\")", self.algo),
                ));
            }
        }
        match self.algo {
            Algo::Ppo => self
                .ppo
                .as_ref()
                .map_or(Ok(()), |c| c.validate().map_err(|e| e.under("ppo"))),
            Algo::Sac => self
                .sac
                .as_ref()
                .map_or(Ok(()), |c| c.validate().map_err(|e| e.under("sac"))),
            Algo::Td3 => self
                .td3
                .as_ref()
                .map_or(Ok(()), |c| c.validate().map_err(|e| e.under("td3"))),
        }
    }

    /// The hidden widths of the algorithm's networks.
    pub fn hidden(&self) -> &[usize] {
        match self.algo {
            Algo::Ppo => &self.ppo.as_ref().expect("filled").net.hidden,
            Algo::Sac => &self.sac.as_ref().expect("filled").net.hidden,
            Algo::Td3 => &self.td3.as_ref().expect("filled").net.hidden,
        }
    }

    /// Sets the hidden widths of the algorithm's networks.
    pub fn set_hidden(&mut self, hidden: Vec<usize>) {
        match self.algo {
            Algo::Ppo => self.ppo.as_mut().expect("filled").net.hidden = hidden,
            Algo::Sac => self.sac.as_mut().expect("filled").net.hidden = hidden,
            Algo::Td3 => self.td3.as_mut().expect("filled").net.hidden = hidden,
        }
    }
}

/// 1-based line of byte offset `at`.
fn line_at(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}

/// 1-based line where the dotted `key` is written (or its deepest written parent).
fn line_of_key(text: &str, key: &str) -> Option<usize> {
    let doc = toml::de::DeTable::parse(text).ok()?;
    let mut table = doc.get_ref();
    let mut line = None;
    for part in key.split('.') {
        let Some((k, v)) = table.iter().find(|(k, _)| k.get_ref().as_ref() == part) else {
            break;
        };
        line = Some(line_at(text, k.span().start));
        match v.get_ref() {
            toml::de::DeValue::Table(t) => table = t,
            _ => break,
        }
    }
    line
}
