//! Mapping of errors to the documented exit codes.

pub const OK: i32 = 0;
pub const FOUND_PROBLEMS: i32 = 1;
pub const USAGE: i32 = cook::EXIT_USAGE;
pub const INVALID_INPUT: i32 = cook::EXIT_INVALID_INPUT;
pub const IO: i32 = cook::EXIT_IO;

/// A subcommand's outcome: `Ok(code)` for a run that completed (0 or 1), `Err` for a failure.
pub type Outcome = anyhow::Result<i32>;

/// Marks an error as bad usage (exit 2) rather than bad input.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// Exit code for an error: I/O errors of the operating system are 4, usage errors 2, and
/// everything else (malformed files, invalid packs) is invalid input, 3.
pub fn code_for(e: &anyhow::Error) -> i32 {
    for cause in e.chain() {
        if cause.downcast_ref::<UsageError>().is_some() {
            return USAGE;
        }
        // The remote cache failed where it had to answer: an I/O failure, not bad input.
        if cause
            .downcast_ref::<crate::cache_cmd::RemoteFailure>()
            .is_some()
        {
            return IO;
        }
        if let Some(code) = cook::exit_code(cause) {
            return code;
        }
    }
    INVALID_INPUT
}

pub fn report(result: Outcome) -> i32 {
    match result {
        Ok(code) => code,
        Err(e) => {
            use std::io::Write;
            // The failure's own code, even where stderr cannot take its message.
            let _ = writeln!(std::io::stderr(), "error: {e:#}");
            code_for(&e)
        }
    }
}
