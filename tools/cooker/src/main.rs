//! `cooker`: cooks scenes into packs, validates material tagging, inspects, diffs and extracts.
//!
//! Exit codes (every subcommand): 0 success; 1 the command ran and found problems; 2 bad usage;
//! 3 invalid input (a malformed source file or pack); 4 an operating-system I/O error.
//! A panic (101) is a bug.

mod alloc;
mod cache_cmd;
mod cook;
mod diff;
mod exit;
mod extract;
mod info;
mod init;
mod remote;
mod scene_cache;
mod size;
mod transcript;
mod validate;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "cooker",
    version,
    about = "Stained-glass asset cooker",
    after_help = EXIT_CODES
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// The exit codes, in `--help` of the cooker and of every subcommand (scripts gate on them).
const EXIT_CODES: &str = "Exit codes: 0 success, 1 problems found (validation findings, a diff over \
its thresholds), 2 bad usage, 3 invalid input (the message names the file and the line or \
offset), 4 operating-system I/O error.";

#[derive(Subcommand)]
enum Command {
    /// Print what a pack holds: sections, materials, textures.
    #[command(after_help = EXIT_CODES)]
    Info(info::Args),
    /// Cook a scene (or a bare OBJ/glTF file) into a pack.
    #[command(after_help = EXIT_CODES)]
    Cook(cook::Args),
    /// Write a starter scene.toml for a model: rules, windows, sun and cameras it guesses.
    #[command(after_help = EXIT_CODES)]
    Init(init::Args),
    /// Check material tagging and window geometry of a scene or a pack.
    #[command(after_help = EXIT_CODES)]
    Validate(validate::Args),
    /// Compare two packs: per section, geometry, and per texture level error.
    #[command(after_help = EXIT_CODES)]
    Diff(diff::Args),
    /// Write one cooked texture level as an 8-bit PNG (its texels as stored; a block-compressed
    /// level decoded).
    #[command(after_help = EXIT_CODES)]
    Extract(extract::Args),
    /// Inspect the cook cache: stats, verify, explain why a scene would be cooked.
    #[command(after_help = EXIT_CODES)]
    Cache(cache_cmd::Args),
}

/// Options that clap may fill from the environment, with the variable each reads.
const FROM_ENV: [(&str, &str); 1] = [("--cache-max-size", "STAINED_GLASS_CACHE_MAX_SIZE")];

/// Clap reports a bad value read from an environment variable as if the flag had been given
/// ("invalid value 'abc' for '--cache-max-size <SIZE>'"), which sends the user looking at a
/// command line that does not have it. Where the flag is absent, name the variable instead.
fn blame_environment(
    e: &clap::Error,
    args: impl Iterator<Item = std::ffi::OsString>,
) -> Option<String> {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    if !matches!(
        e.kind(),
        ErrorKind::ValueValidation | ErrorKind::InvalidValue
    ) {
        return None;
    }
    let Some(ContextValue::String(arg)) = e.get(ContextKind::InvalidArg) else {
        return None;
    };
    let (flag, var) = FROM_ENV
        .iter()
        .find(|(f, _)| arg.split(' ').next() == Some(*f))?;
    let args: Vec<_> = args.collect();
    let given = args.iter().any(|a| {
        let a = a.to_string_lossy();
        a == *flag || a.starts_with(&format!("{flag}="))
    });
    if given {
        return None;
    }
    let value = std::env::var_os(var)?;
    let why = std::error::Error::source(e).map_or_else(String::new, |s| format!(": {s}"));
    Some(format!(
        "error: invalid value '{}' in ${var} (read as {flag}){why}",
        value.to_string_lossy()
    ))
}

/// Rust ignores SIGPIPE, so a closed stdout (`cooker info p.pack | head`) made the next
/// `println!` panic; like other Unix tools, stop quietly instead.
fn default_sigpipe() {
    // SAFETY: called first thing in main, before any other thread exists; SIG_DFL is a valid
    // disposition for SIGPIPE.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

fn main() {
    alloc::tune();
    default_sigpipe();
    ::cook::cli::exit_on_failed_output();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let code = if e.use_stderr() {
                exit::USAGE
            } else {
                exit::OK
            };
            if let Some(msg) = blame_environment(&e, std::env::args_os().skip(1)) {
                use std::io::Write;
                let _ = writeln!(std::io::stderr(), "{msg}");
                std::process::exit(code);
            }
            // `--help` into a full disk did not print what was asked; a usage error keeps its
            // code whether or not its message could be printed.
            let printed = e.print().is_ok();
            std::process::exit(if printed || e.use_stderr() {
                code
            } else {
                exit::IO
            });
        }
    };
    let result = match cli.command {
        Command::Info(args) => info::run(args),
        Command::Cook(args) => cook::run(args),
        Command::Init(args) => init::run(args),
        Command::Validate(args) => validate::run(args),
        Command::Diff(args) => diff::run(args),
        Command::Extract(args) => extract::run(args),
        Command::Cache(args) => cache_cmd::run(args),
    };
    std::process::exit(exit::report(result));
}
