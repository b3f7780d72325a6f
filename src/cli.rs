//! What the command-line tools share: how they end.

use std::process::ExitCode;

/// Prints `result`'s text and exits 0, or prints `error: <message>` on stderr and exits 2.
pub fn finish(result: Result<String, String>) -> ExitCode {
    match result {
        Ok(text) => {
            println!("{text}");
            ExitCode::SUCCESS
        }
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}
