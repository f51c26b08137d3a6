//! The fault-injection suite: the `wgcloth` binary and the library driven
//! the way a hostile user or a failing machine would drive them. One module
//! per class of fault; each row asserts the exit status, the message and
//! what is on disk afterwards.

mod character;
#[path = "../cli_common/mod.rs"]
mod cli_common;
mod divergence;
mod energy;
#[path = "../gpu_common/mod.rs"]
mod gpu_common;
mod inputs;
mod memory_device;
mod messages;
mod moving_bodies;
mod outputs;

use std::process::Output;

/// A unit cube about the origin, its faces quads wound outward: the
/// collider of the rows that bake one.
const CUBE_OBJ: &str = "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5\n\
    v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n\
    f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

/// A 5 × 5 cloth over [`CUBE_OBJ`] (as `cube.obj` beside the scene) baked
/// at `resolution` cells a side without padding: `resolution + 5` lattice
/// points a side. At 240 that is 245³ ≈ 14.7 Mi points (56 MiB of
/// samples), about 8 s of baking on the development machine (2-vCPU
/// shared host); at 16, 21³ points and a few milliseconds.
fn cube_collider_scene(resolution: u32) -> String {
    format!(
        "[cloth]\nresolution = [5, 5]\n\n[[collider]]\nmesh = \"cube.obj\"\n\
         resolution = {resolution}\nthickness = 0.0\n"
    )
}

/// [`cube_collider_scene`]'s resolution of a slow, large bake.
const FINE_BAKE: u32 = 240;

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
