//! The built-in `drape` scene (a free cloth falling onto a ball on the
//! ground) to PNG frames in `out/drape/`, through the library API.
//!
//! `cargo run --release --example drape`

mod common;

fn main() -> anyhow::Result<()> {
    // Before any thread exists: quiets Mesa's complaint about an unset
    // XDG_RUNTIME_DIR (Linux hosts).
    wgcloth::gpu::quiet_mesa();
    common::render_builtin("drape", 2.0)
}
