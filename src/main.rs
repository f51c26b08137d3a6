//! The `wgcloth` command-line tool: run a scene, print a summary, write the
//! final positions and a per-step trace. See `docs/cli.md`.

mod cli;

fn main() -> std::process::ExitCode {
    // Before any thread exists (see its docs).
    wgcloth::gpu::quiet_mesa();
    cli::main()
}
