//! The process environment Mesa's Vulkan drivers expect, for hosts on
//! Linux: [`quiet_mesa`].

use std::path::PathBuf;

/// Points `XDG_RUNTIME_DIR` at a private directory when it is unusable, so
/// that Mesa's Vulkan drivers (lavapipe among them) do not print `error:
/// XDG_RUNTIME_DIR is invalid or not set in the environment` — a message
/// the user of a program that draws nothing on screen cannot act on.
///
/// For hosts on Linux (elsewhere it does nothing): call it first thing in
/// `main`, before any thread exists and before the first adapter is
/// opened, as the `wgcloth` binary and the examples do. Changing the
/// environment while another thread reads it is undefined behaviour in C,
/// which is why the library never calls this itself: the environment is
/// the host's business.
///
/// A usable value (an absolute path to a directory) is left alone. Else
/// the variable is set to `TMPDIR/wgcloth-runtime-UID` (mode 0700, owned
/// by this user, created if missing); nothing is ever written there by
/// wgcloth. Where that directory cannot be made private the variable is
/// left as it was.
pub fn quiet_mesa() {
    let usable = std::env::var_os("XDG_RUNTIME_DIR")
        .map(PathBuf::from)
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
#[cfg(target_os = "linux")]
fn private_runtime_dir() -> Option<PathBuf> {
    use std::os::unix::fs::{DirBuilderExt as _, MetadataExt as _};
    // The owner of /proc/self is this process's user.
    let uid = std::fs::metadata("/proc/self").ok()?.uid();
    let dir = std::env::temp_dir().join(format!("wgcloth-runtime-{uid}"));
    let _ = std::fs::DirBuilder::new().mode(0o700).create(&dir);
    let meta = std::fs::symlink_metadata(&dir).ok()?;
    (meta.is_dir() && meta.uid() == uid && meta.mode() & 0o077 == 0).then_some(dir)
}

#[cfg(not(target_os = "linux"))]
fn private_runtime_dir() -> Option<PathBuf> {
    None
}
