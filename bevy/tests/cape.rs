//! The `cape` example on an X server of the test's own (Xvfb) with the
//! test adapter (lavapipe in CI): its screenshots at two frame counts show
//! the cape, drawn through its detailed render mesh (the simulation's own
//! mesh is hidden, so every cape pixel is the render mesh's), and the cape
//! moved between them (the character runs off with it); read back every frame, the cape's pinned particles stay on
//! the character's shoulders as it jogs and turns. Xvfb missing is a
//! failure naming the package, never a skip.

// Shared with the core's viewer test.
#[path = "../../tests/common/xvfb.rs"]
mod xvfb;

use std::io::BufReader;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{bail, Context as _};
use xvfb::Xvfb;

/// The example's window \[pixels\] (`WINDOW` in examples/common).
const WINDOW: (u32, u32) = (640, 480);
/// A pixel is the cape's when its red channel exceeds green and blue by
/// more than this: the cape is deep red (sRGB 0.75, 0.08, 0.06, lit and
/// shaded it stays far redder than anything else); the ground is grey-green
/// and the character grey, within 15 levels of neutral.
const CAPE_RED_MARGIN: i32 = 40;
/// The least cape pixels in a screenshot: the cape 6 m from the camera
/// covers about 1500 pixels of the 640 × 480 window; a tenth of that is a
/// cape drawn, and a picture without it has none.
const MIN_CAPE_PIXELS: usize = 150;
/// Frames of the two screenshots (60 a simulated second): 1/3 s, the
/// character standing while the cape settles; 5/3 s, jogging, 2.1 m
/// further on (each frame is about half a second on lavapipe, shadows and
/// all).
const EARLY: u32 = 20;
const LATE: u32 = 100;
/// How far the cape's centre on the screen must move between them
/// \[pixels\]: it rides about 110 pixels with the character; a cape left
/// at rest (its render mesh never skinned) moves 16, as the character in front
/// of it changes what shows.
const MIN_SHIFT: f32 = 50.0;
/// How far a pinned particle may be from its place on the character \[m\]
/// (`--check-pins`): the pins land on the character's pose at the end of
/// each frame's steps, so the only error is f32 rounding of positions a
/// few metres from the origin (about a micrometre); a pin one frame behind
/// the jogging character is 33 mm off, and the cape once seen left behind
/// was a metre off.
const PIN_TOLERANCE: f32 = 0.001;
/// Frames of a run without a read-back: the cloth is built in the first
/// frame's render, a read-back reaches the main world a frame after its
/// steps, and the last frames' may come after the exit.
const READBACK_SLACK: usize = 3;

/// The cape example, built in this test's profile (`cargo test` builds
/// examples only when it runs every target), at the path cargo names for
/// this build: `target/<profile>/examples/cape` is also the name of the
/// core crate's `cape` example, so a workspace build can leave the other
/// one (or an older build) there.
fn cape_example() -> anyhow::Result<PathBuf> {
    let exe = std::env::current_exe()?;
    // target/<profile>/deps/cape-<hash>
    let profile = exe
        .parent()
        .and_then(Path::parent)
        .and_then(Path::file_name)
        .and_then(|n| n.to_str())
        .context("the test runs from target/<profile>/deps")?;
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut build = Command::new(cargo);
    build.args([
        "build",
        "-p",
        "wgcloth-bevy",
        "--example",
        "cape",
        "--ignore-rust-version",
        "--message-format=json-render-diagnostics",
    ]);
    match profile {
        "debug" => {}
        "release" => {
            build.arg("--release");
        }
        other => {
            build.args(["--profile", other]);
        }
    }
    let out = build
        .stderr(Stdio::inherit())
        .output()
        .context("running cargo")?;
    if !out.status.success() {
        bail!("building the cape example failed");
    }
    let executable = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|line| serde_json::from_str::<serde_json::Value>(line).ok())
        .filter(|m| m["reason"] == "compiler-artifact" && m["target"]["name"] == "cape")
        .find_map(|m| m["executable"].as_str().map(PathBuf::from));
    executable.context("cargo named no cape executable")
}

/// One run of the example: its last frame (RGBA rows) and, for each
/// read-back, the steps the cape had run and its pins' error \[m\].
struct Run {
    rgba: Vec<u8>,
    pins: Vec<(u64, f32)>,
}

/// Runs the example for `frames` frames on `x` with `--check-pins`.
fn run(example: &Path, x: &Xvfb, frames: u32, dir: &Path) -> anyhow::Result<Run> {
    let out = dir.join(format!("cape-{frames}.png"));
    let output = Command::new(example)
        .args([
            "--frames",
            &frames.to_string(),
            "--check-pins",
            "--screenshot",
        ])
        .arg(&out)
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .stderr(Stdio::inherit())
        .output()
        .context("running the cape example")?;
    if !output.status.success() {
        bail!(
            "the cape example failed ({}) for {frames} frames",
            output.status
        );
    }
    let pins = String::from_utf8_lossy(&output.stdout)
        .lines()
        .filter_map(|line| {
            // pins: steps S error E m
            let words: Vec<&str> = line.split_whitespace().collect();
            match words[..] {
                ["pins:", "steps", steps, "error", error, "m"] => {
                    Some((steps.parse().ok()?, error.parse().ok()?))
                }
                _ => None,
            }
        })
        .collect();
    let decoder = png::Decoder::new(BufReader::new(
        std::fs::File::open(&out).with_context(|| format!("reading {}", out.display()))?,
    ));
    let mut reader = decoder.read_info()?;
    let mut rgba = vec![0; reader.output_buffer_size().context("PNG size")?];
    let info = reader.next_frame(&mut rgba)?;
    assert_eq!((info.width, info.height), WINDOW, "{}", out.display());
    assert_eq!(info.color_type, png::ColorType::Rgba);
    Ok(Run { rgba, pins })
}

/// The cape's pixels: their count and mean position \[pixels\].
fn cape(rgba: &[u8]) -> (usize, [f32; 2]) {
    let mut sum = [0.0f32; 2];
    let mut n = 0;
    for (i, p) in rgba.chunks(4).enumerate() {
        let (r, g, b) = (i32::from(p[0]), i32::from(p[1]), i32::from(p[2]));
        if r - g > CAPE_RED_MARGIN && r - b > CAPE_RED_MARGIN {
            n += 1;
            sum[0] += (i % WINDOW.0 as usize) as f32;
            sum[1] += (i / WINDOW.0 as usize) as f32;
        }
    }
    (n, sum.map(|s| s / n.max(1) as f32))
}

#[test]
fn cape_screenshots_show_the_cape_moving() -> anyhow::Result<()> {
    let example = cape_example()?;
    let x = Xvfb::start("cape").map_err(anyhow::Error::msg)?;
    let dir = std::env::temp_dir().join(format!("wgcloth-bevy-cape-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let early = run(&example, &x, EARLY, &dir)?;
    let late = run(&example, &x, LATE, &dir)?;
    // The pins follow the character through the whole jog and turn.
    assert!(
        late.pins.len() + READBACK_SLACK >= LATE as usize,
        "{} read-backs of the cape in {LATE} frames",
        late.pins.len()
    );
    for &(steps, error) in &late.pins {
        assert!(
            error <= PIN_TOLERANCE,
            "after {steps} steps the cape's pins are {error} m from the character's shoulders \
             (at most {PIN_TOLERANCE} m)"
        );
    }
    let (early, late) = (cape(&early.rgba), cape(&late.rgba));
    for ((n, _), frames) in [(early, EARLY), (late, LATE)] {
        assert!(
            n >= MIN_CAPE_PIXELS,
            "frame {frames}: {n} cape pixels (at least {MIN_CAPE_PIXELS}); the screenshots are in {}",
            dir.display()
        );
    }
    let shift = (late.1[0] - early.1[0]).hypot(late.1[1] - early.1[1]);
    assert!(
        shift > MIN_SHIFT,
        "the cape moved {shift} pixels between frames {EARLY} and {LATE} \
         (from {:?} to {:?}); the screenshots are in {}",
        early.1,
        late.1,
        dir.display()
    );
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}
