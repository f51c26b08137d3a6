//! The `wgcloth` command-line tool: run a scene, print a summary, write the
//! final positions and a per-step trace. See `docs/cli.md`.

mod cli;

fn main() -> std::process::ExitCode {
    quiet_mesa();
    cli::main()
}

/// Mesa's Vulkan drivers print `error: XDG_RUNTIME_DIR is invalid or not
/// set in the environment` when that variable is unset or not an absolute
/// path, which a user of a command-line tool cannot act on. When it is
/// unusable, this points it at a private directory of the temporary
/// folder (`wgcloth-runtime-UID`, mode 0700, owned by this user); nothing
/// is ever written there by wgcloth. Runs first thing in `main`, before
/// any thread exists, so changing the environment races with nothing. The
/// library never touches the environment: that is the binary's business.
fn quiet_mesa() {
    let usable = std::env::var_os("XDG_RUNTIME_DIR")
        .map(std::path::PathBuf::from)
        .is_some_and(|dir| dir.is_absolute() && dir.is_dir());
    if usable {
        return;
    }
    if let Some(dir) = private_runtime_dir() {
        std::env::set_var("XDG_RUNTIME_DIR", dir);
    }
}

/// `$TMPDIR/wgcloth-runtime-UID`, created if missing; `None` unless it is
/// a real directory (not a link) owned by this user and closed to others.
#[cfg(unix)]
fn private_runtime_dir() -> Option<std::path::PathBuf> {
    use std::os::unix::fs::{DirBuilderExt as _, MetadataExt as _};
    // The owner of /proc/self is this process's user (Linux; where there
    // is no /proc the variable is left as it is).
    let uid = std::fs::metadata("/proc/self").ok()?.uid();
    let dir = std::env::temp_dir().join(format!("wgcloth-runtime-{uid}"));
    let _ = std::fs::DirBuilder::new().mode(0o700).create(&dir);
    let meta = std::fs::symlink_metadata(&dir).ok()?;
    (meta.is_dir() && meta.uid() == uid && meta.mode() & 0o077 == 0).then_some(dir)
}

#[cfg(not(unix))]
fn private_runtime_dir() -> Option<std::path::PathBuf> {
    None
}
