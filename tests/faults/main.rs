//! The fault-injection suite: the `wgcloth` binary and the library driven
//! the way a hostile user or a failing machine would drive them. One module
//! per class of fault; each row asserts the exit status, the message and
//! what is on disk afterwards.

#[path = "../cli_common/mod.rs"]
mod cli_common;
mod divergence;
#[path = "../gpu_common/mod.rs"]
mod gpu_common;
mod memory_device;
mod messages;
mod moving_bodies;
mod outputs;
