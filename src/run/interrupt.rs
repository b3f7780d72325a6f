//! Stopping a run cleanly on SIGTERM or SIGINT: what SLURM sends a task before it kills
//! it (preemption, `scancel`, the time limit) and what Ctrl-C sends.
//!
//! A command-line tool calls [`install`] once; the training loop then asks
//! [`requested`] after every env step and, when a signal came, stops between two steps:
//! no file is left half written (each is replaced atomically anyway), the run keeps its
//! last epoch-end checkpoint and resumes from it, losing at most the epoch in flight. A
//! second signal ends the process at once. Without [`install`] (a library user) signals
//! keep their default action and [`requested`] stays false.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

static STOP: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// Exit status of a process ended by a second signal (128 + SIGTERM, the shells' convention).
pub const SECOND_SIGNAL_EXIT: i32 = 143;

/// Handles SIGTERM and SIGINT from now on: the first asks the run to stop ([`requested`]),
/// the second exits with [`SECOND_SIGNAL_EXIT`]. Calling it again does nothing.
pub fn install() -> std::io::Result<()> {
    if STOP.get().is_some() {
        return Ok(());
    }
    let flag = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGINT] {
        // Registered first, so it sees the flag before the second registration sets it.
        signal_hook::flag::register_conditional_shutdown(
            signal,
            SECOND_SIGNAL_EXIT,
            Arc::clone(&flag),
        )?;
        signal_hook::flag::register(signal, Arc::clone(&flag))?;
    }
    let _ = STOP.set(flag);
    Ok(())
}

/// Whether a stop signal has come since [`install`].
pub fn requested() -> bool {
    STOP.get().is_some_and(|f| f.load(Ordering::Relaxed))
}
