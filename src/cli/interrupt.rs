//! Ctrl-C and SIGTERM: the first asks the running command to stop at its
//! next check (between batches of steps, between frames), so that it drops
//! its temporaries and leaves only whole files; a second one exits at once.

use std::sync::atomic::{AtomicBool, Ordering};

use super::EXIT_INTERRUPTED;

/// Set by the first Ctrl-C or SIGTERM.
static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Installs the handler. Where that fails, the signals keep their default
/// action (the process ends, possibly leaving a temporary, which never
/// blocks a later run), so the command runs on.
pub fn install() {
    let installed = ctrlc::set_handler(|| {
        if REQUESTED.swap(true, Ordering::SeqCst) {
            std::process::exit(EXIT_INTERRUPTED.into());
        }
        note!("\ninterrupted: stopping and removing temporaries (again to stop at once)");
    });
    if let Err(e) = installed {
        note!("warning: Ctrl-C will end wgcloth at once: {e}");
    }
}

/// Whether a stop was asked for.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}

/// [`wgcloth::Error::Interrupted`] once a stop was asked for.
pub fn check() -> wgcloth::Result<()> {
    if requested() {
        Err(wgcloth::Error::Interrupted)
    } else {
        Ok(())
    }
}
