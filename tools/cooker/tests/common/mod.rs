//! Helpers shared by the cooker's integration tests.

// Each test crate compiles this module and uses a different subset of it.
#![allow(dead_code)]

use std::ffi::OsStr;
use std::process::{Command, Output};

/// A command running the `cooker` binary this package builds.
pub fn command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_cooker"))
}

/// Runs the cooker with `args` and waits for it.
pub fn cooker(args: &[&dyn AsRef<OsStr>]) -> Output {
    let mut c = command();
    for a in args {
        c.arg(a);
    }
    c.output().expect("cooker runs")
}

/// Panics when a line of `msg` says the same thing twice: after the `error:`/`warning:` label,
/// no `": "`-separated part may contain another. That is how an error that prints its cause
/// and also returns it as its `source` shows up in a printed chain
/// (`x.pack: No such file…: No such file…`, `writing x.pack: x.pack: …`).
pub fn assert_said_once(msg: &str) {
    for line in msg.lines() {
        let parts: Vec<&str> = line
            .split(": ")
            .skip_while(|p| matches!(*p, "error" | "warning" | "note"))
            .map(str::trim)
            .filter(|p| p.len() >= 4)
            .collect();
        for (i, a) in parts.iter().enumerate() {
            for (j, b) in parts.iter().enumerate() {
                assert!(
                    i == j || !a.contains(b),
                    "repeated {b:?} in the message line {line:?}"
                );
            }
        }
    }
}
