//! The built-in `drape` scene (a free cloth falling onto a ball on the
//! ground) to PNG frames in `out/drape/`, through the library API.
//!
//! `cargo run --release --example drape`

mod common;

fn main() -> anyhow::Result<()> {
    common::render_builtin("drape", 2.0)
}
