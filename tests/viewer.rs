//! The live viewer (`examples/viewer`), headless: on an X server of its
//! own (Xvfb) with the test adapter (lavapipe in CI) it opens its window,
//! runs frames, and saves what its swap chain showed. The pictures must
//! show the cloth where the camera frames it, and a scripted mouse drag
//! must pull the cloth to the cursor. Xvfb missing is a failure naming the
//! package, never a skip.

mod gpu_common;
#[path = "common/xvfb.rs"]
mod xvfb;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use wgcloth::render;
use xvfb::Xvfb;

/// The viewer's window size \[pixels\] (`WINDOW` in `examples/viewer`):
/// the screenshot is the swap chain, so it has the window's size.
const WINDOW: (u32, u32) = (800, 600);
/// A pixel counts as cloth when its red channel exceeds green and blue by
/// more than this: the cloth is red (front) or orange (back), whose
/// palest shades lead by about 30 levels; the grey ground and the
/// blue-grey sky lead by under 10.
const CLOTH_RED_MARGIN: i32 = 20;
/// The least share of the picture the cloth covers: after a second the
/// hanging cloth covers about 3 % of the starting view; a third of that
/// is a cloth drawn, and a picture without it has none.
const MIN_CLOTH_SHARE: f64 = 0.01;
/// The swap chain is `Bgra8UnormSrgb` on lavapipe: its clear colour is
/// the background decoded from sRGB and encoded back, a level of
/// rounding at most.
const SRGB_ROUNDING_LEVELS: i32 = 1;
/// Frames each run: 1 s of simulated time at the viewer's 60 frames/s,
/// enough for the released cloth to fall and swing well away from where
/// it started.
const FRAMES: u32 = 60;
/// Half the side of the square around the drag's end that is searched for
/// cloth \[pixels\]: the grabbed particle lands under the cursor, and the
/// cloth around it fills much of a square this size.
const NEAR_CURSOR: i32 = 20;
/// The least cloth pixels in that square after the drag: a tenth of it.
/// Without the drag the same square is sky (checked).
const MIN_CLOTH_AT_CURSOR: usize = 160;
/// Where the drag ends, from where it starts \[pixels\]: up and to the
/// right, into the sky above the cloth's swing.
const DRAG_BY: (f32, f32) = (220.0, -110.0);

/// The viewer example, built (once per test run) in this test's profile:
/// `cargo test` builds examples only when it runs them all.
fn viewer() -> &'static Path {
    static BUILT: OnceLock<PathBuf> = OnceLock::new();
    BUILT.get_or_init(|| {
        let exe = std::env::current_exe().expect("the test's own path");
        // target/<profile>/deps/viewer-<hash>
        let profile_dir = exe
            .parent()
            .and_then(Path::parent)
            .expect("the test runs from target/<profile>/deps");
        let profile = profile_dir
            .file_name()
            .and_then(|n| n.to_str())
            .expect("a profile directory");
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let mut build = Command::new(cargo);
        build.args(["build", "--example", "viewer"]);
        // Cargo rebuilds every dependency when RUSTC_BOOTSTRAP differs from
        // the build that made them; CI's test runner (.ci/test-times) sets
        // it for this process alone, and it must not reach this build.
        build.env_remove("RUSTC_BOOTSTRAP");
        match profile {
            "debug" => {}
            "release" => {
                build.arg("--release");
            }
            other => {
                build.args(["--profile", other]);
            }
        }
        let status = build.status().expect("running cargo");
        assert!(status.success(), "building the viewer example failed");
        let built = profile_dir.join("examples").join("viewer");
        assert!(
            built.is_file(),
            "cargo built the viewer, but not at {} (a --target build puts it elsewhere)",
            built.display()
        );
        built
    })
}

/// Runs the viewer headless on `hanging` for `frames` frames with `args`,
/// and decodes its screenshot (kept in the temp directory until the test
/// passes).
fn screenshot(test: &str, frames: u32, args: &[&str]) -> Picture {
    let x = Xvfb::start("viewer").unwrap_or_else(|e| panic!("{e}"));
    let dir = std::env::temp_dir().join(format!("wgcloth-viewer-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    let path = dir.join(format!("{test}.png"));
    let out = Command::new(viewer())
        .args(["hanging", "--frames", &frames.to_string(), "--screenshot"])
        .arg(&path)
        .args(args)
        .env("DISPLAY", &x.display)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .expect("running the viewer");
    assert!(
        out.status.success(),
        "the viewer failed ({}):\n{}{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    Picture::decode(&path)
}

/// A decoded screenshot.
struct Picture {
    path: PathBuf,
    width: u32,
    height: u32,
    rgba: Vec<u8>,
}

impl Picture {
    fn decode(path: &Path) -> Picture {
        let (width, height, rgba) = gpu_common::decode_png(path);
        Picture {
            path: path.to_path_buf(),
            width,
            height,
            rgba,
        }
    }

    /// Removes the file, and its folder once empty: the test passed.
    fn passed(self) {
        let _ = std::fs::remove_file(&self.path);
        if let Some(dir) = self.path.parent() {
            let _ = std::fs::remove_dir(dir);
        }
    }

    fn pixel(&self, x: u32, y: u32) -> [u8; 4] {
        let at = ((y * self.width + x) * 4) as usize;
        [
            self.rgba[at],
            self.rgba[at + 1],
            self.rgba[at + 2],
            self.rgba[at + 3],
        ]
    }

    fn is_cloth(&self, x: u32, y: u32) -> bool {
        let c = self.pixel(x, y).map(i32::from);
        c[0] - c[1].max(c[2]) > CLOTH_RED_MARGIN
    }

    /// The cloth's pixels.
    fn cloth(&self) -> Vec<(u32, u32)> {
        (0..self.height)
            .flat_map(|y| (0..self.width).map(move |x| (x, y)))
            .filter(|&(x, y)| self.is_cloth(x, y))
            .collect()
    }

    /// Cloth pixels in the square of half-side `half` around `(x, y)`.
    fn cloth_near(&self, (x, y): (f32, f32), half: i32) -> usize {
        let (cx, cy) = (x.round() as i32, y.round() as i32);
        (cy - half..=cy + half)
            .flat_map(|y| (cx - half..=cx + half).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                (0..self.width as i32).contains(&x) && (0..self.height as i32).contains(&y)
            })
            .filter(|&(x, y)| self.is_cloth(x as u32, y as u32))
            .count()
    }
}

/// The screenshot is the window's picture: its size, the sky in the top
/// corner, and the cloth, a red shape of its expected size in the upper
/// half of the view (it hangs a metre above the ground the camera looks
/// down on).
#[test]
fn the_headless_screenshot_shows_the_cloth() {
    let picture = screenshot("hanging", FRAMES, &[]);
    let shown = picture.path.display();
    assert_eq!((picture.width, picture.height), WINDOW, "{shown}");
    let corner = picture.pixel(0, 0);
    let off = corner
        .iter()
        .zip(render::BACKGROUND)
        .map(|(a, b)| (i32::from(*a) - i32::from(b)).abs())
        .max()
        .unwrap_or(0);
    assert!(
        off <= SRGB_ROUNDING_LEVELS,
        "{shown}: the top-left corner is {corner:?}, not the background {:?}",
        render::BACKGROUND
    );
    let cloth = picture.cloth();
    let share = cloth.len() as f64 / f64::from(picture.width * picture.height);
    eprintln!("cloth covers {:.1} % of the picture", 100.0 * share);
    assert!(
        share >= MIN_CLOTH_SHARE,
        "{shown}: the cloth covers {:.2} % of the picture, less than {:.0} %",
        100.0 * share,
        100.0 * MIN_CLOTH_SHARE
    );
    let low = cloth
        .iter()
        .filter(|(_, y)| *y >= picture.height / 2)
        .count();
    assert_eq!(
        low, 0,
        "{shown}: {low} cloth pixels in the lower half, on the ground"
    );
    picture.passed();
}

/// A drag scripted through the viewer's mouse handling (press on the
/// cloth at its centre, move the cursor into the sky, hold) pulls the
/// cloth there; without it, that spot stays sky.
#[test]
fn a_scripted_drag_pulls_the_cloth_to_the_cursor() {
    // Where the cloth is at the first frame: grab it at its centre.
    let first = screenshot("first-frame", 1, &[]);
    let cloth = first.cloth();
    assert!(!cloth.is_empty(), "{}: no cloth", first.path.display());
    let n = cloth.len() as f32;
    let from = (
        cloth.iter().map(|p| p.0 as f32).sum::<f32>() / n,
        cloth.iter().map(|p| p.1 as f32).sum::<f32>() / n,
    );
    assert!(
        first.is_cloth(from.0.round() as u32, from.1.round() as u32),
        "{}: the cloth's centre {from:?} is not on the cloth",
        first.path.display()
    );
    let to = (from.0 + DRAG_BY.0, from.1 + DRAG_BY.1);
    let left_alone = screenshot("no-drag", FRAMES, &[]);
    let without = left_alone.cloth_near(to, NEAR_CURSOR);
    assert_eq!(
        without,
        0,
        "{}: the cloth reaches {to:?} without a drag",
        left_alone.path.display()
    );
    let drag = format!("{},{}:{},{}", from.0, from.1, to.0, to.1);
    let dragged = screenshot("drag", FRAMES, &["--drag", &drag]);
    let with = dragged.cloth_near(to, NEAR_CURSOR);
    eprintln!("cloth pixels within {NEAR_CURSOR} px of {to:?}: {with} dragged, {without} not");
    assert!(
        with >= MIN_CLOTH_AT_CURSOR,
        "{}: dragged from {from:?} to {to:?}, the cloth covers {with} pixels around the \
         cursor, fewer than {MIN_CLOTH_AT_CURSOR}",
        dragged.path.display()
    );
    for picture in [first, left_alone, dragged] {
        picture.passed();
    }
}

/// Where the swap chain cannot be copied, the screenshot is the same frame
/// drawn again offscreen: the same picture, byte for byte, as the copy of
/// the presented texture (same pipelines, formats and state).
#[test]
fn the_offscreen_screenshot_is_the_presented_picture() {
    let presented = screenshot("presented", FRAMES, &[]);
    let offscreen = screenshot("offscreen", FRAMES, &["--offscreen-screenshot"]);
    assert_eq!(
        (offscreen.width, offscreen.height),
        (presented.width, presented.height)
    );
    let differ = presented
        .rgba
        .chunks(4)
        .zip(offscreen.rgba.chunks(4))
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(
        differ,
        0,
        "{} and {}: {differ} pixels differ",
        presented.path.display(),
        offscreen.path.display()
    );
    assert!(
        !presented.cloth().is_empty(),
        "{}: no cloth, so the comparison shows nothing",
        presented.path.display()
    );
    presented.passed();
    offscreen.passed();
}
