//! The fault-injection suite: the `wgcloth` binary and the library driven
//! the way a hostile user or a failing machine would drive them. One module
//! per class of fault; each row asserts the exit status, the message and
//! what is on disk afterwards.

mod character;
#[path = "../cli_common/mod.rs"]
mod cli_common;
mod divergence;
#[path = "../gpu_common/mod.rs"]
mod gpu_common;
mod inputs;
mod memory_device;
mod messages;
mod moving_bodies;
mod outputs;

use std::process::Output;

/// What is wrong with a run that should have been refused as invalid
/// input (exit status 2): a wrong status, a message that lacks one of
/// `expect` or has one of `absent` (or a panic), anything on stdout, and
/// a directory listing that changed from `before` to `after`. Empty when
/// the refusal is right.
fn refusal_faults(
    out: &Output,
    expect: &[&str],
    absent: &[&str],
    before: &[String],
    after: &[String],
) -> Vec<String> {
    let err = cli_common::stderr(out);
    let mut wrong = Vec::new();
    if out.status.code() != Some(cli_common::EXIT_INVALID) {
        wrong.push(format!("exit status {:?}", out.status.code()));
    }
    let lacks: Vec<&str> = expect
        .iter()
        .copied()
        .filter(|s| !err.contains(s))
        .collect();
    if !lacks.is_empty() {
        wrong.push(format!("lacks {lacks:?}"));
    }
    let has: Vec<&str> = absent
        .iter()
        .chain(&["panicked"])
        .copied()
        .filter(|s| err.contains(s))
        .collect();
    if !has.is_empty() {
        wrong.push(format!("has {has:?}"));
    }
    if !cli_common::stdout(out).is_empty() {
        wrong.push(format!("printed {}", cli_common::stdout(out)));
    }
    if after != before {
        wrong.push(format!("left {after:?} (before: {before:?})"));
    }
    wrong
}
