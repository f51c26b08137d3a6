//! An X server of a test's own (Xvfb), for the tests that open a window:
//! `tests/viewer.rs` here and the Bevy plugin's `bevy/tests/cape.rs`,
//! which includes this file by path.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};

/// The X server's screen: larger than the tests' windows (at most
/// 800 × 600), so nothing clips them.
const SCREEN: &str = "1024x768x24";

/// An X server on a display it chose free; killed when dropped.
pub struct Xvfb {
    child: Child,
    /// The display, `:N`, for `DISPLAY`.
    pub display: String,
}

impl Xvfb {
    /// Starts the server and waits until it accepts connections; what
    /// failed where it cannot (`test` names the test that needs it).
    pub fn start(test: &str) -> Result<Xvfb, String> {
        // `-displayfd 1`: the server picks a free display and writes its
        // number to our pipe once it accepts connections.
        let mut child = Command::new("Xvfb")
            .args([
                "-displayfd",
                "1",
                "-screen",
                "0",
                SCREEN,
                "-nolisten",
                "tcp",
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| {
                format!(
                    "cannot start Xvfb ({e}): the {test} test needs an X server; \
                     install the `xvfb` package (apt-get install xvfb)"
                )
            })?;
        let mut line = String::new();
        let read = child
            .stdout
            .take()
            .map(|out| BufReader::new(out).read_line(&mut line));
        let number = line.trim();
        if !matches!(read, Some(Ok(n)) if n > 0) || number.parse::<u32>().is_err() {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!(
                "Xvfb started but reported no display number (read {read:?}: `{number}`)"
            ));
        }
        Ok(Xvfb {
            display: format!(":{number}"),
            child,
        })
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
