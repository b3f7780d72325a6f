//! The error of a setting with a value it must not take, named by its dotted key; the
//! table's configuration and the observation's both report through it.

/// A setting with a value it must not take.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid value for `{key}`: {message}")]
pub struct ConfigError {
    /// Dotted path of the setting, e.g. `rules.stagnant_steps`.
    pub key: String,
    /// What is wrong with its value.
    pub message: String,
}

impl ConfigError {
    /// An error for the dotted `key`.
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            key: key.into(),
            message: message.into(),
        }
    }

    /// The same error with `prefix.` put before its key (for a section nested in a
    /// larger configuration).
    pub fn under(self, prefix: &str) -> Self {
        Self::new(format!("{prefix}.{}", self.key), self.message)
    }
}
