//! What the end-to-end CLI tests share: running the binary and asserting success.
#![allow(dead_code)]

use std::process::{Command, Output};

/// Runs the `slothsim` binary with `args`.
pub fn slothsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_slothsim"))
        .args(args)
        .output()
        .expect("run slothsim")
}

/// Asserts the run succeeded (printing its exit code and output otherwise)
/// and returns its stdout.
pub fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "exit {:?}\nstdout:\n{}\nstderr:\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}
