//! A policy in another program, spoken to in `act`'s line protocol: each observation is
//! one line of `obs_dim` numbers written to its stdin, each answer one line of
//! `action_dim` numbers read from its stdout, in order, separated by spaces or commas.
//! Numbers are written as Rust prints an `f32` (the shortest text that reads back to the
//! same bits), so a program that parses them as floats sees the table's exact values.
//! The program's stderr is passed through. A Python policy enters a test or a league so,
//! without an export (docs/league.md, "Entering an agent").

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::Duration;

/// How long an answer may take by default (the first one included: a Python program
/// importing torch takes a few seconds) before the program counts as stalled.
pub const ANSWER_LIMIT: Duration = Duration::from_secs(30);

/// `count` numbers from a protocol `line`, each finite; `what` names the line in errors
/// (`line 3`, `answer 12 of process ...`).
pub fn parse_values(line: &str, count: usize, what: &str) -> Result<Vec<f32>, String> {
    let values: Vec<&str> = line
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .collect();
    if values.len() != count {
        return Err(format!("{what}: {} values, expected {count}", values.len()));
    }
    values
        .iter()
        .enumerate()
        .map(|(i, text)| {
            text.parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("{what}: value {i} is not a finite number: `{text}`"))
        })
        .collect()
}

/// `values` as one protocol line (no newline).
pub fn format_values(values: &[f32]) -> String {
    let text: Vec<String> = values.iter().map(f32::to_string).collect();
    text.join(" ")
}

/// A running program that answers observations with actions.
pub struct ProcessPolicy {
    command: String,
    child: Child,
    stdin: ChildStdin,
    answers: Receiver<std::io::Result<String>>,
    obs_dim: usize,
    action_dim: usize,
    limit: Duration,
    answered: usize,
}

impl ProcessPolicy {
    /// Starts `command` with `sh -c`, to answer `[n, obs_dim]` observations with
    /// `[n, action_dim]` actions, each answer within `limit`; an error names it.
    pub fn start(
        command: &str,
        (obs_dim, action_dim): (usize, usize),
        limit: Duration,
    ) -> Result<Self, String> {
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(command)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| format!("process `{command}`: cannot start it: {e}"))?;
        let stdin = child.stdin.take().expect("stdin piped");
        let stdout = child.stdout.take().expect("stdout piped");
        let (send, answers) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                if send.send(line).is_err() {
                    break;
                }
            }
        });
        Ok(Self {
            command: command.to_string(),
            child,
            stdin,
            answers,
            obs_dim,
            action_dim,
            limit,
            answered: 0,
        })
    }

    /// Actions `[n, action_dim]` for observations `[n, obs_dim]`; an error says whether
    /// the program ended (with its exit status), stalled past its time limit, or
    /// answered something else than `action_dim` finite numbers.
    pub fn act(&mut self, obs: &[f32]) -> Result<Vec<f32>, String> {
        let mut text = String::new();
        for row in obs.chunks_exact(self.obs_dim) {
            text += &format_values(row);
            text.push('\n');
        }
        if let Err(e) = self
            .stdin
            .write_all(text.as_bytes())
            .and_then(|()| self.stdin.flush())
        {
            return Err(self.ended(&format!("cannot write to it ({e})")));
        }
        let mut actions = Vec::with_capacity(obs.len() / self.obs_dim * self.action_dim);
        for _ in 0..obs.len() / self.obs_dim {
            self.answered += 1;
            let line = match self.answers.recv_timeout(self.limit) {
                Ok(Ok(line)) => line,
                Ok(Err(e)) => return Err(self.ended(&format!("unreadable stdout ({e})"))),
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(self.ended("it closed its stdout"));
                }
                Err(RecvTimeoutError::Timeout) => {
                    return Err(format!(
                        "process `{}`: no answer to observation {} within {} s",
                        self.command,
                        self.answered,
                        self.limit.as_secs_f64()
                    ));
                }
            };
            let what = format!("process `{}`, answer {}", self.command, self.answered);
            actions.extend(parse_values(&line, self.action_dim, &what)?);
        }
        Ok(actions)
    }

    /// The error of a program that stopped answering: `why`, and its exit status where
    /// it has ended.
    fn ended(&mut self, why: &str) -> String {
        // A program that closed its pipes is usually exiting: give it 0.2 s to say how.
        let mut status = String::new();
        for _ in 0..20 {
            if let Ok(Some(s)) = self.child.try_wait() {
                status = format!(", {s}");
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        format!(
            "process `{}`: {why} after {} answers{status}",
            self.command,
            self.answered.saturating_sub(1)
        )
    }
}

impl Drop for ProcessPolicy {
    /// Stops the program (killed) and reaps it.
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
