//! The built-in `flag` scene (a vertical cloth held along one edge, in the
//! wind) to PNG frames in `out/flag/`, through the library API.
//!
//! `cargo run --release --example flag`

mod common;

fn main() -> anyhow::Result<()> {
    // Before any thread exists: quiets Mesa's complaint about an unset
    // XDG_RUNTIME_DIR (Linux hosts).
    wgcloth::gpu::quiet_mesa();
    common::render_builtin("flag", 3.0)
}
