//! The benches' command-line flags: `--name value` pairs (after `cargo bench ... --`).

/// The value after `--name` on the command line, if the flag is given; exits with a
/// message naming the flag when no value follows it.
pub fn flag(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    let i = args.iter().position(|a| a == name)?;
    match args.get(i + 1) {
        Some(value) => Some(value.clone()),
        None => {
            eprintln!("{name} needs a value");
            std::process::exit(2)
        }
    }
}
